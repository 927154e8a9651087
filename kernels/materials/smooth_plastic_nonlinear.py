"""`smooth_plastic_nonlinear`: Mitsuba 3's `plastic` with `nonlinear = true`: the base's internal
reflections tint it, albedo / (1 - albedo Fdr) instead of albedo / (1 - Fdr); otherwise
`smooth_plastic.py` (its docstring is the model; its sampling)."""
import warp as wp

from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.smooth_plastic import pdf, plastic_base, sample, sampling

__all__ = ["eval", "sample", "pdf", "sampling"]


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return plastic_base(mat.albedo, mat.ior, n, wo, wi, 1)
