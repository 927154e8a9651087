"""`beckmann_dielectric`: rough glass with Beckmann microfacets, as Mitsuba 3's `roughdielectric` with
`distribution="beckmann"` (its default): the model of `ggx_dielectric_separable` (Walter et al. 2007;
`albedo` the transmission tint, the 1/eta^2 of radiance) with beckmann.py's D and Walter's rational
G1, separable G = G1(wo) G1(wi).

A kind from the kind table (`material_kinds.MaterialKind.model`), transmitting: eval_bsdf, and the
lobe sampling behind the interface of a lobe sampler (kernels/lobe_samplers.py): a normal drawn with
density D(m) cos theta_m (Mitsuba draws visible normals: the same estimate, another variance),
reflection with probability F(wo.wm) (the lobe choice number u_lobe), else refraction, a direction
landing on the wrong side dropped; pdf = D(wm) cos theta_m |dwm/dwi| times the lobe's probability.
"""
import warp as wp

from drtlab.kernels.materials.beckmann import beckmann_d, beckmann_g1, beckmann_normal
from drtlab.kernels.materials.dielectric import interface, scatter_at_normal
from drtlab.kernels.materials.ggx import ggx_half, lobe_choice


@wp.func
def eval_bsdf(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    it = interface(n, wo, ior)
    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
    if mf.valid == 0:
        return wp.vec3(0.0)
    ci = wp.abs(wp.dot(it.nf, wi))
    dg = beckmann_d(shape, wp.dot(it.nf, mf.wm)) * beckmann_g1(shape, it.co) * beckmann_g1(shape, ci) / it.co
    if mf.reflect == 1:
        return wp.vec3(0.25 * mf.F * dg)
    return albedo * ((1.0 - mf.F) * dg * mf.dwm * mf.om / (it.eta * it.eta))


@wp.func
def sample(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, u_lobe: float,
           u: wp.vec2) -> wp.vec3:
    it = interface(n, wo, ior)
    if it.co <= 0.0:
        return wp.vec3(0.0)
    return scatter_at_normal(wo, beckmann_normal(shape, it.nf, u), it.nf, it.eta, u_lobe)


@wp.func
def pdf(shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    it = interface(n, wo, ior)
    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
    if mf.valid == 0:
        return 0.0
    c = wp.dot(it.nf, mf.wm)
    return beckmann_d(shape, c) * c * mf.dwm * lobe_choice(mf)
