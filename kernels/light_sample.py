"""The one interface of an area light kind (sphere_light.py, quad_light.py, mesh_light.py), which
lights.py composes into a variant's `sample_light` / `light_pdf`; and what the kinds share.

A kind's module has `make(features, strategy, motion, spherical) -> LightKind`:
    code                                        its shape kind (device_scene: SPHERE, QUAD, MESH)
    sample(sd, s, x, u, bounce, dt) -> LightSample
        a point of shape s seen from x (a path vertex of bounce index `bounce`, at shutter time dt):
        the unit direction, distance, the emitted radiance towards x and the solid-angle density,
        the light's choice not included (lights.py multiplies the selection's pmf)
    pdf(sd, s, x, y, ny, prim, bounce, dt) -> float
        the solid-angle density with which `sample` proposes point y (normal ny; face `prim` of a
        mesh) from x: exactly what `sample` does, else MIS is biased
    tag                                         what names the closures for the kernel cache
`spherical` (SphericalRules) carries the spherical maps and the rules of rect_pays (read when the
kernel is built). Solid-angle sampling of a flat light only where `spherical_ok` (the thresholds
below, explained in lights.py).
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import PI  # noqa: F401 (the kinds' area formulas)
from drtlab.kernels.device_scene import SceneData

# Solid-angle sampling of a rectangle or triangle only where the solid angle Omega (sr) it subtends
# from x lies in [SPHERICAL_MIN, SPHERICAL_MAX] and x stands at least SPHERICAL_MIN_ELEVATION x (the
# distance to the shape's farthest corner) off its plane (lights.py says why).
SPHERICAL_MIN = 3.0e-4
SPHERICAL_MAX = 6.22
SPHERICAL_MIN_ELEVATION = 0.01
# A quad is a rectangle (spherical-rectangle sampling applies) when the cosine of the angle between
# its edges is below this: float32 edges of rotated boxes are ~1e-7 off; the sampled rectangle then
# differs from the quad by a sliver of relative area below it.
RECTANGLE_COS = 1.0e-5


@wp.struct
class LightSample:
    wi: wp.vec3
    dist: float
    radiance: wp.vec3
    pdf: float          # solid-angle pdf (lights.py's sample_light: including the light choice)
    valid: int
    prim: int           # a mesh light's face the point lies on (in the per-face arrays)


class LightKind(NamedTuple):
    code: int
    sample: wp.Function
    pdf: wp.Function
    tag: tuple


class SphericalRules(NamedTuple):
    maps: object            # estimators.spherical_maps.make_spherical_maps(linear=...)
    linear: bool            # features.SPHERICAL_LINEAR: the maps' wrong variant (names the maps)
    pays: float             # lights.SPHERICAL_PAYS
    max_bounce: int         # lights.SPHERICAL_MAX_BOUNCE
    mis_area: bool          # features.SPHERICAL_MIS_AREA: pdf ignores solid-angle sampling
    mis_first_vertex: bool  # features.SPHERICAL_MIS_FIRST_VERTEX: pdf ignores max_bounce


@wp.func
def spherical_ok(omega: float, height2: float, reach2: float) -> int:
    """Whether a flat light of solid angle omega, whose plane is sqrt(height2) from x and whose
    farthest corner is sqrt(reach2) from x, is sampled by solid angle (the thresholds above)."""
    if omega >= wp.static(SPHERICAL_MIN) and omega <= wp.static(SPHERICAL_MAX):
        if height2 >= wp.static(SPHERICAL_MIN_ELEVATION * SPHERICAL_MIN_ELEVATION) * reach2:
            return 1
    return 0


def make_toward(wrong_jacobian: bool):
    """toward(sd, m, x, y, ny, spherical, area) -> LightSample: the sample of point y (normal ny,
    material m) from x: by its solid-angle density `spherical` where > 0, else by area (the density
    1/area converted to solid angle; features.LIGHT_JACOBIAN drops the cosine)."""
    WRONG = wrong_jacobian

    @wp.func
    def toward(sd: SceneData, m: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, spherical: float,
               area: float) -> LightSample:
        ls = LightSample()
        ls.valid = 0
        d = y - x
        dist = wp.length(d)
        if dist <= 0.0:
            return ls
        wi = d / dist
        cos_l = -wp.dot(ny, wi)
        if cos_l <= 0.0:
            return ls
        pdf = float(0.0)
        if spherical > 0.0:
            pdf = spherical
        else:
            pdf = dist * dist / (cos_l * area)
            if wp.static(WRONG):
                pdf = dist * dist / area
        ls.wi = wi
        ls.dist = dist
        ls.radiance = sd.materials.emission[m]
        ls.pdf = pdf
        ls.valid = 1
        return ls

    return toward
