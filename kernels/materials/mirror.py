"""`mirror`: a smooth reflector of `albedo` about the normal on wo's side (a delta lobe).

A delta kind of the kind table (`MaterialKind.delta`), on the one BSDF interface (the package
docstring): no density, so eval and pdf are 0 and sample returns the delta lobe.
"""
import warp as wp

from drtlab.estimators.domain_maps import mirror_dir
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.func
def eval(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
    return wp.vec3(0.0)


@wp.func
def pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return 0.0


@wp.func
def sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return delta_scatter(mirror_dir(n, wo), mat.albedo)
