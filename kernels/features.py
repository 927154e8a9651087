"""What a scene uses (Features, decided once by features_of): the switches of a kernel variant."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from drtlab.errors import InputError
from drtlab.kernels.scene_model.material_kinds import kinds_where
from drtlab.kernels.scene_model.scene import Scene

# The built-in integrators that never roulette: their variants carry no roulette flag. Every other
# integrator (path, and every plugin's) is told the scene's `russian_roulette` (api.features.roulette).
ROULETTE_FREE = ("whitted", "drt", "direct")

# Faults a test may compile into a kernel to check that a statistical test rejects a wrong estimator.
DROP_COSINE = "drop_cosine"         # diffuse/glossy f|cos| loses its cosine (light samples, scattering)
PDF_HIGH_10PCT = "pdf_high_10pct"   # scattered rays are weighted as if their pdf were 10% higher
RR_NO_REWEIGHT = "rr_no_reweight"   # roulette kills paths without dividing survivors by their probability
LIGHT_JACOBIAN = "light_jacobian"   # area light samples reach solid angle without the cosine at the light
FAULTS = (DROP_COSINE, PDF_HIGH_10PCT, RR_NO_REWEIGHT, LIGHT_JACOBIAN)
# Faults of mesh code, whose negative controls live in tests/kernels/test_meshes.py (the ones above are
# controlled on built-in scenes by tests/estimators/test_unbiased.py).
MESH_PDF_HIGH_10PCT = "mesh_pdf_high_10pct"  # mesh lights claim an area density 10% too high
MESH_FAULTS = (MESH_PDF_HIGH_10PCT,)
# Faults of the pixel filters (tests/kernels/test_pixel_filters.py): filter importance sampling that
# drops the sign of negative lobes, or samples the filter over a radius 10% too wide.
FILTER_NO_SIGN = "filter_no_sign"
FILTER_RADIUS_HIGH_10PCT = "filter_radius_high_10pct"
FILTER_FAULTS = (FILTER_NO_SIGN, FILTER_RADIUS_HIGH_10PCT)
# Faults of solid-angle light sampling (estimators/spherical_maps.py), controlled in
# tests/estimators/test_chi2_solid_angle.py and (SPHERICAL_MIS_FIRST_VERTEX)
# tests/kernels/test_solid_angle_floor.py.
SPHERICAL_LINEAR = "spherical_linear"        # the maps' second coordinate linear, not area-preserving
SPHERICAL_MIS_AREA = "spherical_mis_area"    # light_pdf claims the area density where sample_light
                                             # used the solid-angle one (MIS weights not summing to 1)
# light_pdf claims the density of a first vertex (lights.SPHERICAL_MAX_BOUNCE ignored) whatever
# vertex sampled: solid angle where a later vertex used area
SPHERICAL_MIS_FIRST_VERTEX = "spherical_mis_first_vertex"
SPHERICAL_FAULTS = (SPHERICAL_LINEAR, SPHERICAL_MIS_AREA, SPHERICAL_MIS_FIRST_VERTEX)
# A fault of the mask (kernels/materials/mask.py), controlled in tests/kernels/test_mask.py: its
# pass-through weighted 1 / (1 - opacity), as if it were a lobe divided by its choice probability.
MASK_DIVIDES_BY_CHOICE = "mask_divides_by_choice"
MASK_FAULTS = (MASK_DIVIDES_BY_CHOICE,)
# Faults that leave an estimator unbiased and only waste its samples: no unbiasedness test can see
# them; tests/kernels/test_mis_variance.py controls them by the pixel variance.
MIS_SWAPPED = "mis_swapped"         # each MIS technique weighted by the other's weight (b/(a+b) for a)
VARIANCE_FAULTS = (MIS_SWAPPED,)
# Not faults but the profile's probes (`profile_kernels components`): the kernel does one part of a
# sample's work twice, the second time on perturbed inputs folded into the radiance at 1e-30 (so the
# compiler cannot drop it, and the image moves by no more than rounding); the extra time is what
# that part costs inside a render, where a microbenchmark of it alone misleads (the caches, branch
# history and register pressure of the whole kernel are absent). What each repeats:
REPEAT_CAMERA = "repeat_camera"          # the camera ray's generation (pixel, lens, time draws)
REPEAT_INTERSECT = "repeat_intersect"    # the nearest hit of a path's ray (reversed direction)
REPEAT_NEXT_EVENT = "repeat_next_event"  # the whole light sample: pick, point, BSDF, shadow ray, MIS
REPEAT_SAMPLE_LIGHT = "repeat_sample_light"  # the light pick and the point on it
REPEAT_VISIBLE = "repeat_visible"        # the shadow ray (reversed direction)
REPEAT_SAMPLE_BSDF = "repeat_sample_bsdf"    # the scattering direction and its weight
REPEAT_DRAW = "repeat_draw"              # every 2D point-set draw of the integrator, once more
REPEATS = (REPEAT_CAMERA, REPEAT_INTERSECT, REPEAT_NEXT_EVENT, REPEAT_SAMPLE_LIGHT, REPEAT_VISIBLE,
           REPEAT_SAMPLE_BSDF, REPEAT_DRAW)

# Scenes with at least this many spheres find them through a wp.Bvh of their bounding boxes instead
# of a loop over all of them. `make bench` measures the crossover (experiments/bench/primitives.py,
# results/bench/render.json "primitives"): the BVH is as fast as the loop at 15-17 spheres on the
# sphere-grid scene (2-core x86 CPU, Warp 1.19; 0.85x the loop's speed at 4, 2.2x at 100, 120x at
# 10^4), so from 20 on. A module value so that the bench and the tests can force either side
# (SPHERE_BVH_MIN = 0: always, a huge value: never).
SPHERE_BVH_MIN = 20

# On the CPU, the lone quads and open boxes' faces of a scene are one vector test
# (kernels/intersection/quad_simd.py; quad_records.vector_lanes) when they are at least
# QUAD_SIMD_MIN and at most QUAD_SIMD_MAX; else, and on CUDA, every quad is in the scalar grouped
# tests. Closed boxes stay slab tests behind their bounding ball either way: their faces as lanes
# made a scene of one lone quad and one box (environment) 7% slower. Measured on the built-in
# scenes (2-8 lanes): 1.00-1.65x the all-scalar speed. PROVISIONAL upper bound: no built-in scene
# has more than 8 lanes; past some count a BVH of the quads would be the better test.
QUAD_SIMD_MIN = 2
QUAD_SIMD_MAX = 64


def uses_quad_simd(lanes: int) -> bool:
    return QUAD_SIMD_MIN <= lanes <= QUAD_SIMD_MAX


# Features the kernels test at runtime (a branch per sample or hit), not at code generation.
RUNTIME_SWITCHES = ("lens", "motion", "checker", "background")

# Whitted splits a ray at up to this many dielectric interfaces (2**N reflect/refract paths).
WHITTED_SPLITS = 4
SPLITTING_KINDS = frozenset(kinds_where(lambda k: k.transmits))    # they reflect and refract
ANISOTROPIC_KINDS = frozenset(kinds_where(lambda k: k.anisotropic))


def material_kinds(scene: Scene) -> frozenset:
    """The material kinds the scene's shapes use."""
    return frozenset(scene.materials[shape.material].kind for shape in scene.shapes)


