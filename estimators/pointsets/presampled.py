"""Cook's pre-sampled glossy reflections (Cook, Porter, Carpenter 1984), as point sets.

Cook 1984 drew reflection directions from per-material tables of K pre-computed jittered
directions, reused across pixels. Here the table lives in the point set, so no kernel changes: on
the BOUNCE DIRECTION dimensions (estimators/dimensions.py: per bounce b, the 2D slot
BOUNCE_BASE + PER_BOUNCE * b + DIRECTION) the set returns one of K = 16 jittered points, one in each
cell of a 4 x 4 grid, and each material's lobe warp turns that table into the material's table of K
directions (Cook's per-material table). Sample `index` reads table entry perm(index mod K), so at
spp = K a pixel uses the whole table once (at spp = 16 m, m times). Every other dimension (pixel,
lens, time, light choice / position, lobe choice, roulette) is the `stratified` set, unchanged.

  * presampled: the table (jitter and the index -> entry permutation) depends on the bounce's
    dimension only, the SAME for every pixel and every seed. Biased by design, like Cook's fixed
    tables: the error of a 16-point quadrature of each pixel's reflection integral never averages
    out, neither over samples (indices past K replay the table) nor over seeds (the table ignores
    the seed), so the MSE plateaus at the squared bias. Marked `biased`.
  * presampled_random: the same 4 x 4 jittered table, re-drawn (jitter and permutation) per
    (seed, pixel, block of K samples, dimension): Cook's tables randomised per pixel. Every sample
    is uniform on [0, 1)^2 and independent of the other dimensions, so unbiased.

The table's x component is read by get1d(dim) and its y component by get1d(dim + 1), so a
dimension means the same thing whichever accessor reads it. Values are a pure function of
(seed, pixel, index, dim) (plus spp for the stratified dimensions).
"""
import warp as wp

from drtlab.estimators import dimensions as D
from drtlab.estimators.hashing import hash_key, mix32, permute
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import fixed_place, stratified_1d, stratified_2d

K = 16          # table size: 4 x 4 jittered strata
SIDE = 4
_K = wp.constant(wp.uint32(K))
_SIDE = wp.constant(wp.uint32(SIDE))
# Fixed keys (below 2**31: plain int32 literals in the generated C++) standing in for seed and pixel
# in the fixed table: the table's "seed".
_TABLE = wp.constant(wp.uint32(0x3C6EF372))
_PERM = wp.constant(wp.uint32(0x1B873593))
_JIT = wp.constant(wp.uint32(0x0B4A5E27))


_bounce_offset = D.warp_functions().bounce_offset


@wp.func
def direction_component(dim: wp.uint32) -> int:
    """0 / 1 where dim is the x / y dimension of a bounce's direction slot, else -1."""
    r = _bounce_offset(dim)
    if r == wp.static(D.DIRECTION):
        return 0
    if r == wp.static(D.DIRECTION + 1):
        return 1
    return -1


@wp.func
def table_point(seed: wp.uint32, pixel: wp.uint32, block: wp.uint32, slot: wp.uint32,
                entry_of: wp.uint32) -> wp.vec2:
    """Entry perm(entry_of) of the jittered 4 x 4 table keyed by (seed, pixel, block, slot)."""
    e = permute(entry_of, _K, hash_key(seed, pixel, block, slot ^ _PERM))
    h = hash_key(seed, pixel, block * _K + e, slot ^ _JIT)
    return wp.vec2(fixed_place(e % _SIDE, h, _SIDE), fixed_place(e / _SIDE, mix32(h), _SIDE))


@wp.func
def fixed_table(index: wp.uint32, slot: wp.uint32) -> wp.vec2:
    # The same table for every seed, pixel and block: sample index reads entry perm(index mod K).
    return table_point(_TABLE, _TABLE, wp.uint32(0), slot, index % _K)


@wp.func
def random_table(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, slot: wp.uint32) -> wp.vec2:
    # A fresh jittered table (and entry order) per seed, pixel and block of K samples.
    return table_point(seed, pixel, index / _K, slot, index % _K)


@wp.func
def presampled_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> float:
    c = direction_component(dim)
    if c < 0:
        return stratified_1d(seed, pixel, index, dim, spp)
    return fixed_table(index, dim - wp.uint32(c))[c]


@wp.func
def presampled_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> wp.vec2:
    if direction_component(dim) != 0:
        return stratified_2d(seed, pixel, index, dim, spp)
    return fixed_table(index, dim)


@wp.func
def presampled_random_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                         spp: wp.uint32) -> float:
    c = direction_component(dim)
    if c < 0:
        return stratified_1d(seed, pixel, index, dim, spp)
    return random_table(seed, pixel, index, dim - wp.uint32(c))[c]


@wp.func
def presampled_random_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                         spp: wp.uint32) -> wp.vec2:
    if direction_component(dim) != 0:
        return stratified_2d(seed, pixel, index, dim, spp)
    return random_table(seed, pixel, index, dim)


_COST = ("every draw first tells a bounce direction from the other dimensions; a direction is a "
         "table entry by a permutation of 16 and its jitter, the rest stratified's draws")
POINTSET = PointSet("presampled", "Cook 1984 pre-sampled table: bounce directions from one fixed "
                    "4 x 4 jittered table of 16 points, the same for every pixel and seed (biased); "
                    "other dimensions stratified", presampled_1d, presampled_2d, biased=True,
                    same_as_outside_directions="stratified", cost_note=_COST)
RANDOM_POINTSET = PointSet("presampled_random", "Cook 1984 table randomised: bounce directions from "
                           "a 4 x 4 jittered table of 16 points re-drawn per pixel, seed and block "
                           "of 16 samples (unbiased); other dimensions stratified",
                           presampled_random_1d, presampled_random_2d,
                           same_as_outside_directions="stratified", cost_note=_COST)
