"""Scrambled Halton points with random digit permutations (pbrt-v4's `PermutationDigitsSampler`
randomisation, `ScrambledRadicalInverse` with a `DigitPermutation` per base).

Dimension d < `len(PRIMES)` (the first 1000 primes, as pbrt's prime table) is the radical inverse
of the sample index in base b = PRIMES[d] (2, 3, 5, 7, ...), every digit position j mapped through
its own random permutation sigma_j of {0, ..., b - 1}, keyed by (seed, pixel, d, j). Digits are
taken until b^-D < 2^-24 (the 24 bits of a float32 in [0, 1)), the leading zeros of short indices
included, as pbrt does (so the first point is not at 0). A uniformly random permutation is a
uniformly random value r_j = sigma_j(0) followed by a uniformly random bijection of the other
digits: sigma_j(0) = r_j and sigma_j(d) = (1 + permute(d - 1, b - 1, key_j) + r_j) mod b
(`hashing.permute`), so the (many) zero digits cost one hash, not a permutation. In base 2 a
permutation of {0, 1} is "flip or not", so there the digit permutations are a random 24-bit XOR
of the bit-reversed index (the same distribution, computed at once). get2d(d) is (dimension d,
dimension d + 1): bases PRIMES[d] and PRIMES[d + 1].

Per pixel: each pixel has its own digit permutations (its own seed) and uses sample indices
0, 1, ... of the sequence; a pixel does not take a share of one global sequence (pbrt-v4's Halton
sampler maps pixels to global indices instead; that needs the pixel's x, y, which get1d/get2d do
not receive).

Dimensions beyond the table (d >= 1000) reuse base PRIMES[d mod 1000] with their own digit
permutations and, so that two dimensions of one base do not read the same radical inverse of the
same index (which would correlate them completely), a padded index: index b * spp + i reads
sequence index b * spp + permute(i, spp, key(d)) - a random pairing within each block of spp, as
pbrt-v4 pads its Sobol sampler.

Sample counts: Halton stratifies in base b, not in spp. In dimension d with base b, the first
b^k points (and every aligned block of b^k) fall one per 1/b^k stratum; in a pair of bases
(b1, b2) any b1^k1 * b2^k2 consecutive aligned points fall one per elementary interval
b1^-k1 x b2^-k2 (get2d(0): spp = 2^a 3^c -> one point per cell of the 2^a x 3^c grid). Other
counts are prefixes of the sequence: unbiased, stratified only at the coarser levels. Large bases
need large spp to stratify at all (base 7919 at spp 64: 64 random cells out of 7919).
"""
import warp as wp

from drtlab.estimators.hashing import hash_key, mix32, permute
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.digital import reverse_bits


def first_primes(count: int) -> list[int]:
    out, n = [], 2
    while len(out) < count:
        if all(n % p for p in out if p * p <= n):
            out.append(n)
        n += 1
    return out


PRIMES = first_primes(1000)
_PRIMES = wp.constant(wp.types.vector(length=len(PRIMES), dtype=wp.uint32)(*PRIMES))
_NPRIMES = wp.constant(wp.uint32(len(PRIMES)))
_SALT_DIGITS = wp.constant(wp.uint32(0x48A1702B))
_SALT_PAD = wp.constant(wp.uint32(0x48A1702C))
_GOLDEN = wp.constant(wp.uint32(0x1E3779B9))
_FULL = wp.constant(wp.uint64(1 << 24))


@wp.func
def scrambled_radical_inverse(a: wp.uint32, base: wp.uint32, key: wp.uint32) -> float:
    if base == wp.uint32(2):
        return float((reverse_bits(a) ^ mix32(key)) >> wp.uint32(8)) * 5.9604644775390625e-08
    b = wp.uint64(base)
    rest = a
    digits = wp.uint64(0)      # the permuted digits, most significant first
    scale = wp.uint64(1)       # base^D
    j = wp.uint32(0)
    while scale < _FULL:
        d = rest % base
        rest = rest / base
        kj = mix32(key + j * _GOLDEN)
        p = kj % base                                   # sigma_j(0)
        if d != wp.uint32(0):
            p = (wp.uint32(1) + permute(d - wp.uint32(1), base - wp.uint32(1), kj) + p) % base
        digits = digits * b + wp.uint64(p)
        scale = scale * b
        j = j + wp.uint32(1)
    # floor(digits / base^D * 2^24) exactly (digits < base^D < 2^24 * base < 2^37, so no overflow).
    q = (digits << wp.uint64(24)) / scale
    return float(wp.uint32(q)) * 5.9604644775390625e-08


@wp.func
def halton_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
    base = _PRIMES[int(dim % _NPRIMES)]
    a = index
    if dim >= _NPRIMES:
        n = wp.max(spp, wp.uint32(1))
        a = (index / n) * n + permute(index % n, n, hash_key(seed ^ _SALT_PAD, pixel, index / n,
                                                              dim))
    return scrambled_radical_inverse(a, base, hash_key(seed ^ _SALT_DIGITS, pixel, wp.uint32(0),
                                                       dim))


@wp.func
def halton_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
    return wp.vec2(halton_1d(seed, pixel, index, dim, spp),
                   halton_1d(seed, pixel, index, dim + wp.uint32(1), spp))


POINTSET = PointSet(
    "halton", "Halton with random digit permutations per pixel (pbrt-v4 PermutationDigits); base "
              "PRIMES[dim], dims >= 1000 padded; stratified at spp = products of base powers",
    halton_1d, halton_2d,
    cost_note="every base-b digit of the index (16 in base 3) through its own hashed permutation, "
              "drawn per pixel and dimension at every draw (pbrt-v4 tabulates one set for all "
              "pixels)")
