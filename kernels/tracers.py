"""The stochastic tracers (path, drt) per kernel variant: one path of a sample, as a loop.

`make_trace(features, pointset, strategy, rays=rays, bsdf=bsdf, lighting=lighting)` (from
make_intersect, make_bsdf and make_direct) returns the Warp function
trace(sd, seed, pix, idx, spp, o, d, dt) -> radiance.
Random numbers come from the point set at the dimensions of estimators.dimensions per bounce.
"""
import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME, MATERIAL_CODE
from drtlab.kernels.direct import DirectLighting
from drtlab.kernels.environment_lighting import oriented
from drtlab.kernels.features import (DROP_COSINE, PDF_HIGH_10PCT, REPEAT_DRAW, REPEAT_INTERSECT,
                                     REPEAT_NEXT_EVENT, REPEAT_SAMPLE_BSDF, RR_NO_REWEIGHT,
                                     Features)
from drtlab.kernels.intersection.primitives import offset_origin, shading_consistent
from drtlab.kernels.intersection.scene_rays import SceneRays
from drtlab.kernels.materials import DIFFUSE, EMITTER, LOBE_CHOICE_KINDS, Bsdf, emitted
from drtlab.kernels.materials.material_at import material_at
from drtlab.kernels.static_tag import variant_tag

# Hard cap on path length even for max_depth = -1 with roulette (guards against a stuck loop).
DEPTH_CAP = 512


@wp.func
def black(c: wp.vec3) -> int:
    if c[0] > 0.0 or c[1] > 0.0 or c[2] > 0.0:
        return 0
    return 1


