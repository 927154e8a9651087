"""Smooth dielectric boundaries: Fresnel reflectance, refraction, the side a direction arrives from,
and the glossy dielectric's two Phong lobes."""
import warp as wp

from drtlab.estimators.domain_maps import phong_lobe_pdf


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
def glossy_dielectric_lobes(it: Interface, wo: wp.vec3, wi: wp.vec3, exponent: float) -> wp.vec2:
    """Phong lobe densities at wi around the mirror (x) and refracted (y) directions, on either
    side of the surface: a lobe near the horizon proposes directions on both sides. The refracted
    lobe is zero under total internal reflection."""
    r = phong_lobe_pdf(wp.dot(2.0 * it.co * it.nf - wo, wi), exponent)
    t = float(0.0)
    if it.F < 1.0:
        t = phong_lobe_pdf(wp.dot(refract_dir(wo, it.nf, it.co, it.eta), wi), exponent)
    return wp.vec2(r, t)


@wp.func
def eval_glossy_dielectric(albedo: wp.vec3, exponent: float, ior: float, n: wp.vec3,
                           wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    # f|cos| is the Phong lobe density around the mirror (weight F) or the refracted direction
    # (weight (1 - F) * albedo / eta^2), so energy is conserved up to what crosses the surface.
    # A lobe's part on the wrong side of the surface is not scattering: reflection counts only
    # above, transmission only below (the sampler's pdf still counts both, see pdf_bsdf).
    it = interface(n, wo, ior)
    lobes = glossy_dielectric_lobes(it, wo, wi, exponent)
    ci = wp.dot(it.nf, wi)
    r = wp.vec3(0.0)
    if ci > 0.0:
        r = wp.vec3(it.F * lobes[0])
    elif ci < 0.0:
        r = albedo * ((1.0 - it.F) / (it.eta * it.eta) * lobes[1])
    return r

