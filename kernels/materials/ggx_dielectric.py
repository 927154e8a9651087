"""`ggx_dielectric`: rough glass with GGX microfacets and height-correlated Smith masking (Walter et
al. 2007 reflection and transmission; the model is ggx.py's comment, `eval_ggx` with transmits 1).

A kind from the kind table (`material_kinds.MaterialKind.model`), transmitting: eval_bsdf, and the
lobe sampling behind the interface of a lobe sampler (kernels/lobe_samplers.py): a normal drawn as
the strategy's `microfacet` says (`sampling`), reflection with probability F(wo.wm) (the lobe choice
number u_lobe), else refraction, a direction landing on the wrong side dropped; the pdf is the
normal's times |dwm/dwi| times the lobe's probability.
"""
import warp as wp

from drtlab.kernels.materials.dielectric import interface, scatter_at_normal
from drtlab.kernels.materials.ggx import eval_ggx, ggx_half, lobe_choice, make_ggx_normals


@wp.func
def eval_bsdf(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_ggx(albedo, shape, ior, n, wo, wi, 1)


def _make_lobe(vndf: bool):
    """(sample, pdf) of the lobes, the normal drawn as `vndf` says."""
    sample_normal, normal_pdf = make_ggx_normals(vndf)

    @wp.func
    def sample(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, u_lobe: float,
               u: wp.vec2) -> wp.vec3:
        it = interface(n, wo, ior)
        if it.co <= 0.0:
            return wp.vec3(0.0)
        return scatter_at_normal(wo, sample_normal(it.nf, wo, it.co, shape, u), it.nf, it.eta, u_lobe)

    @wp.func
    def pdf(shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        it = interface(n, wo, ior)
        mf = ggx_half(it.nf, it.eta, wo, wi, 1)
        p = float(0.0)
        if mf.valid == 1:
            p = normal_pdf(shape, it.nf, it.co, mf.wm, mf.om) * mf.dwm * lobe_choice(mf)
        return p

    return sample, pdf


_LOBES = {True: _make_lobe(True), False: _make_lobe(False)}
sample, pdf = _LOBES[True]


def sampling(microfacet: str):
    """(sample, pdf) as a strategy of `microfacet` ("vndf" or "d") draws the normal."""
    return _LOBES[microfacet == "vndf"]