def splits_for(kinds: frozenset) -> int:
    """How many dielectric interfaces Whitted splits a ray at in a scene of these material kinds."""
    return WHITTED_SPLITS if kinds & SPLITTING_KINDS else 0


@dataclass(frozen=True)
class Features:
    """What a scene uses; one compiled kernel per distinct code_key() (with the sampler)."""
    integrator: str
    lens: bool              # thin lens (never for whitted)
    motion: bool            # moving shapes within an open shutter (never for whitted)
    spheres: bool
    quads: bool
    kinds: frozenset        # material kinds of the shapes
    checker: bool
    area_lights: bool
    point_lights: bool
    dir_lights: bool
    roulette: bool          # Russian roulette (path and plugin integrators; not ROULETTE_FREE)
    background: bool        # escaping rays carry radiance
    # Deliberately wrong estimators, compiled in only for the tests' negative controls (see FAULTS).
    faults: frozenset = frozenset()
    moments: bool = False   # also sum each sample's square (a per-pixel variance image)
    meshes: bool = False    # triangle meshes (wp.Mesh ray queries; absent: compiled out)
    sphere_bvh: bool = False  # spheres found through a wp.Bvh (uses_sphere_bvh), else by a loop
    environment: bool = False  # an [environment] light (kernels/environment.py; absent: compiled out)
    filter: str = "box"     # pixel filter (kernels/filters.py); box: no filter code at all
    splat: bool = False     # the splatting estimator of a non-box filter (else filter importance sampling)
    filter_stddev: float = 0.0  # the filter's stddev (kernels/filters.get_filter); 0: its default
    filter_clip: bool = False   # the filter truncated to the film (Camera.filter_clip)
    quad_simd: bool = False  # quads by the CPU's vector test (QUAD_SIMD_MAX), else grouped scalar tests
    orthographic: bool = False  # an orthographic camera (kernels/camera.py; absent: compiled out)
    spot_lights: bool = False  # some point light is a spot (kernels/spot.py; absent: compiled out)
    textures: bool = False  # some material reads a texture (kernels/materials/texture.py; absent:
                            # compiled out)
    masks: bool = False     # some material has opacity < 1 (kernels/materials/mask.py; absent:
                            # compiled out)
    one_sided: bool = False  # some material is black from behind (mask.py; absent: compiled out)
    emission_textures: bool = False  # some emitter's emission is textured (kernels/emission.py;
                                     # absent: compiled out)
    projections: bool = False  # some point light projects: a projector or a textured spot
                               # (kernels/projection.py; absent: compiled out)
    mesh_attributes: bool = False  # some texture is a mesh attribute (kernels/materials/
                                   # mesh_attribute.py; absent: compiled out)
    frame_maps: bool = False  # some material has a normal or bump map (kernels/materials/shading_frame.py;
                              # absent: compiled out)
    emitter_samples: int = 1  # the direct integrator's light and BSDF samples (compile-time counts)
    bsdf_samples: int = 1

    def __post_init__(self):
        if self.roulette and self.integrator in ROULETTE_FREE:
            raise ValueError(f"{self.integrator} has no Russian roulette")

    @property
    def whitted(self) -> bool:
        return self.integrator == "whitted"

    @property
    def drt(self) -> bool:
        return self.integrator == "drt"

    @property
    def whitted_splits(self) -> int:
        """Dielectric interfaces a Whitted ray splits at (0: none, or not Whitted)."""
        return splits_for(self.kinds) if self.whitted else 0

    @property
    def light_centres(self) -> bool:
        """Whitted lights surfaces by shadow rays to the area lights' centres."""
        return self.area_lights and self.whitted

    @property
    def sampled_area_lights(self) -> bool:
        """The stochastic integrators sample area lights (next-event estimation)."""
        return self.area_lights and not self.whitted

    @property
    def anisotropic(self) -> bool:
        """A kind whose lobe turns with the surface's tangent (MaterialKind.anisotropic): the hit's
        tangent, alpha_v and roughness textures reach the BSDF (kernels/materials/material_at.py)."""
        return bool(self.kinds & ANISOTROPIC_KINDS)

    @property
    def delta_lights(self) -> bool:
        """Point or directional lights, evaluated exactly at every non-delta surface."""
        return self.point_lights or self.dir_lights

    @property
    def filter_def(self):
        """The pixel filter's definition (kernels/filters.py: Filter), its stddev applied."""
        from drtlab.kernels.filters import get_filter
        return get_filter(self.filter, self.filter_stddev)

    def code_key(self) -> Features:
        """The features the generated code depends on: a lens, motion, checker textures and a
        background are runtime switches in the kernels (RUNTIME_SWITCHES), not variant selectors."""
        return replace(self, **{name: False for name in RUNTIME_SWITCHES})

    def key(self) -> str:
        flags = [n for n in ("lens", "motion", "spheres", "quads", "checker", "area_lights",
                             "point_lights", "dir_lights", "roulette", "background", "meshes",
                             "sphere_bvh", "environment", "quad_simd", "orthographic", "spot_lights",
                             "textures", "masks", "one_sided", "projections", "emission_textures",
                             "mesh_attributes", "frame_maps")
                 if getattr(self, n)]
        key = f"{self.integrator}[{','.join(flags)}|{','.join(sorted(self.kinds))}]"
        key += (f"+{self.filter}" + (f"{self.filter_stddev:g}" if self.filter_stddev else "")
                + ("-clip" if self.filter_clip else "") + ("-splat" if self.splat else "")
                if self.filter != "box" else "")
        key += "+moments" if self.moments else ""
        if self.integrator == "direct":
            key += f"+e{self.emitter_samples}b{self.bsdf_samples}"
        return key + (f"!{','.join(sorted(self.faults))}" if self.faults else "")


