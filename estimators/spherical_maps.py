"""Area-preserving maps of [0, 1)^2 onto the solid angle a rectangle or a triangle subtends from a
point x, with the solid angle each covers (its density is 1 / solid angle).

Rectangles: Urena, Fajardo and King 2013, "An area-preserving parametrization for spherical
rectangles" (the first coordinate picks the sub-rectangle's solid angle u0 * S, which fixes the
abscissa xu; the second is linear in the sine of the elevation along the segment at xu).
Triangles: Arvo 1995, "Stratified sampling of spherical triangles" (the first coordinate picks the
sub-triangle's area u0 * A, which fixes the vertex c' on the arc ac; the second is linear in the
cosine along the arc b c').

Solid angles come from Van Oosterom and Strackee's formula, tan(Omega / 2) = |a . (b x c)| /
(|a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|), with the triple product taken from the edges (exact in
the geometry, no cancellation): it keeps its relative precision for tiny solid angles, where the
sum of a polygon's angles minus (n - 2) pi loses it in float32. Below a small solid angle the maps'
own angles still lose precision; kernels/lights.py falls back to area sampling there.

`make_spherical_maps(linear)` returns the two maps; `linear` compiles a deliberately wrong variant
(the second coordinate linear in the edge's length or the arc's angle instead of area-preserving)
for the chi-square tests' negative control.
"""
from typing import NamedTuple

import warp as wp

PI = wp.constant(3.14159265358979323846)


@wp.struct
class SphericalRect:
    """A rectangle q0 + s u + t v (u, v orthogonal) seen from x, in the frame ex = u/|u|, ey =
    v/|v|, ez = ex x ey: the corners are x + (x0|x1) ex + (y0|y1) ey + z0 ez."""
    ex: wp.vec3
    ey: wp.vec3
    ez: wp.vec3
    x0: float
    y0: float
    z0: float
    x1: float
    y1: float
    l00: float              # |(x0, y0, z0)|, |(x0, y1, z0)|: corner distances the map reuses
    l01: float
    solid_angle: float      # 0 when x is not strictly in front (z0 >= 0): nothing to sample


@wp.func
def tri_solid_angle(triple: float, a: wp.vec3, b: wp.vec3, c: wp.vec3) -> float:
    """The solid angle of the triangle with corners x + a, x + b, x + c, given a . (b x c)."""
    la = wp.length(a)
    lb = wp.length(b)
    lc = wp.length(c)
    den = la * lb * lc + wp.dot(a, b) * lc + wp.dot(a, c) * lb + wp.dot(b, c) * la
    return 2.0 * wp.atan2(wp.abs(triple), den)


@wp.func
def spherical_rect(x: wp.vec3, q0: wp.vec3, u: wp.vec3, v: wp.vec3) -> SphericalRect:
    """The rectangle's frame and solid angle from x (x in front: on the side of u x v)."""
    r = SphericalRect()
    exl = wp.length(u)
    eyl = wp.length(v)
    r.ex = u / exl
    r.ey = v / eyl
    r.ez = wp.cross(r.ex, r.ey)
    d = q0 - x
    r.x0 = wp.dot(d, r.ex)
    r.y0 = wp.dot(d, r.ey)
    r.z0 = wp.dot(d, r.ez)
    r.x1 = r.x0 + exl
    r.y1 = r.y0 + eyl
    r.solid_angle = 0.0
    if r.z0 < 0.0:
        # Two triangles (v00, v10, v11) and (v00, v11, v01), each of triple product |z0| |u| |v|:
        # Omega / 2 = atan2(T, den1) + atan2(T, den2), summed as one atan2 (the sum is at most pi).
        z2 = r.z0 * r.z0
        r.l00 = wp.sqrt(r.x0 * r.x0 + r.y0 * r.y0 + z2)
        l10 = wp.sqrt(r.x1 * r.x1 + r.y0 * r.y0 + z2)
        l11 = wp.sqrt(r.x1 * r.x1 + r.y1 * r.y1 + z2)
        r.l01 = wp.sqrt(r.x0 * r.x0 + r.y1 * r.y1 + z2)
        d00_10 = r.x0 * r.x1 + r.y0 * r.y0 + z2
        d00_11 = r.x0 * r.x1 + r.y0 * r.y1 + z2
        d10_11 = r.x1 * r.x1 + r.y0 * r.y1 + z2
        d00_01 = r.x0 * r.x0 + r.y0 * r.y1 + z2
        d11_01 = r.x0 * r.x1 + r.y1 * r.y1 + z2
        t = -r.z0 * exl * eyl
        den1 = r.l00 * l10 * l11 + d00_10 * l11 + d00_11 * l10 + d10_11 * r.l00
        den2 = r.l00 * l11 * r.l01 + d00_11 * r.l01 + d00_01 * l11 + d11_01 * r.l00
        r.solid_angle = 2.0 * wp.atan2(t * (den1 + den2), den1 * den2 - t * t)
    return r


