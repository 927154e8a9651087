"""`glossy_dielectric`: a rough interface of index `ior` as two Phong lobes of the material's
`exponent`, about the mirror direction (weight F) and the refracted one (weight (1 - F) albedo /
eta^2), F the Fresnel reflectance of wo (`eval_glossy_dielectric`'s comment).

A kind of the kind table (`material_kinds.MaterialKind.model`), transmitting, on the one BSDF
interface (the package docstring): the reflected lobe with probability F (the lobe choice number
u_lobe), else the refracted one; the pdf is their F-weighted mixture wherever wi lies.
"""
import warp as wp

from drtlab.estimators.domain_maps import frame_to_world, mirror_dir, phong_lobe_pdf, square_to_phong_lobe
from drtlab.kernels.materials.dielectric import Interface, interface, refract_dir
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def glossy_dielectric_lobes(it: Interface, wo: wp.vec3, wi: wp.vec3, shape: float) -> wp.vec2:
    """Phong lobe densities at wi around the mirror (x) and refracted (y) directions, on either
    side of the surface: a lobe near the horizon proposes directions on both sides. The refracted
    lobe is zero under total internal reflection."""
    r = phong_lobe_pdf(wp.dot(2.0 * it.co * it.nf - wo, wi), shape)
    t = float(0.0)
    if it.F < 1.0:
        t = phong_lobe_pdf(wp.dot(refract_dir(wo, it.nf, it.co, it.eta), wi), shape)
    return wp.vec2(r, t)


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    # f|cos| is the Phong lobe density around the mirror (weight F) or the refracted direction
    # (weight (1 - F) * albedo / eta^2), so energy is conserved up to what crosses the surface.
    # A lobe's part on the wrong side of the surface is not scattering: reflection counts only
    # above, transmission only below (the sampler's pdf still counts both, see pdf below).
    it = interface(n, wo, mat.ior)
    lobes = glossy_dielectric_lobes(it, wo, wi, mat.shape)
    ci = wp.dot(it.nf, wi)
    r = wp.vec3(0.0)
    if ci > 0.0:
        r = wp.vec3(it.F * lobes[0])
    elif ci < 0.0:
        r = mat.albedo * ((1.0 - it.F) / (it.eta * it.eta) * lobes[1])
    return r


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    it = interface(n, wo, mat.ior)
    axis = mirror_dir(n, wo)
    if u_lobe >= it.F:
        axis = refract_dir(wo, it.nf, it.co, it.eta)
    return proposal(frame_to_world(square_to_phong_lobe(u, mat.shape), axis))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    it = interface(n, wo, mat.ior)
    lobes = glossy_dielectric_lobes(it, wo, wi, mat.shape)
    # The proposal is the Fresnel-weighted mixture of both lobes wherever wi lies.
    return it.F * lobes[0] + (1.0 - it.F) * lobes[1]
