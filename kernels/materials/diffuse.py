"""`diffuse`: a Lambertian reflector of `albedo`, two-sided (f = albedo / pi on wo's side).

A kind of the kind table (`material_kinds.MaterialKind.model`), on the one BSDF interface (the
package docstring): the cosine lobe about the normal on wo's side, pdf = |cos_i| / pi.
"""
import warp as wp

from drtlab.estimators.domain_maps import cosine_pdf, facing, frame_to_world, square_to_cosine_hemisphere
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return mat.albedo * cosine_pdf(n, wo, wi)


@wp.func
def sample_cosine(n: wp.vec3, wo: wp.vec3, u: wp.vec2) -> wp.vec3:
    """A direction of the cosine lobe on wo's side."""
    return frame_to_world(square_to_cosine_hemisphere(u), facing(n, wo))


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(sample_cosine(n, wo, u))


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return cosine_pdf(n, wo, wi)
