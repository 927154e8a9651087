"""Direct lighting at a surface point, per kernel variant: delta lights, area-light samples, MIS weights.

`make_direct(features, strategy, rays=rays, bsdf=bsdf, lights=lights)` (from make_intersect,
make_bsdf and make_lights) returns DirectLighting, Warp functions:
    direct_delta_lights(sd, mat, p, n, ns, wo, dt) -> point (spot: times its falloff,
        kernels/spot.py; a projection's factor, kernels/projection.py) and directional light (n: geometric normal, which offsets shadow rays; ns: shading normal, which the BSDF
        sees; equal but on meshes, where geometry.shading_consistent guards against leaks)
    next_event(sd, beta, mat, h, wo, u_light, u_point, bounce, dt) -> beta
        times one area-light sample's estimate (MIS-weighted when the strategy combines by MIS) at
        h, the path vertex of bounce index `bounce` (0: the camera ray's hit)
    light_visible(sd, h, li, ls, dt) -> 1 when the shadow ray of light li's sample ls from hit h
        reaches it unblocked, else 0
    hit_weight(sd, h, prev_delta, prev_pdf, prev_p, prev_bounce, dt) -> weight of an emitter a
        scattered ray hits (light_pdf at the hit's point and, on a mesh, its face, from prev_p, the
        vertex of bounce index prev_bounce that scattered it: which density its light sample used
        depends on that index, lights.SPHERICAL_MAX_BOUNCE)
With an environment (`environment`: kernels/environment_lighting.py) the light choice u_light first
picks it with probability env_pick (u_light < env_pick), else an area light with u_light rescaled to
[0, 1); the area lights' densities then carry the factor 1 - env_pick.
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import MESH, SceneData
from drtlab.kernels.features import DROP_COSINE, REPEAT_SAMPLE_LIGHT, REPEAT_VISIBLE, Features
from drtlab.kernels.intersection.primitives import Hit, offset_origin, shading_consistent
from drtlab.kernels.intersection.scene_rays import SceneRays
from drtlab.kernels.lights import AreaLights, LightSample
from drtlab.kernels.materials import Bsdf
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.mis import heuristic_of
from drtlab.kernels.projection import projected
from drtlab.kernels.spot import spot_falloff


class DirectLighting(NamedTuple):
    direct_delta_lights: wp.Function
    next_event: wp.Function
    hit_weight: wp.Function
    light_visible: wp.Function


def make_direct(f: Features, strategy: Strategy, *, rays: SceneRays, bsdf: Bsdf,
                lights: AreaLights, environment=None) -> DirectLighting:
    ENV = environment is not None
    env_pick = environment.env_pick if ENV else None
    env_next_event = environment.env_next_event if ENV else None
    POINTS = f.point_lights
    SPOTS = f.spot_lights
    PROJECTIONS = f.projections
    DIRS = f.dir_lights
    MIS = strategy.mis
    mis_weight = heuristic_of(strategy, f.faults)
    COUNT_HITS = strategy.counts_hits
    FAULT_DROP_COSINE = DROP_COSINE in f.faults
    MESHES = f.meshes
    # The profile's probes (features.REPEATS), folded into the estimate at 1e-30.
    TWICE_SAMPLE_LIGHT = REPEAT_SAMPLE_LIGHT in f.faults
    TWICE_VISIBLE = REPEAT_VISIBLE in f.faults
    visible = rays.visible
    eval_bsdf = bsdf.eval_bsdf
    pdf_bsdf = bsdf.pdf_bsdf
    pick_light = lights.pick_light
    light_pdf = lights.light_pdf
    sample_light = lights.sample_light

    @wp.func
    def direct_delta_lights(sd: SceneData, mat: MaterialAt, p: wp.vec3, n: wp.vec3, ns: wp.vec3, wo: wp.vec3,
                            dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        if wp.static(POINTS):
            i = int(0)
            while i < sd.lights.n_point:
                d = sd.lights.point_position[i] - p
                dist = wp.length(d)
                wi = d / dist
                fc = eval_bsdf(mat, ns, wo, wi)
                if wp.static(MESHES):
                    fc = fc * shading_consistent(n, ns, wo, wi)
                if wp.static(SPOTS):    # a point light's cone gives exactly 1
                    fc = fc * spot_falloff(-wp.dot(wi, sd.lights.point_axis[i]), sd.lights.point_cone[i])
                if wp.static(PROJECTIONS):
                    fc = wp.cw_mul(fc, projected(sd, i, -wi))
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, wp.length(sd.lights.point_position[i] - o), dt, -1, -1) == 1:
                        L += wp.cw_mul(fc, sd.lights.point_intensity[i]) / (dist * dist)
                i += 1
        if wp.static(DIRS):
            i = int(0)
            while i < sd.lights.n_dir:
                wi = -sd.lights.dir_direction[i]
                fc = eval_bsdf(mat, ns, wo, wi)
                if wp.static(MESHES):
                    fc = fc * shading_consistent(n, ns, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, 1.0e30, dt, -1, -1) == 1:
                        L += wp.cw_mul(fc, sd.lights.dir_irradiance[i])
                i += 1
        return L

    @wp.func
    def next_event(sd: SceneData, beta: wp.vec3, mat: MaterialAt, h: Hit, wo: wp.vec3, u_light: float,
                   u_point: wp.vec2, bounce: int, dt: float) -> wp.vec3:
        ul = u_light
        share = float(1.0)      # the area lights' share of the light choice
        if wp.static(ENV):
            pe = env_pick(sd.environment)
            if ul < pe:
                return env_next_event(sd, beta, mat, h, wo, u_point, pe, dt)
            ul = (ul - pe) / (1.0 - pe)
            share = 1.0 - pe
        li = pick_light(sd, h.p, ul)
        ls = sample_light(sd, li, h.p, u_point, bounce, dt)
        probe = float(0.0)
        if wp.static(TWICE_SAMPLE_LIGHT):
            probe += sample_light(sd, pick_light(sd, h.p, 1.0 - ul), h.p,
                                  wp.vec2(u_point[1], u_point[0]), bounce, dt).pdf
        if wp.static(ENV):
            ls.pdf = ls.pdf * share
        if ls.valid == 1:
            ns = h.n
            if wp.static(MESHES):
                ns = h.ns
            fc = eval_bsdf(mat, ns, wo, ls.wi)
            if wp.static(MESHES):
                fc = fc * shading_consistent(h.n, ns, wo, ls.wi)
            if wp.static(FAULT_DROP_COSINE):
                fc = fc / wp.abs(wp.dot(h.n, ls.wi))
            if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                so = offset_origin(h.p, h.n, ls.wi, sd.eps)
                lk = sd.lights.shape_kind[li]
                target = sd.lights.shape[li]
                if wp.static(MESHES):
                    if lk == MESH:
                        target = ls.prim        # visible() needs the face, not just the mesh
                if wp.static(TWICE_VISIBLE):
                    probe += float(visible(sd, so, -ls.wi, ls.dist, dt, lk, target)) * ls.dist
                if visible(sd, so, ls.wi, ls.dist, dt, lk, target) == 1:
                    w = float(1.0)
                    if wp.static(MIS):
                        pb = pdf_bsdf(mat, ns, wo, ls.wi)
                        w = mis_weight(ls.pdf, pb)
                    est = wp.cw_mul(beta, wp.cw_mul(fc, ls.radiance)) * (w / ls.pdf)
                    if wp.static(TWICE_SAMPLE_LIGHT or TWICE_VISIBLE):
                        est += wp.vec3(1.0e-30 * probe)
                    return est
        if wp.static(TWICE_SAMPLE_LIGHT or TWICE_VISIBLE):
            return wp.vec3(1.0e-30 * probe)
        return wp.vec3(0.0)

    @wp.func
    def hit_weight(sd: SceneData, h: Hit, prev_delta: int, prev_pdf: float, prev_p: wp.vec3,
                   prev_bounce: int, dt: float) -> float:
        # Camera rays and delta bounces see emitters at full weight; after a non-delta bounce
        # MIS weighs the hit against light sampling, NEE alone counts it through light samples.
        w = float(1.0)
        if prev_delta == 0:
            if wp.static(MIS):
                pl = light_pdf(sd, h.light, prev_p, h.p, h.n, h.index, prev_bounce, dt)
                if wp.static(ENV):
                    pl = pl * (1.0 - env_pick(sd.environment))
                w = mis_weight(prev_pdf, pl)
            elif wp.static(not COUNT_HITS):
                w = 0.0
        return w

    @wp.func
    def light_visible(sd: SceneData, h: Hit, li: int, ls: LightSample, dt: float) -> int:
        # The shadow ray of light li's sample ls from the hit h: 1 when nothing blocks it.
        so = offset_origin(h.p, h.n, ls.wi, sd.eps)
        lk = sd.lights.shape_kind[li]
        target = sd.lights.shape[li]
        if wp.static(MESHES):
            if lk == MESH:
                target = ls.prim        # visible() needs the face, not just the mesh
        return visible(sd, so, ls.wi, ls.dist, dt, lk, target)

    return DirectLighting(direct_delta_lights=direct_delta_lights, next_event=next_event,
                          hit_weight=hit_weight, light_visible=light_visible)
