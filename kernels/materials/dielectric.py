"""Smooth dielectric boundaries: Fresnel reflectance, refraction, the side a direction arrives from
(the glossy dielectric's two Phong lobes are glossy_dielectric.py).

This module is also the `dielectric` kind of the kind table, a delta kind (`MaterialKind.model`
with `delta`): `sample_delta` (mirror.py's docstring) in place of eval_bsdf, sample and pdf. Mirror
reflection with weight F, else refraction tinted by `albedo` (the 1/eta^2 of radiance); the lobe
chosen by u_lobe with probability F (1/2 under a strategy that samples uniformly, `uniform` 1; 1
under total internal reflection), the weight divided by the choice's probability."""
import warp as wp

from drtlab.kernels.materials.scatter import Scatter


@wp.struct
class Interface:
    """The side of a dielectric boundary a direction wo arrives from."""
    nf: wp.vec3         # normal on wo's side
    co: float           # |cos| of wo
    eta: float          # n_transmitted / n_incident
    F: float            # Fresnel reflectance (1 on total internal reflection)



@wp.func
def fresnel(cos_i: float, eta: float) -> float:
    # Unpolarised Fresnel reflectance; eta = n_transmitted / n_incident; 1 on total reflection.
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = wp.sqrt(1.0 - sin2_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


@wp.func
def refract_dir(wo: wp.vec3, nf: wp.vec3, cos_o: float, eta: float) -> wp.vec3:
    sin2_t = (1.0 - cos_o * cos_o) / (eta * eta)
    cos_t = wp.sqrt(wp.max(0.0, 1.0 - sin2_t))
    return wp.normalize(-wo / eta + (cos_o / eta - cos_t) * nf)


@wp.func
def interface(n: wp.vec3, wo: wp.vec3, ior: float) -> Interface:
    # n is the outward normal: wo below it means the ray leaves the medium.
    it = Interface()
    cos_o = wp.dot(n, wo)
    it.nf = n
    it.eta = ior
    if cos_o < 0.0:
        it.nf = -n
        it.eta = 1.0 / ior
    it.co = wp.abs(cos_o)
    it.F = fresnel(it.co, it.eta)
    return it


@wp.func
def sample_delta(albedo: wp.vec3, ior: float, cond_eta: wp.vec3, cond_k: wp.vec3, n: wp.vec3, wo: wp.vec3,
                 u_lobe: float, uniform: int) -> Scatter:
    s = Scatter()
    cos_o = wp.dot(n, wo)
    nf = n
    if cos_o < 0.0:
        nf = -n
    co = wp.abs(cos_o)
    it = interface(n, wo, ior)
    eta = it.eta
    F = it.F
    p_reflect = F
    if uniform == 1:
        p_reflect = 0.5
    if F >= 1.0:
        p_reflect = 1.0
    s.delta = 1
    s.valid = 1
    if u_lobe < p_reflect:
        s.wi = 2.0 * co * nf - wo
        s.weight = wp.vec3(F / p_reflect)
    else:
        s.wi = refract_dir(wo, nf, co, eta)
        s.weight = albedo * ((1.0 - F) / ((1.0 - p_reflect) * eta * eta))
    return s
