"""`mirror`: a smooth reflector of `albedo` about the normal on wo's side (a delta lobe).

A delta kind of the kind table (`MaterialKind.model` with `delta`): no density to sample or
evaluate, so its module has `sample_delta` in place of eval_bsdf, sample and pdf:
    sample_delta(mat: MaterialAt, n, wo, u_lobe, uniform: int) -> Scatter
(the delta lobe's direction and weight, delta 1, from the material at the hit, material_at.py;
`uniform` is 1 under a strategy that samples directions uniformly, for a kind that chooses
between two lobes).
"""
import warp as wp

from drtlab.estimators.domain_maps import mirror_dir
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.func
def sample_delta(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, uniform: int) -> Scatter:
    return delta_scatter(mirror_dir(n, wo), mat.albedo)
