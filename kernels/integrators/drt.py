"""Cook, Porter and Carpenter 1984, distribution ray tracing: each sample chains pixel, lens, time,
light area and one distributed reflection/refraction ray per bounce. Paths continue through glossy,
specular and transmissive surfaces; at a diffuse surface direct light is gathered and the path ends
after one more segment, which counts only the emitter it hits (no diffuse interreflection). Plastic
(diffuse base, glossy coat) counts as glossy. Unbiased for that estimand.

The vertex is path tracing's (kernels/integrators/path.py) without roulette; what differs is the
last segment after a diffuse scatter.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData

DIMENSIONS = ()


@wp.func
def black(c: wp.vec3) -> int:
    if c[0] > 0.0 or c[1] > 0.0 or c[2] > 0.0:
        return 0
    return 1


def make(api):
    f = api.features
    AREA, ENV = f.area_lights, f.environment
    DEPTH_CAP, EMITTER, DIFFUSE = api.depth_cap, api.emitter, api.diffuse
    # After a diffuse scatter only the emission hit counts; nothing to find there when emitters
    # count only through light samples and the background is black.
    COUNTS_HITS = api.strategy.counts_hits
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
        last_segment = int(0)    # after a diffuse scatter only the emission hit counts
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
            if last_segment == 1:
                break
            if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                break
            if depth >= wp.static(DEPTH_CAP):
                break
            kind = kind_of(sd, h.material)
            if kind == wp.static(EMITTER):
                break
            mat = material_at_hit(sd, h)
            ns = shading_normal(h)
            if not is_delta(kind):
                L = direct_light(sd, L, beta, mat, h, wo, ns, seed, pix, idx, spp, depth, dt)
            s = scatter(mat, h, wo, ns, seed, pix, idx, spp, depth)
            if s.valid == 0:
                break
            beta = wp.cw_mul(beta, s.weight)
            if kind == wp.static(DIFFUSE):
                last_segment = 1
                if wp.static(not COUNTS_HITS):
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
