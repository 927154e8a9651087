"""`diffuse`: a Lambertian reflector of `albedo`, two-sided (f = albedo / pi on wo's side).

A kind from the kind table (`material_kinds.MaterialKind.model`): eval_bsdf, and the lobe sampling
behind the interface of a lobe sampler (kernels/lobe_samplers.py): the cosine lobe about the normal
on wo's side, pdf = |cos_i| / pi.
"""
import warp as wp

from drtlab.estimators.domain_maps import cosine_pdf, facing, frame_to_world, square_to_cosine_hemisphere


@wp.func
def eval_bsdf(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return albedo * cosine_pdf(n, wo, wi)


@wp.func
def sample(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, u_lobe: float,
           u: wp.vec2) -> wp.vec3:
    return frame_to_world(square_to_cosine_hemisphere(u), facing(n, wo))


@wp.func
def pdf(shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return cosine_pdf(n, wo, wi)
