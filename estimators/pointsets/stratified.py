"""Jittered (stratified) points: one point in each stratum of every dimension.

1D dimensions use spp strata. 2D dimensions use an nx x ny grid with nx * ny = spp and nx the largest
divisor of spp not above sqrt(spp): a square count gives n x n strata, any other count a rectangular
grid (8 -> 2 x 4, a prime p -> 1 x p), so every count stays fully stratified and unbiased; only the
strata's aspect changes. Which sample lands in which stratum is a keyed permutation per (pixel,
dimension), so dimensions are not correlated with each other. Indices past spp start a new block of
spp samples with its own permutation.

The grid costs a search: nx is found counting down from sqrt(spp), up to sqrt(spp) divisibility
tests (a prime spp: all of them), which a 2D draw would repeat every time. A render therefore hands
the set a *count word* (PointSet.count_word, computed once per pixel and pass) instead of the bare
spp: the count with its grid packed in (spp < 2^20), or marked prime (nx = 1, spp < 2^30); any
other count, and every bare spp a caller passes, is its own word and searched per draw. The values
are the same whichever word carries the count.
"""
import warp as wp

from drtlab.estimators.hashing import (div_mod, hash_prefix, mix32, mix64, permute_wide, unit_float,
                                       wide_key)
from drtlab.estimators.pointsets.base import PointSet

JITTER = wp.constant(wp.uint32(0x68E31DA4))
_JITTER_MUL = wp.constant(wp.uint32(0x3B1F0E95))
_JITTER_PAIR = wp.constant(wp.uint64(0xA0761D6478BD642F))
_UNIT = wp.constant(wp.uint32(1 << 24))


# A count word's top two bits: 0x: a bare count (spp < 2^31); 10: nx in bits 20..29 and spp < 2^20
# in bits 0..19; 11: a prime spp < 2^30 in bits 0..29.
_MARKED = wp.constant(wp.uint32(0x80000000))
_PRIME = wp.constant(wp.uint32(0x40000000))
_PACKED_BITS = wp.constant(wp.uint32(20))
_PACKED_COUNT = wp.constant(wp.uint32(0xFFFFF))
_PRIME_COUNT = wp.constant(wp.uint32(0x3FFFFFFF))
_COLUMNS_MASK = wp.constant(wp.uint32(0x3FF))
# Tests a count word makes first, from sqrt(spp) down: a square or near-square count needs no more.
_NEAR_SQUARE = wp.constant(wp.uint32(32))


@wp.func
def isqrt(n: wp.uint32) -> wp.uint32:
    """floor(sqrt(n)), exactly and without a loop: float64 holds n exactly and its square root is
    correctly rounded, and a non-square's root lies at least 2^-17 below the next integer."""
    return wp.uint32(wp.sqrt(wp.float64(n)))


@wp.func
def grid_search(spp: wp.uint32) -> wp.vec2ui:
    """(nx, divisibility tests made): nx the largest divisor of spp not above sqrt(spp)."""
    nx = isqrt(spp)
    tests = wp.uint32(1)
    while spp % nx != wp.uint32(0):
        nx = nx - wp.uint32(1)
        tests = tests + wp.uint32(1)
    return wp.vec2ui(nx, tests)


@wp.func
def grid_columns(spp: wp.uint32) -> wp.uint32:
    return grid_search(spp)[0]


@wp.func
def _mulmod(a: wp.uint64, b: wp.uint64, m: wp.uint64) -> wp.uint64:
    return (a * b) % m


@wp.func
def _strong_probable_prime(n: wp.uint32, base: wp.uint32) -> bool:
    """Miller-Rabin with one base; n odd, > base."""
    m = wp.uint64(n)
    d = n - wp.uint32(1)
    r = int(0)
    while d % wp.uint32(2) == wp.uint32(0):
        d = d / wp.uint32(2)
        r += 1
    x = wp.uint64(1)
    b = wp.uint64(base) % m
    e = d
    while e > wp.uint32(0):
        if e % wp.uint32(2) == wp.uint32(1):
            x = _mulmod(x, b, m)
        b = _mulmod(b, b, m)
        e = e / wp.uint32(2)
    if x == wp.uint64(1) or x == m - wp.uint64(1):
        return True
    for _ in range(r - 1):
        x = _mulmod(x, x, m)
        if x == m - wp.uint64(1):
            return True
    return False


