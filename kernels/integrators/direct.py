"""Mitsuba 3's `direct`: direct illumination by multiple importance sampling of `emitter_samples`
light samples and `bsdf_samples` BSDF samples at the camera ray's hit, combined by the strategy's
heuristic (the power heuristic, as Mitsuba) over the techniques' sample fractions, each technique's
sum divided by its count. Emitters the camera sees count at full weight; nothing is indirect.

    light sample:  f Le / p_l * w(p_l f_l, p_b f_b) / emitter_samples     (non-delta surfaces only)
    BSDF sample:   f Le / p_b * w(p_b f_b, p_l f_l) / bsdf_samples        (delta lobe: weight 1)
with f_l, f_b the techniques' fractions of all samples. Point and directional lights are exact where
emitter sampling runs (emitter_samples > 0). An environment (or the background) is seen by BSDF
samples only, at full weight. Sample i of each technique reads bounce i's light (light_choice,
light_position) or direction (lobe_choice, direction) dimensions: with one of each, exactly path
tracing's at its first vertex.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData

DIMENSIONS = ()


def make(api):
    f = api.features
    N_LIGHT, N_BSDF = f.emitter_samples, f.bsdf_samples
    FRAC_LIGHT = N_LIGHT / (N_LIGHT + N_BSDF)
    FRAC_BSDF = N_BSDF / (N_LIGHT + N_BSDF)
    LIGHTS = N_LIGHT > 0 and f.sampled_area_lights and api.strategy.light is not None
    AREA, ENV, MESHES = f.area_lights, f.environment, f.meshes
    DELTA_LIGHTS = f.delta_lights and N_LIGHT > 0
    CHOICE_FROM, LOBE_CHOICE, EMITTER = api.choice_from, api.lobe_choice, api.emitter
    get1d, get2d = api.get1d, api.get2d
    LIGHT_CHOICE, LIGHT_POSITION = api.dim("light_choice"), api.dim("light_position")
    LOBE, DIRECTION = api.dim("lobe_choice"), api.dim("direction")
    intersect, emitted, env_radiance = api.intersect, api.emitted, api.env_radiance
    kind_of, material_at_hit, is_delta = api.kind, api.material_at_hit, api.is_delta
    shading_normal, shading_consistent = api.shading_normal, api.shading_consistent
    eval_bsdf, pdf_bsdf, sample_bsdf = api.eval_bsdf, api.pdf_bsdf, api.sample_bsdf
    pick_light, sample_light, light_pdf = api.pick_light, api.sample_light, api.light_pdf
    light_visible, direct_delta_lights = api.light_visible, api.direct_delta_lights
    offset_origin, mis_weight = api.offset_origin, api.mis_weight

    @wp.func(inline=True)
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o: wp.vec3, d: wp.vec3, dt: float) -> wp.vec3:
        h = intersect(sd, o, d, 1.0e30, dt)
        if h.index < 0:
            if wp.static(ENV):
                return env_radiance(sd.environment, d)
            return sd.background
        wo = -d
        L = emitted(sd, h, wo)
        kind = kind_of(sd, h.material)
        if kind == wp.static(EMITTER):
            return L
        mat = material_at_hit(sd, h)
        ns = shading_normal(h)
        if not is_delta(kind):
            if wp.static(LIGHTS):
                for i in range(wp.static(N_LIGHT)):
                    ul = float(0.0)
                    if sd.lights.n_area >= wp.static(CHOICE_FROM):
                        ul = get1d(seed, pix, idx, LIGHT_CHOICE(i), spp)
                    li = pick_light(sd, h.p, ul)
                    ls = sample_light(sd, li, h.p, get2d(seed, pix, idx, LIGHT_POSITION(i), spp), 0, dt)
                    if ls.valid == 1:
                        fc = eval_bsdf(mat, ns, wo, ls.wi)
                        if wp.static(MESHES):
                            fc = fc * shading_consistent(h.n, ns, wo, ls.wi)
                        if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                            if light_visible(sd, h, li, ls, dt) == 1:
                                w = mis_weight(ls.pdf * wp.static(FRAC_LIGHT),
                                               pdf_bsdf(mat, ns, wo, ls.wi) * wp.static(FRAC_BSDF))
                                L += wp.cw_mul(fc, ls.radiance) * (w / (ls.pdf * float(wp.static(N_LIGHT))))
            if wp.static(DELTA_LIGHTS):
                L += direct_delta_lights(sd, mat, h.p, h.n, ns, wo, dt)
        for j in range(wp.static(N_BSDF)):
            u_lobe = float(0.0)
            if wp.static(LOBE_CHOICE):
                u_lobe = get1d(seed, pix, idx, LOBE(j), spp)
            s = sample_bsdf(mat, ns, wo, u_lobe, get2d(seed, pix, idx, DIRECTION(j), spp))
            if s.valid == 1:
                ok = float(1.0)
                if wp.static(MESHES):
                    ok = shading_consistent(h.n, ns, wo, s.wi)
                if ok > 0.0:
                    g = intersect(sd, offset_origin(h.p, h.n, s.wi, sd.eps), s.wi, 1.0e30, dt)
                    Le = wp.vec3(0.0)
                    w = float(1.0)
                    if g.index < 0:
                        if wp.static(ENV):
                            Le = env_radiance(sd.environment, s.wi)
                        else:
                            Le = sd.background
                    elif wp.static(AREA):
                        if g.light >= 0:
                            Le = emitted(sd, g, -s.wi)
                            if wp.static(LIGHTS):
                                if s.delta == 0:
                                    pl = light_pdf(sd, g.light, h.p, g.p, g.n, g.index, 0, dt)
                                    w = mis_weight(s.pdf * wp.static(FRAC_BSDF), pl * wp.static(FRAC_LIGHT))
                    L += wp.cw_mul(s.weight, Le) * (w / float(wp.static(N_BSDF)))
        return L

    return trace
