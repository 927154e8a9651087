"""What Mitsuba 3's two Disney kinds share (src/bsdfs/principledhelpers.h, include/mitsuba/render/
microfacet.h): a local frame at the hit, the anisotropic GGX of the main specular lobes (Mitsuba's
separable Smith masking, visible-normal sampling), the clearcoat's GTR1, Schlick's Fresnel weights,
the diffuse and sheen lobes. principled.py and principled_thin.py are the kinds.

Local frames: z the shading normal, x the tangent; a hit carries no tangent in drtlab, so the
tangent is frame_to_world's (Duff et al.) for the normal: an anisotropic lobe's orientation about
the normal is that basis's, not Mitsuba's dp/du (the lobe's shape and its energy are Mitsuba's).
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, PI, frame_to_world, sincos_turns
from drtlab.kernels.materials.dielectric import fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.texture import luminance
from drtlab.kernels.scene_model.principled_params import PARAM_INDEX

# Places in MaterialAt.param (principled_params.PARAMS).
ROUGHNESS, ANISOTROPIC, METALLIC, SPEC_TRANS, SPEC_TINT, SHEEN, SHEEN_TINT, CLEARCOAT, \
    CLEARCOAT_GLOSS, FLATNESS, DIFF_TRANS = (wp.constant(PARAM_INDEX[n]) for n in (
        "roughness", "anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint",
        "clearcoat", "clearcoat_gloss", "flatness", "diff_trans"))
SPEC_RATE, CLEARCOAT_RATE, DIFF_REFL_RATE, SPEC_REFL_RATE, SPEC_TRANS_RATE, DIFF_TRANS_RATE = (
    wp.constant(PARAM_INDEX[n]) for n in (
        "main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate",
        "specular_reflectance_sampling_rate", "specular_transmittance_sampling_rate",
        "diffuse_transmittance_sampling_rate"))


@wp.struct
class Local:
    """wo and wi in the hit's local frame (z the normal n)."""
    s: wp.vec3
    t: wp.vec3
    n: wp.vec3
    wo: wp.vec3
    wi: wp.vec3


