"""Materials per kernel variant: kind codes, BSDFs, (checkered) albedo and emission.

`make_bsdf(features, strategy)` returns Bsdf, Warp functions of the features' material kinds that
can be called on their own (the tracer, MIS and the chi-square tests use the same ones):
    eval_bsdf(kind, albedo, exponent, ior, n, wo, wi) -> f(wo, wi) |cos theta_i|  (non-delta kinds)
    pdf_bsdf(kind, exponent, ior, n, wo, wi)          -> solid-angle density of sample_bsdf
    sample_bsdf(kind, albedo, exponent, ior, n, wo, u_lobe, u) -> Scatter (weight = f|cos|/pdf)
`strategy.lobe` True samples cosine / Phong lobes / Fresnel, False samples uniform hemisphere
(sphere for glossy transmission) and picks reflect/refract with probability 1/2.
`plastic` is a diffuse base under a glossy dielectric coat; its model is `eval_plastic`'s docstring.
`exponent` is the material's lobe shape (MaterialKind.shape_key): the Phong exponent, or GGX's alpha
for `ggx` (a rough conductor whose facets reflect `albedo`) and `ggx_dielectric` (Walter et al. 2007
rough reflection and transmission); their model is the "GGX" section's comment. `strategy.microfacet`
picks how the lobe strategy draws their microfacet normals (visible normals or D cos).
`surface_albedo(sd, m, uv)` is the (checkered) albedo, `emitted(sd, h, wo)` a hit's emission.
"""
from typing import NamedTuple

import numpy as np
import warp as wp

from drtlab.estimators.domain_maps import (INV_4PI, INV_PI, frame_to_world, phong_lobe_pdf,
                                           sincos_turns, square_to_cosine_hemisphere,
                                           square_to_phong_lobe, square_to_uniform_hemisphere,
                                           square_to_uniform_sphere)
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.intersection.primitives import Hit
from drtlab.kernels.material_kinds import MATERIAL_CODE, kinds_where

# Material kind codes (MaterialData.kind), defined by material_kinds.KINDS.
DIFFUSE = wp.constant(MATERIAL_CODE["diffuse"])
GLOSSY = wp.constant(MATERIAL_CODE["glossy"])
MIRROR = wp.constant(MATERIAL_CODE["mirror"])
DIELECTRIC = wp.constant(MATERIAL_CODE["dielectric"])
GLOSSY_DIELECTRIC = wp.constant(MATERIAL_CODE["glossy_dielectric"])
EMITTER = wp.constant(MATERIAL_CODE["emitter"])
PLASTIC = wp.constant(MATERIAL_CODE["plastic"])
GGX = wp.constant(MATERIAL_CODE["ggx"])
GGX_DIELECTRIC = wp.constant(MATERIAL_CODE["ggx_dielectric"])


@wp.struct
class Scatter:
    wi: wp.vec3
    weight: wp.vec3     # f * |cos| / pdf, or the delta lobe's weight
    pdf: float          # solid-angle pdf; 0 for delta lobes
    delta: int
    valid: int


@wp.struct
class Interface:
    """The side of a dielectric boundary a direction wo arrives from."""
    nf: wp.vec3         # normal on wo's side
    co: float           # |cos| of wo
    eta: float          # n_transmitted / n_incident
    F: float            # Fresnel reflectance (1 on total internal reflection)


