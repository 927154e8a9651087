"""`beckmann_dielectric`: rough glass with Beckmann microfacets, as Mitsuba 3's `roughdielectric` with
`distribution="beckmann"` (its default): the model of `ggx_dielectric_separable` (Walter et al. 2007;
`albedo` the transmission tint, the 1/eta^2 of radiance) with beckmann.py's D and Walter's rational
G1, separable G = G1(wo) G1(wi).

A kind of the kind table (`material_kinds.MaterialKind.model`), transmitting, on the one BSDF
interface (the package docstring): a normal drawn with
density D(m) cos theta_m (Mitsuba draws visible normals: the same estimate, another variance),
reflection with probability F(wo.wm) (the lobe choice number u_lobe), else refraction, a direction
landing on the wrong side dropped; pdf = D(wm) cos theta_m |dwm/dwi| times the lobe's probability.
"""
import warp as wp

from drtlab.kernels.materials.beckmann import beckmann_d, beckmann_g1, beckmann_normal
from drtlab.kernels.materials.dielectric import interface, scatter_at_normal
from drtlab.kernels.materials.ggx import ggx_half, lobe_choice
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    shape = mat.shape
    it = interface(n, wo, mat.ior)
    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
    if mf.valid == 0:
        return wp.vec3(0.0)
    ci = wp.abs(wp.dot(it.nf, wi))
    dg = beckmann_d(shape, wp.dot(it.nf, mf.wm)) * beckmann_g1(shape, it.co) * beckmann_g1(shape, ci) / it.co
    if mf.reflect == 1:
        return wp.vec3(0.25 * mf.F * dg)
    return mat.albedo * ((1.0 - mf.F) * dg * mf.dwm * mf.om / (it.eta * it.eta))


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    it = interface(n, wo, mat.ior)
    if it.co <= 0.0:
        return proposal(wp.vec3(0.0))
    return proposal(scatter_at_normal(wo, beckmann_normal(mat.shape, it.nf, u), it.nf, it.eta, u_lobe))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    it = interface(n, wo, mat.ior)
    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
    if mf.valid == 0:
        return 0.0
    c = wp.dot(it.nf, mf.wm)
    return beckmann_d(mat.shape, c) * c * mf.dwm * lobe_choice(mf)
