"""Jittered (stratified) points: one point in each stratum of every dimension.

1D dimensions use spp strata. 2D dimensions use an nx x ny grid with nx * ny = spp and nx the largest
divisor of spp not above sqrt(spp): a square count gives n x n strata, any other count a rectangular
grid (8 -> 2 x 4, a prime p -> 1 x p), so every count stays fully stratified and unbiased; only the
strata's aspect changes. Which sample lands in which stratum is a keyed permutation per (pixel,
dimension), so dimensions are not correlated with each other. Indices past spp start a new block of
spp samples with its own permutation.
"""
import warp as wp

from drtlab.estimators.hashing import hash_key, mix32, permute, unit_float
from drtlab.estimators.pointsets.base import PointSet

JITTER = wp.constant(wp.uint32(0x68E31DA4))


@wp.func
def grid_columns(spp: wp.uint32) -> wp.uint32:
    nx = wp.uint32(wp.floor(wp.sqrt(float(spp)) + 0.5))
    while nx * nx > spp:
        nx = nx - wp.uint32(1)
    while spp % nx != wp.uint32(0):
        nx = nx - wp.uint32(1)
    return nx


@wp.func
def place(s: wp.uint32, jitter: float, n: wp.uint32) -> float:
    # (s + jitter) / n rounded to float32 can land a hair outside stratum s; nudge it back by ulps so
    # that floor(x * n) == s holds exactly (the property the stratification tests check).
    x = (float(s) + jitter) / float(n)
    lo = wp.float64(s)
    hi = wp.float64(s + wp.uint32(1))
    while wp.float64(x) * wp.float64(n) >= hi:
        x = x - wp.max(x * 5.9604645e-08, 1.0e-30)
    while wp.float64(x) * wp.float64(n) < lo:
        x = x + wp.max(x * 5.9604645e-08, 1.0e-30)
    return x


@wp.func
def stratum(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
            spp: wp.uint32) -> wp.uint32:
    n = wp.max(spp, wp.uint32(1))
    block = index / n
    key = hash_key(seed, pixel, block, dim)
    return permute(index % n, n, key)


@wp.func
def stratified_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    s = stratum(seed, pixel, index, dim, n)
    jitter = unit_float(hash_key(seed, pixel, index, dim ^ JITTER))
    return place(s, jitter, n)


@wp.func
def stratified_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    nx = grid_columns(n)
    ny = n / nx
    s = stratum(seed, pixel, index, dim, n)
    h = hash_key(seed, pixel, index, dim ^ JITTER)
    jx = unit_float(h)
    jy = unit_float(mix32(h))
    return wp.vec2(place(s % nx, jx, nx), place(s / nx, jy, ny))


POINTSET = PointSet("stratified", "jittered strata: n x n per 2D dimension, spp per 1D dimension, "
                    "permuted per dimension", stratified_1d, stratified_2d)
