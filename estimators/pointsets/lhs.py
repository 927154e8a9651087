"""Latin hypercube (N-rooks) points, padded: every dimension is Latin on its own.

Dimension d of the spp samples of a pixel: sample i lands in stratum permute(i, spp, key(pixel, d))
of spp equal strata of [0, 1), uniformly jittered inside it, with an independent keyed permutation
(`hashing.permute_wide`) per (seed, pixel, dimension, block): McKay, Beckman & Conover's Latin
hypercube, as `scipy.stats.qmc.LatinHypercube` (scramble=True). A 2D dimension pair is the two 1D
dimensions dim and dim + 1 (get2d(dim) == (get1d(dim), get1d(dim + 1))): Latin in x and in y, with
no 2D strata (the N-rooks pattern; `stratified` and `cmj` add 2D strata).

Any spp: exactly one point per 1/spp stratum in every dimension. Indices past spp start a new
block of spp samples with its own permutations.
"""
import warp as wp

from drtlab.estimators.hashing import div_mod, hash_prefix, permute_wide
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import jitter_bits, place_bits, strata_key

_STRATA = wp.constant(wp.uint32(0x1A75C3E1))
_JITTER = wp.constant(wp.uint32(0x6C8E9CF5))


@wp.func
def lhs_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
           spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    bi = div_mod(index, n)
    s = permute_wide(bi[1], n, strata_key(seed ^ _STRATA, pixel, bi[0], dim))
    return place_bits(s, jitter_bits(hash_prefix(seed ^ _JITTER, pixel, index), dim), n)


@wp.func
def lhs_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
           spp: wp.uint32) -> wp.vec2:
    return wp.vec2(lhs_1d(seed, pixel, index, dim, spp),
                   lhs_1d(seed, pixel, index, dim + wp.uint32(1), spp))


POINTSET = PointSet("lhs", "Latin hypercube (N-rooks): spp strata per dimension, an independent "
                           "permutation per dimension and pixel; any spp", lhs_1d, lhs_2d,
                    cost_note="a keyed permutation of the pixel's strata per dimension, so three "
                              "per 2D + 1D pair (the Latin property is per dimension)")