@wp.func
def is_prime(n: wp.uint32) -> bool:
    """Deterministic for every 32-bit n: Miller-Rabin with bases 2, 7 and 61 (Jaeschke 1993) decides
    primality below 4,759,123,141; about a hundred multiplications instead of sqrt(n) divisions."""
    if n < wp.uint32(2):
        return False
    if n % wp.uint32(2) == wp.uint32(0) or n % wp.uint32(7) == wp.uint32(0) or \
            n % wp.uint32(61) == wp.uint32(0):
        return n == wp.uint32(2) or n == wp.uint32(7) or n == wp.uint32(61)
    return (_strong_probable_prime(n, wp.uint32(2)) and _strong_probable_prime(n, wp.uint32(7))
            and _strong_probable_prime(n, wp.uint32(61)))


@wp.func
def count_word(spp: wp.uint32) -> wp.uint32:
    """The word a render passes as `spp` (module docstring): once per pixel and pass."""
    n = wp.max(spp, wp.uint32(1))
    nx = wp.uint32(0)
    s = isqrt(n)
    c = s
    while nx == wp.uint32(0) and c > wp.uint32(0) and s - c < _NEAR_SQUARE:
        if n % c == wp.uint32(0):
            nx = c
        c = c - wp.uint32(1)
    if nx == wp.uint32(0) and n <= _PRIME_COUNT and is_prime(n):
        nx = wp.uint32(1)
        if n > _PACKED_COUNT:
            return _MARKED | _PRIME | n
    if n > _PACKED_COUNT:
        return n
    if nx == wp.uint32(0):
        nx = grid_columns(n)
    return _MARKED | (nx << _PACKED_BITS) | n


@wp.func
def word_count(word: wp.uint32) -> wp.uint32:
    """The sample count a count word (or a bare count) carries, at least 1."""
    if word & _MARKED == wp.uint32(0):
        return wp.max(word, wp.uint32(1))
    if word & _PRIME == wp.uint32(0):
        return word & _PACKED_COUNT
    return word & _PRIME_COUNT


@wp.func
def word_grid(word: wp.uint32) -> wp.vec2ui:
    """(nx, divisibility tests a draw makes to find it) of a count word: none when packed or prime.
    One loop, which a packed or prime word leaves at once: grid_search's own loop in a separate
    branch cost a render's 2D draw 7 ns of its 30 (the compiler kept the branch in the bounce loop)."""
    n = word_count(word)
    nx = isqrt(n)
    tests = wp.uint32(1)
    if word & _MARKED != wp.uint32(0):
        tests = wp.uint32(0)
        nx = wp.uint32(1)
        if word & _PRIME == wp.uint32(0):
            nx = (word >> _PACKED_BITS) & _COLUMNS_MASK
    while n % nx != wp.uint32(0):
        nx = nx - wp.uint32(1)
        tests = tests + wp.uint32(1)
    return wp.vec2ui(nx, tests)


@wp.func
def place(s: wp.uint32, jitter: float, n: wp.uint32) -> float:
    # (s + jitter) / n rounded to float32 can land a hair outside stratum s; nudge it back by ulps so
    # that floor(x * n) == s holds exactly (the property the stratification tests check). A multiply
    # by 1 / n (hoisted out of a render's sample loop: n is fixed per pixel) instead of a division:
    # its extra rounding is what the nudges are for anyway.
    x = (float(s) + jitter) * (1.0 / float(n))
    lo = wp.float64(s)
    hi = wp.float64(s + wp.uint32(1))
    while wp.float64(x) * wp.float64(n) >= hi:
        x = x - wp.max(x * 5.9604645e-08, 1.0e-30)
    while wp.float64(x) * wp.float64(n) < lo:
        x = x + wp.max(x * 5.9604645e-08, 1.0e-30)
    return x