def features_of(scene: Scene, integrator: str) -> Features:
    """The features `integrator` needs to render `scene`."""
    if scene.camera.orthographic and integrator == "whitted":
        raise InputError("integrator", "whitted traces a pinhole's sub-pixel grid; an orthographic "
                                       "camera renders with drt or path")
    if integrator == "whitted" and any(scene.materials[s.material].opacity < 1.0
                                       or "opacity" in scene.materials[s.material].textures for s in scene.shapes):
        raise InputError("integrator", "whitted does not sample a mask's pass-through (a material's "
                                       "opacity < 1); render with path, drt or direct")
    return Features(
        integrator=integrator,
        lens=scene.camera.has_lens and integrator != "whitted",
        motion=scene.has_motion and integrator != "whitted",
        spheres=any(shape.kind == "sphere" for shape in scene.shapes),
        quads=any(shape.kind == "quad" for shape in scene.shapes),
        kinds=material_kinds(scene),
        checker=any(scene.materials[shape.material].checker is not None for shape in scene.shapes),
        area_lights=bool(scene.emitter_shapes()),
        point_lights=bool(scene.point_lights),
        dir_lights=bool(scene.directional_lights),
        roulette=scene.russian_roulette and integrator not in ROULETTE_FREE,
        background=bool(np.any(np.asarray(scene.background) > 0)),
        meshes=any(shape.kind == "mesh" for shape in scene.shapes),
        sphere_bvh=uses_sphere_bvh(scene),
        environment=scene.environment is not None,
        filter=scene.camera.filter,
        filter_stddev=scene.camera.filter_stddev,
        filter_clip=scene.camera.filter_clip,
        orthographic=scene.camera.orthographic,
        spot_lights=any(pl.spot for pl in scene.point_lights),
        projections=any(pl.projects for pl in scene.point_lights),
        emission_textures=any("emission" in scene.materials[s.material].textures for s in scene.shapes),
        textures=any(scene.materials[s.material].textures for s in scene.shapes),
        masks=any(scene.materials[s.material].opacity < 1.0 or "opacity" in scene.materials[s.material].textures
                  for s in scene.shapes),
        one_sided=any(scene.materials[s.material].one_sided for s in scene.shapes),
        mesh_attributes=any(t.kind == "mesh_attribute" for s in scene.shapes
                            for t in scene.materials[s.material].textures.values()),
        frame_maps=any({"normal", "bump"} & set(scene.materials[s.material].textures) for s in scene.shapes),
        # Other integrators ignore them: the defaults, so that their variants stay one each.
        emitter_samples=scene.emitter_samples if integrator == "direct" else 1,
        bsdf_samples=scene.bsdf_samples if integrator == "direct" else 1,
    )


def grown_margin(f: Features) -> int:
    """Pixels beyond each image edge whose samples splatting traces: the filter's margin, or none
    when the estimator is not splatting or the filter is cut at the film's edge (filter_clip)."""
    return f.filter_def.margin if f.splat and f.filter != "box" and not f.filter_clip else 0


def uses_sphere_bvh(scene: Scene) -> bool:
    """Whether the scene's spheres are many enough for the BVH (SPHERE_BVH_MIN, read at call time)."""
    return sum(shape.kind == "sphere" for shape in scene.shapes) >= max(SPHERE_BVH_MIN, 1)
