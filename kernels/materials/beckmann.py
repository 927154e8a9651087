"""`beckmann`: a rough conductor with Beckmann microfacets, as Mitsuba 3's `roughconductor` with
`distribution="beckmann"` and `material="none"` (facets reflect `albedo`, its `specular_reflectance`).

A kind of the kind table (`material_kinds.MaterialKind.model`) on the one BSDF interface (the
package docstring); the facets' functions of loose arguments (`eval_facets`, `sample_facets`,
`pdf_facets`) are what beckmann_conductor.py and rough_plastic.py build on. With wo, wi on the side
of nf and wm their half vector (Walter et al. 2007; Mitsuba's conventions):
    D(m) = exp(-tan^2 theta_m / alpha^2) / (pi alpha^2 cos^4 theta_m)
    G(wo, wi) = G1(wo) G1(wi), Smith's G1 in Walter's rational fit of the Beckmann masking:
        a = 1 / (alpha tan theta); G1 = (3.535 a + 2.181 a^2) / (1 + 2.276 a + 2.577 a^2), 1 for a >= 1.6
    f |cos_i| = albedo D(wm) G(wo, wi) / (4 |cos_o|)
Sampling draws wm from D(m) cos theta_m (tan^2 theta_m = -alpha^2 log(1 - u.x), phi = 2 pi u.y),
reflects wo about it and drops a direction below the surface: pdf = D(wm) cos theta_m / (4 wo.wm).
Single scattering only, as the GGX conductor: light among the facets is lost at large alpha.
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, facing, frame_to_world, sincos_turns
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def beckmann_d(alpha: float, c: float) -> float:
    if c <= 0.0:
        return 0.0
    c2 = c * c
    t2 = wp.max(1.0 - c2, 0.0) / c2
    a2 = alpha * alpha
    return wp.exp(-t2 / a2) * INV_PI / (a2 * c2 * c2)


@wp.func
def beckmann_g1(alpha: float, c: float) -> float:
    """Smith's masking of a direction at |cos| c (Walter et al. 2007, eq. 27)."""
    s = wp.sqrt(wp.max(1.0 - c * c, 0.0))
    if s <= 0.0:
        return 1.0
    a = c / (alpha * s)
    if a >= 1.6:
        return 1.0
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)


@wp.func
def beckmann_normal(alpha: float, nf: wp.vec3, u: wp.vec2) -> wp.vec3:
    """A microfacet normal drawn with density D(m) cos theta_m about nf."""
    t2 = -alpha * alpha * wp.log(1.0 - u[0])
    c = 1.0 / wp.sqrt(1.0 + t2)
    s = wp.sqrt(wp.max(1.0 - c * c, 0.0))
    sc = sincos_turns(u[1])
    return frame_to_world(wp.vec3(s * sc[0], s * sc[1], c), nf)


@wp.func
def _half(nf: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    h = wo + wi
    ll = wp.length(h)
    if ll <= 0.0:
        return wp.vec3(0.0)
    return h / ll


@wp.func
def eval_facets(albedo: wp.vec3, shape: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    if cos_o * cos_i <= 0.0:
        return wp.vec3(0.0)
    nf = n
    if cos_o < 0.0:
        nf = -n
    wm = _half(nf, wo, wi)
    co = wp.abs(cos_o)
    d = beckmann_d(shape, wp.dot(nf, wm))
    g = beckmann_g1(shape, co) * beckmann_g1(shape, wp.abs(cos_i))
    return albedo * (d * g / (4.0 * co))


@wp.func
def sample_facets(shape: float, n: wp.vec3, wo: wp.vec3, u: wp.vec2) -> wp.vec3:
    nf = facing(n, wo)
    wm = beckmann_normal(shape, nf, u)
    om = wp.dot(wo, wm)
    if om <= 0.0:
        return wp.vec3(0.0)
    wi = 2.0 * om * wm - wo
    if wp.dot(nf, wi) <= 0.0:
        return wp.vec3(0.0)
    return wi


@wp.func
def pdf_facets(shape: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    nf = facing(n, wo)
    if wp.dot(nf, wi) <= 0.0 or wp.dot(nf, wo) <= 0.0:
        return 0.0
    wm = _half(nf, wo, wi)
    om = wp.dot(wo, wm)
    if om <= 0.0:
        return 0.0
    c = wp.dot(nf, wm)
    return beckmann_d(shape, c) * c / (4.0 * om)


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_facets(mat.albedo, mat.shape, n, wo, wi)


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(sample_facets(mat.shape, n, wo, u))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return pdf_facets(mat.shape, n, wo, wi)
