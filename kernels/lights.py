"""Area-light sampling, built per kernel variant.

`make_lights(features, strategy, motion=motion)` (motion from intersection/motion.py) returns
AreaLights, Warp functions callable on their own:
    pick_light(sd, u) -> light index;  light_pick_pmf(sd, li) -> its probability
    sample_light(sd, li, x, u, dt) -> LightSample (direction, distance, radiance, solid-angle pdf
        including the light choice)
    light_pdf(sd, li, x, y, ny, dt) -> the density sample_light has of proposing point y from x
`strategy.solid_angle` samples the cone a sphere light subtends (area sampling when x is inside it);
rectangles are always area-sampled. `strategy.power_pick` picks lights proportionally to emitted
power. The fault features.LIGHT_JACOBIAN in `features.faults` drops the cosine at the light.
`features.meshes` compiles in emitting triangle meshes, area-sampled like rectangles: a triangle
picked with probability proportional to its area (MeshData.tri_cdf), a uniform point on it, so the
density is 1 / (the mesh's area) everywhere on it; the fault features.MESH_PDF_HIGH_10PCT claims a
density 10% too high.
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import (PI, cone_pdf, frame_to_world, square_to_cone,
                                     square_to_uniform_sphere)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import MESH, SPHERE, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN, MESH_PDF_HIGH_10PCT, Features
from drtlab.kernels.intersection.motion import Motion


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
    pick_light: wp.Function         # (sd, u) -> light index
    light_pick_pmf: wp.Function     # (sd, li) -> the probability pick_light picks li
    sample_light: wp.Function       # (sd, li, x, u, dt) -> LightSample
    light_pdf: wp.Function          # (sd, li, x, y, ny, dt) -> sample_light's density of y


def _make_mesh_lights(meshes: bool, mesh_fault: bool, mesh_shift) -> tuple:
    MESHES = meshes
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
    def sample_triangle(sd: SceneData, s: int, u: wp.vec2, dt: float) -> TrianglePoint:
        """A point on mesh s: the face whose cdf interval holds u[0] (binary search), then u[0]
        rescaled to that interval and u[1] make a uniform point on it (the square-root warp). The
        rescaled u[0] keeps 24 - log2(1 / the face's probability) bits of resolution."""
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
        idx = sd.meshes.tri_index[lo]
        shift = mesh_shift(sd, s, dt)
        a = sd.meshes.points[idx[0]] + shift
        b = sd.meshes.points[idx[1]] + shift
        c = sd.meshes.points[idx[2]] + shift
        su = wp.sqrt(u0)
        b1 = (1.0 - u[1]) * su
        b2 = u[1] * su
        tp = TrianglePoint()
        tp.y = a + (b - a) * b1 + (c - a) * b2
        tp.n = wp.normalize(wp.cross(b - a, c - a))
        tp.face = lo
        return tp

    return flat_area, sample_triangle


def make_lights(f: Features, strategy: Strategy, *, motion: Motion) -> AreaLights:
    sphere_center = motion.sphere_center
    quad_origin = motion.quad_origin
    SOLID_ANGLE = strategy.solid_angle
    POWER_PICK = strategy.power_pick
    MESHES = f.meshes
    wrong_jacobian = LIGHT_JACOBIAN in f.faults
    flat_area, sample_triangle = _make_mesh_lights(f.meshes, MESH_PDF_HIGH_10PCT in f.faults,
                                                   motion.mesh_shift)

    @wp.func
    def light_pick_pmf(sd: SceneData, li: int) -> float:
        if wp.static(POWER_PICK):
            return sd.lights.pmf[li]
        return 1.0 / float(sd.lights.n_area)

    @wp.func
    def pick_light(sd: SceneData, u: float) -> int:
        li = int(0)
        if wp.static(POWER_PICK):
            # Few lights: a linear scan of the cdf is cheaper than a search.
            while li < sd.lights.n_area - 1 and u >= sd.lights.cdf[li]:
                li += 1
        else:
            li = wp.min(int(u * float(sd.lights.n_area)), sd.lights.n_area - 1)
        return li

    @wp.func
    def light_pdf(sd: SceneData, li: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, dt: float) -> float:
        """Solid-angle density (light choice included) of light sampling producing point y from x."""
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
        return pdf * light_pick_pmf(sd, li)

    @wp.func
    def sample_light(sd: SceneData, li: int, x: wp.vec3, u: wp.vec2, dt: float) -> LightSample:
        ls = LightSample()
        ls.valid = 0
        k = sd.lights.shape_kind[li]
        s = sd.lights.shape[li]
        y = wp.vec3(0.0)
        ny = wp.vec3(0.0)
        m = int(0)
        pdf = float(0.0)
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
                    tp = sample_triangle(sd, s, u, dt)
                    m = sd.meshes.material[s]
                    y = tp.y
                    ny = tp.n
                    ls.prim = tp.face
                    is_quad = False
            if is_quad:
                m = sd.quads.material[s]
                q0 = quad_origin(sd, s, dt)
                y = q0 + sd.quads.u[s] * u[0] + sd.quads.v[s] * u[1]
                ny = sd.quads.normal[s]
        if pdf == 0.0:
            d = y - x
            dist = wp.length(d)
            if dist <= 0.0:
                return ls
            wi = d / dist
            cos_l = -wp.dot(ny, wi)
            if cos_l <= 0.0:
                return ls
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
        ls.pdf = pdf * light_pick_pmf(sd, li)
        ls.valid = 1
        return ls

    return AreaLights(pick_light=pick_light, light_pick_pmf=light_pick_pmf,
                      sample_light=sample_light, light_pdf=light_pdf)
