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
        # Two triangles (v00, v10, v11) and (v00, v11, v01); each triple product is z0 |u| |v|.
        triple = r.z0 * exl * eyl
        v00 = wp.vec3(r.x0, r.y0, r.z0)
        v10 = wp.vec3(r.x1, r.y0, r.z0)
        v11 = wp.vec3(r.x1, r.y1, r.z0)
        v01 = wp.vec3(r.x0, r.y1, r.z0)
        r.solid_angle = tri_solid_angle(triple, v00, v10, v11) + tri_solid_angle(triple, v00, v11,
                                                                                  v01)
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
        # Unit normals of the planes through x and each edge; Urena's internal angles g2, g3.
        n0 = wp.normalize(wp.vec3(0.0, z0, -r.y0))
        n2 = wp.normalize(wp.vec3(0.0, -z0, r.y1))
        n3 = wp.normalize(wp.vec3(z0, 0.0, -r.x0))
        g2 = angle_between(-n2, n3)
        g3 = angle_between(-n3, n0)
        b0 = n0[2]
        b1 = n2[2]
        # The sub-rectangle of solid angle u0 S ends at xu (angles taken mod 2 pi).
        au = u[0] * r.solid_angle - g2 - g3
        fu = (wp.cos(au) * b0 - b1) / wp.sin(au)
        cu = 1.0 / wp.sqrt(fu * fu + b0 * b0)
        if fu < 0.0:
            cu = -cu
        cu = wp.clamp(cu, -0.99999994, 0.99999994)
        xu = wp.clamp(-(cu * z0) / wp.sqrt(1.0 - cu * cu), r.x0, r.x1)
        yv = float(0.0)
        if wp.static(LINEAR):
            yv = r.y0 + u[1] * (r.y1 - r.y0)
        else:
            dd2 = xu * xu + z0 * z0
            h0 = r.y0 / wp.sqrt(dd2 + r.y0 * r.y0)
            h1 = r.y1 / wp.sqrt(dd2 + r.y1 * r.y1)
            hv = h0 + u[1] * (h1 - h0)
            yv = r.y1
            if hv * hv < 1.0 - 1.0e-6:
                yv = hv * wp.sqrt(dd2) / wp.sqrt(1.0 - hv * hv)
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
        alpha = angle_between(n_ab, -n_ca)
        # Arvo: the sub-triangle a b c' of area u0 A (alpha + beta' + gamma' = pi + u0 A).
        ap = PI + u[0] * solid_angle
        cos_alpha = wp.cos(alpha)
        sin_alpha = wp.sin(alpha)
        sin_phi = -wp.sin(ap) * cos_alpha + wp.cos(ap) * sin_alpha
        cos_phi = -wp.cos(ap) * cos_alpha - wp.sin(ap) * sin_alpha
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
