"""The suite's negative controls and the profiler's probes, as wrappers of the API's functions.

`with_probes(api, features)` returns the API with each function a fault or probe of
`features.faults` concerns replaced by a wrapper around it; without faults the API is returned
unchanged (no wrapper, no cost). So every integrator, built-in or a plugin, gets the same controls
and probes, and none of them names one in its body.

Negative controls (features.FAULTS; the statistical tests must reject them):
    DROP_COSINE     sample_bsdf's weight of a non-delta scatter and eval_bsdf's f|cos| divided by
                    |cos| at the vertex (kernels/direct.py's next_event drops it from its own)
    PDF_HIGH_10PCT  sample_bsdf's weight of a non-delta scatter divided by 1.1 (its pdf claimed 10% high)
    RR_NO_REWEIGHT  roulette kills as before but returns the survivor's throughput unweighted
Probes (features.REPEATS): the wrapped function does its work a second time on perturbed inputs and
folds the result in at 1e-30 (below float32 rounding, and the compiler cannot drop it):
    REPEAT_INTERSECT     intersect (the reversed ray), into the hit point
    REPEAT_NEXT_EVENT    next_event (the other light choice, the swapped point), into its estimate
    REPEAT_SAMPLE_BSDF   sample_bsdf (the swapped direction numbers), into its weight
    REPEAT_DRAW          get2d (the next sample index), into the value: every 2D draw of the path
(REPEAT_CAMERA wraps the camera ray in kernels/render_kernel.py; REPEAT_SAMPLE_LIGHT and
REPEAT_VISIBLE live in kernels/direct.py's next_event.)
"""
import warp as wp

from drtlab.kernels.features import (DROP_COSINE, PDF_HIGH_10PCT, REPEAT_DRAW, REPEAT_INTERSECT,
                                     REPEAT_NEXT_EVENT, REPEAT_SAMPLE_BSDF, RR_NO_REWEIGHT, Features)
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.materials import Scatter
from drtlab.kernels.materials.material_at import MaterialAt


def with_probes(api, f: Features):
    faults = f.faults
    changes = {}
    if DROP_COSINE in faults or PDF_HIGH_10PCT in faults or REPEAT_SAMPLE_BSDF in faults:
        changes["sample_bsdf"] = _sample_bsdf(api.sample_bsdf, DROP_COSINE in faults,
                                              PDF_HIGH_10PCT in faults, REPEAT_SAMPLE_BSDF in faults)
    if DROP_COSINE in faults:
        changes["eval_bsdf"] = _eval_without_cosine(api.eval_bsdf)
    if RR_NO_REWEIGHT in faults:
        changes["roulette"] = _roulette_no_reweight()
    if REPEAT_INTERSECT in faults:
        changes["intersect"] = _intersect_twice(api.intersect)
    if REPEAT_NEXT_EVENT in faults:
        changes["next_event"] = _next_event_twice(api.next_event)
    if REPEAT_DRAW in faults:
        changes["get2d"] = _draw_twice(api.get2d)
    return api._replace(**changes) if changes else api


def _sample_bsdf(sample_bsdf, drop_cosine: bool, pdf_high: bool, twice: bool):
    DROP, HIGH, TWICE = drop_cosine, pdf_high, twice

    @wp.func
    def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        s = sample_bsdf(mat, n, wo, u_lobe, u)
        if wp.static(TWICE):
            s.weight = s.weight + 1.0e-30 * sample_bsdf(mat, n, wo, u_lobe, wp.vec2(u[1], u[0])).weight
        if s.delta == 0:
            if wp.static(DROP):
                s.weight = s.weight / wp.abs(wp.dot(n, s.wi))
            if wp.static(HIGH):
                s.weight = s.weight / 1.1
        return s
    return sample


def _eval_without_cosine(eval_bsdf):
    @wp.func
    def eval_(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        return eval_bsdf(mat, n, wo, wi) / wp.abs(wp.dot(n, wi))
    return eval_


def _roulette_no_reweight():
    @wp.func
    def roulette(beta: wp.vec3, u: float) -> wp.vec3:
        q = wp.min(wp.max(beta[0], wp.max(beta[1], beta[2])), 0.95)
        if u >= q:
            return wp.vec3(0.0)
        return beta
    return roulette


def _intersect_twice(intersect):
    @wp.func
    def twice(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> Hit:
        h = intersect(sd, o, d, tmax, dt)
        h.p = h.p + wp.vec3(1.0e-30 * wp.min(intersect(sd, o, -d, tmax, dt).t, 1.0))
        return h
    return twice


def _next_event_twice(next_event):
    @wp.func
    def twice(sd: SceneData, beta: wp.vec3, mat: MaterialAt, h: Hit, wo: wp.vec3, u_light: float,
              u_point: wp.vec2, bounce: int, dt: float) -> wp.vec3:
        est = next_event(sd, beta, mat, h, wo, u_light, u_point, bounce, dt)
        return est + 1.0e-30 * next_event(sd, beta, mat, h, wo, 1.0 - u_light,
                                          wp.vec2(u_point[1], u_point[0]), bounce, dt)
    return twice


def _draw_twice(get2d):
    @wp.func
    def twice(seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
        v = get2d(seed, pix, idx, dim, spp)
        return v + wp.vec2(1.0e-30 * get2d(seed, pix, idx + wp.uint32(1), dim, spp)[0], 0.0)
    return twice
