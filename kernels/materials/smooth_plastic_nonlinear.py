"""`smooth_plastic_nonlinear`: Mitsuba 3's `plastic` with `nonlinear = true`: the base's internal
reflections tint it, albedo / (1 - albedo Fdr) instead of albedo / (1 - Fdr); otherwise
`smooth_plastic.py` (its docstring is the model)."""
import warp as wp

from drtlab.kernels.materials.smooth_plastic import delta_reflection, pdf, plastic_base, sample

__all__ = ["eval_bsdf", "sample", "pdf", "delta_reflection"]


@wp.func
def eval_bsdf(albedo: wp.vec3, shape: float, ior: float, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return plastic_base(albedo, ior, n, wo, wi, 1)
