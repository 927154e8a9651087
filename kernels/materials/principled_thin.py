"""`principled_thin`: Mitsuba 3's thin-surface Disney BSDF (src/bsdfs/principledthin.cpp), its
formulas and defaults; the parameters (MaterialAt.param, kernels/scene_model/principled_params.py)
at the hit, `albedo` its base_color, `ior` its eta. A sheet with nothing inside: the same from both
sides (directions are mirrored to wo's side first), and light passing it is not bent. With
dt = diff_trans / 2, wh = normalize(wo + wi'), wi' wi mirrored to wo's side, F the dielectric
Fresnel at wo.wh:
  specular reflection    spec_trans lerp(F, Schlick(tint R0(eta)), spec_tint) D G / (4 |cos_o|)
  specular transmission  spec_trans base_color (1 - F) D' G' / (4 |cos_o|), D', G' of roughness
                         scaled by 0.65 eta - 0.35 (Burley 2015, figure 15)
  diffuse reflection     (1 - spec_trans)(1 - dt) base_color (Disney diffuse + retro, flattened by
                         `flatness`) |cos_i| / pi, plus its sheen
  diffuse transmission   (1 - spec_trans) dt base_color |cos_i| / pi
(wo the viewer's direction, Mitsuba's si.wi). Lobe choice as Mitsuba's sample(): specular
reflection and transmission spec_trans / 2 each, cosine reflection (1 - spec_trans)(1 - dt),
cosine transmission (1 - spec_trans) dt, each times its sampling rate.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, square_to_cosine_hemisphere
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.principled_common import (ANISOTROPIC, DIFF_REFL_RATE, DIFF_TRANS,
    DIFF_TRANS_RATE, ROUGHNESS, SHEEN, SPEC_REFL_RATE, SPEC_TINT, SPEC_TRANS, SPEC_TRANS_RATE, alphas,
    diffuse_retro, fresnel_signed, ggx_d, ggx_g1, ggx_vndf_pdf, ggx_vndf_sample, local, mulsign,
    schlick_eta, schlick_r0, schlick_rgb, sheen_colour, tint, to_world)
from drtlab.kernels.materials.scatter import Scatter, proposal
from drtlab.kernels.scene_model.principled_params import param_row

__all__ = ["eval", "sample", "pdf", "table_row", "lobe_probabilities"]


def table_row(kind: str, albedo, alpha: float, eta: float, params: dict | None = None):
    """The material's row of MaterialData.table: its parameter vector (principled_params)."""
    return param_row(params)


@wp.func
def lobe_probabilities(mat: MaterialAt) -> wp.vec4:
    """(specular reflection, specular transmission, cosine reflection, cosine transmission)."""
    st = mat.param[SPEC_TRANS]
    dt = 0.5 * mat.param[DIFF_TRANS]
    p = wp.vec4(0.5 * st * mat.param[SPEC_REFL_RATE], 0.5 * st * mat.param[SPEC_TRANS_RATE],
                mat.param[DIFF_REFL_RATE] * (1.0 - st) * (1.0 - dt),
                mat.param[DIFF_TRANS_RATE] * (1.0 - st) * dt)
    return p / (p[0] + p[1] + p[2] + p[3])


