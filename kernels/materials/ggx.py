"""GGX (Trowbridge-Reitz) microfacets: the rough conductor `ggx` and rough dielectric `ggx_dielectric`,
their normal distributions and the two ways of sampling a normal.

This module is also the `ggx` kind of the kind table (`material_kinds.MaterialKind.model`), on the
one BSDF interface (the package docstring), the normal drawn as the strategy's `microfacet` says
(`sampling`); `ggx_dielectric.py` is the other kind."""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, facing, frame_to_world, sincos_turns
from drtlab.kernels.materials.dielectric import fresnel, interface
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


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
def lobe_choice(mf: Microfacet) -> float:
    """The probability with which a rough dielectric chose mf's lobe: F(wo.wm) to reflect, else
    1 - F (dielectric.scatter_at_normal)."""
    pl = mf.F
    if mf.reflect == 0:
        pl = 1.0 - mf.F
    return pl


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



@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_ggx(mat.albedo, mat.shape, mat.ior, n, wo, wi, 0)


def _make_lobe(vndf: bool):
    """(sample, pdf) of the conductor's lobe: a normal drawn as `vndf` says, wo reflected about it."""
    sample_normal, normal_pdf = make_ggx_normals(vndf)

    @wp.func
    def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        nf = facing(n, wo)
        co = wp.abs(wp.dot(n, wo))
        if co <= 0.0:
            return proposal(wp.vec3(0.0))
        wm = sample_normal(nf, wo, co, mat.shape, u)
        return proposal(2.0 * wp.dot(wo, wm) * wm - wo)

    @wp.func
    def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        nf = facing(n, wo)
        p = float(0.0)
        mf = ggx_half(nf, 1.0, wo, wi, 0)
        if mf.valid == 1:
            p = normal_pdf(mat.shape, nf, wp.abs(wp.dot(n, wo)), mf.wm, mf.om) * mf.dwm
        return p

    return sample, pdf


_LOBES = {True: _make_lobe(True), False: _make_lobe(False)}
sample, pdf = _LOBES[True]


def sampling(strategy):
    """(sample, pdf) as `strategy` draws the normal (its `microfacet`: "vndf" or "d")."""
    return _LOBES[strategy.microfacet == "vndf"]
