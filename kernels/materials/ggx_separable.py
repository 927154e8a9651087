"""`ggx_separable`: a rough conductor with GGX microfacets and Smith masking in its separable form,
G = G1(wo) G1(wi), as Mitsuba 3's `roughconductor` with `distribution="ggx"` and
`material="none"` (facets reflecting `albedo`, its `specular_reflectance`).

drtlab's `ggx` kind uses the height-correlated G2 = 1 / (1 + Lambda(wo) + Lambda(wi)) (Heitz 2014),
which is never below the separable product: the two differ most at grazing angles and large alpha.
This kind is the model Mitsuba renders, so its scenes import with their own masking. A kind of the
kind table (`material_kinds.MaterialKind.model`) on the one BSDF interface (the package docstring):
visible normals (Dupuy & Benyoub 2023, the density of Heitz 2018), as Mitsuba samples them, whatever
the strategy's `microfacet` says. The facets' functions of loose arguments (`eval_facets`,
`sample_facets`, `pdf_facets`) are what ggx_conductor.py and rough_plastic.py build on.
    f |cos_i| = albedo D(wm) G1(wo) G1(wi) / (4 |cos_o|), D and G1 as in ggx.py
"""
import warp as wp

from drtlab.estimators.domain_maps import facing
from drtlab.kernels.materials.ggx import ggx_d_at, ggx_g1, ggx_half, make_ggx_normals
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal

_sample_normal, _normal_pdf = make_ggx_normals(True)


@wp.func
def eval_facets(albedo: wp.vec3, shape: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    co = wp.dot(n, wo)
    nf = n
    if co < 0.0:
        nf = -n
        co = -co
    mf = ggx_half(nf, 1.0, wo, wi, 0)
    if mf.valid == 0:
        return wp.vec3(0.0)
    ci = wp.abs(wp.dot(nf, wi))
    return albedo * (0.25 * ggx_d_at(shape, nf, mf.wm) * ggx_g1(shape, co) * ggx_g1(shape, ci) / co)


@wp.func
def sample_facets(shape: float, n: wp.vec3, wo: wp.vec3, u: wp.vec2) -> wp.vec3:
    nf = n
    co = wp.dot(n, wo)
    if co < 0.0:
        nf = -n
        co = -co
    if co <= 0.0:
        return wp.vec3(0.0)
    wm = _sample_normal(nf, wo, co, shape, u)
    wi = 2.0 * wp.dot(wo, wm) * wm - wo
    if wp.dot(nf, wi) <= 0.0:
        return wp.vec3(0.0)
    return wi


@wp.func
def pdf_facets(shape: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    mf = ggx_half(facing(n, wo), 1.0, wo, wi, 0)
    if mf.valid == 0:
        return 0.0
    nf = facing(n, wo)
    return _normal_pdf(shape, nf, wp.dot(nf, wo), mf.wm, mf.om) * mf.dwm


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_facets(mat.albedo, mat.shape, n, wo, wi)


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(sample_facets(mat.shape, n, wo, u))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return pdf_facets(mat.shape, n, wo, wi)
