"""`principled`: Mitsuba 3's Disney (2012, 2015) BSDF (src/bsdfs/principled.cpp), its formulas and
defaults; the parameters (MaterialAt.param, kernels/scene_model/principled_params.py) at the hit,
`albedo` its base_color, `ior` its eta. With brdf = (1 - metallic)(1 - spec_trans), bsdf =
(1 - metallic) spec_trans, wh the half vector (outward), D, G the anisotropic GGX of alphas(
anisotropic, roughness) with separable Smith masking, F the dielectric Fresnel at wo.wh:
  specular reflection  F_p D G / (4 |cos_o|),  F_p = (1 - metallic)(1 - spec_tint) F + metallic
                       Schlick(base_color) + (1 - metallic) spec_tint Schlick(tint R0(eta)) on the
                       front side, bsdf F inside
  transmission         sqrt(base_color) bsdf (1 - F) D G |wo.wh wi.wh| / (|cos_o| (wo.wh +
                       eta wi.wh)^2) (radiance: the eta^2 cancels, as Mitsuba's)
  clearcoat (front)    clearcoat / 4 Schlick(0.04) GTR1(lerp(0.1, 0.001, clearcoat_gloss)) G_cc |cos_i|
  diffuse (front)      brdf base_color (Disney diffuse + retro, flattened by `flatness`) |cos_i| / pi
  sheen (front)        sheen (1 - metallic) Schlick_w(wh.wi) lerp(1, tint, sheen_tint) |cos_i|
(wo the viewer's direction, Mitsuba's si.wi; wi the sampled one). Lobe choice as Mitsuba's sample():
on the front side diffuse brdf, clearcoat clearcoat / 4, transmission bsdf (1 - F), reflection
1 - bsdf (1 - F), each times its sampling rate; inside reflection F, transmission 1 - F; F at the
visible normal drawn for the specular lobes. The surface is two-sided in drtlab's sense: n is the
outward normal, and from inside only the dielectric lobes scatter, as in Mitsuba.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, square_to_cosine_hemisphere
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.principled_common import (ANISOTROPIC, CLEARCOAT, CLEARCOAT_GLOSS,
    CLEARCOAT_RATE, DIFF_REFL_RATE, METALLIC, ROUGHNESS, SHEEN, SPEC_RATE, SPEC_TINT, SPEC_TRANS,
    alphas, diffuse_retro, fresnel_signed, ggx_d, ggx_g1, ggx_vndf_pdf, ggx_vndf_sample, gtr1_d,
    gtr1_sample, local, mulsign, schlick_eta, schlick_r0, schlick_rgb, sheen_colour, smith_ggx1, tint,
    to_world)
from drtlab.kernels.materials.scatter import Scatter, proposal
from drtlab.kernels.scene_model.principled_params import param_row

__all__ = ["eval", "sample", "pdf", "table_row", "lobe_probabilities"]


def table_row(kind: str, albedo, alpha: float, eta: float, params: dict | None = None):
    """The material's row of MaterialData.table: its parameter vector (principled_params)."""
    return param_row(params)


@wp.struct
class Half:
    wh: wp.vec3
    reflect: int        # 1 reflection, 0 transmission (-1: neither)
    eta_path: float     # eta seen from wo's side


@wp.func
def half_vector(vi: wp.vec3, vo: wp.vec3, eta: float) -> Half:
    """Mitsuba's half vector of (vi, vo), turned outward (+z)."""
    h = Half()
    h.reflect = -1
    h.eta_path = eta
    if vi[2] < 0.0:
        h.eta_path = 1.0 / eta
    p = vi[2] * vo[2]
    s = float(1.0)
    if p > 0.0:
        h.reflect = 1
    elif p < 0.0:
        h.reflect = 0
        s = h.eta_path
    h.wh = wp.normalize(vi + vo * s)
    if h.wh[2] < 0.0:
        h.wh = -h.wh
    return h


