"""Plastic: a diffuse base under a smooth-Fresnel Phong coat (the model is eval_plastic's docstring).

The `plastic` kind of the kind table (`material_kinds.MaterialKind.model`), on the one BSDF
interface (the package docstring): the coat's Phong lobe with probability plastic_coat_probability
(the lobe choice number u_lobe), else the base's cosine lobe; the pdf is their mixture."""
import numpy as np
import warp as wp

from drtlab.estimators.domain_maps import (INV_PI, facing, frame_to_world, mirror_dir, phong_lobe_pdf,
                                           square_to_cosine_hemisphere, square_to_phong_lobe)
from drtlab.kernels.materials.dielectric import fresnel
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


# ---------------------------------------------------------------------------------------------------
# Plastic: a diffuse base under a smooth-Fresnel Phong coat
# ---------------------------------------------------------------------------------------------------

# 16-point Gauss-Legendre rule on [0, 1] for fresnel_average: the integrand is analytic in mu for
# ior > 1, so the error is below 2e-7 for ior >= 1.001 (1e-10 from 1.01 on), and exactly 0 at 1.
_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)
_GL16 = wp.types.vector(length=16, dtype=float)
GL16_X = wp.constant(_GL16(*(0.5 * (_GL_NODES + 1.0)).tolist()))
GL16_W = wp.constant(_GL16(*(0.5 * _GL_WEIGHTS).tolist()))


@wp.func
def fresnel_average(eta: float) -> float:
    """2 int_0^1 F(mu) mu dmu: the cosine-weighted hemispherical average of fresnel(., eta)
    (0.0918 at eta = 1.5), the fraction of diffuse light arriving from outside that the coat
    reflects."""
    s = float(0.0)
    for k in range(16):
        mu = GL16_X[k]
        s += GL16_W[k] * mu * fresnel(mu, eta)
    return 2.0 * s


@wp.func
def eval_plastic(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3,
                 wi: wp.vec3) -> wp.vec3:
    """f|cos_i| of plastic, two-sided like diffuse and glossy: with F_o = F(|cos_o|), F_i = F(|cos_i|)
    (fresnel at the coat's ior), alpha the angle between wi and wo's mirror direction and
    Fbar = fresnel_average(ior),
        f = min(F_o, F_i) (n + 2) / (2 pi) cos^n(alpha)                     (coat, white)
          + albedo (1 - F_o)(1 - F_i) / (pi (1 - Fbar))                     (base)
    for wo, wi on one side (0 otherwise). The base is the coupled diffuse term of Shirley et al.
    1997 / Ashikhmin & Shirley 2000 (there with Schlick's approximation and the constants 21/20,
    28/23) with the exact Fresnel and its exact average: its albedo is exactly (1 - F_o) albedo.
    The coat is the glossy kind's normalised modified Phong lobe (albedo <= 1, Lewis 1994) weighted
    by min(F_o, F_i) <= F_o, which keeps f reciprocal; so the directional albedo is
    <= F_o + (1 - F_o) albedo <= 1 (= 1 at normal incidence for albedo 1: F_i >= F_o there).
    Multiple reflections inside the coat are not modelled (no internal-reflection term)."""
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    r = wp.vec3(0.0)
    if cos_o * cos_i > 0.0:
        co = wp.abs(cos_o)
        ci = wp.abs(cos_i)
        fo = fresnel(co, ior)
        fi = fresnel(ci, ior)
        ca = wp.dot(mirror_dir(n, wo), wi)
        coat = float(0.0)
        if ca > 0.0:
            coat = wp.min(fo, fi) * (shape + 2.0) * 0.5 * INV_PI * wp.pow(ca, shape)
        base = (1.0 - fo) * (1.0 - fi) * INV_PI / (1.0 - fresnel_average(ior))
        r = (wp.vec3(coat) + albedo * base) * ci
    return r


@wp.func
def plastic_coat_probability(co: float, ior: float) -> float:
    """Lobe strategy: the coat lobe is sampled with probability F(|cos_o|), its share of the energy
    for a white base (pdf_bsdf gets no albedo, so the choice cannot depend on it)."""
    return fresnel(co, ior)


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return eval_plastic(mat.albedo, mat.shape, mat.ior, n, wo, wi)


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    if u_lobe < plastic_coat_probability(wp.abs(wp.dot(n, wo)), mat.ior):
        return proposal(frame_to_world(square_to_phong_lobe(u, mat.shape), mirror_dir(n, wo)))
    return proposal(frame_to_world(square_to_cosine_hemisphere(u), facing(n, wo)))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    shape = mat.shape
    ior = mat.ior
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    p = float(0.0)
    if cos_o * cos_i > 0.0:
        # The mixture of the coat's Phong lobe and the base's cosine lobe.
        pc = plastic_coat_probability(wp.abs(cos_o), ior)
        p = pc * phong_lobe_pdf(wp.dot(mirror_dir(n, wo), wi), shape) + (1.0 - pc) * wp.abs(cos_i) * INV_PI
    return p
