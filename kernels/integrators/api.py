"""The estimator API: the one namespace of Warp functions an integrator is written with.

`make_api(features, pointset, strategy, own=DIMENSIONS)` builds it for one kernel variant (what
the scene lacks compiled out); `kernels/render_kernel.py` hands it to the integrator's
`make(api) -> trace`, and `trace(sd, seed, pix, idx, spp, o, d, dt) -> wp.vec3` is called once per
camera sample. docs/plugins.md states each function's contract; in short:

    scene      intersect(sd, o, d, tmax, dt) -> Hit;  visible(sd, o, d, dist, dt, kind, index) -> 1/0;
               offset_origin(p, n, wi, eps); shading_normal(h); shading_consistent(n, ns, wo, wi)
    material   material_at_hit(sd, h) -> MaterialAt (also what only the hit knows: a mesh's
               attributes, an anisotropic lobe's tangent; material_at(sd, m, uv) without them);
               frame_at(sd, mat, h, wo) -> mat with the hit's normal or bump map (mat itself
               without one); eval_bsdf(mat, ns, wo, wi) -> f|cos|;
               pdf_bsdf(mat, ns, wo, wi); sample_bsdf(mat, ns, wo, u_lobe, u) -> Scatter;
               is_delta(kind) -> bool; kind(sd, m) -> int; emitted(sd, h, wo)
    lights     pick_light(sd, x, u); light_pick_pmf(sd, x, li); sample_light(sd, li, x, u, bounce, dt)
               -> LightSample; light_pdf(sd, li, x, y, ny, prim, bounce, dt);
               light_visible(sd, h, li, ls, dt) -> 1/0; next_event(sd, beta,
               mat, h, wo, u_light, u_point, bounce, dt); hit_weight(sd, h, prev_delta, prev_pdf,
               prev_p, prev_bounce, dt); direct_delta_lights(sd, mat, p, n, ns, wo, dt)
    environment  escape(sd, d, prev_delta, prev_pdf, prev_n) -> what a ray leaving the scene brings
               (the background without an environment); oriented(ns, wo)
    camera     camera_ray(sd, seed, pix, idx, spp, px, py) -> CameraRay
    MIS        mis_weight(a, b) (the strategy's heuristic), power_heuristic, balance_heuristic
    roulette   roulette(beta, u) -> the survivor's throughput beta / q, or 0 (killed)
    numbers    get1d(seed, pix, idx, dim, spp), get2d(...); dim(name)(depth) -> the uint32
               dimension of a named decision at a bounce (the built-in ones and the integrator's own DIMENSIONS)
    vertex     direct_light(sd, L, beta, mat, h, wo, ns, seed, pix, idx, spp, depth, dt) -> L plus
               the vertex's light sample and delta lights; scatter(mat, h, wo, ns, seed, pix, idx,
               spp, depth) -> Scatter, valid = 0 where the path ends (kernels/integrators/vertex.py)

The suite's negative controls (features.FAULTS) and the profiler's probes (features.REPEATS) are
applied here, to the functions handed out (kernels/integrators/probes.py), so that no integrator's
body names them.
"""
from __future__ import annotations

from typing import NamedTuple

import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.camera import make_camera
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.direct import make_direct
from drtlab.kernels.environment import env_radiance
from drtlab.kernels.environment_lighting import make_environment_lighting, oriented
from drtlab.kernels.features import Features
from drtlab.kernels.filter_sampling import make_pixel_filter
from drtlab.kernels.integrators.probes import with_probes
from drtlab.kernels.integrators.vertex import with_vertex_steps
from drtlab.kernels.intersection.motion import make_motion
from drtlab.kernels.intersection.primitives import Hit, offset_origin, shading_consistent
from drtlab.kernels.intersection.scene_rays import make_intersect
from drtlab.kernels.lights import make_lights
from drtlab.kernels.emission import emitted_for
from drtlab.kernels.materials import DIFFUSE, EMITTER, LOBE_CHOICE_KINDS, make_bsdf
from drtlab.kernels.materials.dielectric import interface, refract_dir
from drtlab.kernels.materials.material_at import material_at_for
from drtlab.kernels.materials.shading_frame import frame_at_for
from drtlab.kernels.mis import balance_heuristic, heuristic_of, power_heuristic
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME, MATERIAL_CODE
from drtlab.kernels.static_tag import variant_tag
from drtlab.kernels.whitted import make_whitted_parts