@wp.func
def scaled_roughness(mat: MaterialAt) -> float:
    return (0.65 * mat.ior - 0.35) * mat.param[ROUGHNESS]


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    f = local(n, wo, wi)
    r = wp.vec3(0.0)
    if f.wo[2] == 0.0:
        return r
    vi = mulsign(f.wo, f.wo[2])
    vo = mulsign(f.wi, f.wo[2])
    ci = vi[2]
    co = vo[2]
    if co == 0.0:
        return r
    vr = wp.vec3(vo[0], vo[1], wp.abs(co))
    wh = wp.normalize(vi + vr)
    st = mat.param[SPEC_TRANS]
    dt = 0.5 * mat.param[DIFF_TRANS]
    base = mat.albedo
    eta = mat.ior
    m_ok = wp.dot(vi, wh) > 0.0
    if co > 0.0:
        if st > 0.0 and m_ok and wp.dot(vo, wh) > 0.0:
            F = fresnel_signed(wp.dot(vi, wh), eta)
            a = alphas(mat.param[ANISOTROPIC], mat.param[ROUGHNESS])
            spec_tint = mat.param[SPEC_TINT]
            fs = wp.vec3(F) * (1.0 - spec_tint)
            if spec_tint > 0.0:
                fs += schlick_rgb(tint(base) * schlick_r0(eta), schlick_eta(wp.dot(vi, wh), eta)) * spec_tint
            r += fs * (st * ggx_d(a, wh) * ggx_g1(a, vi, wh) * ggx_g1(a, vo, wh) / (4.0 * ci))
        if st < 1.0 and dt < 1.0:
            cos_d = wp.dot(wh, vo)
            r += base * ((1.0 - st) * (1.0 - dt) * co * diffuse_retro(mat, co, ci, cos_d))
            sheen = mat.param[SHEEN]
            if sheen > 0.0:
                r += sheen_colour(mat, cos_d) * (sheen * (1.0 - st) * (1.0 - dt) * co)
    else:
        if st > 0.0 and m_ok and wp.dot(vo, wh) < 0.0:
            F = fresnel_signed(wp.dot(vi, wh), eta)
            a = alphas(mat.param[ANISOTROPIC], scaled_roughness(mat))
            dg = ggx_d(a, wh) * ggx_g1(a, vi, wh) * ggx_g1(a, vo, wh)
            r += base * (st * (1.0 - F) * dg / (4.0 * ci))
        if st < 1.0 and dt > 0.0:
            r += base * ((1.0 - st) * dt * wp.abs(co) * INV_PI)
    return r


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    f = local(n, wo, wi)
    if f.wo[2] == 0.0:
        return 0.0
    vi = mulsign(f.wo, f.wo[2])
    vo = mulsign(f.wi, f.wo[2])
    co = vo[2]
    p = lobe_probabilities(mat)
    r = float(0.0)
    vr = wp.vec3(vo[0], vo[1], wp.abs(co))
    wh = wp.normalize(vi + vr)
    dwh = wp.abs(1.0 / (4.0 * wp.dot(vr, wh)))
    if co > 0.0:
        if p[0] > 0.0 and wp.dot(vi, wh) > 0.0 and wp.dot(vo, wh) > 0.0:
            a = alphas(mat.param[ANISOTROPIC], mat.param[ROUGHNESS])
            r += p[0] * ggx_vndf_pdf(a, vi, wh) * dwh
        r += p[2] * co * INV_PI
    elif co < 0.0:
        if p[1] > 0.0 and wp.dot(vi, wh) > 0.0 and wp.dot(vo, wh) < 0.0:
            a = alphas(mat.param[ANISOTROPIC], scaled_roughness(mat))
            r += p[1] * ggx_vndf_pdf(a, vi, wh) * dwh
        r += p[3] * (-co) * INV_PI
    return r


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    f = local(n, wo, wo)
    c = f.wo[2]
    if c == 0.0:
        return proposal(wp.vec3(0.0))
    vi = mulsign(f.wo, c)
    p = lobe_probabilities(mat)
    vo = wp.vec3(0.0)
    if u_lobe < p[0] + p[1]:
        rough = mat.param[ROUGHNESS]
        if u_lobe >= p[0]:
            rough = scaled_roughness(mat)
        m = ggx_vndf_sample(alphas(mat.param[ANISOTROPIC], rough), vi, u)
        vo = 2.0 * wp.dot(vi, m) * m - vi
        if vo[2] <= 0.0:
            # below the sheet: Mitsuba drops it (the other lobe's density would count it)
            return proposal(wp.vec3(0.0))
        if u_lobe >= p[0]:
            vo = wp.vec3(vo[0], vo[1], -vo[2])      # to the other side, unbent
    else:
        vo = square_to_cosine_hemisphere(u)
        if u_lobe >= p[0] + p[1] + p[2]:
            vo = -vo
    return proposal(to_world(f, mulsign(vo, c)))