@wp.func
def local(n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> Local:
    r = Local()
    r.s = frame_to_world(wp.vec3(1.0, 0.0, 0.0), n)
    r.t = frame_to_world(wp.vec3(0.0, 1.0, 0.0), n)
    r.n = n
    r.wo = wp.vec3(wp.dot(wo, r.s), wp.dot(wo, r.t), wp.dot(wo, n))
    r.wi = wp.vec3(wp.dot(wi, r.s), wp.dot(wi, r.t), wp.dot(wi, n))
    return r


@wp.func
def to_world(f: Local, v: wp.vec3) -> wp.vec3:
    return f.s * v[0] + f.t * v[1] + f.n * v[2]


@wp.func
def tint(c: wp.vec3) -> wp.vec3:
    """The colour normalised by its luminance (white where that is 0)."""
    lum = luminance(c)
    if lum > 0.0:
        return c / lum
    return wp.vec3(1.0)


@wp.func
def mulsign(v: wp.vec3, s: float) -> wp.vec3:
    if s < 0.0:
        return -v
    return v


# ---- Fresnel --------------------------------------------------------------------------------------

@wp.func
def fresnel_signed(cos_i: float, eta: float) -> float:
    """Mitsuba's fresnel(cos_i, eta): cos_i < 0 arrives from inside (index 1 / eta beyond)."""
    if eta == 1.0:
        return 0.0
    if cos_i >= 0.0:
        return fresnel(cos_i, eta)
    return fresnel(-cos_i, 1.0 / eta)


@wp.func
def schlick_weight(c: float) -> float:
    m = wp.clamp(1.0 - c, 0.0, 1.0)
    return m * m * m * m * m


@wp.func
def schlick_eta(cos_i: float, eta: float) -> float:
    """The Schlick weight Mitsuba's calc_schlick lerps R0 to 1 with: of |cos_i| where the ray
    enters the denser side, else of the transmitted cosine (0 beyond the critical angle: weight 1)."""
    eta_it = eta
    eta_ti = 1.0 / eta
    if cos_i < 0.0:
        eta_it = 1.0 / eta
        eta_ti = eta
    if eta_it > 1.0:
        return schlick_weight(wp.abs(cos_i))
    ct2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti
    return schlick_weight(wp.sqrt(wp.max(ct2, 0.0)))


@wp.func
def schlick_rgb(r0: wp.vec3, w: float) -> wp.vec3:
    return r0 * (1.0 - w) + wp.vec3(w)


@wp.func
def schlick_r0(eta: float) -> float:
    r = (eta - 1.0) / (eta + 1.0)
    return r * r


# ---- anisotropic GGX (Mitsuba's MicrofacetDistribution, separable Smith G) -------------------------

@wp.func
def alphas(anisotropic: float, roughness: float) -> wp.vec2:
    """(alpha_x, alpha_y): Disney's roughness^2 stretched by sqrt(1 - 0.9 anisotropic), >= 1e-3."""
    r2 = roughness * roughness
    aspect = wp.sqrt(1.0 - 0.9 * anisotropic)
    return wp.vec2(wp.max(0.001, r2 / aspect), wp.max(0.001, r2 * aspect))


@wp.func
def ggx_d(a: wp.vec2, m: wp.vec3) -> float:
    x = m[0] / a[0]
    y = m[1] / a[1]
    t = x * x + y * y + m[2] * m[2]
    d = 1.0 / (PI * a[0] * a[1] * t * t)
    if d * m[2] > 1.0e-20:
        return d
    return 0.0


@wp.func
def ggx_g1(a: wp.vec2, v: wp.vec3, m: wp.vec3) -> float:
    xy = (a[0] * v[0]) * (a[0] * v[0]) + (a[1] * v[1]) * (a[1] * v[1])
    g = float(1.0)
    if xy != 0.0:
        g = 2.0 / (1.0 + wp.sqrt(1.0 + xy / (v[2] * v[2])))
    if wp.dot(v, m) * v[2] <= 0.0:
        g = 0.0
    return g


@wp.func
def ggx_vndf_pdf(a: wp.vec2, v: wp.vec3, m: wp.vec3) -> float:
    """Density of a visible normal m seen from v (v.z > 0)."""
    return ggx_d(a, m) * ggx_g1(a, v, m) * wp.abs(wp.dot(v, m)) / v[2]


@wp.func
def ggx_vndf_sample(a: wp.vec2, v: wp.vec3, u: wp.vec2) -> wp.vec3:
    """A visible normal seen from v (v.z > 0) with density ggx_vndf_pdf: Dupuy & Benyoub 2023's
    spherical cap in the stretched frame (the same density as Mitsuba's Heitz 2018 sampler)."""
    s = wp.normalize(wp.vec3(a[0] * v[0], a[1] * v[1], v[2]))
    cs = sincos_turns(u[0])
    z = (1.0 - u[1]) * (1.0 + s[2]) - s[2]
    st = wp.sqrt(wp.max(1.0 - z * z, 0.0))
    h = wp.vec3(st * cs[0], st * cs[1], z) + s
    return wp.normalize(wp.vec3(a[0] * h[0], a[1] * h[1], wp.max(h[2], 0.0)))


# ---- the clearcoat's GTR1 ---------------------------------------------------------------------------

@wp.func
def gtr1_d(alpha: float, m: wp.vec3) -> float:
    a2 = alpha * alpha
    c = m[2]
    d = (a2 - 1.0) / (PI * wp.log(a2) * (1.0 + (a2 - 1.0) * c * c))
    if d * c > 1.0e-20:
        return d
    return 0.0


@wp.func
def gtr1_sample(alpha: float, u: wp.vec2) -> wp.vec3:
    a2 = alpha * alpha
    c2 = (1.0 - wp.pow(a2, 1.0 - u[1])) / (1.0 - a2)
    st = wp.sqrt(wp.max(0.0, 1.0 - c2))
    cs = sincos_turns(u[0])
    return wp.vec3(cs[0] * st, cs[1] * st, wp.sqrt(wp.max(0.0, c2)))


@wp.func
def smith_ggx1(v: wp.vec3, m: wp.vec3, alpha: float) -> float:
    """The clearcoat's masking (principledhelpers.h smith_ggx1)."""
    c = wp.abs(v[2])
    c2 = c * c
    t2 = (1.0 - c2) / c2
    g = 2.0 / (1.0 + wp.sqrt(1.0 + alpha * alpha * t2))
    if v[2] == 1.0:
        g = 1.0
    if wp.dot(v, m) * v[2] <= 0.0:
        g = 0.0
    return g


# ---- the diffuse and sheen lobes both kinds share -----------------------------------------------------

@wp.func
def diffuse_retro(mat: MaterialAt, co: float, ci: float, cos_d: float) -> float:
    """Disney's diffuse with retro-reflection, blended by `flatness` with the Hanrahan-Krueger fake
    subsurface term, over pi (co, ci the two |cos|, cos_d of the sampled direction to wh)."""
    fo = schlick_weight(co)
    fi = schlick_weight(ci)
    f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo)
    rr = 2.0 * mat.param[ROUGHNESS] * cos_d * cos_d
    f = f_diff + rr * (fo + fi + fo * fi * (rr - 1.0))
    flat = mat.param[FLATNESS]
    if flat > 0.0:
        fss90 = 0.5 * rr
        fss = (1.0 + fo * (fss90 - 1.0)) * (1.0 + fi * (fss90 - 1.0))
        f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5)
        f = f * (1.0 - flat) + f_ss * flat
    return f * INV_PI


@wp.func
def sheen_colour(mat: MaterialAt, cos_d: float) -> wp.vec3:
    """The sheen lobe without its weight and cosine: Schlick's weight at cos_d, tinted towards the
    base colour by sheen_tint."""
    c = wp.vec3(1.0)
    st = mat.param[SHEEN_TINT]
    if st > 0.0:
        c = wp.vec3(1.0) * (1.0 - st) + tint(mat.albedo) * st
    return c * schlick_weight(wp.abs(cos_d))
