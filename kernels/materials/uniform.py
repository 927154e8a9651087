"""The uniform strategy's proposal for a kind with a density only (bsdf.py), on the one sample / pdf
interface: the hemisphere on wo's side, or the whole sphere for a kind that transmits. A kind with a
delta lobe samples itself under the uniform strategy (`MaterialKind.strategy_sampling`)."""
import warp as wp

from drtlab.estimators.domain_maps import (INV_4PI, INV_PI, frame_to_world, square_to_uniform_hemisphere,
                                           square_to_uniform_sphere)
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def sample_hemisphere(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    nf = n
    if wp.dot(n, wo) < 0.0:
        nf = -n
    return proposal(frame_to_world(square_to_uniform_hemisphere(u), nf))


@wp.func
def pdf_hemisphere(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    p = float(0.0)
    if wp.dot(n, wo) * wp.dot(n, wi) > 0.0:
        p = 0.5 * INV_PI
    return p


@wp.func
def sample_sphere(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    return proposal(square_to_uniform_sphere(u))


@wp.func
def pdf_sphere(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    return INV_4PI
