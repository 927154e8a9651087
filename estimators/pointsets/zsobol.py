"""Z-ordered Owen-scrambled Sobol' (Ahmed & Wonka 2020, "Screen-Space Blue-Noise Diffusion of Monte
Carlo Sampling Error via Hierarchical Ordering of Pixels"; pbrt-v4's `ZSobolSampler`).

One global Sobol' (0,2)-sequence is shared by all pixels: pixel key P and sample index i give the
global index (P << k) | i with k = log2(spp); its base-4 digits are permuted per dimension by a
hash of the digits above them (pbrt-v4's `GetSampleIndex`; with k odd the lowest digit is a single
bit, flipped by a hash), which maps every aligned block of 4^j pixels onto an aligned block of the
sequence, and differently per dimension (the dimensions decorrelate). The point is the Sobol'
point of that index (`digital.sobol_bits`: dims 0 and 1 for get2d, dim 0 for get1d), Owen-scrambled
with a per-dimension seed (not per pixel: the sequence is global). Index bits above 32 (large keys
times large spp) select the Owen seed, so they cannot alias pixels either.

Pixel key. The blue-noise diffusion needs P = Morton(px, py), so that 4 neighbouring pixels own 4
consecutive blocks (a (0, k+2, 2)-net together, 16 a (0, k+4, 2)-net, ...): the set's `pixel_key`
(`zsobol_pixel_key`, `digital.morton2` of 16-bit coordinates) is what kernels/render_kernel.py passes as
`pixel`; the image still accumulates at the scanline index. `points(..., pixel=P)` takes the key.

Sample counts: spp must be a power of 2 for the per-pixel nets. At spp = 2^k each pixel's points
are a (0,k,2)-net in every 2D dimension (one point per 1/spp stratum in 1D). At any other spp the
index space is rounded up, k = ceil(log2 spp): each pixel owns a block of 2^k global indices and
uses the first spp of them (before the digit permutation), so its points are spp of the 2^k points
of its net - unbiased, but not stratified into spp strata, and 2^k - spp indices per pixel of the
global sequence stay unused (spp = 12: 12 of each pixel's 16-point net; the first 12 of what
spp = 16 gives). Indices past spp start a new block: index = b * spp + i takes local index i with
an Owen seed keyed by b.
"""
import warp as wp

from drtlab.estimators.hashing import (bit_length, div_mod, hash_key, hash_prefix, key_from_prefix,
                                       mix32, unit_float)
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.digital import ceil_log2, morton2, owen_sobol


def packed_permutations() -> list[int]:
    """The 24 permutations of (0, 1, 2, 3), each packed as 4 x 2 bits (entry d at bits 2d)."""
    from itertools import permutations
    return [sum(p[d] << (2 * d) for d in range(4)) for p in permutations(range(4))]


_PERM4 = wp.constant(wp.types.vector(length=24, dtype=wp.uint32)(*packed_permutations()))
_SALT_DIGITS = wp.constant(wp.uint32(0x2D1B5A0F))
_SALT_OWEN = wp.constant(wp.uint32(0x7A3C11E5))
_SY = wp.constant(wp.uint32(0x4F6CDD1D))
_M55 = wp.constant(wp.uint32(0x55555555))


@wp.func
def _digit_hash(higher: wp.uint64, dkey: wp.uint32) -> wp.uint32:
    # wp.uint32(u64) keeps the low 32 bits (a literal 0xFFFFFFFF mask would be emitted as int32 -1).
    return mix32(wp.uint32(higher) ^ mix32(wp.uint32(higher >> wp.uint64(32)) ^ dkey))


@wp.func
def _bit_length64(x: wp.uint64) -> int:
    hi = wp.uint32(x >> wp.uint64(32))
    if hi != wp.uint32(0):
        return 32 + bit_length(hi)
    return bit_length(wp.uint32(x))