@wp.func
def power_of_2(n: wp.uint32) -> bool:
    """n a power of 2 below 2^24 (the counts fixed_place places: at least one jitter bit)."""
    return n & (n - wp.uint32(1)) == wp.uint32(0) and n < _UNIT


@wp.func
def fixed_place(s: wp.uint32, bits: wp.uint32, n: wp.uint32) -> float:
    """place for a power_of_2 n = 2^k, exactly: the 24-bit fixed-point value whose top k bits are s
    and the rest the jitter's top 24 - k bits, so floor(x n) = s with no float64 check (place's
    nudges cost stratified's draw pair ~4 ns of 21). k is a popcount, not a division: a value
    derived from the count word inside the bounce loop is recomputed per draw."""
    k = wp.uint32(wp.bit_count(n - wp.uint32(1)))
    return float((s << (wp.uint32(24) - k)) | (bits >> (wp.uint32(8) + k))) * 5.9604644775390625e-08


@wp.func
def place_bits(s: wp.uint32, bits: wp.uint32, n: wp.uint32) -> float:
    """place(s, jitter, n) of 32 jitter bits: fixed_place where n is a power_of_2 (the same branch
    for every sample of a pixel), place(s, unit_float(bits), n) otherwise."""
    if power_of_2(n):
        return fixed_place(s, bits, n)
    return place(s, unit_float(bits), n)


@wp.func
def jitter_bits(sample: wp.uint32, dim: wp.uint32) -> wp.uint32:
    # One mix32 of the sample's hash_prefix (seed, pixel, index: the same for all its dimensions,
    # computed once per sample) and the dimension; the strata come from the block's prefix.
    return mix32(sample ^ (dim * _JITTER_MUL + JITTER))


@wp.func
def jitter_pair(sample: wp.uint32, dim: wp.uint32) -> wp.vec2ui:
    """Jitter bits of dimensions dim and dim + 1 of a sample: the two halves of one mix64."""
    w = mix64(((wp.uint64(sample) << wp.uint64(32)) | wp.uint64(dim)) ^ _JITTER_PAIR)
    return wp.vec2ui(wp.uint32(w), wp.uint32(w >> wp.uint64(32)))


@wp.func
def strata_key(seed: wp.uint32, pixel: wp.uint32, block: wp.uint32, dim: wp.uint32) -> wp.vec2ul:
    """The permutation key of (seed, pixel, block, dimension): hash_prefix (once per sample in a
    render) and one wide_key of the dimension."""
    return wide_key(hash_prefix(seed, pixel, block), dim)


@wp.func
def stratum(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
            spp: wp.uint32) -> wp.uint32:
    """The stratum of sample `index` in dimension dim: a permutation of each block of spp."""
    n = wp.max(spp, wp.uint32(1))
    bi = div_mod(index, n)
    return permute_wide(bi[1], n, strata_key(seed, pixel, bi[0], dim))


@wp.func
def stratified_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> float:
    n = word_count(spp)
    s = stratum(seed, pixel, index, dim, n)
    return place_bits(s, jitter_bits(hash_prefix(seed, pixel, index), dim), n)


@wp.func
def stratified_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                  spp: wp.uint32) -> wp.vec2:
    n = word_count(spp)
    nx = word_grid(spp)[0]
    s = stratum(seed, pixel, index, dim, n)
    j = jitter_pair(hash_prefix(seed, pixel, index), dim)
    if power_of_2(n):
        # nx and ny powers of 2 too: the cell by a shift and a mask, no division (ny = n / nx and
        # div_mod's float64 multiply depend on nx, which word_grid's loop leaves per draw).
        kx = wp.uint32(wp.bit_count(nx - wp.uint32(1)))
        return wp.vec2(fixed_place(s & (nx - wp.uint32(1)), j[0], nx),
                       fixed_place(s >> kx, j[1], n >> kx))
    rc = div_mod(s, nx)
    return wp.vec2(place(rc[1], unit_float(j[0]), nx), place(rc[0], unit_float(j[1]), n / nx))


POINTSET = PointSet("stratified", "jittered strata: n x n per 2D dimension, spp per 1D dimension, "
                    "permuted per dimension", stratified_1d, stratified_2d, count_word=count_word)
