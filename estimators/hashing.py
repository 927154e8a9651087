"""Integer hashing shared by every point set: a sample value is a pure function of its key.

`hash_key(seed, pixel, index, dim)` decorrelates all four coordinates; `permute` is a bijection of
[0, n) keyed by a hash (cycle-walking over the next power of two, then a keyed rotation), used to
decorrelate strata between dimensions the way pbrt-v4 permutes per dimension.
"""
import warp as wp

# Multipliers kept below 2**31 so the generated C++ holds them as plain int32 literals.
_M1 = wp.constant(wp.uint32(0x7FEB352D))
_M2 = wp.constant(wp.uint32(0x2C1B3C6D))
_M3 = wp.constant(wp.uint32(0x297A2D39))
_GOLDEN = wp.constant(wp.uint32(0x1E3779B9))


@wp.func
def mix32(x: wp.uint32) -> wp.uint32:
    # "lowbias32"-style avalanche: xorshift-multiply rounds, every bit of x reaches every output bit.
    h = x ^ (x >> wp.uint32(16))
    h = h * _M1
    h = h ^ (h >> wp.uint32(15))
    h = h * _M2
    h = h ^ (h >> wp.uint32(16))
    return h


@wp.func
def hash_key(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32) -> wp.uint32:
    # Adding a constant before each round keeps a zero key from mapping to zero.
    h = mix32(seed + _GOLDEN)
    h = mix32(h ^ (pixel + _M3))
    h = mix32(h ^ (index + _GOLDEN))
    h = mix32(h ^ (dim + _M1))
    return h


@wp.func
def unit_float(h: wp.uint32) -> float:
    # 24 high bits -> [0, 1) exactly representable in float32, never 1.0.
    return float(h >> wp.uint32(8)) * 5.9604644775390625e-08


@wp.func
def permute(i: wp.uint32, n: wp.uint32, key: wp.uint32) -> wp.uint32:
    if n <= wp.uint32(1):
        return wp.uint32(0)
    w = n - wp.uint32(1)
    mask = w | (w >> wp.uint32(1))
    mask = mask | (mask >> wp.uint32(2))
    mask = mask | (mask >> wp.uint32(4))
    mask = mask | (mask >> wp.uint32(8))
    mask = mask | (mask >> wp.uint32(16))
    # Each step is a bijection on the low bits under `mask` (xor with a constant, multiply by an odd
    # constant, xorshift of the masked value), so walking until the value falls below n is a
    # bijection of [0, n); fewer than two rounds are needed on average.
    x = i
    k2 = mix32(key)
    done = int(0)
    while done == 0:
        x = x ^ key
        x = (x * _M1) & mask
        x = x ^ ((x & mask) >> wp.uint32(3))
        x = x ^ (k2 & mask)
        x = (x * (_M2 | wp.uint32(1))) & mask
        x = x ^ ((x & mask) >> wp.uint32(5))
        x = (x * (_M3 | wp.uint32(1))) & mask
        x = x ^ ((x & mask) >> wp.uint32(7))
        x = x & mask
        if x < n:
            done = 1
    # The walk alone mixes few bits for small n, so sample i's stratum would not be uniform over keys
    # (dimensions of one sample would correlate); a keyed rotation makes every position uniform and,
    # with independent keys, the strata of two dimensions independent.
    return (x + mix32(k2 ^ _GOLDEN) % n) % n