# Hard cap on path length even for max_depth = -1 with roulette (guards against a stuck loop).
DEPTH_CAP = 512


class EstimatorApi(NamedTuple):
    # What the variant has, for wp.static (Python values, read when the integrator is built).
    features: Features
    strategy: Strategy
    next_events: bool       # lights to sample: area lights or an environment, and a strategy that does
    choice_from: int        # the light choice is drawn from this many area lights on (1 with an env)
    lobe_choice: bool       # a kind that reads the lobe-choice number is present
    depth_cap: int
    diffuse: int            # kind codes the built-ins test (drt stops after DIFFUSE)
    emitter: int
    # Scene queries
    intersect: wp.Function
    visible: wp.Function
    visible_mesh: wp.Function
    offset_origin: wp.Function
    shading_normal: wp.Function
    shading_consistent: wp.Function
    # The material at a hit
    material_at: wp.Function
    material_at_hit: wp.Function
    kind: wp.Function
    is_delta: wp.Function
    eval_bsdf: wp.Function
    pdf_bsdf: wp.Function
    sample_bsdf: wp.Function
    emitted: wp.Function
    # Lights
    pick_light: wp.Function
    light_pick_pmf: wp.Function
    sample_light: wp.Function
    light_pdf: wp.Function
    next_event: wp.Function
    hit_weight: wp.Function
    light_visible: wp.Function
    direct_delta_lights: wp.Function
    # The environment (or the background)
    escape: wp.Function
    env_radiance: wp.Function
    oriented: wp.Function
    # Camera rays
    camera_ray: wp.Function
    # MIS, roulette
    mis_weight: wp.Function
    power_heuristic: wp.Function
    balance_heuristic: wp.Function
    roulette: wp.Function
    # Random numbers
    get1d: wp.Function
    get2d: wp.Function
    dim: object             # (depth: int, name: str) -> wp.uint32 dimension, see make_dims
    # Whitted's pieces (kernels/whitted.py): deterministic lighting and specular chains
    light_centres: wp.Function
    ends_path: wp.Function
    specular_reflect: wp.Function
    splits: wp.Function
    interface: wp.Function          # (ns, wo, ior) -> a smooth interface's eta and Fresnel F
    refract_dir: wp.Function        # (wo, nf, cos_o, eta) -> the refracted direction
    pixel_filter: object            # kernels/filter_sampling.PixelFilter, or None (the box)
    # One vertex's steps, composed from the functions above once the probes wrap them (vertex.py)
    direct_light: wp.Function = None
    scatter: wp.Function = None
    # The hit's normal or bump map applied to the material at it (the identity in a variant without)
    frame_at: wp.Function = None


def make_dims(own=()) -> object:
    """`dim(depth, name)`, a Python function returning the Warp function of one named decision:
    `api.dim("direction")(depth)` is the uint32 dimension of bounce `depth`'s direction (its 2D
    pair starts there). Built-in names: estimators/dimensions.BUILT_IN; an integrator's own:
    its DIMENSIONS (dimensions.own_layout), each at its own dimension, none moving another."""
    offsets, stride = dims.own_layout(own)
    bounce_base = dims.warp_functions().bounce_base
    cache = {}

    def dim(name: str):
        if name in cache:
            return cache[name]
        if name in dims.BUILT_IN:
            OFFSET = dims.BUILT_IN[name][0]

            @wp.func
            def at(depth: int) -> wp.uint32:
                return bounce_base(depth) + wp.uint32(wp.static(OFFSET))
        elif name in offsets:
            BASE, STRIDE, OFFSET = dims.OWN_BASE, stride, offsets[name]

            @wp.func
            def at(depth: int) -> wp.uint32:
                return (wp.uint32(wp.static(BASE)) + wp.uint32(wp.static(STRIDE)) * wp.uint32(depth)
                        + wp.uint32(wp.static(OFFSET)))
        else:
            raise KeyError(f"no sample decision named {name!r}: built-in "
                           f"{', '.join(dims.BUILT_IN)}; own {', '.join(offsets) or '(none declared)'}")
        cache[name] = at
        return at
    return dim


