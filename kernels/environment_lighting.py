"""Lighting by the environment, per kernel variant: its next-event estimate and the weight of a ray
that leaves the scene.

`make_environment_lighting(features, strategy, rays=rays, bsdf=bsdf)` (from make_intersect and
make_bsdf) returns EnvironmentLighting, Warp functions:
    env_next_event(sd, beta, mat, h, wo, u, pick, dt) -> beta times one
        environment sample's estimate; `pick` is the probability the light choice gave it
        (kernels/direct.py splits the light choice between the environment and the area lights)
    env_escape(sd, d, prev_delta, prev_pdf, prev_n) -> the radiance a ray leaving along d brings,
        weighted as kernels/direct.py's hit_weight weighs an emitter hit: full after the camera or a
        delta bounce; after a non-delta bounce MIS against the environment sampler's density
        (power heuristic), or 0 when emitters count only through light samples
    oriented(ns, wo) -> the shading normal on wo's side, the cosine sampler's axis (prev_n)
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.environment import make_environment
from drtlab.kernels.features import DROP_COSINE, Features
from drtlab.kernels.intersection.primitives import Hit, offset_origin, shading_consistent
from drtlab.kernels.intersection.scene_rays import SceneRays
from drtlab.kernels.materials import Bsdf
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.mis import heuristic_of


class EnvironmentLighting(NamedTuple):
    env_pick: wp.Function
    env_next_event: wp.Function
    env_escape: wp.Function


@wp.func
def oriented(ns: wp.vec3, wo: wp.vec3) -> wp.vec3:
    if wp.dot(ns, wo) < 0.0:
        return -ns
    return ns


def make_environment_lighting(f: Features, strategy: Strategy, *, rays: SceneRays,
                              bsdf: Bsdf) -> EnvironmentLighting:
    MIS = strategy.mis
    mis_weight = heuristic_of(strategy, f.faults)
    COUNT_HITS = strategy.counts_hits
    MESHES = f.meshes
    FAULT_DROP_COSINE = DROP_COSINE in f.faults
    env = make_environment(strategy)
    env_sample, env_pdf, env_pick, env_radiance = (env.env_sample, env.env_pdf, env.env_pick,
                                                   env.env_radiance)
    visible = rays.visible
    eval_bsdf = bsdf.eval_bsdf
    pdf_bsdf = bsdf.pdf_bsdf

    @wp.func
    def env_next_event(sd: SceneData, beta: wp.vec3, mat: MaterialAt, h: Hit, wo: wp.vec3, u: wp.vec2,
                       pick: float, dt: float) -> wp.vec3:
        ns = h.n
        if wp.static(MESHES):
            ns = h.ns
        es = env_sample(sd.environment, oriented(ns, wo), u)
        if es.valid == 1:
            fc = eval_bsdf(mat, ns, wo, es.wi)
            if wp.static(MESHES):
                fc = fc * shading_consistent(h.n, ns, wo, es.wi)
            if wp.static(FAULT_DROP_COSINE):
                fc = fc / wp.abs(wp.dot(h.n, es.wi))
            c = wp.cw_mul(fc, es.radiance)
            if c[0] > 0.0 or c[1] > 0.0 or c[2] > 0.0:
                so = offset_origin(h.p, h.n, es.wi, sd.eps)
                if visible(sd, so, es.wi, 1.0e30, dt, -1, -1) == 1:
                    pdf = es.pdf * pick
                    w = float(1.0)
                    if wp.static(MIS):
                        pb = pdf_bsdf(mat, ns, wo, es.wi)
                        w = mis_weight(pdf, pb)
                    return wp.cw_mul(beta, c) * (w / pdf)
        return wp.vec3(0.0)

    @wp.func
    def env_escape(sd: SceneData, d: wp.vec3, prev_delta: int, prev_pdf: float,
                   prev_n: wp.vec3) -> wp.vec3:
        w = float(1.0)
        if prev_delta == 0:
            if wp.static(MIS):
                pl = env_pick(sd.environment) * env_pdf(sd.environment, prev_n, d)
                w = mis_weight(prev_pdf, pl)
            elif wp.static(not COUNT_HITS):
                w = 0.0
        return env_radiance(sd.environment, d) * w

    return EnvironmentLighting(env_pick=env_pick, env_next_event=env_next_event,
                               env_escape=env_escape)
