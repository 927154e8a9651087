"""`glossy`: a modified-Phong reflector, two-sided: with wo, wi on one side and alpha the angle
between wi and wo's mirror direction, f |cos_i| = albedo (n + 2) / (2 pi) cos^n(alpha) |cos_i|
(n the lobe's shape, the material's `exponent`; the normalised lobe of Lewis 1994, albedo <= 1).

A kind of the kind table (`material_kinds.MaterialKind.model`), on the one BSDF interface (the
package docstring): the Phong lobe cos^n about the mirror direction (its part below the surface
dropped by eval).
"""
import warp as wp

from drtlab.estimators.domain_maps import INV_PI, frame_to_world, mirror_dir, phong_lobe_pdf, square_to_phong_lobe
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    r = wp.vec3(0.0)
    if cos_o * cos_i > 0.0:
        ca = wp.dot(mirror_dir(n, wo), wi)
        if ca > 0.0:
            r = mat.albedo * ((mat.shape + 2.0) * 0.5 * INV_PI * wp.pow(ca, mat.shape) * wp.abs(cos_i))
    return r


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(frame_to_world(square_to_phong_lobe(u, mat.shape), mirror_dir(n, wo)))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    p = float(0.0)
    if wp.dot(n, wo) * wp.dot(n, wi) > 0.0:
        p = phong_lobe_pdf(wp.dot(mirror_dir(n, wo), wi), mat.shape)
    return p
