"""`ggx_dielectric`: rough glass with GGX microfacets and height-correlated Smith masking (Walter et
al. 2007 reflection and transmission; the model is ggx.py's comment, `eval_ggx` with transmits 1).

A kind of the kind table (`material_kinds.MaterialKind.model`), transmitting, on the one BSDF
interface (the package docstring): a normal drawn as the strategy's `microfacet` says (`sampling`),
reflection with probability F(wo.wm) (the lobe choice
number u_lobe), else refraction, a direction landing on the wrong side dropped; the pdf is the
normal's times |dwm/dwi| times the lobe's probability.
"""
import warp as wp

from drtlab.kernels.materials.dielectric import interface, scatter_at_normal
from drtlab.kernels.materials.ggx import eval_ggx, ggx_half, lobe_choice, make_ggx_normals
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_ggx(mat.albedo, mat.shape, mat.ior, n, wo, wi, 1)


def _make_lobe(vndf: bool):
    """(sample, pdf) of the lobes, the normal drawn as `vndf` says."""
    sample_normal, normal_pdf = make_ggx_normals(vndf)

    @wp.func
    def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        it = interface(n, wo, mat.ior)
        if it.co <= 0.0:
            return proposal(wp.vec3(0.0))
        return proposal(scatter_at_normal(wo, sample_normal(it.nf, wo, it.co, mat.shape, u), it.nf, it.eta,
                                          u_lobe))

    @wp.func
    def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        it = interface(n, wo, mat.ior)
        mf = ggx_half(it.nf, it.eta, wo, wi, 1)
        p = float(0.0)
        if mf.valid == 1:
            p = normal_pdf(mat.shape, it.nf, it.co, mf.wm, mf.om) * mf.dwm * lobe_choice(mf)
        return p

    return sample, pdf


_LOBES = {True: _make_lobe(True), False: _make_lobe(False)}
sample, pdf = _LOBES[True]


def sampling(strategy):
    """(sample, pdf) as `strategy` draws the normal (its `microfacet`: "vndf" or "d")."""
    return _LOBES[strategy.microfacet == "vndf"]
