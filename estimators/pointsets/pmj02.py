"""Progressive multi-jittered (0,2) points (Christensen, Kensler & Kilpatrick 2018, "Progressive
Multi-Jittered Sample Sequences"), from a table built at import.

Table. `TABLE_SIZE` = 4096 points of one pmj02 sequence, generated deterministically in Python by
the stochastic construction of Helmer, Christensen & Kensler 2021 ("Stochastic Generation of (t, s)
Sample Sequences"), which produces pmj02 sequences in O(N): point 2^L + i (i < 2^L) copies the
first L digits of each coordinate of point i ^ x_L (a per-level xor value, one list per
coordinate: the pmj02 values of Helmer et al.'s method, as OpenQMC's `pmj.h` (Apache-2.0) lists
them; Sobol's values would give Owen-scrambled Sobol' instead), flips
digit L + 1 and draws the finer digits at random. Randomness comes from a fixed integer hash
(bit-identical everywhere). Every aligned block of 2^m points of the table is a (0,m,2)-net -
multi-jittered: elementary intervals of every shape 2^-a x 2^-b, a + b = m, including the 1 x 2^-m
Latin strata - which tests/estimators/test_pointsets_modern.py checks for the whole table.

Warp reaches the table because it is a `wp.constant` vector (4096 uint32: 16 bits of x and of y
each, finer bits hashed per point); get1d / get2d stay pure functions of (seed, pixel, index, dim).
Kernels cannot read module-level arrays, so pbrt's 65536-point tables (or Cycles' several) are
not copied; one table of 4096 is randomised per pixel and dimension instead, the way pbrt-v4's
PMJ02BN sampler and Cycles randomise theirs: the samples of a pixel read the table's first spp
entries in an order permuted per (seed, pixel, dimension) (`sobol.padded_index`: pbrt's
`PermutationElement`; it pairs the dimensions of one pixel at random), and each coordinate's
digits are XORed with a random key (a digital shift in base 2: it keeps every elementary-interval
stratification and makes every point uniform on [0, 1)). Unlike pbrt-v4's Cranley-Patterson
rotation, neither breaks the (0,2) property.

Sample counts: at spp = 2^m <= 4096 a pixel's points are a (0,m,2)-net in 2D (one per 1/spp
stratum in 1D: get1d reads the x coordinate), at other counts the first spp points of a (0,2)-
sequence (each power-of-two chunk of spp's binary expansion stratified). Sequence index a (the
permuted index) reads table entry a mod 4096 with a scramble keyed by a div 4096: spp > 4096 is
stratified per block of 4096 only, each block its own independently scrambled net (unbiased
throughout). The difference to `sobol`: the same (0,2) guarantees, a different (pmj02) pairing of
the strata, random positions inside the finest strata, a digital shift instead of Owen scrambling.
"""
import warp as wp

from drtlab.estimators.hashing import hash_prefix, mix32, mix64, unit_float
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.sobol import padded_index

TABLE_BITS = 12
TABLE_SIZE = 1 << TABLE_BITS
# Helmer, Christensen & Kensler 2021: per-level xor values whose construction yields pmj02 (x, y)
# (data as listed by OpenQMC, framestore/openqmc include/oqmc/pmj.h; tests check the result).
PMJ02_XORS = ((0x0000, 0x0000, 0x0002, 0x0006, 0x0006, 0x000E, 0x0036, 0x004E,
               0x0016, 0x002E, 0x0276, 0x06CE, 0x0716, 0x0C2E, 0x3076, 0x40CE),
              (0x0000, 0x0001, 0x0003, 0x0003, 0x0007, 0x001B, 0x0027, 0x000B,
               0x0017, 0x013B, 0x0367, 0x038B, 0x0617, 0x183B, 0x2067, 0x008B))
TABLE_SEED = 0x9E3779B9


def _mix32(x: int) -> int:
    # hashing.mix32 in Python integers.
    m = 0xFFFFFFFF
    h = (x ^ (x >> 16)) & m
    h = (h * 0x7FEB352D) & m
    h ^= h >> 15
    h = (h * 0x2C1B3C6D) & m
    h ^= h >> 16
    return h


