"""Integer hashing shared by every point set: a sample value is a pure function of its key.

`hash_key(seed, pixel, index, dim)` decorrelates all four coordinates; `permute` is a keyed
pseudo-random bijection of [0, n) (a Feistel network with cycle-walking, then a keyed rotation),
used to decorrelate strata between dimensions the way pbrt-v4 permutes per dimension.
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
    # A second avalanche round: with one, neighbouring dimensions (inputs a few low bits apart) of
    # one sample were measurably not jointly uniform.
    return mix32(h + _GOLDEN)


@wp.func
def unit_float(h: wp.uint32) -> float:
    # 24 high bits -> [0, 1) exactly representable in float32, never 1.0.
    return float(h >> wp.uint32(8)) * 5.9604644775390625e-08


@wp.func
def bit_length(x: wp.uint32) -> int:
    """Bits needed to write x (0 for 0), by binary search: no loop."""
    b = int(0)
    if x >= wp.uint32(65536):
        x = x >> wp.uint32(16)
        b += 16
    if x >= wp.uint32(256):
        x = x >> wp.uint32(8)
        b += 8
    if x >= wp.uint32(16):
        x = x >> wp.uint32(4)
        b += 4
    if x >= wp.uint32(4):
        x = x >> wp.uint32(2)
        b += 2
    if x >= wp.uint32(2):
        x = x >> wp.uint32(1)
        b += 1
    return b + int(x)


@wp.func
def permute(i: wp.uint32, n: wp.uint32, key: wp.uint32) -> wp.uint32:
    if n <= wp.uint32(1):
        return wp.uint32(0)
    # A 4-round Feistel network on an even number of bits >= log2(n) is a keyed pseudo-random
    # permutation (Luby-Rackoff); cycle-walking restricts it to [0, n) (under 4 rounds of walking
    # on average). Simpler keyed bijections (xor-multiply chains) give a family of permutations so
    # small that the strata of two dimensions of one pixel correlate.
    bits = bit_length(n - wp.uint32(1))     # the smallest bits with 2**bits >= n
    half = wp.uint32((bits + 1) / 2)
    hmask = (wp.uint32(1) << half) - wp.uint32(1)
    # The round keys depend on the key alone: computed once, not per cycle-walking step.
    k0 = mix32(key ^ _M1)
    k1 = mix32(key ^ (_M1 + wp.uint32(1)))
    k2 = mix32(key ^ (_M1 + wp.uint32(2)))
    k3 = mix32(key ^ (_M1 + wp.uint32(3)))
    x = i
    done = int(0)
    while done == 0:
        left = x >> half
        right = x & hmask
        t = left ^ (mix32(right ^ k0) & hmask)
        left = right
        right = t
        t = left ^ (mix32(right ^ k1) & hmask)
        left = right
        right = t
        t = left ^ (mix32(right ^ k2) & hmask)
        left = right
        right = t
        t = left ^ (mix32(right ^ k3) & hmask)
        left = right
        right = t
        x = (left << half) | right
        if x < n:
            done = 1
    # A keyed rotation makes every position exactly uniform over keys. x and the rotation are
    # below n: one conditional subtraction is the "% n" of their sum (a division the less).
    y = x + mix32(key + _GOLDEN) % n
    if y >= n:
        y = y - n
    return y
