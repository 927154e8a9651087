"""Path tracing with one-sample MIS (Veach 1995, 9.2.4): at each vertex, light sampling with
probability LIGHT_PROB, else none; the direct light of the sample that was taken weighted by the
balance heuristic over the mixture, f / (c p_light + (1 - c) p_bsdf). The BSDF sample that
continues the path stands for the BSDF technique: an emitter it hits counts with
p_bsdf / (c p_light + (1 - c) p_bsdf) after a vertex that chose the BSDF, and not at all after one
that chose the light. The choice is the integrator's own sample decision `technique` (DIMENSIONS).

    drtlab render cornell-box --plugin examples/plugins/one_sample_mis.py --integrator one-sample-mis

Unbiased: E = c * integral p_l f/(c p_l + (1-c) p_b) + (1-c) * integral p_b f/(c p_l + (1-c) p_b)
= integral f. One shadow ray per vertex half the time: cheaper than path tracing's, noisier per
sample. An environment is seen only by BSDF samples (at full weight). Written against the estimator
API alone (docs/plugins.md).
"""
import warp as wp

import drtlab
from drtlab.kernels.device_scene import SceneData

LIGHT_PROB = 0.5
DIMENSIONS = (("technique", 1),)


def make(api):
    f = api.features
    MESHES, ENV, DELTA_LIGHTS, RR = f.meshes, f.environment, f.delta_lights, f.roulette
    # The light technique needs area lights a strategy samples; else c = 0 (the BSDF alone).
    C = LIGHT_PROB if (f.sampled_area_lights and api.strategy.light is not None) else 0.0
    DEPTH_CAP, EMITTER = api.depth_cap, api.emitter
    get1d, get2d, roulette, ROULETTE = api.get1d, api.get2d, api.roulette, api.dim("roulette")
    LIGHT_CHOICE, LIGHT_POSITION = api.dim("light_choice"), api.dim("light_position")
    TECHNIQUE = api.dim("technique")
    intersect, emitted, env_radiance = api.intersect, api.emitted, api.env_radiance
    kind_of, material_at_hit, is_delta = api.kind, api.material_at_hit, api.is_delta
    frame_at = api.frame_at
    shading_normal, shading_consistent = api.shading_normal, api.shading_consistent
    eval_bsdf, pdf_bsdf, scatter = api.eval_bsdf, api.pdf_bsdf, api.scatter
    pick_light, sample_light, light_pdf = api.pick_light, api.sample_light, api.light_pdf
    light_visible, direct_delta_lights = api.light_visible, api.direct_delta_lights
    offset_origin = api.offset_origin

    @wp.func(inline=True)
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o0: wp.vec3, d0: wp.vec3, dt: float) -> wp.vec3:
        L = wp.vec3(0.0)
        beta = wp.vec3(1.0)
        o = o0
        d = d0
        depth = int(0)
        prev_weighted = int(0)   # the last vertex chose a technique (0: camera or delta bounce)
        prev_light = int(0)      # ... and it was the light
        prev_pdf = float(0.0)
        prev_p = o0
        c = float(0.0)
        if sd.lights.n_area > 0:
            c = wp.static(C)
        while True:
            h = intersect(sd, o, d, 1.0e30, dt)
            if h.index < 0:
                if wp.static(ENV):
                    L += wp.cw_mul(beta, env_radiance(sd.environment, d))
                else:
                    L += wp.cw_mul(beta, sd.background)
                break
            wo = -d
            if h.light >= 0:
                w = float(1.0)
                if prev_weighted == 1:
                    w = 0.0
                    if prev_light == 0:
                        pl = light_pdf(sd, h.light, prev_p, h.p, h.n, h.index, depth - 1, dt)
                        w = prev_pdf / (c * pl + (1.0 - c) * prev_pdf)
                L += wp.cw_mul(beta, emitted(sd, h, wo)) * w
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
            chose_light = int(0)
            if not is_delta(kind):
                if get1d(seed, pix, idx, TECHNIQUE(depth), spp) < c:
                    chose_light = 1
                    ul = get1d(seed, pix, idx, LIGHT_CHOICE(depth), spp)
                    li = pick_light(sd, h.p, ul)
                    ls = sample_light(sd, li, h.p, get2d(seed, pix, idx, LIGHT_POSITION(depth), spp),
                                      depth, dt)
                    if ls.valid == 1:
                        fc = eval_bsdf(mat, ns, wo, ls.wi)
                        if wp.static(MESHES):
                            fc = fc * shading_consistent(h.n, ns, wo, ls.wi)
                        if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                            if light_visible(sd, h, li, ls, dt) == 1:
                                mix = c * ls.pdf + (1.0 - c) * pdf_bsdf(mat, ns, wo, ls.wi)
                                L += wp.cw_mul(beta, wp.cw_mul(fc, ls.radiance)) / mix
                if wp.static(DELTA_LIGHTS):
                    L += wp.cw_mul(beta, direct_delta_lights(sd, mat, h.p, h.n, ns, wo, dt))
            s = scatter(mat, h, wo, ns, seed, pix, idx, spp, depth)    # the BSDF sample continues
            if s.valid == 0:
                break
            beta = wp.cw_mul(beta, s.weight)
            prev_weighted = 1 - s.delta
            prev_light = chose_light
            prev_pdf = s.pdf
            prev_p = h.p
            o = offset_origin(h.p, h.n, s.wi, sd.eps)
            d = s.wi
            depth += 1
        return L

    return trace


drtlab.register_integrator(
    "one-sample-mis", make, f"path tracing, one-sample MIS: light sampling with probability "
    f"{LIGHT_PROB}, balance-weighted", unbiased=True,
    handles=("direct", "indirect", "specular", "glossy", "transmission", "environment",
             "point_lights", "lens", "motion", "meshes"),
    dimensions=DIMENSIONS)
