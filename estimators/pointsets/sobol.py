"""Owen-scrambled Sobol' points, padded per dimension (pbrt-v4's `PaddedSobolSampler`).

Every 2D dimension pair (get2d) reads Sobol' dimensions 0 and 1 (`digital.sobol_bits`: van der
Corput and the Pascal matrix), every 1D dimension (get1d) Sobol' dimension 0, so only those two
generator matrices are needed. Per (seed, pixel, dimension) a hashed key gives
  * an index shuffle, as pbrt-v4's `PermutationElement(sampleIndex, spp, hash)`: sample i of a
    pixel reads Sobol' index permute(i, spp, key) (`hashing.permute_wide`, a keyed pseudo-random
    permutation, keyed per block too), so the spp points of a pixel are the sequence's first spp points in an order
    drawn independently per dimension - the dimensions of one pixel are paired at random;
  * independent Owen scrambles of the two coordinates (Burley's hash, pbrt-v4's FastOwenScrambler;
    `digital.owen_sobol` scrambles the Sobol' digits without reversing them twice).
The first point (index 0) is used, scrambled like every other point: dropping it breaks the nets.

Why not Burley's own shuffle (a nested uniform scramble of the index, `digital.owen_scramble` on
it)? It keeps every power-of-two prefix of a pixel stratified, but it pairs two dimensions'
samples hierarchically (index siblings stay siblings in every dimension): within a pixel the
correlation between two padded dimensions then has (spp - 1) E[r^2] ~ 1.55 at spp = 64 instead of
the 1 of independent dimensions (tests/estimators/test_pointset_uniformity.py's per-pixel test rejects it).

Sample counts: at spp = 2^m the spp points of a pixel in a 2D dimension are a (0,m,2)-net (every
elementary interval 2^-a x 2^-b with a + b = m holds exactly one point) and in a 1D dimension one
point per 1/spp stratum. At any other count a pixel takes the first spp points of the (0,2)-
sequence: each power-of-two chunk of spp's binary expansion (spp = 12: points 0-7, then 8-11) is
such a net, but the whole is not stratified into spp strata (unbiased either way; `stratified`,
`lhs` or `cmj` stratify any count). Which points a pixel uses does not depend on spp beyond the
permutation: index b * spp + i reads Sobol' index b * spp + permute(i, spp, key(b)), so indices
past spp continue the sequence (at spp = 2^m every such block is again a (0,m,2)-net).
"""
import warp as wp

from drtlab.estimators.hashing import div_mod, hash_prefix, permute_wide, unit_float, wide_key
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.digital import owen_sobol

_SALT_1D = wp.constant(wp.uint32(0x5B0B1D01))
_SALT_2D = wp.constant(wp.uint32(0x5B0B2D02))
# The index slot of the Owen seeds' hash_prefix (blocks use 0, 1, ...).
_OWEN = wp.constant(wp.uint32(0xF0E1D2C3))


@wp.func
def padded_index(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                 spp: wp.uint32) -> wp.uint32:
    """The sequence index sample `index` reads: its block of spp, permuted within the block by a
    key of (seed, pixel, block, dim) (hash_prefix once per sample, one wide_key per draw)."""
    n = wp.max(spp, wp.uint32(1))
    bi = div_mod(index, n)
    return bi[0] * n + permute_wide(bi[1], n, wide_key(hash_prefix(seed, pixel, bi[0]), dim))


@wp.func
def owen_seeds(seed: wp.uint32, pixel: wp.uint32, dim: wp.uint32) -> wp.vec2ui:
    """The two coordinates' Owen seeds of (seed, pixel, dim), one mix64 for both; not keyed by the
    block, so that blocks past spp continue one scrambled sequence."""
    w = wide_key(hash_prefix(seed, pixel, _OWEN), dim)[0]
    return wp.vec2ui(wp.uint32(w), wp.uint32(w >> wp.uint64(32)))


@wp.func
def sobol_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
             spp: wp.uint32) -> float:
    i = padded_index(seed ^ _SALT_1D, pixel, index, dim, spp)
    return unit_float(owen_sobol(i, 0, owen_seeds(seed ^ _SALT_1D, pixel, dim)[0]))


@wp.func
def sobol_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
             spp: wp.uint32) -> wp.vec2:
    i = padded_index(seed ^ _SALT_2D, pixel, index, dim, spp)
    o = owen_seeds(seed ^ _SALT_2D, pixel, dim)
    return wp.vec2(unit_float(owen_sobol(i, 0, o[0])), unit_float(owen_sobol(i, 1, o[1])))


POINTSET = PointSet(
    "sobol", "Owen-scrambled Sobol' (Burley 2020), padded (pbrt-v4): dims (0,1) per 2D pair, samples "
             "permuted per pixel and dimension; (0,m,2)-nets at spp = 2^m, other spp a prefix",
    sobol_1d, sobol_2d,
    cost_note="a keyed permutation of the pixel's samples per dimension (padding, as pbrt-v4) "
              "and an Owen scramble of each coordinate")
