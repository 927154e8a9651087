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


# Round-key multipliers (odd: each k * C is a bijection of the key) and the rounds' multiplier.
_RK1 = wp.constant(wp.uint32(0x1E3779B9))
_RK2 = wp.constant(wp.uint32(0x4C957F2D))
_RK3 = wp.constant(wp.uint32(0x2545F491))
_RM = wp.constant(wp.uint32(0x5851F42D))
# Up to this many bits a Feistel round is a table lookup (below).
TABLE_BITS = 8


@wp.func
def _round(v: wp.uint32, k: wp.uint32, out_bits: int) -> wp.uint32:
    # Half a mix32 (xor the key, multiply, xorshift, multiply), its top out_bits bits: the high
    # bits of a product depend on every input bit. One multiply alone is nearly affine in v, and
    # at 128 strata two dimensions' permutations then correlated ((n - 1) E[r^2] = 1.27, not 1).
    h = (v ^ k) * _RM
    h = h ^ (h >> wp.uint32(15))
    h = h * _M2
    return (h >> wp.uint32(31 - out_bits)) >> wp.uint32(1)


@wp.func
def _table(key: wp.uint32, r: wp.uint32, wide: bool) -> wp.uint64:
    # 64 hashed bits for round r (32 when the tables fit in 32, as up to 6 bits: 2^3 x 3 = 24).
    lo = wp.uint64(mix32(key ^ (_M1 + wp.uint32(2) * r)))
    if wide:
        return lo | (wp.uint64(mix32(key ^ (_M1 + wp.uint32(2) * r + wp.uint32(1)))) << wp.uint64(32))
    return lo


@wp.func
def _lookup(table: wp.uint64, v: wp.uint32, out_bits: int) -> wp.uint32:
    return wp.uint32(table >> wp.uint64(v * wp.uint32(out_bits))) & \
        ((wp.uint32(1) << wp.uint32(out_bits)) - wp.uint32(1))


@wp.func
def permute(i: wp.uint32, n: wp.uint32, key: wp.uint32) -> wp.uint32:
    if n <= wp.uint32(1):
        return wp.uint32(0)
    # A 4-round Feistel network is a keyed pseudo-random permutation (Luby-Rackoff); on exactly
    # bits = ceil(log2 n) bits, halves of a = bits / 2 (low) and b = bits - a (high) bits updated
    # in turn (each round invertible on its own), so a power-of-2 n never cycle-walks and any other
    # n walks under 2 rounds on average. Simpler keyed bijections (xor-multiply chains) give a
    # family of permutations so small that the strata of two dimensions of one pixel correlate.
    bits = bit_length(n - wp.uint32(1))     # the smallest bits with 2**bits >= n
    a = bits / 2
    b = bits - a
    amask = (wp.uint32(1) << wp.uint32(a)) - wp.uint32(1)
    x = i
    if bits <= TABLE_BITS:
        # Up to 8 bits a round function (4 bits -> 4 bits) is a random table of 2^4 x 4 = 64 bits:
        # hashed once per draw, looked up by a shift; a Feistel network of random functions, the
        # Luby-Rackoff ideal, at a few instructions a round (pbrt-v4's and Kensler's hash
        # permutations cost a multiply chain per element).
        wide = bits > 6
        t0 = _table(key, wp.uint32(0), wide)
        t1 = _table(key, wp.uint32(1), wide)
        t2 = _table(key, wp.uint32(2), wide)
        t3 = _table(key, wp.uint32(3), wide)
        done = int(0)
        while done == 0:
            high = x >> wp.uint32(a)
            low = x & amask
            high = high ^ _lookup(t0, low, b)
            low = low ^ _lookup(t1, high, a)
            high = high ^ _lookup(t2, low, b)
            low = low ^ _lookup(t3, high, a)
            x = (high << wp.uint32(a)) | low
            if x < n:
                done = 1
    else:
        # Round keys by one multiply each (not a hash each): the rounds' own multiplies mix them.
        k0 = key
        k1 = key * _RK1
        k2 = key * _RK2
        k3 = key * _RK3
        done = int(0)
        while done == 0:
            high = x >> wp.uint32(a)
            low = x & amask
            high = high ^ _round(low, k0, b)
            low = low ^ _round(high, k1, a)
            high = high ^ _round(low, k2, b)
            low = low ^ _round(high, k3, a)
            x = (high << wp.uint32(a)) | low
            if x < n:
                done = 1
    # A keyed rotation makes every position uniform over keys, and its carries mix the halves: a
    # 4-round network of 3-bit halves alone pairs the rows of two 64-sample dimensions measurably
    # ((n - 1) E[r^2] = 1.07 between s div 8 and another dimension's s; 0.99 with the rotation).
    # r = floor(h n / 2^32) (Lemire's multiply-shift, no division; exactly uniform for a power-of-2
    # n, within n / 2^32 otherwise). x and r are below n: one conditional subtraction is the "% n"
    # of their sum.
    r = wp.uint32((wp.uint64(mix32(key + _GOLDEN)) * wp.uint64(n)) >> wp.uint64(32))
    y = x + r
    if y >= n:
        y = y - n
    return y
