"""Kajiya 1986 path tracing with next-event estimation: unbiased for the full rendering equation up
to `max_depth` (Mitsuba 3's convention), with optional Russian roulette.

At every vertex that is not a delta surface: one light sample (MIS-weighted against the BSDF where
the strategy combines by MIS) and the exact point and directional lights; then one BSDF sample
continues the path, and an emitter it hits counts with `hit_weight` (the light sample's MIS
complement). Roulette from `rr_depth` on, survival probability the throughput's largest component
(at most 0.95).
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData

DIMENSIONS = ()     # only the built-in decisions: light_choice, light_position, lobe_choice, ...


def make(api):
    f = api.features
    AREA, ENV, RR = f.area_lights, f.environment, f.roulette
    DEPTH_CAP, EMITTER = api.depth_cap, api.emitter
    get1d, roulette, ROULETTE = api.get1d, api.roulette, api.dim("roulette")
    intersect, escape, emitted, hit_weight = api.intersect, api.escape, api.emitted, api.hit_weight
    kind_of, material_at_hit, is_delta, shading_normal = api.kind, api.material_at_hit, api.is_delta, api.shading_normal
    direct_light, scatter, offset_origin, oriented = api.direct_light, api.scatter, api.offset_origin, api.oriented

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
        while True:
            h = intersect(sd, o, d, 1.0e30, dt)
            if h.index < 0:
                L += wp.cw_mul(beta, escape(sd, d, prev_delta, prev_pdf, prev_n))
                break
            wo = -d
            if wp.static(AREA):
                if h.light >= 0:
                    L += wp.cw_mul(beta, emitted(sd, h, wo)) * hit_weight(sd, h, prev_delta, prev_pdf,
                                                                          prev_p, depth - 1, dt)
            if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                break
            if depth >= wp.static(DEPTH_CAP):
                break
            kind = kind_of(sd, h.material)
            if kind == wp.static(EMITTER):
                break
            if wp.static(RR):
                if depth >= sd.rr_depth:
                    beta = roulette(beta, get1d(seed, pix, idx, ROULETTE(depth), spp))
                    if beta[0] == 0.0 and beta[1] == 0.0 and beta[2] == 0.0:
                        break
            mat = material_at_hit(sd, h)
            ns = shading_normal(h)
            if not is_delta(kind):
                L = direct_light(sd, L, beta, mat, h, wo, ns, seed, pix, idx, spp, depth, dt)
            s = scatter(mat, h, wo, ns, seed, pix, idx, spp, depth)
            if s.valid == 0:
                break
            beta = wp.cw_mul(beta, s.weight)
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
