"""Correlated multi-jittered points (Kensler 2013, "Correlated Multi-Jittered Sampling").

2D: spp = m x n cells, m = the largest divisor of spp not above sqrt(spp) (the grid `stratified`
uses: 16 -> 4 x 4, 8 -> 2 x 4, 12 -> 3 x 4, a prime p -> 1 x p), n = spp / m. Sample s (after
Kensler's shuffle s = permute(i, spp)) sits in cell (s mod m, s div m); inside its column it is
offset by sy = permute(s div m, n) of n sub-columns and inside its row by sx = permute(s mod m, m)
of m sub-rows, one permutation for all columns and one for all rows (the "correlated" of the
name), then jittered uniformly inside its 1/spp x 1/spp sub-cell:
    x = (s mod m + (sy + jx) / n) / m,    y = (s div m + (sx + jy) / m) / n.
So every count is exactly multi-jittered: one point per cell of the m x n grid (the 2D jitter
strata) and one per 1/spp stratum in x and in y (Latin). Kensler's hash permutation is
`hashing.permute_wide` here (a keyed Feistel bijection with cycle-walking, like his). Kensler picks
m = round(sqrt(spp * aspect)) and n = ceil(spp / m), leaving cells empty when m n > spp; m n = spp
keeps every count fully stratified, at the cost of thin grids for counts with no divisor near
sqrt(spp) (a prime p: 1 x p cells, still Latin in both axes).

1D: the jittered Latin points of the same construction (one point per 1/spp stratum, permuted).
Permutations are keyed per (seed, pixel, dimension, block), jitter per (seed, pixel, sample index,
dimension); indices past spp start a new block of spp samples.
"""
import warp as wp

from drtlab.estimators.hashing import div_mod, hash_prefix, permute_wide, wide_key
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import (count_word, jitter_bits, jitter_pair,
                                                    place_bits, power_of_2, strata_key, word_count,
                                                    word_grid)

# Salts of the shuffle (the jitter's seed), sx, sy, the jitter pair (Kensler's per-pattern
# multipliers, masked below 2^31), and of the 1D points.
_SHUFFLE = wp.constant(wp.uint32(0x51633E2D))
_KX = wp.constant(wp.uint32(0x2511E9B3))
_KY = wp.constant(wp.uint32(0x63D83595))
_JX = wp.constant(wp.uint32(0x2399D265))
_ONE_D = wp.constant(wp.uint32(0x0CD1D1D1))


@wp.func
def cmj_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
           spp: wp.uint32) -> float:
    n = word_count(spp)
    bi = div_mod(index, n)
    s = permute_wide(bi[1], n, strata_key(seed ^ _ONE_D, pixel, bi[0], dim))
    return place_bits(s, jitter_bits(hash_prefix(seed ^ _ONE_D, pixel, index), dim), n)


@wp.func
def cmj_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
           spp: wp.uint32) -> wp.vec2:
    N = word_count(spp)
    m = word_grid(spp)[0]
    bi = div_mod(index, N)
    # The block's hash_prefix once per sample in a render; one wide_key per permutation.
    p = hash_prefix(seed, pixel, bi[0])
    s = permute_wide(bi[1], N, wide_key(p, dim))
    # A power-of-2 N (m and n powers of 2 too): the cell by a shift and a mask; N / m and div_mod
    # would be a division and a float64 multiply per draw (m leaves word_grid's loop per draw).
    km = wp.uint32(wp.bit_count(m - wp.uint32(1)))
    n = N >> km
    col = s & (m - wp.uint32(1))
    row = s >> km
    if not power_of_2(N):
        n = N / m
        rc = div_mod(s, m)
        col = rc[1]
        row = rc[0]
    sx = permute_wide(col, m, wide_key(p, dim ^ _KX))
    sy = permute_wide(row, n, wide_key(p, dim ^ _KY))
    j = jitter_pair(hash_prefix(seed ^ _SHUFFLE, pixel, index), dim ^ _JX)
    # x = (col + (sy + jx) / n) / m = (col * n + sy + jx) / N, placed so floor(x * N) is exact.
    return wp.vec2(place_bits(col * n + sy, j[0], N), place_bits(row * m + sx, j[1], N))


POINTSET = PointSet("cmj", "correlated multi-jittered (Kensler 2013): m x n = spp cells, Latin in "
                           "x and y; any spp (m the largest divisor <= sqrt(spp))", cmj_1d, cmj_2d,
                    count_word=count_word,
                    cost_note="three keyed permutations per 2D draw (Kensler's shuffle of the "
                              "samples, then one of the sub-columns and one of the sub-rows)")