@wp.func
def compatible(wh: wp.vec3, vi: wp.vec3, vo: wp.vec3, reflect: int) -> bool:
    """Mitsuba's mac_mic_compatibility: both directions on the facet's sides they should be."""
    m = mulsign(wh, vi[2])
    if reflect == 1:
        return wp.dot(vi, m) > 0.0 and wp.dot(vo, m) > 0.0
    return wp.dot(vi, m) > 0.0 and wp.dot(vo, m) < 0.0


@wp.func
def lobe_probabilities(mat: MaterialAt, front: bool, f: float) -> wp.vec4:
    """(diffuse, clearcoat, transmission, reflection) choice probabilities at Fresnel F = f."""
    metallic = mat.param[METALLIC]
    st = mat.param[SPEC_TRANS]
    brdf = (1.0 - metallic) * (1.0 - st)
    bsdf = (1.0 - metallic) * st
    p = wp.vec4(0.0, 0.0, 1.0 - f, f)
    if front:
        rate = mat.param[SPEC_RATE]
        p = wp.vec4(brdf * mat.param[DIFF_REFL_RATE], 0.25 * mat.param[CLEARCOAT] * mat.param[CLEARCOAT_RATE],
                    rate * bsdf * (1.0 - f), rate * (1.0 - bsdf * (1.0 - f)))
    return p / (p[0] + p[1] + p[2] + p[3])


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    f = local(n, wo, wi)
    vi = f.wo
    vo = f.wi
    ci = vi[2]
    co = vo[2]
    r = wp.vec3(0.0)
    if ci == 0.0:
        return r
    eta = mat.ior
    metallic = mat.param[METALLIC]
    st = mat.param[SPEC_TRANS]
    brdf = (1.0 - metallic) * (1.0 - st)
    bsdf = (1.0 - metallic) * st
    front = ci > 0.0
    h = half_vector(vi, vo, eta)
    if h.reflect < 0:
        return r
    wh = h.wh
    a = alphas(mat.param[ANISOTROPIC], mat.param[ROUGHNESS])
    dot_ih = wp.dot(vi, wh)
    dot_oh = wp.dot(vo, wh)
    F = fresnel_signed(dot_ih, eta)
    base = mat.albedo
    ok = compatible(wh, vi, vo, h.reflect)
    dg = ggx_d(a, wh) * ggx_g1(a, vi, wh) * ggx_g1(a, vo, wh)
    if h.reflect == 1:
        if ok and F > 0.0:
            fp = wp.vec3(bsdf * F)
            if front:
                w = schlick_eta(dot_ih, eta)
                r0 = schlick_r0(eta)
                if dot_ih < 0.0:
                    r0 = schlick_r0(1.0 / eta)
                spec_tint = mat.param[SPEC_TINT]
                fp = ((1.0 - metallic) * (1.0 - spec_tint) * F * wp.vec3(1.0)
                      + metallic * schlick_rgb(base, w)
                      + (1.0 - metallic) * spec_tint * schlick_rgb(tint(base) * r0, w))
            r += fp * (dg / (4.0 * wp.abs(ci)))
        cc = mat.param[CLEARCOAT]
        if ok and front and cc > 0.0:
            gloss = mat.param[CLEARCOAT_GLOSS]
            fcc = 0.04 * (1.0 - schlick_eta(dot_ih, eta)) + schlick_eta(dot_ih, eta)
            dcc = gtr1_d(0.1 * (1.0 - gloss) + 0.001 * gloss, wh)
            gcc = smith_ggx1(vi, wh, 0.25) * smith_ggx1(vo, wh, 0.25)
            r += wp.vec3(0.25 * cc * fcc * dcc * gcc * wp.abs(co))
        if front:
            if brdf > 0.0:
                r += base * (brdf * wp.abs(co) * diffuse_retro(mat, wp.abs(co), wp.abs(ci), dot_oh))
            sheen = mat.param[SHEEN]
            if sheen > 0.0 and metallic < 1.0:
                r += sheen_colour(mat, dot_oh) * (sheen * (1.0 - metallic) * wp.abs(co))
    elif ok and bsdf > 0.0 and F < 1.0:
        ep = h.eta_path
        d = dot_ih + ep * dot_oh
        # Mitsuba's radiance scale 1 / eta_path^2 times its eta_path^2: 1.
        t = wp.abs((1.0 - F) * dg * dot_ih * dot_oh / (ci * d * d))
        r += wp.vec3(wp.sqrt(base[0]), wp.sqrt(base[1]), wp.sqrt(base[2])) * (bsdf * t)
    return r


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    f = local(n, wo, wi)
    vi = f.wo
    vo = f.wi
    ci = vi[2]
    if ci == 0.0:
        return 0.0
    eta = mat.ior
    h = half_vector(vi, vo, eta)
    if h.reflect < 0:
        return 0.0
    wh = h.wh
    a = alphas(mat.param[ANISOTROPIC], mat.param[ROUGHNESS])
    dot_ih = wp.dot(vi, wh)
    dot_oh = wp.dot(vo, wh)
    front = ci > 0.0
    p = lobe_probabilities(mat, front, fresnel_signed(dot_ih, eta))
    ok = compatible(wh, vi, vo, h.reflect)
    r = float(0.0)
    if h.reflect == 1:
        dwh = wp.abs(1.0 / (4.0 * dot_oh))
        if ok:
            r += p[3] * ggx_vndf_pdf(a, mulsign(vi, ci), wh) * dwh
            if p[1] > 0.0:
                gloss = mat.param[CLEARCOAT_GLOSS]
                r += p[1] * gtr1_d(0.1 * (1.0 - gloss) + 0.001 * gloss, wh) * wh[2] * dwh
        r += p[0] * wp.abs(vo[2]) * INV_PI
    elif ok:
        ep = h.eta_path
        d = dot_ih + ep * dot_oh
        r += p[2] * ggx_vndf_pdf(a, mulsign(vi, ci), wh) * wp.abs(ep * ep * dot_oh / (d * d))
    return r


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    f = local(n, wo, wo)
    vi = f.wo
    ci = vi[2]
    if ci == 0.0:
        return proposal(wp.vec3(0.0))
    eta = mat.ior
    front = ci > 0.0
    a = alphas(mat.param[ANISOTROPIC], mat.param[ROUGHNESS])
    m = ggx_vndf_sample(a, mulsign(vi, ci), u)
    dot_im = wp.dot(vi, m)
    F = fresnel_signed(dot_im, eta)
    p = lobe_probabilities(mat, front, F)
    # Mitsuba drops a direction its lobe cannot give (the wrong side of the surface or of the
    # facet): there another lobe's density would count it.
    vo = wp.vec3(0.0)
    if u_lobe < p[0]:
        vo = square_to_cosine_hemisphere(u)
    elif u_lobe < p[0] + p[1]:
        gloss = mat.param[CLEARCOAT_GLOSS]
        mc = gtr1_sample(0.1 * (1.0 - gloss) + 0.001 * gloss, u)
        if wp.dot(vi, mc) <= 0.0:
            return proposal(wp.vec3(0.0))
        vo = 2.0 * wp.dot(vi, mc) * mc - vi
    elif u_lobe < p[0] + p[1] + p[2]:
        # Refraction through m from vi's side (Mitsuba's refract with its fresnel's cos_theta_t).
        eta_ti = 1.0 / eta
        if dot_im < 0.0:
            eta_ti = eta
        ct2 = 1.0 - eta_ti * eta_ti * (1.0 - dot_im * dot_im)
        if ct2 <= 0.0:
            return proposal(wp.vec3(0.0))
        ct = wp.sqrt(ct2)
        if dot_im >= 0.0:
            ct = -ct
        vo = m * (dot_im * eta_ti + ct) - vi * eta_ti
        if vo[2] * ci >= 0.0:
            return proposal(wp.vec3(0.0))
        return proposal(to_world(f, vo))
    else:
        vo = 2.0 * dot_im * m - vi
    if vo[2] * ci <= 0.0:
        return proposal(wp.vec3(0.0))
    return proposal(to_world(f, vo))