@wp.func
def zsobol_index(seed: wp.uint32, pixel: wp.uint32, local: wp.uint32, k: int,
                 dim: wp.uint32) -> wp.uint64:
    """The digit-permuted global index of sample `local` (< 2^k) of pixel key `pixel`."""
    m = (wp.uint64(pixel) << wp.uint64(k)) | wp.uint64(local)
    dkey = hash_key(seed, _SALT_DIGITS, wp.uint32(0), dim)
    # _digit_hash(higher, dkey) is mix32(low ^ mix32(high ^ dkey)) of higher's 32-bit halves; where
    # m < 2^32 (every key of an image up to 2^(32 - k) pixels) every high half is 0, so the inner
    # mix32 is the same for all digits: computed once, the digits cost one mix32 each, not two.
    inner = mix32(dkey)
    small = (m >> wp.uint64(32)) == wp.uint64(0)
    odd = k % 2
    n4 = 16 + k / 2
    # Every digit at or above m's top bit is 0 with all higher digits 0, so one hash permutes all
    # of them alike: they are one constant digit c0 each (the leading 32 - log2(pixels) bits of a
    # small image's keys), set at once; only the digits below are permuted one by one.
    top = _bit_length64(m)
    p0 = (_digit_hash(wp.uint64(0), dkey) >> wp.uint32(8)) % wp.uint32(24)
    c0 = wp.uint64(_PERM4[int(p0)] & wp.uint32(3))
    first = (top - odd + 1) / 2             # digits t' = 0 .. first - 1 have shift 2 t' + odd < top
    out = wp.uint64(0)
    if first < n4:
        ones = (wp.uint64(_M55) | (wp.uint64(_M55) << wp.uint64(32))) << wp.uint64(2 * first + odd)
        if 2 * n4 + odd < 64:               # the digits' bits: 0 .. 2 n4 + odd - 1 = 31 + k
            ones = ones & ((wp.uint64(1) << wp.uint64(2 * n4 + odd)) - wp.uint64(1))
        out = c0 * ones                     # c0 at every constant digit (one bit per digit)
    t = wp.min(first, n4) - 1
    while t >= 0:
        shift = 2 * t + odd
        digit = wp.uint32((m >> wp.uint64(shift)) & wp.uint64(3))
        higher = wp.uint64(0)
        if shift + 2 < 64:                  # k = 32 (spp > 2^31) would shift by 64
            higher = m >> wp.uint64(shift + 2)
        hh = mix32(wp.uint32(higher) ^ inner)
        if not small:
            hh = _digit_hash(higher, dkey)
        p = (hh >> wp.uint32(8)) % wp.uint32(24)
        digit = (_PERM4[int(p)] >> (wp.uint32(2) * digit)) & wp.uint32(3)
        out = out | (wp.uint64(digit) << wp.uint64(shift))
        t -= 1
    if odd == 1:
        flip = _digit_hash(m >> wp.uint64(1), dkey ^ wp.uint32(1)) & wp.uint32(1)
        out = out | ((m & wp.uint64(1)) ^ wp.uint64(flip))
    return out


@wp.func
def zsobol_seed(seed: wp.uint32, block: wp.uint32, dim: wp.uint32, g: wp.uint64) -> wp.uint32:
    """hash_key(seed ^ _SALT_OWEN, g >> 32, block, dim). g >> 32 is 0 unless keys times spp pass
    2^32: then the hash_prefix is the block's, the same for every bounce of a sample (once per
    sample in a render), and the draw pays for the dimension's rounds alone."""
    high = wp.uint32(g >> wp.uint64(32))
    prefix = hash_prefix(seed ^ _SALT_OWEN, wp.uint32(0), block)
    if high != wp.uint32(0):
        prefix = hash_prefix(seed ^ _SALT_OWEN, high, block)
    return key_from_prefix(prefix, dim)


@wp.func
def zsobol_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    bi = div_mod(index, n)
    g = zsobol_index(seed, pixel, bi[1], ceil_log2(n), dim)
    s = zsobol_seed(seed, bi[0], dim, g)
    return unit_float(owen_sobol(wp.uint32(g), 0, s))


@wp.func
def zsobol_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    bi = div_mod(index, n)
    g = zsobol_index(seed, pixel, bi[1], ceil_log2(n), dim)
    s = zsobol_seed(seed, bi[0], dim, g)
    low = wp.uint32(g)
    return wp.vec2(unit_float(owen_sobol(low, 0, s)),
                   unit_float(owen_sobol(low, 1, mix32(s ^ _SY))))


@wp.func
def zsobol_pixel_key(px: int, py: int, width: int) -> wp.uint32:
    """The pixel key the Z-curve needs: Morton(px, py) (16-bit coordinates: images up to 65536
    pixels wide and high keep distinct keys)."""
    return morton2(wp.uint32(px), wp.uint32(py))


POINTSET = PointSet(
    "zsobol", "Sobol' along pixel order (Ahmed & Wonka 2020, pbrt-v4 ZSobol): base-4 digits "
              "permuted per dimension, Owen-scrambled; spp a power of 2 (else rounded up: spp of "
              "the 2^k net); pixels in Morton order",
    zsobol_1d, zsobol_2d, pixel_key=zsobol_pixel_key,
    cost_note="a hash per base-4 digit of the pixel's Morton key and the sample index (9 at "
              "64 x 64 pixels and 64 spp), per dimension: pbrt-v4's GetSampleIndex")
