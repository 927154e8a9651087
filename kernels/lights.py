"""Area-light sampling, built per kernel variant.

`make_lights(features, strategy, motion=motion)` (motion from intersection/motion.py) returns
AreaLights, Warp functions callable on their own:
    pick_light(sd, x, u) -> light index;  light_pick_pmf(sd, x, li) -> its probability from x
    sample_light(sd, li, x, u, bounce, dt) -> LightSample (direction, distance, radiance,
        solid-angle pdf including the light choice) from x, a path vertex of bounce index `bounce`
    light_pdf(sd, li, x, y, ny, prim, bounce, dt) -> the density sample_light has of proposing
        point y (on face `prim` of a mesh light; ignored for other shapes) from x at that bounce
`strategy.solid_angle` samples the cone a sphere light subtends (area sampling when x is inside it),
the spherical rectangle of a rectangular quad light (box faces included) and, on a mesh light, the
spherical triangle of the face picked by area (estimators/spherical_maps.py), each uniform in solid
angle, where that solid angle lies in [SPHERICAL_MIN, SPHERICAL_MAX], x is not nearly in the light's
plane (SPHERICAL_MIN_ELEVATION) and, for a rectangle, where it pays per unit time: A cos_l / d^2 at
its centre >= SPHERICAL_PAYS and x is a path vertex of bounce index <= SPHERICAL_MAX_BOUNCE (0: the
camera ray's hit); area sampling elsewhere, and for quads that are not rectangles. Otherwise every
flat light is area-sampled. The strategy's light selection (`kernels/light_selection.py`: `uniform`,
`power`, or a plugin's) picks the light from the shading point.
The fault features.LIGHT_JACOBIAN in `features.faults` drops the cosine at the light. `features.meshes` compiles in emitting triangle meshes: a triangle
picked with probability proportional to its area (MeshData.tri_cdf), then a uniform point on it (area
sampling: the density is 1 / (the mesh's area) everywhere on it) or its spherical triangle; the fault
features.MESH_PDF_HIGH_10PCT claims a density 10% too high. features.SPHERICAL_LINEAR compiles the
spherical maps' wrong variant, features.SPHERICAL_MIS_AREA a light_pdf that ignores them,
features.SPHERICAL_MIS_FIRST_VERTEX one that ignores SPHERICAL_MAX_BOUNCE.
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import (PI, cone_pdf, frame_to_world, square_to_cone,
                                     square_to_uniform_sphere)
from drtlab.estimators.spherical_maps import (SphericalRect, make_spherical_maps, spherical_rect,
                                             triangle_solid_angle)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import MESH, SPHERE, SceneData
from drtlab.kernels.features import (LIGHT_JACOBIAN, MESH_PDF_HIGH_10PCT, SPHERICAL_LINEAR,
                                     SPHERICAL_MIS_AREA, SPHERICAL_MIS_FIRST_VERTEX, Features)
from drtlab.kernels.intersection.motion import Motion
from drtlab.kernels.light_selection import selection_of

# Solid-angle sampling of a rectangle or triangle only where the solid angle Omega (sr) it subtends
# from x lies in [SPHERICAL_MIN, SPHERICAL_MAX] and x stands at least SPHERICAL_MIN_ELEVATION x (the
# distance to the shape's farthest corner) off its plane; area sampling elsewhere, decided by the
# same numbers in sample_light and light_pdf so that MIS sees the density actually used. Why:
# below SPHERICAL_MIN the maps' float32 angles (errors ~1e-7 rad each, against a sub-polygon of
# u0 Omega) misplace a relative ~1e-3 of the samples, and area sampling is as good there (the light
# is small and far: its cosines and distances vary little over it); pbrt-v4 uses 3e-4 for triangles
# too. Above SPHERICAL_MAX (within 1% of the hemisphere) Arvo's map divides by nearly zero. Seen
# nearly edge-on (elevation sine below 0.01) the maps recover a position from the cosine of an angle
# within ~1e-4 of 0 or pi, which float32 cannot resolve: the samples pile up on the far edge
# (tests/estimators/test_chi2_solid_angle.py measured 5% of them at elevation 2e-4).
SPHERICAL_MIN = 3.0e-4
SPHERICAL_MAX = 6.22
SPHERICAL_MIN_ELEVATION = 0.01
# A rectangle is sampled by solid angle only where, besides, A cos_l / d^2 at its centre (its solid
# angle while it is small, from one sqrt: no atan2) is at least SPHERICAL_PAYS sr. Below, area
# sampling's variance is nearly as low (cos_l / d^2 varies little over the light) and does not pay
# for the spherical rectangle's cost (solid angle costs 2.1x area's ns per sample where every pixel
# uses it, direct light of a square light over a plane, one CPU thread). Calibrated by
# experiments/bench/light_switch.py: per pixel, variance ratio area / solid angle over that cost
# ratio, binned by Omega, crosses 1 at ~4e-3 sr (0.75 at 1.8-4.1e-3, 1.12 at 4.1-6.9e-3; the
# variance ratio alone rises to ~15 at 0.3-0.5 sr and is still 4.3 at 3.6 sr). The spread of
# cos_l / d^2 over the light (farthest corner over nearest point) predicts it worse: not monotone.
# Points below it skip the spherical rectangle entirely. Triangles keep SPHERICAL_MIN alone.
SPHERICAL_PAYS = 4.0e-3
# ...and only from a path vertex of bounce index (tracers' depth: delta bounces count) at most
# SPHERICAL_MAX_BOUNCE, 0: the camera ray's hit. Later vertices sample by area: their light sample's
# variance is mostly swamped by the path's, so the map's cost buys little there. Measured by
# experiments/bench/light_bounce.py (one thread; efficiency = (var x ns) of importance-area over
# importance's, 96 x 72 pixels) on the lights study's Cornell box with a 1.4 x 1.4 light under
# path tracing: every vertex costs 1.64x area's ns per sample for a 1.35x lower variance
# (efficiency 0.82); bounces 0-1, 1.27x for 1.28x (1.00); bounce 0 only, 1.15x for 1.20x (1.04).
# The built-in Cornell box: 0.62 -> 0.86 (1.62x -> 1.17x the cost, variance equal either way).
# drt samples lights at its first hit only (soft-shadows: 1.6x either way). sample_light and
# light_pdf take the index of the vertex that samples (for light_pdf: the vertex that scattered
# the ray) so that MIS sees the density used there.
SPHERICAL_MAX_BOUNCE = 0
# A quad is a rectangle (spherical-rectangle sampling applies) when the cosine of the angle between
# its edges is below this: float32 edges of rotated boxes are ~1e-7 off; the sampled rectangle then
# differs from the quad by a sliver of relative area below it.
RECTANGLE_COS = 1.0e-5


@wp.struct
class LightSample:
    wi: wp.vec3
    dist: float
    radiance: wp.vec3
    pdf: float          # solid-angle pdf, including the light choice
    valid: int
    prim: int           # a mesh light's face the point lies on (in the per-face arrays)


@wp.struct
class TrianglePoint:
    y: wp.vec3
    n: wp.vec3          # the face's unit normal (b - a) x (c - a): the side it emits to
    face: int
    pdf: float          # solid-angle density of y given the mesh (spherical triangle); 0: by area


@wp.struct
class Corners:
    a: wp.vec3
    b: wp.vec3
    c: wp.vec3


@wp.func
def spherical_ok(omega: float, height2: float, reach2: float) -> int:
    """Whether a flat light of solid angle omega, whose plane is sqrt(height2) from x and whose
    farthest corner is sqrt(reach2) from x, is sampled by solid angle (the thresholds above)."""
    if omega >= wp.static(SPHERICAL_MIN) and omega <= wp.static(SPHERICAL_MAX):
        if height2 >= wp.static(SPHERICAL_MIN_ELEVATION * SPHERICAL_MIN_ELEVATION) * reach2:
            return 1
    return 0


@wp.func
def rect_ok(r: SphericalRect) -> int:
    reach2 = wp.max(r.x0 * r.x0, r.x1 * r.x1) + wp.max(r.y0 * r.y0, r.y1 * r.y1) + r.z0 * r.z0
    return spherical_ok(r.solid_angle, r.z0 * r.z0, reach2)


@wp.func
def triangle_ok(x: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3, omega: float) -> int:
    n = wp.cross(b - a, c - a)
    h = wp.dot(a - x, n)
    reach2 = wp.max(wp.length_sq(a - x), wp.max(wp.length_sq(b - x), wp.length_sq(c - x)))
    return spherical_ok(omega, h * h, reach2 * wp.dot(n, n))


@wp.func
def is_rectangle(u: wp.vec3, v: wp.vec3) -> int:
    uv = wp.dot(u, v)
    if uv * uv <= wp.static(RECTANGLE_COS * RECTANGLE_COS) * wp.dot(u, u) * wp.dot(v, v):
        return 1
    return 0


@wp.func
def sphere_cone(sd: SceneData, c: wp.vec3, r: float, x: wp.vec3) -> wp.vec2:
    """(1 - cos theta_max, distance to centre); first component <= 0 when x is inside."""
    dc = wp.length(c - x)
    if dc <= r * (1.0 + 1.0e-4):
        return wp.vec2(-1.0, dc)
    sin2 = (r / dc) * (r / dc)
    cos_max = wp.sqrt(wp.max(0.0, 1.0 - sin2))
    return wp.vec2(sin2 / (1.0 + cos_max), dc)


class AreaLights(NamedTuple):
    pick_light: wp.Function         # (sd, x, u) -> light index
    light_pick_pmf: wp.Function     # (sd, x, li) -> the probability pick_light picks li from x
    sample_light: wp.Function       # (sd, li, x, u, bounce, dt) -> LightSample
    light_pdf: wp.Function          # (sd, li, x, y, ny, prim, bounce, dt) -> density of y


def _make_mesh_lights(meshes: bool, mesh_fault: bool, mesh_shift, solid_angle: bool,
                      to_triangle) -> tuple:
    MESHES = meshes
    SOLID_ANGLE = solid_angle
    # features.MESH_PDF_HIGH_10PCT: the area a mesh light's density is taken from is 10% short.
    MESH_AREA_SCALE = 1.0 / 1.1 if mesh_fault else 1.0

    @wp.func
    def flat_area(sd: SceneData, k: int, s: int) -> float:
        """The area of a light that is not a sphere: a quad, or (meshes) a whole mesh."""
        if wp.static(MESHES):
            if k == MESH:
                return sd.meshes.area[s] * wp.static(MESH_AREA_SCALE)
        return sd.quads.area[s]

    @wp.func
    def face_probability(sd: SceneData, s: int, f: int) -> float:
        """The probability sample_triangle picks face f of mesh s."""
        c0 = float(0.0)
        if f > sd.meshes.face0[s]:
            c0 = sd.meshes.tri_cdf[f - 1]
        return sd.meshes.tri_cdf[f] - c0

    @wp.func
    def face_corners(sd: SceneData, f: int, shift: wp.vec3) -> Corners:
        idx = sd.meshes.tri_index[f]
        p = Corners()
        p.a = sd.meshes.points[idx[0]] + shift
        p.b = sd.meshes.points[idx[1]] + shift
        p.c = sd.meshes.points[idx[2]] + shift
        return p

    @wp.func
    def face_solid_angle_pdf(sd: SceneData, s: int, f: int, x: wp.vec3, dt: float) -> float:
        """Solid-angle sampling's density of face f's points given mesh s (the face's probability
        over its solid angle from x), or 0 where the face is area-sampled from x."""
        p = face_corners(sd, f, mesh_shift(sd, s, dt))
        omega = triangle_solid_angle(x, p.a, p.b, p.c)
        if triangle_ok(x, p.a, p.b, p.c, omega) == 1:
            return face_probability(sd, s, f) / (omega * wp.static(MESH_AREA_SCALE))
        return 0.0

    @wp.func
    def sample_triangle(sd: SceneData, s: int, x: wp.vec3, u: wp.vec2, dt: float) -> TrianglePoint:
        """A point on mesh s: the face whose cdf interval holds u[0] (binary search), then u[0]
        rescaled to that interval and u[1] make a uniform point on it (the square-root warp) or,
        solid angle sampling, one uniform in its solid angle from x. The rescaled u[0] keeps
        24 - log2(1 / the face's probability) bits of resolution."""
        lo = sd.meshes.face0[s]
        hi = sd.meshes.face0[s + 1] - 1
        while lo < hi:
            mid = (lo + hi) / 2
            if u[0] < sd.meshes.tri_cdf[mid]:
                hi = mid
            else:
                lo = mid + 1
        c0 = float(0.0)
        if lo > sd.meshes.face0[s]:
            c0 = sd.meshes.tri_cdf[lo - 1]
        u0 = wp.clamp((u[0] - c0) / (sd.meshes.tri_cdf[lo] - c0), 0.0, 1.0)
        p = face_corners(sd, lo, mesh_shift(sd, s, dt))
        a = p.a
        b = p.b
        c = p.c
        tp = TrianglePoint()
        tp.n = wp.normalize(wp.cross(b - a, c - a))
        tp.face = lo
        tp.pdf = 0.0
        if wp.static(SOLID_ANGLE):
            omega = triangle_solid_angle(x, a, b, c)
            if triangle_ok(x, a, b, c, omega) == 1:
                tp.y = to_triangle(x, a, b, c, omega, wp.vec2(u0, u[1]))
                tp.pdf = (sd.meshes.tri_cdf[lo] - c0) / (omega * wp.static(MESH_AREA_SCALE))
                return tp
        su = wp.sqrt(u0)
        b1 = (1.0 - u[1]) * su
        b2 = u[1] * su
        tp.y = a + (b - a) * b1 + (c - a) * b2
        return tp

    return flat_area, sample_triangle, face_solid_angle_pdf


def make_lights(f: Features, strategy: Strategy, *, motion: Motion) -> AreaLights:
    sphere_center = motion.sphere_center
    quad_origin = motion.quad_origin
    SOLID_ANGLE = strategy.solid_angle
    SELECTION = selection_of(strategy)
    MESHES = f.meshes
    wrong_jacobian = LIGHT_JACOBIAN in f.faults
    MIS_AREA = SPHERICAL_MIS_AREA in f.faults
    MIS_FIRST_VERTEX = SPHERICAL_MIS_FIRST_VERTEX in f.faults
    maps = make_spherical_maps(linear=SPHERICAL_LINEAR in f.faults)
    # Read when the kernel is built (experiments/bench/light_switch.py sets PAYS to 0 to measure
    # solid angle on both sides of it).
    PAYS = SPHERICAL_PAYS
    MAX_BOUNCE = SPHERICAL_MAX_BOUNCE

    @wp.func
    def rect_pays(x: wp.vec3, q0: wp.vec3, u: wp.vec3, v: wp.vec3, n: wp.vec3, area: float,
                  bounce: int) -> int:
        """Whether the rectangle q0 + s u + t v (unit normal n, area A) is worth solid-angle
        sampling from x, a vertex of bounce index `bounce`: bounce <= SPHERICAL_MAX_BOUNCE and
        A cos_l / d^2 at its centre reaches SPHERICAL_PAYS. Tested before, and deciding whether,
        the spherical rectangle is built."""
        if bounce > wp.static(MAX_BOUNCE):
            return 0
        c = q0 + (u + v) * 0.5 - x
        d2 = wp.dot(c, c)
        if area * wp.abs(wp.dot(c, n)) >= wp.static(PAYS) * d2 * wp.sqrt(d2):
            return 1
        return 0

    @wp.func
    def rect_to_sample(sd: SceneData, s: int, x: wp.vec3, q0: wp.vec3, bounce: int) -> SphericalRect:
        """The spherical rectangle by which quad s (origin q0 now) is sampled from x, a vertex of
        bounce index `bounce`, or one of solid angle 0: sampled by area. The one place that decides:
        sample_light draws by it and light_pdf gives its density, and MIS is unbiased only while
        the two agree."""
        uu = sd.quads.u[s]
        vv = sd.quads.v[s]
        out = SphericalRect()
        if is_rectangle(uu, vv) == 1 and rect_pays(x, q0, uu, vv, sd.quads.normal[s], sd.quads.area[s],
                                                   bounce) == 1:
            rect = spherical_rect(x, q0, uu, vv)
            if rect_ok(rect) == 1:
                out = rect
        return out

    to_rect = maps.square_to_spherical_rect
    flat_area, sample_triangle, face_solid_angle_pdf = _make_mesh_lights(
        f.meshes, MESH_PDF_HIGH_10PCT in f.faults, motion.mesh_shift, SOLID_ANGLE,
        maps.square_to_spherical_triangle)

    pick_light, light_pick_pmf = SELECTION.pick, SELECTION.pmf

    @wp.func
    def light_pdf(sd: SceneData, li: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, prim: int,
                  bounce: int, dt: float) -> float:
        """Solid-angle density (light choice included) of light sampling producing point y from x,
        a path vertex of bounce index `bounce` (rect_pays)."""
        k = sd.lights.shape_kind[li]
        s = sd.lights.shape[li]
        d = y - x
        dist2 = wp.dot(d, d)
        cos_l = wp.abs(wp.dot(ny, d)) / wp.sqrt(dist2)
        pdf = float(0.0)
        if k == SPHERE:
            c = sphere_center(sd, s, dt)
            r = sd.spheres.radius[s]
            cone = wp.vec2(-1.0, 0.0)
            if wp.static(SOLID_ANGLE):
                cone = sphere_cone(sd, c, r, x)
            if cone[0] > 0.0:
                pdf = cone_pdf(cone[0])
            elif cos_l > 0.0:
                pdf = dist2 / (cos_l * 4.0 * PI * r * r)
        else:
            if cos_l > 0.0:
                pdf = dist2 / (cos_l * flat_area(sd, k, s))
            if wp.static(SOLID_ANGLE and not MIS_AREA):
                sa_pdf = float(0.0)
                if wp.static(MESHES):
                    if k == MESH:
                        sa_pdf = face_solid_angle_pdf(sd, s, prim, x, dt)
                if k != MESH:
                    b = bounce
                    if wp.static(MIS_FIRST_VERTEX):
                        b = 0
                    rect = rect_to_sample(sd, s, x, quad_origin(sd, s, dt), b)
                    if rect.solid_angle > 0.0:
                        sa_pdf = 1.0 / rect.solid_angle
                if sa_pdf > 0.0:
                    pdf = sa_pdf
        return pdf * light_pick_pmf(sd, x, li)

    @wp.func
    def sample_light(sd: SceneData, li: int, x: wp.vec3, u: wp.vec2, bounce: int,
                     dt: float) -> LightSample:
        ls = LightSample()
        ls.valid = 0
        k = sd.lights.shape_kind[li]
        s = sd.lights.shape[li]
        y = wp.vec3(0.0)
        ny = wp.vec3(0.0)
        m = int(0)
        pdf = float(0.0)
        spherical = float(0.0)      # a flat light's solid-angle density, 0: area-sampled
        if k == SPHERE:
            c = sphere_center(sd, s, dt)
            r = sd.spheres.radius[s]
            m = sd.spheres.material[s]
            cone = wp.vec2(-1.0, 0.0)
            if wp.static(SOLID_ANGLE):
                cone = sphere_cone(sd, c, r, x)
            if cone[0] > 0.0:
                axis = (c - x) / cone[1]
                w = frame_to_world(square_to_cone(u, cone[0]), axis)
                # Nearest intersection of the cone direction with the sphere.
                b = wp.dot(c - x, w)
                perp = (c - x) - w * b
                disc = r * r - wp.dot(perp, perp)
                t = b - wp.sqrt(wp.max(0.0, disc))
                y = x + w * t
                ny = wp.normalize(y - c)
                pdf = cone_pdf(cone[0])
                ls.wi = w
                ls.dist = t
            else:
                ny = square_to_uniform_sphere(u)
                y = c + ny * r
        else:
            is_quad = True
            if wp.static(MESHES):
                if k == MESH:
                    tp = sample_triangle(sd, s, x, u, dt)
                    m = sd.meshes.material[s]
                    y = tp.y
                    ny = tp.n
                    ls.prim = tp.face
                    spherical = tp.pdf
                    is_quad = False
            if is_quad:
                m = sd.quads.material[s]
                q0 = quad_origin(sd, s, dt)
                uu = sd.quads.u[s]
                vv = sd.quads.v[s]
                ny = sd.quads.normal[s]
                if wp.static(SOLID_ANGLE):
                    rect = rect_to_sample(sd, s, x, q0, bounce)
                    if rect.solid_angle > 0.0:
                        y = to_rect(rect, x, u)
                        spherical = 1.0 / rect.solid_angle
                if spherical == 0.0:
                    y = q0 + uu * u[0] + vv * u[1]
        if pdf == 0.0:
            d = y - x
            dist = wp.length(d)
            if dist <= 0.0:
                return ls
            wi = d / dist
            cos_l = -wp.dot(ny, wi)
            if cos_l <= 0.0:
                return ls
            if spherical > 0.0:
                pdf = spherical
            else:
                area = float(0.0)
                if k == SPHERE:
                    area = 4.0 * PI * sd.spheres.radius[s] * sd.spheres.radius[s]
                else:
                    area = flat_area(sd, k, s)
                pdf = dist * dist / (cos_l * area)
                if wp.static(wrong_jacobian):
                    pdf = dist * dist / area
            ls.wi = wi
            ls.dist = dist
        else:
            if wp.dot(ny, ls.wi) >= 0.0:
                return ls
        ls.radiance = sd.materials.emission[m]
        ls.pdf = pdf * light_pick_pmf(sd, x, li)
        ls.valid = 1
        return ls

    return AreaLights(pick_light=pick_light, light_pick_pmf=light_pick_pmf,
                      sample_light=sample_light, light_pdf=light_pdf)
