"""`ggx_dielectric`: rough glass with GGX microfacets and height-correlated Smith masking (Walter et
al. 2007 reflection and transmission; the model is ggx.py's comment, `eval_ggx` with transmits 1).

A kind from the kind table (`material_kinds.MaterialKind.model`), transmitting: eval_bsdf, and the
lobe sampling behind the interface of a lobe sampler (kernels/lobe_samplers.py): a normal drawn as
the strategy's `microfacet` says (`sampling`), reflection with probability F(wo.wm) (the lobe choice
number u_lobe), else refraction, a direction landing on the wrong side dropped; the pdf is the
normal's times |dwm/dwi| times the lobe's probability.
"""
import warp as wp

from drtlab.kernels.materials.dielectric import fresnel, interface, refract_dir
from drtlab.kernels.materials.ggx import eval_ggx, ggx_half, make_ggx_normals


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
        wm = sample_normal(it.nf, wo, it.co, shape, u)
        om = wp.dot(wo, wm)
        if om <= 0.0:
            return wp.vec3(0.0)
        if u_lobe < fresnel(om, it.eta):
            wi = 2.0 * om * wm - wo
            if wp.dot(it.nf, wi) <= 0.0:
                return wp.vec3(0.0)         # reflected below: the pdf would read it as refracted
            return wi
        wi = refract_dir(wo, wm, om, it.eta)
        if wp.dot(it.nf, wi) >= 0.0:
            return wp.vec3(0.0)             # refracted above: the pdf would read it as reflected
        return wi

    @wp.func
    def pdf(shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        it = interface(n, wo, ior)
        mf = ggx_half(it.nf, it.eta, wo, wi, 1)
        p = float(0.0)
        if mf.valid == 1:
            pl = mf.F
            if mf.reflect == 0:
                pl = 1.0 - mf.F
            p = normal_pdf(shape, it.nf, it.co, mf.wm, mf.om) * mf.dwm * pl
        return p

    return sample, pdf


_LOBES = {True: _make_lobe(True), False: _make_lobe(False)}
sample, pdf = _LOBES[True]


def sampling(microfacet: str):
    """(sample, pdf) as a strategy of `microfacet` ("vndf" or "d") draws the normal."""
    return _LOBES[microfacet == "vndf"]
