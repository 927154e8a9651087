"""Whitted's deterministic tracer per kernel variant: mirror chains, dielectric splits, shadow rays.

`make_whitted(features, rays, bsdf, lighting)` (from make_intersect, make_bsdf and make_direct)
returns trace_whitted(sd, o, d) -> radiance and light_centres(sd, kind, albedo, exponent,
ior, p, n, wo) -> the area lights' light at p, each seen as a point source at its centre.
"""
from types import SimpleNamespace

import warp as wp

from drtlab.estimators.warps import PI
from drtlab.kernels.device_scene import QUAD, SPHERE, SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.geometry import offset_origin
from drtlab.kernels.materials import (DIELECTRIC, DIFFUSE, EMITTER, GLOSSY, GLOSSY_DIELECTRIC,
                                      MIRROR, emitted, interface, refract_dir, surface_albedo)


def make_whitted(f: Features, rays: SimpleNamespace, bsdf: SimpleNamespace,
                 lighting: SimpleNamespace) -> SimpleNamespace:
    AREA_CENTRES = f.light_centres
    DELTA_LIGHTS = f.delta_lights
    SPLITS = f.whitted_splits
    intersect = rays.intersect
    visible = rays.visible
    eval_bsdf = bsdf.eval_bsdf
    direct_delta_lights = lighting.direct_delta_lights

    @wp.func
    def light_centres(sd: SceneData, kind: int, albedo: wp.vec3, exponent: float, ior: float,
                      p: wp.vec3, n: wp.vec3, wo: wp.vec3) -> wp.vec3:
        # Whitted's shadow rays to area-light centres: each light acts as a point source with its
        # radiant intensity towards p (sphere: Le * pi r^2; one-sided quad: Le * A * cos).
        L = wp.vec3(0.0)
        for li in range(sd.n_lights):
            k = sd.light_shape_kind[li]
            s = sd.light_shape[li]
            c = wp.vec3(0.0)
            intensity = float(0.0)
            m = int(0)
            if k == SPHERE:
                c = sd.sph_center[s]
                intensity = PI * sd.sph_radius[s] * sd.sph_radius[s]
                m = sd.sph_material[s]
            else:
                c = sd.quad_origin[s] + 0.5 * (sd.quad_u[s] + sd.quad_v[s])
                m = sd.quad_material[s]
            d = c - p
            dist = wp.length(d)
            wi = d / dist
            if k == QUAD:
                intensity = sd.quad_area[s] * wp.max(0.0, -wp.dot(sd.quad_normal[s], wi))
            if intensity > 0.0:
                fc = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)
                if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                    o = offset_origin(p, n, wi, sd.eps)
                    if visible(sd, o, wi, wp.length(c - o), 0.0, k, s) == 1:
                        L += wp.cw_mul(fc, sd.mat_emission[m]) * (intensity / (dist * dist))
        return L

    # Called once per sample: inlined, so SceneData is not copied per call.
    @wp.func(inline=True)
    def trace_whitted(sd: SceneData, o0: wp.vec3, d0: wp.vec3) -> wp.vec3:
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
                    L += wp.cw_mul(beta, sd.background)
                    break
                wo = -d
                L += wp.cw_mul(beta, emitted(sd, h, wo))
                if sd.max_depth >= 0 and depth + 1 >= sd.max_depth:
                    break
                m = h.material
                kind = sd.mat_kind[m]
                if kind == EMITTER:
                    break
                albedo = surface_albedo(sd, m, h.uv)
                cos_o = wp.dot(h.n, wo)
                nf = h.n
                if cos_o < 0.0:
                    nf = -h.n
                co = wp.abs(cos_o)
                if kind == DIFFUSE or kind == GLOSSY:
                    direct = wp.vec3(0.0)
                    if wp.static(AREA_CENTRES):
                        direct += light_centres(sd, kind, albedo, sd.mat_exponent[m],
                                                sd.mat_ior[m], h.p, h.n, wo)
                    if wp.static(DELTA_LIGHTS):
                        direct += direct_delta_lights(sd, kind, albedo, sd.mat_exponent[m],
                                                      sd.mat_ior[m], h.p, h.n, wo, 0.0)
                    L += wp.cw_mul(beta, direct)
                    break
                wi = 2.0 * co * nf - wo
                if kind == MIRROR:
                    beta = wp.cw_mul(beta, albedo)
                if wp.static(SPLITS > 0):
                    if kind == DIELECTRIC or kind == GLOSSY_DIELECTRIC:
                        it = interface(h.n, wo, sd.mat_ior[m])
                        eta = it.eta
                        F = it.F
                        if F < 1.0:
                            if used >= wp.static(SPLITS):
                                break
                            if ((code >> used) & 1) == 1:
                                wi = refract_dir(wo, nf, co, eta)
                                beta = wp.cw_mul(beta, albedo) * ((1.0 - F) / (eta * eta))
                            else:
                                beta = beta * F
                            used += 1
                o = offset_origin(h.p, h.n, wi, sd.eps)
                d = wi
                depth += 1
            # A path that used fewer splits than the code encodes is counted by the code whose
            # unused bits are zero only.
            if (code >> used) == 0:
                total += L
        return total

    return SimpleNamespace(trace_whitted=trace_whitted, light_centres=light_centres)
