"""`mirror`: a smooth reflector of `albedo` about the normal on wo's side (a delta lobe).

A delta kind of the kind table (`MaterialKind.model` with `delta`): no density to sample or
evaluate, so its module has `sample_delta` in place of eval_bsdf, sample and pdf:
    sample_delta(albedo, ior, cond_eta, cond_k, n, wo, u_lobe, uniform: int) -> Scatter
(the delta lobe's direction and weight, delta 1; `uniform` is 1 under a strategy that samples
directions uniformly, for a kind that chooses between two lobes; cond_eta, cond_k a conductor's
index, conductor.py).
"""
import warp as wp

from drtlab.estimators.domain_maps import mirror_dir
from drtlab.kernels.materials.scatter import Scatter, delta_scatter


@wp.func
def sample_delta(albedo: wp.vec3, ior: float, cond_eta: wp.vec3, cond_k: wp.vec3, n: wp.vec3, wo: wp.vec3,
                 u_lobe: float, uniform: int) -> Scatter:
    return delta_scatter(mirror_dir(n, wo), albedo)
