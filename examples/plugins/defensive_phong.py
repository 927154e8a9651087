"""A lobe sampler for the `glossy` (modified Phong) kind: defensive importance sampling (Hesterberg
1995), half the samples from the Phong lobe about the mirror direction and half cosine-weighted about
the normal, and the strategy `importance-defensive`: `importance` with it.

The mixture's density is the average of the two, so a sharp lobe seen at grazing angles (where much
of the lobe lies below the surface and its samples are lost) still gets directions from the cosine
half; the price is half the samples on a sharp lobe's peak. `drtlab check defensive-phong` tests it;
`--sampler stratified+importance-defensive` renders with it. The first direction number picks the
half and is stretched back to [0, 1), so one 2D sample drives both (the glossy kind has no lobe
choice number)."""
import warp as wp

import drtlab
from drtlab.estimators.domain_maps import (INV_PI, frame_to_world, phong_lobe_pdf, square_to_cosine_hemisphere,
                                           square_to_phong_lobe)
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, proposal


@wp.func
def defensive_sample(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
    nf = wp.sign(wp.dot(n, wo)) * n                 # the normal on wo's side: the lobe reflects
    if u[0] < 0.5:
        return proposal(frame_to_world(square_to_phong_lobe(wp.vec2(2.0 * u[0], u[1]), mat.shape),
                                       2.0 * wp.dot(nf, wo) * nf - wo))
    return proposal(frame_to_world(square_to_cosine_hemisphere(wp.vec2(2.0 * u[0] - 1.0, u[1])), nf))


@wp.func
def defensive_pdf(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    nf = wp.sign(wp.dot(n, wo)) * n
    cos_i = wp.dot(nf, wi)
    if cos_i <= 0.0:
        return 0.0
    refl = 2.0 * wp.dot(nf, wo) * nf - wo
    return 0.5 * phong_lobe_pdf(wp.dot(refl, wi), mat.shape) + 0.5 * cos_i * INV_PI


drtlab.register_lobe_sampler(drtlab.LobeSampler(
    "defensive-phong", "half Phong lobe, half cosine (defensive mixture)", "glossy",
    defensive_sample, defensive_pdf))
drtlab.register_strategy("importance-defensive", "as importance, glossy lobes sampled by the defensive "
                         "mixture", like="importance", lobe_samplers=["defensive-phong"])