def make_trace(f: Features, pointset: PointSet, strategy: Strategy, *, rays: SceneRays, bsdf: Bsdf,
               lighting: DirectLighting, environment=None) -> wp.Function:
    get1d = pointset.get1d
    get2d = pointset.get2d
    bounce_base = dims.warp_functions().bounce_base
    AREA = f.area_lights
    # An environment (kernels/environment_lighting.py) is a light to sample and what escaping rays see.
    ENV = environment is not None
    env_escape = environment.env_escape if ENV else None
    NEE = (f.sampled_area_lights or ENV) and strategy.light is not None
    # With an environment the light choice matters from one area light on.
    CHOICE_FROM = 1 if ENV else 2
    DELTA_LIGHTS = f.delta_lights
    RR = f.roulette
    RR_REWEIGHT = RR_NO_REWEIGHT not in f.faults
    FAULT_DROP_COSINE = DROP_COSINE in f.faults
    FAULT_PDF_HIGH = PDF_HIGH_10PCT in f.faults
    # The profile's probes (features.REPEATS): compiled out of every other kernel.
    TWICE_INTERSECT = REPEAT_INTERSECT in f.faults
    TWICE_NEXT_EVENT = REPEAT_NEXT_EVENT in f.faults
    TWICE_SAMPLE_BSDF = REPEAT_SAMPLE_BSDF in f.faults
    TWICE_DRAW = REPEAT_DRAW in f.faults
    MESHES = f.meshes
    # The kind table's delta kinds present: their one direction has no density for light sampling.
    DELTA_CODES = tuple(MATERIAL_CODE[k] for k in sorted(f.kinds) if KIND_BY_NAME[k].delta)
    # Draws whose value the variant never reads are skipped (each dimension is keyed on its own, so
    # skipping one leaves every other value as it was): the lobe choice of one-lobe materials.
    LOBE_CHOICE = bool(f.kinds & LOBE_CHOICE_KINDS)
    # drt stops at the emission hit after a diffuse scatter; nothing to find there when emitters
    # count only through light samples and the background is black.
    DRT = f.drt
    DRT_COUNTS_HITS = strategy.counts_hits
    intersect = rays.intersect
    sample_bsdf = bsdf.sample_bsdf
    direct_delta_lights = lighting.direct_delta_lights
    next_event = lighting.next_event
    hit_weight = lighting.hit_weight

    # Called once per sample: inlined, so SceneData is not copied per call.
    @wp.func(inline=True)
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o0: wp.vec3, d0: wp.vec3, dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        beta = wp.vec3(1.0)
        o = o0
        d = d0
        depth = int(0)
        prev_delta = int(1)      # camera rays and delta bounces see emitters at full weight
        prev_pdf = float(0.0)
        prev_p = o0
        prev_n = d0              # the environment's cosine sampler's axis at the last vertex
        last_segment = int(0)    # drt: after a diffuse scatter only the emission hit counts
        while True:
            h = intersect(sd, o, d, 1.0e30, dt)
            if wp.static(TWICE_INTERSECT):
                L += wp.vec3(1.0e-30 * wp.min(intersect(sd, o, -d, 1.0e30, dt).t, 1.0))
            if h.index < 0:
                if wp.static(ENV):
                    L += wp.cw_mul(beta, env_escape(sd, d, prev_delta, prev_pdf, prev_n))
                else:
                    L += wp.cw_mul(beta, sd.background)
                break
            wo = -d
            m = h.material
            if wp.static(AREA):
                if h.light >= 0:
                    L += wp.cw_mul(beta, emitted(sd, h, wo)) * hit_weight(sd, h, prev_delta,
                                                                          prev_pdf, prev_p,
                                                                          depth - 1, dt)
            if last_segment == 1:
                break
            if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                break
            if depth >= wp.static(DEPTH_CAP):
                break
            kind = sd.materials.kind[m]
            if kind == EMITTER:
                break
            base = bounce_base(depth)
            if wp.static(RR):
                if depth >= sd.rr_depth:
                    q = wp.min(wp.max(beta[0], wp.max(beta[1], beta[2])), 0.95)
                    if get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.ROULETTE)),
                             spp) >= q:
                        break
                    if wp.static(RR_REWEIGHT):
                        beta = beta / q
            mat = material_at(sd, m, h.uv)
            is_delta = False
            _deltas = wp.static(variant_tag(DELTA_CODES))  # noqa: F841 (static_tag.py)
            for i in range(wp.static(len(DELTA_CODES))):
                if kind == wp.static(DELTA_CODES[i]):
                    is_delta = True
            # The BSDF sees the shading normal (a mesh's interpolated one); offsets and the side
            # test stay geometric (geometry.shading_consistent).
            ns = h.n
            if wp.static(MESHES):
                ns = h.ns
            if not is_delta:
                if wp.static(NEE):
                    ul = float(0.0)
                    if sd.lights.n_area >= wp.static(CHOICE_FROM):  # else one light is picked
                        ul = get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.LIGHT_CHOICE)),
                                   spp)
                    up = get2d(seed, pix, idx, base + wp.uint32(wp.static(dims.LIGHT_POSITION)),
                               spp)
                    L += next_event(sd, beta, mat, h, wo, ul, up, depth, dt)
                    if wp.static(TWICE_NEXT_EVENT):
                        L += 1.0e-30 * next_event(sd, beta, mat, h, wo, 1.0 - ul, wp.vec2(up[1], up[0]), depth, dt)
                if wp.static(DELTA_LIGHTS):
                    L += wp.cw_mul(beta, direct_delta_lights(sd, mat, h.p, h.n, ns, wo, dt))
            u_lobe = float(0.0)
            if wp.static(LOBE_CHOICE):
                u_lobe = get1d(seed, pix, idx, base + wp.uint32(wp.static(dims.LOBE_CHOICE)), spp)
            u_dir = get2d(seed, pix, idx, base + wp.uint32(wp.static(dims.DIRECTION)), spp)
            if wp.static(TWICE_DRAW):
                L += wp.vec3(1.0e-30 * get2d(seed, pix, idx + wp.uint32(1),
                                             base + wp.uint32(wp.static(dims.DIRECTION)), spp)[0])
            s = sample_bsdf(mat, ns, wo, u_lobe, u_dir)
            if wp.static(TWICE_SAMPLE_BSDF):
                L += 1.0e-30 * sample_bsdf(mat, ns, wo, u_lobe, wp.vec2(u_dir[1], u_dir[0])).weight
            if s.valid == 0:
                break
            if wp.static(MESHES):
                if shading_consistent(h.n, ns, wo, s.wi) == 0.0:
                    break
            beta = wp.cw_mul(beta, s.weight)
            if wp.static(FAULT_DROP_COSINE):
                if s.delta == 0:
                    beta = beta / wp.abs(wp.dot(h.n, s.wi))
            if wp.static(FAULT_PDF_HIGH):
                if s.delta == 0:
                    beta = beta / 1.1
            if wp.static(DRT):
                if kind == DIFFUSE:
                    last_segment = 1
                    if wp.static(not DRT_COUNTS_HITS):
                        if black(sd.background) == 1:   # at runtime: one variant either way
                            break
            prev_delta = s.delta
            prev_pdf = s.pdf
            prev_p = h.p
            if wp.static(ENV):
                prev_n = oriented(ns, wo)
            o = offset_origin(h.p, h.n, s.wi, sd.eps)
            d = s.wi
            depth += 1
        return L

    return trace
