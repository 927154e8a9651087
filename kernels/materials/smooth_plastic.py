"""`smooth_plastic`: Mitsuba 3's `plastic` (src/bsdfs/plastic.cpp), a diffuse base (`albedo`, its
`diffuse_reflectance`) under a smooth dielectric coat of relative index eta (`ior`, int_ior /
ext_ior); the coat reflects white (`specular_reflectance` 1). With F(c) the unpolarised Fresnel
reflectance at eta, F_o = F(|cos_o|), F_i = F(|cos_i|) and Fdr = Mitsuba's
fresnel_diffuse_reflectance(1 / eta) (Egan & Hilgeman's fit of the internal diffuse reflectance):
    a delta reflection of weight F_o about the normal, and
    f |cos_i| = albedo / (1 - Fdr) (1 - F_o)(1 - F_i) |cos_i| / (pi eta^2)
with `nonlinear` (`smooth_plastic_nonlinear.py`) albedo / (1 - albedo Fdr) instead of
albedo / (1 - Fdr). drtlab's own `plastic` is a Phong coat over a coupled base, another model.

A kind of the kind table with a delta lobe beside its density (`MaterialKind.delta_lobe`), on the
one BSDF interface (the package docstring): sample picks the mirror with its probability first, else
proposes the diffuse part by a cosine lobe; eval is the diffuse part, pdf its density times one
minus the mirror's probability. Mitsuba's choice: with w = 1 / (1 + mean(albedo)) (its specular
sampling weight, s_mean = 1), P(mirror) = F_o w / (F_o w + (1 - F_o)(1 - w)); under the uniform
strategy (`sampling`) 1/2, and a uniform hemisphere for the rest. The lobe's shape (MaterialAt.shape)
is mean(albedo) (MaterialKind.albedo_shape): pdf reads no albedo.
Mitsuba's plastic is one-sided; drtlab's is two-sided, as its `twosided` (the importer's rule).
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI
from drtlab.kernels.materials import diffuse, uniform
from drtlab.kernels.materials.dielectric import fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.func
def fresnel_diffuse_reflectance(eta: float) -> float:
    """Mitsuba's fit of the hemispherical average of F at eta (fresnel.h): Egan & Hilgeman 1973
    below 1, d'Eon & Irving 2011 above."""
    inv = 1.0 / eta
    if eta < 1.0:
        return 0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    return 0.919317 + inv * (-3.4793 + inv * (6.75335 + inv * (-7.80989 + inv * (4.98554 - 1.36881 * inv))))


@wp.func
def plastic_base(albedo: wp.vec3, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3,
                 nonlinear: int) -> wp.vec3:
    """f |cos_i| of the diffuse base, linear or `nonlinear`."""
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    if cos_o * cos_i <= 0.0:
        return wp.vec3(0.0)
    ci = wp.abs(cos_i)
    fdr = fresnel_diffuse_reflectance(1.0 / ior)
    t = (1.0 - fresnel(wp.abs(cos_o), ior)) * (1.0 - fresnel(ci, ior)) * ci * INV_PI / (ior * ior)
    if nonlinear == 1:
        return wp.vec3(albedo[0] / (1.0 - albedo[0] * fdr), albedo[1] / (1.0 - albedo[1] * fdr),
                       albedo[2] / (1.0 - albedo[2] * fdr)) * t
    return albedo * (t / (1.0 - fdr))


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return plastic_base(mat.albedo, mat.ior, n, wo, wi, 0)


@wp.func
def delta_reflection(shape: float, ior: float, n: wp.vec3, wo: wp.vec3) -> wp.vec2:
    """(the probability the lobe strategy picks the mirror, its weight F_o): Mitsuba's."""
    f = fresnel(wp.abs(wp.dot(n, wo)), ior)
    w = 1.0 / (1.0 + shape)
    ps = f * w
    return wp.vec2(ps / (ps + (1.0 - f) * (1.0 - w)), f)


def _make_sampling(uniform_choice: bool):
    """(sample, pdf): the mirror with Mitsuba's probability and the rest by a cosine lobe, or with
    probability 1/2 and the rest uniformly (`uniform_choice`)."""
    UNIFORM = uniform_choice

    @wp.func
    def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        cos_o = wp.dot(n, wo)
        nf = n
        if cos_o < 0.0:
            nf = -n
        dr = delta_reflection(mat.shape, mat.ior, n, wo)
        pd = float(0.5)
        if wp.static(not UNIFORM):
            pd = dr[0]
        if u_lobe < pd:
            return delta_scatter(2.0 * wp.abs(cos_o) * nf - wo, wp.vec3(dr[1] / pd))
        if wp.static(UNIFORM):
            return uniform.sample_hemisphere(mat, n, wo, u_lobe, u)
        return diffuse.sample(mat, n, wo, u_lobe, u)

    @wp.func
    def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        p = float(0.0)
        pd = float(0.5)
        if wp.static(UNIFORM):
            p = uniform.pdf_hemisphere(mat, n, wo, wi)
        else:
            p = diffuse.pdf(mat, n, wo, wi)
            pd = delta_reflection(mat.shape, mat.ior, n, wo)[0]
        return p * (1.0 - pd)

    return sample, pdf


_SAMPLING = {False: _make_sampling(False), True: _make_sampling(True)}
sample, pdf = _SAMPLING[False]


def sampling(strategy) -> tuple:
    """(sample, pdf) under `strategy`: Mitsuba's lobe choice, or 1/2 and uniform directions under
    the uniform strategy."""
    return _SAMPLING[not strategy.lobe]
