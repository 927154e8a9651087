"""`ggx_conductor`: a rough metal of complex index `eta` + i `k`, GGX facets with separable Smith
masking (ggx_separable.py): Mitsuba 3's `roughconductor` with `distribution="ggx"` and a `material`.
The facets reflect `albedo` times the conductor Fresnel at the half vector (conductor.py's
`half_fresnel`). A kind of the kind table on the one BSDF interface (the package docstring); it
samples as ggx_separable.py does (the Fresnel is in eval only).
"""
import warp as wp

from drtlab.kernels.materials import ggx_separable
from drtlab.kernels.materials.conductor import half_fresnel
from drtlab.kernels.materials.material_at import MaterialAt

sample, pdf = ggx_separable.sample, ggx_separable.pdf


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return wp.cw_mul(ggx_separable.eval(mat, n, wo, wi), half_fresnel(mat.eta, mat.k, wo, wi))
