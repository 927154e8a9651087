"""The scene as the kernels see it (SceneData, uploaded by render.upload) and the feature set that
selects a kernel variant."""
from dataclasses import dataclass
from types import SimpleNamespace

import warp as wp

# Faults a test may compile into a kernel to check that a statistical test rejects a wrong estimator:
#   drop_cosine     diffuse/glossy f|cos| loses its cosine (light samples and scattered rays)
#   pdf_high_10pct  scattered rays are weighted as if their pdf were 10% higher
#   rr_no_reweight  Russian roulette kills paths without dividing survivors by their probability
#   light_jacobian  area light samples convert to solid angle without the cosine at the light
FAULTS = ("drop_cosine", "pdf_high_10pct", "rr_no_reweight", "light_jacobian")

SPHERE = wp.constant(0)
QUAD = wp.constant(1)


@wp.struct
class SceneData:
    sph_center: wp.array(dtype=wp.vec3)
    sph_radius: wp.array(dtype=float)
    sph_velocity: wp.array(dtype=wp.vec3)
    sph_material: wp.array(dtype=int)
    sph_light: wp.array(dtype=int)
    n_spheres: int
    quad_origin: wp.array(dtype=wp.vec3)
    quad_u: wp.array(dtype=wp.vec3)
    quad_v: wp.array(dtype=wp.vec3)
    quad_normal: wp.array(dtype=wp.vec3)
    quad_area: wp.array(dtype=float)
    quad_velocity: wp.array(dtype=wp.vec3)
    quad_material: wp.array(dtype=int)
    quad_light: wp.array(dtype=int)
    n_quads: int
    mat_kind: wp.array(dtype=int)
    mat_albedo: wp.array(dtype=wp.vec3)
    mat_albedo2: wp.array(dtype=wp.vec3)
    mat_checker: wp.array(dtype=wp.vec2)
    mat_exponent: wp.array(dtype=float)
    mat_ior: wp.array(dtype=float)
    mat_emission: wp.array(dtype=wp.vec3)
    light_shape_kind: wp.array(dtype=int)
    light_shape: wp.array(dtype=int)
    light_pmf: wp.array(dtype=float)
    light_cdf: wp.array(dtype=float)
    n_lights: int
    pl_position: wp.array(dtype=wp.vec3)
    pl_intensity: wp.array(dtype=wp.vec3)
    n_point_lights: int
    dl_direction: wp.array(dtype=wp.vec3)
    dl_irradiance: wp.array(dtype=wp.vec3)
    n_dir_lights: int
    background: wp.vec3
    eps: float
    cam_position: wp.vec3
    cam_right: wp.vec3
    cam_up: wp.vec3
    cam_forward: wp.vec3
    half_width: float
    half_height: float
    aperture: float
    focus_distance: float
    shutter_open: float
    shutter_close: float
    width: int
    height: int
    max_depth: int
    rr_depth: int
    whitted_codes: int


@dataclass(frozen=True)
class Features:
    """What a scene uses; one compiled kernel per distinct value (with the sampler)."""
    integrator: str
    lens: bool
    motion: bool
    spheres: bool
    quads: bool
    kinds: frozenset
    checker: bool
    area_lights: bool
    point_lights: bool
    dir_lights: bool
    roulette: bool
    background: bool
    # Deliberately wrong estimators, compiled in only for the tests' negative controls (see FAULTS).
    faults: frozenset = frozenset()

    def key(self) -> str:
        flags = [n for n in ("lens", "motion", "spheres", "quads", "checker", "area_lights",
                             "point_lights", "dir_lights", "roulette", "background") if getattr(self, n)]
        key = f"{self.integrator}[{','.join(flags)}|{','.join(sorted(self.kinds))}]"
        return key + (f"!{','.join(sorted(self.faults))}" if self.faults else "")


def make_motion(motion: bool) -> SimpleNamespace:
    """Shape positions at shutter offset dt; without motion the velocity is never read."""

    @wp.func
    def sphere_center(sd: SceneData, i: int, dt: float) -> wp.vec3:
        c = sd.sph_center[i]
        if wp.static(motion):
            c = c + sd.sph_velocity[i] * dt
        return c

    @wp.func
    def quad_origin(sd: SceneData, i: int, dt: float) -> wp.vec3:
        q0 = sd.quad_origin[i]
        if wp.static(motion):
            q0 = q0 + sd.quad_velocity[i] * dt
        return q0

    return SimpleNamespace(sphere_center=sphere_center, quad_origin=quad_origin)
