"""`ggx_dielectric_separable`: rough glass with GGX microfacets and Smith masking in its separable
form, G = G1(wo) G1(wi), as Mitsuba 3's `roughdielectric` with `distribution="ggx"`: the model of
`ggx_dielectric` (Walter et al. 2007, ggx.py's comment; `albedo` the transmission tint, the 1/eta^2
of radiance) but with Mitsuba's masking where `ggx_dielectric` has the height-correlated G2.

A kind of the kind table (`material_kinds.MaterialKind.model`), transmitting, on the one BSDF
interface (the package docstring): a visible normal
(Dupuy & Benyoub 2023), reflection with probability F(wo.wm) (the lobe choice number u_lobe), else
refraction, a direction landing on the wrong side dropped; the pdf is the normal's times |dwm/dwi|
times the lobe's probability, as the built-in ggx_dielectric's.
"""
import warp as wp

from drtlab.kernels.materials import ggx_dielectric
from drtlab.kernels.materials.dielectric import interface
from drtlab.kernels.materials.ggx import ggx_d_at, ggx_g1, ggx_half
from drtlab.kernels.materials.material_at import MaterialAt

# The lobes as ggx_dielectric's under visible-normal sampling: only the masking differs.
sample, pdf = ggx_dielectric.sample, ggx_dielectric.pdf


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    shape = mat.shape
    it = interface(n, wo, mat.ior)
    mf = ggx_half(it.nf, it.eta, wo, wi, 1)
    if mf.valid == 0:
        return wp.vec3(0.0)
    ci = wp.abs(wp.dot(it.nf, wi))
    dg = ggx_d_at(shape, it.nf, mf.wm) * ggx_g1(shape, it.co) * ggx_g1(shape, ci) / it.co
    if mf.reflect == 1:
        return wp.vec3(0.25 * mf.F * dg)
    return mat.albedo * ((1.0 - mf.F) * dg * mf.dwm * mf.om / (it.eta * it.eta))

