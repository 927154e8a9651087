"""Whitted 1980: a regular sub-pixel grid (kernels/render_kernel.py draws it: no random numbers),
perfect mirror chains, dielectric interfaces split into reflection and refraction, and direct light
by shadow rays to point lights and to the area lights' centres. Deterministic and biased: the
baseline distribution ray tracing improves on.

Each split ray is one bit of a code (sd.whitted_codes = 2^splits codes): the trace runs once per
code and a bit picks reflection (0) or refraction (1) at each interface, so the tree is a loop.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData

DIMENSIONS = ()


def make(api):
    AREA_CENTRES = api.features.light_centres
    DELTA_LIGHTS = api.features.delta_lights
    SPLITS = api.features.whitted_splits
    MESHES = api.features.meshes
    ENV = api.features.environment
    EMITTER = api.emitter
    intersect, offset_origin, shading_normal = api.intersect, api.offset_origin, api.shading_normal
    shading_consistent, material_at_hit, kind_of = api.shading_consistent, api.material_at_hit, api.kind
    emitted, env_radiance = api.emitted, api.env_radiance
    ends_path, specular_reflect, splits = api.ends_path, api.specular_reflect, api.splits
    interface, refract_dir = api.interface, api.refract_dir
    light_centres, direct_delta_lights = api.light_centres, api.direct_delta_lights

    # Called once per sample: inlined, so SceneData is not copied per call.
    @wp.func(inline=True)
    def trace(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32, spp: wp.uint32,
              o0: wp.vec3, d0: wp.vec3, dt: float) -> wp.vec3:
        total = wp.vec3(0.0)
        # A dynamic bound: Warp would unroll a constant one 2**SPLITS times and compile for long.
        for code in range(sd.whitted_codes):
            L = wp.vec3(0.0)
            beta = wp.vec3(1.0)
            o = o0
            d = d0
            used = int(0)
            depth = int(0)
            while True:
                h = intersect(sd, o, d, 1.0e30, 0.0)
                if h.index < 0:
                    if wp.static(ENV):      # seen, but lights no surface (as its area lights)
                        L += wp.cw_mul(beta, env_radiance(sd.environment, d))
                    else:
                        L += wp.cw_mul(beta, sd.background)
                    break
                wo = -d
                L += wp.cw_mul(beta, emitted(sd, h, wo))
                if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                    break
                m = h.material
                kind = kind_of(sd, m)
                if kind == wp.static(EMITTER):
                    break
                mat = material_at_hit(sd, h)
                ns = shading_normal(h)
                if ends_path(kind):
                    direct = wp.vec3(0.0)
                    if wp.static(AREA_CENTRES):
                        direct += light_centres(sd, mat, h.p, h.n, ns, wo)
                    if wp.static(DELTA_LIGHTS):
                        direct += direct_delta_lights(sd, mat, h.p, h.n, ns, wo, 0.0)
                    L += wp.cw_mul(beta, direct)
                    break
                s = specular_reflect(mat, kind, ns, wo)
                wi = s.wi
                beta = wp.cw_mul(beta, s.weight)
                if wp.static(SPLITS > 0):
                    if splits(kind):
                        it = interface(ns, wo, mat.ior)
                        if it.F < 1.0:
                            if used >= wp.static(SPLITS):
                                break
                            if ((code >> used) & 1) == 1:
                                cos_o = wp.dot(ns, wo)
                                nf = ns
                                if cos_o < 0.0:
                                    nf = -ns
                                wi = refract_dir(wo, nf, wp.abs(cos_o), it.eta)
                                beta = wp.cw_mul(beta, mat.albedo) * ((1.0 - it.F) / (it.eta * it.eta))
                            else:
                                beta = beta * it.F
                            used += 1
                if wp.static(MESHES):
                    if shading_consistent(h.n, ns, wo, wi) == 0.0:
                        break           # reflected through the geometric surface: no leak
                o = offset_origin(h.p, h.n, wi, sd.eps)
                d = wi
                depth += 1
            # A path that used fewer splits than the code encodes is counted by the code whose
            # unused bits are zero only.
            if (code >> used) == 0:
                total += L
        return total

    return trace