def generate(n: int = TABLE_SIZE, seed: int = TABLE_SEED, xors=PMJ02_XORS) -> list[tuple[int, int]]:
    """n (a power of 2, <= 2^16) points of a stochastic (0,2)-sequence as 32-bit digit strings."""
    if n < 1 or n & (n - 1) or n > 1 << 16:
        raise ValueError(f"n must be a power of 2 in [1, 65536], got {n}")
    counter = [seed & 0xFFFFFFFF]

    def rand() -> int:
        counter[0] = (counter[0] + 0x6D2B79F5) & 0xFFFFFFFF
        return _mix32(_mix32(counter[0]) ^ 0x5BD1E995)

    pts = [[rand(), rand()]] + [[0, 0] for _ in range(n - 1)]
    level, length = 0, 1
    while length < n:
        swap = 0x80000000 >> level
        low = swap - 1
        for i in range(length):
            for k in (0, 1):
                strata = pts[i ^ xors[k][level]][k] & ~low & 0xFFFFFFFF
                pts[length + i][k] = (strata ^ swap) | (rand() & low)
        level, length = level + 1, 2 * length
    return [(x, y) for x, y in pts]


TABLE = generate()
_PACKED = [(x >> 16) << 16 | (y >> 16) for x, y in TABLE]
_TABLE = wp.constant(wp.types.vector(length=TABLE_SIZE, dtype=wp.uint32)(*_PACKED))
_SALT_1D = wp.constant(wp.uint32(0x3A1D5C01))
_SALT_2D = wp.constant(wp.uint32(0x3A2D5C02))
_LOW = wp.constant(wp.uint32(0x0000FFFF))
_GOLDEN = wp.constant(wp.uint32(0x1E3779B9))
# The index slot of the digital shifts' hash_prefix, and the odd multiplier of the table block.
_SHIFT = wp.constant(wp.uint32(0x5D1F7A3B))
_BLOCK = wp.constant(wp.uint64(0x9E3779B97F4A7C15))


@wp.func
def pmj02_bits(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
               spp: wp.uint32) -> wp.vec2ui:
    """The two coordinates' 32 digits: 16 from the table, the finer 16 hashed per point, then the
    digital shift keyed by (seed, pixel, dim, table block): one mix64 for both shifts, one mix32
    for both coordinates' fine digits (the pixel's hash_prefix once per pixel)."""
    a = padded_index(seed, pixel, index, dim, spp)
    w = mix64((wp.uint64(hash_prefix(seed, pixel, _SHIFT)) << wp.uint64(32) | wp.uint64(dim)) ^
              (wp.uint64(a >> wp.uint32(12)) * _BLOCK))
    sx = wp.uint32(w)
    sy = wp.uint32(w >> wp.uint64(32))
    fine = mix32((sx ^ sy) + a * _GOLDEN)
    e = _TABLE[int(a & wp.uint32(4095))]
    x = ((e >> wp.uint32(16)) << wp.uint32(16)) | (fine & _LOW)
    y = (e << wp.uint32(16)) | (fine >> wp.uint32(16))
    return wp.vec2ui(x ^ sx, y ^ sy)


@wp.func
def pmj02_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
             spp: wp.uint32) -> float:
    return unit_float(pmj02_bits(seed ^ _SALT_1D, pixel, index, dim, spp)[0])


@wp.func
def pmj02_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
             spp: wp.uint32) -> wp.vec2:
    b = pmj02_bits(seed ^ _SALT_2D, pixel, index, dim, spp)
    return wp.vec2(unit_float(b[0]), unit_float(b[1]))


POINTSET = PointSet(
    "pmj02", "progressive multi-jittered (0,2) (Christensen et al. 2018; Helmer et al. 2021 "
             "construction), 4096-point table, permuted + XOR-scrambled per pixel and dimension; "
             "(0,m,2)-nets at spp = 2^m <= 4096, other spp a prefix",
    pmj02_1d, pmj02_2d,
    cost_note="a keyed permutation of the pixel's samples per dimension (padding, as pbrt-v4) "
              "before the table read and its digital shift")