@wp.func
def fresnel(cos_i: float, eta: float) -> float:
    # Unpolarised Fresnel reflectance; eta = n_transmitted / n_incident; 1 on total reflection.
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = wp.sqrt(1.0 - sin2_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


@wp.func
def refract_dir(wo: wp.vec3, nf: wp.vec3, cos_o: float, eta: float) -> wp.vec3:
    sin2_t = (1.0 - cos_o * cos_o) / (eta * eta)
    cos_t = wp.sqrt(wp.max(0.0, 1.0 - sin2_t))
    return wp.normalize(-wo / eta + (cos_o / eta - cos_t) * nf)


@wp.func
def interface(n: wp.vec3, wo: wp.vec3, ior: float) -> Interface:
    # n is the outward normal: wo below it means the ray leaves the medium.
    it = Interface()
    cos_o = wp.dot(n, wo)
    it.nf = n
    it.eta = ior
    if cos_o < 0.0:
        it.nf = -n
        it.eta = 1.0 / ior
    it.co = wp.abs(cos_o)
    it.F = fresnel(it.co, it.eta)
    return it


@wp.func
def glossy_dielectric_lobes(it: Interface, wo: wp.vec3, wi: wp.vec3, exponent: float) -> wp.vec2:
    """Phong lobe densities at wi around the mirror (x) and refracted (y) directions, on either
    side of the surface: a lobe near the horizon proposes directions on both sides. The refracted
    lobe is zero under total internal reflection."""
    r = phong_lobe_pdf(wp.dot(2.0 * it.co * it.nf - wo, wi), exponent)
    t = float(0.0)
    if it.F < 1.0:
        t = phong_lobe_pdf(wp.dot(refract_dir(wo, it.nf, it.co, it.eta), wi), exponent)
    return wp.vec2(r, t)


@wp.func
def eval_glossy_dielectric(albedo: wp.vec3, exponent: float, ior: float, n: wp.vec3,
                           wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    # f|cos| is the Phong lobe density around the mirror (weight F) or the refracted direction
    # (weight (1 - F) * albedo / eta^2), so energy is conserved up to what crosses the surface.
    # A lobe's part on the wrong side of the surface is not scattering: reflection counts only
    # above, transmission only below (the sampler's pdf still counts both, see pdf_bsdf).
    it = interface(n, wo, ior)
    lobes = glossy_dielectric_lobes(it, wo, wi, exponent)
    ci = wp.dot(it.nf, wi)
    r = wp.vec3(0.0)
    if ci > 0.0:
        r = wp.vec3(it.F * lobes[0])
    elif ci < 0.0:
        r = albedo * ((1.0 - it.F) / (it.eta * it.eta) * lobes[1])
    return r


# ---------------------------------------------------------------------------------------------------
# Plastic: a diffuse base under a smooth-Fresnel Phong coat
# ---------------------------------------------------------------------------------------------------

# 16-point Gauss-Legendre rule on [0, 1] for fresnel_average: the integrand is analytic in mu for
# ior > 1, so the error is below 2e-7 for ior >= 1.001 (1e-10 from 1.01 on), and exactly 0 at 1.
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
_GL16 = wp.types.vector(length=16, dtype=float)
GL16_X = wp.constant(_GL16(*(0.5 * (_GL_NODES + 1.0)).tolist()))
GL16_W = wp.constant(_GL16(*(0.5 * _GL_WEIGHTS).tolist()))


@wp.func
def fresnel_average(eta: float) -> float:
    """2 int_0^1 F(mu) mu dmu: the cosine-weighted hemispherical average of fresnel(., eta)
    (0.0918 at eta = 1.5), the fraction of diffuse light arriving from outside that the coat
    reflects."""
    s = float(0.0)
    for k in range(16):
        mu = GL16_X[k]
        s += GL16_W[k] * mu * fresnel(mu, eta)
    return 2.0 * s


@wp.func
def eval_plastic(albedo: wp.vec3, exponent: float, ior: float, n: wp.vec3, wo: wp.vec3,
                 wi: wp.vec3) -> wp.vec3:
    """f|cos_i| of plastic, two-sided like diffuse and glossy: with F_o = F(|cos_o|), F_i = F(|cos_i|)
    (fresnel at the coat's ior), alpha the angle between wi and wo's mirror direction and
    Fbar = fresnel_average(ior),
        f = min(F_o, F_i) (n + 2) / (2 pi) cos^n(alpha)                     (coat, white)
          + albedo (1 - F_o)(1 - F_i) / (pi (1 - Fbar))                     (base)
    for wo, wi on one side (0 otherwise). The base is the coupled diffuse term of Shirley et al.
    1997 / Ashikhmin & Shirley 2000 (there with Schlick's approximation and the constants 21/20,
    28/23) with the exact Fresnel and its exact average: its albedo is exactly (1 - F_o) albedo.
    The coat is the glossy kind's normalised modified Phong lobe (albedo <= 1, Lewis 1994) weighted
    by min(F_o, F_i) <= F_o, which keeps f reciprocal; so the directional albedo is
    <= F_o + (1 - F_o) albedo <= 1 (= 1 at normal incidence for albedo 1: F_i >= F_o there).
    Multiple reflections inside the coat are not modelled (no internal-reflection term)."""
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    r = wp.vec3(0.0)
    if cos_o * cos_i > 0.0:
        co = wp.abs(cos_o)
        ci = wp.abs(cos_i)
        fo = fresnel(co, ior)
        fi = fresnel(ci, ior)
        ca = wp.dot(2.0 * cos_o * n - wo, wi)
        coat = float(0.0)
        if ca > 0.0:
            coat = wp.min(fo, fi) * (exponent + 2.0) * 0.5 * INV_PI * wp.pow(ca, exponent)
        base = (1.0 - fo) * (1.0 - fi) * INV_PI / (1.0 - fresnel_average(ior))
        r = (wp.vec3(coat) + albedo * base) * ci
    return r


@wp.func
def plastic_coat_probability(co: float, ior: float) -> float:
    """Lobe strategy: the coat lobe is sampled with probability F(|cos_o|), its share of the energy
    for a white base (pdf_bsdf gets no albedo, so the choice cannot depend on it)."""
    return fresnel(co, ior)


# ---------------------------------------------------------------------------------------------------
# GGX (Trowbridge-Reitz) microfacets
# ---------------------------------------------------------------------------------------------------
# Isotropic alpha; D(m) = alpha^2 / (pi (alpha^2 cos^2 + sin^2)^2); Smith masking-shadowing,
# height-correlated: G2 = 1 / (1 + Lambda(wo) + Lambda(wi)), Lambda = (sqrt(1 + alpha^2 tan^2) - 1)/2
# (Heitz 2014). With wo, wi on one side (nf) and wm their half vector:
#   ggx:             f|cos_i| = albedo D G2 / (4 |cos_o|)          (facets reflect `albedo`; no Fresnel)
#   ggx_dielectric:  reflection   F(wo.wm) D G2 / (4 |cos_o|),  wm = normalize(wo + wi)
#                    transmission albedo (1 - F) D G2 |wi.wm| (wo.wm) / (|cos_o| (wi.wm + wo.wm/eta)^2
#                                 eta^2),  wm = +-normalize(wo + eta wi) on wo's side (Walter et al.
#                    2007; the 1/eta^2 of radiance as the other dielectrics); back-facing wm -> 0.
# Single scattering only: light that would scatter more than once among the facets is lost (a white
# ggx keeps 0.988 at alpha 0.1, 0.688 at 0.5, 0.307 at 1, normal incidence; SCENE_FORMAT.md).
# Sampling a normal: "vndf" draws wm with density G1(wo) D(wm) max(0, wo.wm) / cos_o (Dupuy &
# Benyoub 2023's spherical caps, the density of Heitz 2018), "d" with D(wm) cos(theta_m); the lobe
# strategy then reflects (ggx) or picks reflection with probability F(wo.wm), else refracts, and
# drops a direction that lands on the wrong side. The BSDF's pdf is the normal's times |dwm/dwi|.


@wp.func
def ggx_d(alpha: float, c2: float, s2: float) -> float:
    """D at a normal with cos^2 c2 and sin^2 s2 (passed apart: s2 from a cross product keeps its
    precision where the lobe is narrow)."""
    a2 = alpha * alpha
    t = a2 * c2 + s2
    return a2 * INV_PI / (t * t)


@wp.func
def ggx_lambda(alpha: float, c: float) -> float:
    """Smith's Lambda of a direction at |cos| c to the normal, as 0.5 x / (1 + sqrt(1 + x)) with
    x = alpha^2 tan^2 (no cancellation where x is small); large and finite at the horizon."""
    c2 = c * c
    x = alpha * alpha * wp.max(1.0 - c2, 0.0) / wp.max(c2, 1.0e-30)
    return 0.5 * x / (1.0 + wp.sqrt(1.0 + x))


@wp.func
def ggx_g1(alpha: float, c: float) -> float:
    return 1.0 / (1.0 + ggx_lambda(alpha, c))


@wp.func
def ggx_g2(alpha: float, co: float, ci: float) -> float:
    return 1.0 / (1.0 + ggx_lambda(alpha, co) + ggx_lambda(alpha, ci))


@wp.func
def ggx_d_at(alpha: float, nf: wp.vec3, wm: wp.vec3) -> float:
    c = wp.dot(nf, wm)
    x = wp.cross(nf, wm)
    return ggx_d(alpha, c * c, wp.dot(x, x))


@wp.struct
class Microfacet:
    """The microfacet normal that takes wo to wi, on wo's side of the surface."""
    wm: wp.vec3
    om: float           # wo.wm (> 0 when valid)
    dwm: float          # |dwm / dwi|: 1 / (4 wo.wm), or |wi.wm| / (wi.wm + wo.wm / eta)^2
    F: float            # Fresnel at wo.wm (dielectric; 1 for the conductor)
    reflect: int
    valid: int


@wp.func
def ggx_half(nf: wp.vec3, eta: float, wo: wp.vec3, wi: wp.vec3, transmits: int) -> Microfacet:
    r = Microfacet()
    r.valid = 0
    ci = wp.dot(nf, wi)
    if wp.dot(nf, wo) <= 0.0 or ci == 0.0:
        return r
    h = wo + wi
    r.reflect = 1
    if ci < 0.0:
        if transmits == 0:
            return r
        h = wo + eta * wi
        r.reflect = 0
    hl = wp.length(h)
    if hl <= 0.0:
        return r
    wm = h / hl
    if wp.dot(wm, nf) < 0.0:
        wm = -wm
    om = wp.dot(wo, wm)
    im = wp.dot(wi, wm)
    if om <= 0.0 or (r.reflect == 0 and im >= 0.0):
        return r
    r.wm = wm
    r.om = om
    r.F = 1.0
    if transmits == 1:
        r.F = fresnel(om, eta)
    if r.reflect == 1:
        r.dwm = 0.25 / om
    else:
        d = im + om / eta
        r.dwm = -im / (d * d)
    r.valid = 1
    return r


@wp.func
def eval_ggx(albedo: wp.vec3, alpha: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3,
             transmits: int) -> wp.vec3:
    """f|cos_i| of ggx (transmits 0: albedo is the facets' reflectance, two-sided) and of
    ggx_dielectric (transmits 1: n is the outward normal), the model above."""
    nf = n
    eta = float(1.0)
    co = wp.dot(n, wo)
    if transmits == 1:
        it = interface(n, wo, ior)
        nf = it.nf
        eta = it.eta
        co = it.co
    elif co < 0.0:
        nf = -n
        co = -co
    r = wp.vec3(0.0)
    mf = ggx_half(nf, eta, wo, wi, transmits)
    if mf.valid == 1:
        ci = wp.abs(wp.dot(nf, wi))
        dg = ggx_d_at(alpha, nf, mf.wm) * ggx_g2(alpha, co, ci) / co
        if mf.reflect == 1:
            if transmits == 1:
                r = wp.vec3(0.25 * mf.F * dg)
            else:
                r = albedo * (0.25 * dg)
        else:
            r = albedo * ((1.0 - mf.F) * dg * mf.dwm * mf.om / (eta * eta))
    return r


@wp.func
def ggx_normal_pdf_vndf(alpha: float, nf: wp.vec3, co: float, wm: wp.vec3, om: float) -> float:
    return ggx_g1(alpha, co) * ggx_d_at(alpha, nf, wm) * wp.max(om, 0.0) / co


@wp.func
def ggx_normal_pdf_d(alpha: float, nf: wp.vec3, co: float, wm: wp.vec3, om: float) -> float:
    return ggx_d_at(alpha, nf, wm) * wp.dot(nf, wm)


@wp.func
def square_to_ggx_vndf(wo_l: wp.vec3, alpha: float, u: wp.vec2) -> wp.vec3:
    """A normal (local frame, z up) from the visible normals of wo_l (z > 0): Dupuy & Benyoub 2023,
    a uniform point on the spherical cap below the stretched wo's hemisphere, added to it and
    unstretched."""
    v = wp.normalize(wp.vec3(alpha * wo_l[0], alpha * wo_l[1], wo_l[2]))
    cs = sincos_turns(u[0])
    z = (1.0 - u[1]) * (1.0 + v[2]) - v[2]
    st = wp.sqrt(wp.max(1.0 - z * z, 0.0))
    h = wp.vec3(st * cs[0], st * cs[1], z) + v
    return wp.normalize(wp.vec3(alpha * h[0], alpha * h[1], wp.max(h[2], 0.0)))


@wp.func
def square_to_ggx_d(alpha: float, u: wp.vec2) -> wp.vec3:
    """A normal (local frame) with density D cos(theta_m): tan^2 = alpha^2 u / (1 - u), cos^2 and
    sin^2 each from their own ratio (1 - cos^2 would lose sin^2 ~ alpha^2 to rounding)."""
    a2 = alpha * alpha
    q = (1.0 - u[0]) + a2 * u[0]
    c = wp.sqrt((1.0 - u[0]) / q)
    s = wp.sqrt(a2 * u[0] / q)
    cs = sincos_turns(u[1])
    return wp.vec3(s * cs[0], s * cs[1], c)


def make_ggx_normals(vndf: bool):
    """(sample, pdf) of the microfacet normal as `strategy.microfacet` draws it."""
    VNDF = vndf

    @wp.func
    def sample_ggx_normal(nf: wp.vec3, wo: wp.vec3, co: float, alpha: float, u: wp.vec2) -> wp.vec3:
        # A frame whose x axis is wo's tangent part (isotropic D: any azimuth origin will do).
        t = wo - co * nf
        st = wp.length(t)
        if st > 0.0:
            t = t / st
        else:
            t = frame_to_world(wp.vec3(1.0, 0.0, 0.0), nf)
        b = wp.cross(nf, t)
        m = wp.vec3(0.0)
        if wp.static(VNDF):
            m = square_to_ggx_vndf(wp.vec3(st, 0.0, co), alpha, u)
        else:
            m = square_to_ggx_d(alpha, u)
        return t * m[0] + b * m[1] + nf * m[2]

    normal_pdf = ggx_normal_pdf_vndf if VNDF else ggx_normal_pdf_d
    return sample_ggx_normal, normal_pdf


# The material kinds whose sample_bsdf reads u_lobe; every other kind samples one lobe.
LOBE_CHOICE_KINDS = frozenset(kinds_where(lambda k: k.lobe_choice))


class Bsdf(NamedTuple):
    eval_bsdf: wp.Function      # (kind, albedo, exponent, ior, n, wo, wi) -> f|cos|
    pdf_bsdf: wp.Function       # (kind, exponent, ior, n, wo, wi) -> sample_bsdf's density
    sample_bsdf: wp.Function    # (kind, albedo, exponent, ior, n, wo, u_lobe, u) -> Scatter


def make_bsdf(f: Features, strategy: Strategy) -> Bsdf:
    normals = make_ggx_normals(strategy.microfacet == "vndf")
    eval_bsdf, pdf_bsdf = _make_densities(f.kinds, strategy.lobe, normals[1])
    sample_bsdf = _make_sampler(f.kinds, strategy.lobe, eval_bsdf, pdf_bsdf, normals[0])
    return Bsdf(eval_bsdf=eval_bsdf, pdf_bsdf=pdf_bsdf, sample_bsdf=sample_bsdf)


def _make_densities(kinds: frozenset, lobe: bool, ggx_normal_pdf) -> tuple:
    """eval_bsdf (f|cos|) and pdf_bsdf (the density sample_bsdf proposes with) of `kinds`."""
    K_DIFFUSE = "diffuse" in kinds
    K_GLOSSY = "glossy" in kinds
    K_GDIEL = "glossy_dielectric" in kinds
    K_PLASTIC = "plastic" in kinds
    K_GGX = "ggx" in kinds
    K_GGXD = "ggx_dielectric" in kinds
    LOBE = lobe

    @wp.func
    def eval_bsdf(kind: int, albedo: wp.vec3, exponent: float, ior: float, n: wp.vec3,
                  wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        """f(wo, wi) * |cos(theta_i)| for the non-delta kinds; zero for delta kinds."""
        r = wp.vec3(0.0)
        cos_o = wp.dot(n, wo)
        cos_i = wp.dot(n, wi)
        if wp.static(K_DIFFUSE):
            if kind == DIFFUSE:
                if cos_o * cos_i > 0.0:
                    r = albedo * (wp.abs(cos_i) * INV_PI)
        if wp.static(K_GLOSSY):
            if kind == GLOSSY:
                if cos_o * cos_i > 0.0:
                    refl = 2.0 * cos_o * n - wo
                    ca = wp.dot(refl, wi)
                    if ca > 0.0:
                        r = albedo * ((exponent + 2.0) * 0.5 * INV_PI * wp.pow(ca, exponent)
                                      * wp.abs(cos_i))
        if wp.static(K_GDIEL):
            if kind == GLOSSY_DIELECTRIC:
                r = eval_glossy_dielectric(albedo, exponent, ior, n, wo, wi)
        if wp.static(K_PLASTIC):
            if kind == PLASTIC:
                r = eval_plastic(albedo, exponent, ior, n, wo, wi)
        if wp.static(K_GGX):
            if kind == GGX:
                r = eval_ggx(albedo, exponent, ior, n, wo, wi, 0)
        if wp.static(K_GGXD):
            if kind == GGX_DIELECTRIC:
                r = eval_ggx(albedo, exponent, ior, n, wo, wi, 1)
        return r

    @wp.func
    def pdf_bsdf(kind: int, exponent: float, ior: float, n: wp.vec3, wo: wp.vec3,
                 wi: wp.vec3) -> float:
        """Solid-angle density with which `sample_bsdf` proposes wi (non-delta kinds)."""
        cos_o = wp.dot(n, wo)
        cos_i = wp.dot(n, wi)
        p = float(0.0)
        if wp.static(not LOBE):
            if kind == GLOSSY_DIELECTRIC or kind == GGX_DIELECTRIC:
                p = INV_4PI
            elif cos_o * cos_i > 0.0:
                p = 0.5 * INV_PI
        if wp.static(LOBE):
            if wp.static(K_DIFFUSE):
                if kind == DIFFUSE:
                    if cos_o * cos_i > 0.0:
                        p = wp.abs(cos_i) * INV_PI
            if wp.static(K_GLOSSY):
                if kind == GLOSSY:
                    if cos_o * cos_i > 0.0:
                        nf = n
                        if cos_o < 0.0:
                            nf = -n
                        refl = 2.0 * wp.abs(cos_o) * nf - wo
                        p = phong_lobe_pdf(wp.dot(refl, wi), exponent)
            if wp.static(K_GDIEL):
                if kind == GLOSSY_DIELECTRIC:
                    it = interface(n, wo, ior)
                    lobes = glossy_dielectric_lobes(it, wo, wi, exponent)
                    # The proposal is the Fresnel-weighted mixture of both lobes wherever wi lies.
                    p = it.F * lobes[0] + (1.0 - it.F) * lobes[1]
            if wp.static(K_PLASTIC):
                if kind == PLASTIC:
                    if cos_o * cos_i > 0.0:
                        # The mixture of the coat's Phong lobe and the base's cosine lobe.
                        pc = plastic_coat_probability(wp.abs(cos_o), ior)
                        refl = 2.0 * cos_o * n - wo
                        p = (pc * phong_lobe_pdf(wp.dot(refl, wi), exponent)
                             + (1.0 - pc) * wp.abs(cos_i) * INV_PI)
            if wp.static(K_GGX):
                if kind == GGX:
                    nf = n
                    if cos_o < 0.0:
                        nf = -n
                    mf = ggx_half(nf, 1.0, wo, wi, 0)
                    if mf.valid == 1:
                        p = ggx_normal_pdf(exponent, nf, wp.abs(cos_o), mf.wm, mf.om) * mf.dwm
            if wp.static(K_GGXD):
                if kind == GGX_DIELECTRIC:
                    it = interface(n, wo, ior)
                    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
                    if mf.valid == 1:
                        # The lobe chosen with probability F(wo.wm), then its Jacobian.
                        pl = mf.F
                        if mf.reflect == 0:
                            pl = 1.0 - mf.F
                        p = ggx_normal_pdf(exponent, it.nf, it.co, mf.wm, mf.om) * mf.dwm * pl
        return p

    return eval_bsdf, pdf_bsdf


def _make_sampler(kinds: frozenset, lobe: bool, eval_bsdf, pdf_bsdf, sample_ggx_normal):
    """sample_bsdf of `kinds`: delta lobes directly, the others by proposal and eval_bsdf / pdf_bsdf."""
    K_DIFFUSE = "diffuse" in kinds
    K_GLOSSY = "glossy" in kinds
    K_MIRROR = "mirror" in kinds
    K_DIEL = "dielectric" in kinds
    K_GDIEL = "glossy_dielectric" in kinds
    K_PLASTIC = "plastic" in kinds
    K_GGX = "ggx" in kinds
    K_GGXD = "ggx_dielectric" in kinds
    LOBE = lobe

    @wp.func
    def sample_bsdf(kind: int, albedo: wp.vec3, exponent: float, ior: float, n: wp.vec3,
                    wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        s = Scatter()
        s.valid = 0
        s.delta = 0
        cos_o = wp.dot(n, wo)
        nf = n
        if cos_o < 0.0:
            nf = -n
        co = wp.abs(cos_o)
        if wp.static(K_MIRROR):
            if kind == MIRROR:
                s.wi = 2.0 * co * nf - wo
                s.weight = albedo
                s.delta = 1
                s.valid = 1
                return s
        if wp.static(K_DIEL):
            if kind == DIELECTRIC:
                it = interface(n, wo, ior)
                eta = it.eta
                F = it.F
                p_reflect = F
                if wp.static(not LOBE):
                    p_reflect = 0.5
                if F >= 1.0:
                    p_reflect = 1.0
                s.delta = 1
                s.valid = 1
                if u_lobe < p_reflect:
                    s.wi = 2.0 * co * nf - wo
                    s.weight = wp.vec3(F / p_reflect)
                else:
                    s.wi = refract_dir(wo, nf, co, eta)
                    s.weight = albedo * ((1.0 - F) / ((1.0 - p_reflect) * eta * eta))
                return s
        if kind == EMITTER:
            return s
        # Non-delta kinds: propose a direction, then weight = f|cos| / pdf evaluated separately.
        wi = wp.vec3(0.0)
        if wp.static(not LOBE):
            if kind == GLOSSY_DIELECTRIC or kind == GGX_DIELECTRIC:
                wi = square_to_uniform_sphere(u)
            else:
                wi = frame_to_world(square_to_uniform_hemisphere(u), nf)
        if wp.static(LOBE):
            if wp.static(K_DIFFUSE):
                if kind == DIFFUSE:
                    wi = frame_to_world(square_to_cosine_hemisphere(u), nf)
            if wp.static(K_GLOSSY):
                if kind == GLOSSY:
                    wi = frame_to_world(square_to_phong_lobe(u, exponent), 2.0 * co * nf - wo)
            if wp.static(K_GDIEL):
                if kind == GLOSSY_DIELECTRIC:
                    it = interface(n, wo, ior)
                    axis = 2.0 * co * nf - wo
                    if u_lobe >= it.F:
                        axis = refract_dir(wo, nf, co, it.eta)
                    wi = frame_to_world(square_to_phong_lobe(u, exponent), axis)
            if wp.static(K_PLASTIC):
                if kind == PLASTIC:
                    if u_lobe < plastic_coat_probability(co, ior):
                        wi = frame_to_world(square_to_phong_lobe(u, exponent), 2.0 * co * nf - wo)
                    else:
                        wi = frame_to_world(square_to_cosine_hemisphere(u), nf)
            if wp.static(K_GGX):
                if kind == GGX:
                    if co <= 0.0:
                        return s
                    wm = sample_ggx_normal(nf, wo, co, exponent, u)
                    wi = 2.0 * wp.dot(wo, wm) * wm - wo
            if wp.static(K_GGXD):
                if kind == GGX_DIELECTRIC:
                    it = interface(n, wo, ior)
                    if it.co <= 0.0:
                        return s
                    wm = sample_ggx_normal(it.nf, wo, it.co, exponent, u)
                    om = wp.dot(wo, wm)
                    if om <= 0.0:
                        return s
                    if u_lobe < fresnel(om, it.eta):
                        wi = 2.0 * om * wm - wo
                        if wp.dot(it.nf, wi) <= 0.0:
                            return s        # reflected below: pdf_bsdf would read it as refracted
                    else:
                        wi = refract_dir(wo, wm, om, it.eta)
                        if wp.dot(it.nf, wi) >= 0.0:
                            return s        # refracted above: pdf_bsdf would read it as reflected
        pdf = pdf_bsdf(kind, exponent, ior, n, wo, wi)
        if pdf > 0.0:
            fc = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)
            if fc[0] > 0.0 or fc[1] > 0.0 or fc[2] > 0.0:
                s.wi = wi
                s.pdf = pdf
                s.weight = fc / pdf
                s.valid = 1
        return s

    return sample_bsdf


@wp.func
def checkered(sd: SceneData, m: int) -> int:
    """1 when material m is a checker texture (it reads the hit's uv)."""
    if sd.materials.checker[m][0] > 0.0:
        return 1
    return 0


@wp.func
def surface_albedo(sd: SceneData, m: int, uv: wp.vec2) -> wp.vec3:
    """Albedo at a surface point; checkered materials alternate albedo and albedo2. A runtime
    switch, not a compiled-out feature: one load and a branch per hit, and scenes with and without
    checker textures share a kernel variant."""
    a = sd.materials.albedo[m]
    if checkered(sd, m) == 1:
        c = sd.materials.checker[m]
        iu = int(wp.floor(uv[0] * c[0]))
        iv = int(wp.floor(uv[1] * c[1]))
        if (iu + iv) % 2 != 0:
            a = sd.materials.albedo2[m]
    return a


@wp.func
def emitted(sd: SceneData, h: Hit, wo: wp.vec3) -> wp.vec3:
    # Emitters radiate on the side their normal faces (spheres outward, quads edge_u x edge_v).
    if wp.dot(h.n, wo) > 0.0:
        return sd.materials.emission[h.material]
    return wp.vec3(0.0)