@wp.func
def triangle_solid_angle(x: wp.vec3, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3) -> float:
    a = p0 - x
    return tri_solid_angle(wp.dot(a, wp.cross(p1 - p0, p2 - p0)), a, p1 - x, p2 - x)


@wp.func
def angle_between(a: wp.vec3, b: wp.vec3) -> float:
    """The angle between unit vectors, accurate near 0 and pi (where acos of the dot is not)."""
    if wp.dot(a, b) < 0.0:
        return PI - 2.0 * wp.asin(wp.min(1.0, 0.5 * wp.length(a + b)))
    return 2.0 * wp.asin(wp.min(1.0, 0.5 * wp.length(b - a)))


@wp.func
def safe_normalize(v: wp.vec3) -> wp.vec3:
    l2 = wp.dot(v, v)
    if l2 > 0.0:
        return v / wp.sqrt(l2)
    return v


class SphericalMaps(NamedTuple):
    square_to_spherical_rect: wp.Function      # (r: SphericalRect, x, u) -> the point on the rectangle
    square_to_spherical_triangle: wp.Function  # (x, p0, p1, p2, solid_angle, u) -> the point


def make_spherical_maps(linear: bool = False) -> SphericalMaps:
    LINEAR = linear

    @wp.func
    def square_to_spherical_rect(r: SphericalRect, x: wp.vec3, u: wp.vec2) -> wp.vec3:
        """A point of the rectangle (r.solid_angle > 0) whose direction from x is uniform in the
        solid angle the rectangle subtends."""
        z0 = r.z0
        z2 = z0 * z0
        # Urena's au = u0 S - g2 - g3 (angles mod 2 pi), g2, g3 the internal angles at the corners
        # (x0, y1) and (x0, y0), taken through their cosines and sines, which are algebraic in the
        # corners: cos g2 = x0 y1 / (r2 r3), sin g2 = |z0| |v01| / (r2 r3), and likewise g3.
        r0 = wp.sqrt(z2 + r.y0 * r.y0)
        r2 = wp.sqrt(z2 + r.y1 * r.y1)
        r3 = wp.sqrt(z2 + r.x0 * r.x0)
        c2 = r.x0 * r.y1 / (r2 * r3)
        s2 = -z0 * r.l01 / (r2 * r3)
        c3 = -r.x0 * r.y0 / (r3 * r0)
        s3 = -z0 * r.l00 / (r3 * r0)
        c23 = c2 * c3 - s2 * s3
        s23 = s2 * c3 + c2 * s3
        a = u[0] * r.solid_angle
        ca = wp.cos(a)
        sa = wp.sin(a)
        cos_au = ca * c23 + sa * s23
        sin_au = sa * c23 - ca * s23
        b0 = -r.y0 / r0
        b1 = r.y1 / r2
        # The sub-rectangle of solid angle u0 S ends at xu.
        fu = (cos_au * b0 - b1) / sin_au
        cu = 1.0 / wp.sqrt(fu * fu + b0 * b0)
        if fu < 0.0:
            cu = -cu
        cu = wp.clamp(cu, -0.99999994, 0.99999994)
        xu = wp.clamp(-(cu * z0) / wp.sqrt(1.0 - cu * cu), r.x0, r.x1)
        yv = float(0.0)
        if wp.static(LINEAR):
            yv = r.y0 + u[1] * (r.y1 - r.y0)
        else:
            dd2 = xu * xu + z2
            h0 = r.y0 / wp.sqrt(dd2 + r.y0 * r.y0)
            h1 = r.y1 / wp.sqrt(dd2 + r.y1 * r.y1)
            hv = h0 + u[1] * (h1 - h0)
            yv = r.y1
            if hv * hv < 1.0 - 1.0e-6:
                yv = hv * wp.sqrt(dd2 / (1.0 - hv * hv))
            yv = wp.clamp(yv, r.y0, r.y1)
        return x + r.ex * xu + r.ey * yv + r.ez * z0

    @wp.func
    def square_to_spherical_triangle(x: wp.vec3, p0: wp.vec3, p1: wp.vec3, p2: wp.vec3,
                                     solid_angle: float, u: wp.vec2) -> wp.vec3:
        """A point of the triangle (solid_angle: triangle_solid_angle from x, > 0) whose direction
        from x is uniform in the solid angle the triangle subtends."""
        a = wp.normalize(p0 - x)
        b = wp.normalize(p1 - x)
        c = wp.normalize(p2 - x)
        n_ab = safe_normalize(wp.cross(a, b))
        n_ca = safe_normalize(wp.cross(c, a))
        # The angle alpha at a, through its cosine and sine (between n_ab and -n_ca).
        cos_alpha = -wp.dot(n_ab, n_ca)
        sin_alpha = wp.length(wp.cross(n_ab, n_ca))
        # Arvo: the sub-triangle a b c' of area u0 A (alpha + beta' + gamma' = pi + u0 A); with
        # ap = pi + u0 A, sin ap = -sin(u0 A) and cos ap = -cos(u0 A).
        sin_ap = -wp.sin(u[0] * solid_angle)
        cos_ap = -wp.cos(u[0] * solid_angle)
        sin_phi = -sin_ap * cos_alpha + cos_ap * sin_alpha
        cos_phi = -cos_ap * cos_alpha - sin_ap * sin_alpha
        k1 = cos_phi - cos_alpha
        k2 = sin_phi + sin_alpha * wp.dot(a, b)
        cos_bp = ((k2 * cos_phi - k1 * sin_phi) * cos_alpha - k2) / (
            (k2 * sin_phi + k1 * cos_phi) * sin_alpha)
        cos_bp = wp.clamp(cos_bp, -1.0, 1.0)
        sin_bp = wp.sqrt(wp.max(0.0, 1.0 - cos_bp * cos_bp))
        cp = a * cos_bp + safe_normalize(c - a * wp.dot(c, a)) * sin_bp
        cos_t = float(0.0)
        if wp.static(LINEAR):
            cos_t = wp.cos(u[1] * angle_between(cp, b))
        else:
            cos_t = 1.0 - u[1] * (1.0 - wp.dot(cp, b))
        sin_t = wp.sqrt(wp.max(0.0, 1.0 - cos_t * cos_t))
        w = b * cos_t + safe_normalize(cp - b * wp.dot(cp, b)) * sin_t
        # The point where x + t w meets the triangle, by barycentrics clamped onto it.
        e1 = p1 - p0
        e2 = p2 - p0
        s1 = wp.cross(w, e2)
        div = wp.dot(s1, e1)
        if div == 0.0:
            return (p0 + p1 + p2) / 3.0
        s = x - p0
        t1 = wp.clamp(wp.dot(s, s1) / div, 0.0, 1.0)
        t2 = wp.clamp(wp.dot(w, wp.cross(s, e1)) / div, 0.0, 1.0)
        if t1 + t2 > 1.0:
            tot = t1 + t2
            t1 = t1 / tot
            t2 = t2 / tot
        return p0 + e1 * t1 + e2 * t2

    return SphericalMaps(square_to_spherical_rect=square_to_spherical_rect,
                         square_to_spherical_triangle=square_to_spherical_triangle)
