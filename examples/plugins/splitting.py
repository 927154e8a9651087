"""Path tracing with splitting: SPLITS next-event samples at the first vertex (where the camera ray
lands, the one vertex every pixel's noise starts at), one at every later vertex; their mean is the
light sample's estimate there. Each extra sample draws its own light choice and point from the
integrator's own sample decision `split_light` (DIMENSIONS), so every built-in dimension keeps its
value: sample 0 is exactly path tracing's.

    drtlab render cornell-box --plugin examples/plugins/splitting.py --integrator splitting

Unbiased: each of the SPLITS samples is an unbiased estimate of the direct light (the built-in
next_event, MIS-weighted against the BSDF sample as path tracing weighs one), so their mean is too.
Written against the estimator API alone (docs/plugins.md).
"""
import warp as wp

import drtlab
from drtlab.kernels.device_scene import SceneData

SPLITS = 4
# The extra light samples of a vertex: (choice, point.x, point.y) each.
DIMENSIONS = (("split_light", 3 * (SPLITS - 1)),)


def make(api):
    f = api.features
    ENV, DELTA_LIGHTS, RR = f.environment, f.delta_lights, f.roulette
    NEE, CHOICE_FROM = api.next_events, api.choice_from
    DEPTH_CAP, EMITTER = api.depth_cap, api.emitter
    get1d, get2d, roulette, ROULETTE = api.get1d, api.get2d, api.roulette, api.dim("roulette")
    LIGHT_CHOICE, LIGHT_POSITION = api.dim("light_choice"), api.dim("light_position")
    SPLIT = api.dim("split_light")
    intersect, escape, emitted, hit_weight = api.intersect, api.escape, api.emitted, api.hit_weight
    kind_of, material_at_hit, is_delta, shading_normal = api.kind, api.material_at_hit, api.is_delta, api.shading_normal
    frame_at = api.frame_at
    next_event, direct_delta_lights = api.next_event, api.direct_delta_lights
    scatter, offset_origin, oriented = api.scatter, api.offset_origin, api.oriented

    @wp.func(inline=True)
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o0: wp.vec3, d0: wp.vec3, dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        beta = wp.vec3(1.0)
        o = o0
        d = d0
        depth = int(0)
        prev_delta = int(1)
        prev_pdf = float(0.0)
        prev_p = o0
        prev_n = d0
        while True:
            h = intersect(sd, o, d, 1.0e30, dt)
            if h.index < 0:
                L += wp.cw_mul(beta, escape(sd, d, prev_delta, prev_pdf, prev_n))
                break
            wo = -d
            if h.light >= 0:
                L += wp.cw_mul(beta, emitted(sd, h, wo)) * hit_weight(sd, h, prev_delta, prev_pdf,
                                                                      prev_p, depth - 1, dt)
            if (sd.max_depth >= 0 and depth + 1 >= sd.max_depth) or depth >= wp.static(DEPTH_CAP):
                break
            kind = kind_of(sd, h.material)
            if kind == wp.static(EMITTER):
                break
            if wp.static(RR):      # the scene's Russian roulette, as path tracing plays it
                if depth >= sd.rr_depth:
                    beta = roulette(beta, get1d(seed, pix, idx, ROULETTE(depth), spp))
                    if beta[0] == 0.0 and beta[1] == 0.0 and beta[2] == 0.0:
                        break
            mat = material_at_hit(sd, h)
            mat = frame_at(sd, mat, h, wo)
            ns = shading_normal(h)
            if not is_delta(kind):
                if wp.static(NEE):
                    n = int(1)
                    if depth == 0:
                        n = wp.static(SPLITS)
                    direct = wp.vec3(0.0)
                    for j in range(n):
                        ul = float(0.0)
                        up = wp.vec2(0.0)
                        if j == 0:      # path tracing's own light sample
                            if sd.lights.n_area >= wp.static(CHOICE_FROM):
                                ul = get1d(seed, pix, idx, LIGHT_CHOICE(depth), spp)
                            up = get2d(seed, pix, idx, LIGHT_POSITION(depth), spp)
                        else:           # the extra ones, from split_light
                            at = SPLIT(depth) + wp.uint32(3 * (j - 1))
                            ul = get1d(seed, pix, idx, at, spp)
                            up = get2d(seed, pix, idx, at + wp.uint32(1), spp)
                        direct += next_event(sd, beta, mat, h, wo, ul, up, depth, dt)
                    L += direct / float(n)
                if wp.static(DELTA_LIGHTS):
                    L += wp.cw_mul(beta, direct_delta_lights(sd, mat, h.p, h.n, ns, wo, dt))
            s = scatter(mat, h, wo, ns, seed, pix, idx, spp, depth)    # the BSDF sample continues
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


drtlab.register_integrator(
    "splitting", make, f"path tracing, {SPLITS} light samples at the first vertex", unbiased=True,
    handles=("direct", "indirect", "specular", "glossy", "transmission", "environment",
             "point_lights", "lens", "motion", "meshes"),
    dimensions=DIMENSIONS)