def make_api(f: Features, pointset: PointSet, strategy: Strategy, own=()) -> EstimatorApi:
    motion = make_motion()
    rays = make_intersect(f, motion=motion)
    bsdf = make_bsdf(f, strategy)
    lights = make_lights(f, strategy, motion=motion)
    environment = (make_environment_lighting(f, strategy, rays=rays, bsdf=bsdf)
                   if f.environment and not f.whitted else None)
    lighting = make_direct(f, strategy, rays=rays, bsdf=bsdf, lights=lights, environment=environment)
    whitted = make_whitted_parts(f, rays=rays, bsdf=bsdf)
    pixel_filter = make_pixel_filter(f)
    camera_ray = make_camera(f, pointset, pixel_filter)
    ENV = environment is not None
    env_escape = environment.env_escape if ENV else None
    MESHES = f.meshes
    # The kind table's delta kinds present: their one direction has no density for light sampling.
    DELTA_CODES = tuple(MATERIAL_CODE[k] for k in sorted(f.kinds) if KIND_BY_NAME[k].delta)

    @wp.func
    def escape(sd: SceneData, d: wp.vec3, prev_delta: int, prev_pdf: float,
               prev_n: wp.vec3) -> wp.vec3:
        if wp.static(ENV):
            return env_escape(sd, d, prev_delta, prev_pdf, prev_n)
        return sd.background

    @wp.func
    def shading_normal(h: Hit) -> wp.vec3:
        # The BSDF sees the shading normal (a mesh's interpolated one); offsets and the side test
        # stay geometric (shading_consistent).
        if wp.static(MESHES):
            return h.ns
        return h.n

    @wp.func
    def kind(sd: SceneData, m: int) -> int:
        return sd.materials.kind[m]

    @wp.func
    def is_delta(kind: int) -> bool:
        delta = False
        _deltas = wp.static(variant_tag(DELTA_CODES))  # noqa: F841 (static_tag.py)
        for i in range(wp.static(len(DELTA_CODES))):
            if kind == wp.static(DELTA_CODES[i]):
                delta = True
        return delta

    @wp.func
    def roulette(beta: wp.vec3, u: float) -> wp.vec3:
        q = wp.min(wp.max(beta[0], wp.max(beta[1], beta[2])), 0.95)
        if u >= q:
            return wp.vec3(0.0)
        return beta / q

    materials = material_at_for(f.textures, f.masks or f.one_sided, f.kinds, f.mesh_attributes)
    api = EstimatorApi(
        features=f, strategy=strategy,
        next_events=(f.sampled_area_lights or ENV) and strategy.light is not None,
        choice_from=1 if ENV else 2,
        lobe_choice=bool(f.kinds & LOBE_CHOICE_KINDS) or f.masks, depth_cap=DEPTH_CAP,
        diffuse=int(DIFFUSE), emitter=int(EMITTER),
        intersect=rays.intersect, visible=rays.visible, visible_mesh=rays.visible_mesh,
        offset_origin=offset_origin, shading_normal=shading_normal,
        shading_consistent=shading_consistent,
        material_at=materials[0], material_at_hit=materials[1], kind=kind, is_delta=is_delta,
        eval_bsdf=bsdf.eval_bsdf,
        pdf_bsdf=bsdf.pdf_bsdf, sample_bsdf=bsdf.sample_bsdf, emitted=emitted_for(f),
        pick_light=lights.pick_light, light_pick_pmf=lights.light_pick_pmf,
        sample_light=lights.sample_light, light_pdf=lights.light_pdf,
        next_event=lighting.next_event, hit_weight=lighting.hit_weight,
        light_visible=lighting.light_visible,
        direct_delta_lights=lighting.direct_delta_lights,
        escape=escape, env_radiance=env_radiance, oriented=oriented,
        camera_ray=camera_ray,
        mis_weight=heuristic_of(strategy, f.faults), power_heuristic=power_heuristic,
        balance_heuristic=balance_heuristic, roulette=roulette,
        get1d=pointset.get1d, get2d=pointset.get2d, dim=make_dims(own),
        light_centres=whitted.light_centres, ends_path=whitted.ends_path,
        specular_reflect=whitted.specular_reflect, splits=whitted.splits,
        interface=interface, refract_dir=refract_dir, pixel_filter=pixel_filter,
        frame_at=frame_at_for(f.frame_maps))
    return with_vertex_steps(with_probes(api, f))
