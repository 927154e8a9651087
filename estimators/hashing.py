"""Integer hashing shared by every point set: a sample value is a pure function of its key.

`hash_key(seed, pixel, index, dim)` decorrelates all four coordinates; its first rounds,
`hash_prefix(seed, pixel, index)`, are the same for every dimension of a sample, so a set that keys
by them pays for them once per sample in a render (the compiler hoists them out of the bounce loop),
not once per draw. `permute_wide(i, n, key)` is a keyed pseudo-random bijection of [0, n) (a Feistel
network on ceil(log2 n) bits with cycle-walking, then a keyed rotation) of 128 key bits
(`wide_key(hash, dim)`: two splitmix64 finalizers), used to decorrelate strata between dimensions
the way pbrt-v4 permutes per dimension; `permute(i, n, key)` spreads a 32-bit key to them.
`div_mod` divides without an integer division.
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
def hash_prefix(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32) -> wp.uint32:
    """hash_key's rounds before the dimension: the same for every dimension of a sample, so a
    render computes it once per sample (the compiler hoists it out of the bounce loop)."""
    # Adding a constant before each round keeps a zero key from mapping to zero.
    h = mix32(seed + _GOLDEN)
    h = mix32(h ^ (pixel + _M3))
    return mix32(h ^ (index + _GOLDEN))


@wp.func
def key_from_prefix(prefix: wp.uint32, dim: wp.uint32) -> wp.uint32:
    """hash_key's rounds after its hash_prefix:
    hash_key(s, p, i, d) = key_from_prefix(hash_prefix(s, p, i), d)."""
    h = mix32(prefix ^ (dim + _M1))
    # A second avalanche round: with one, neighbouring dimensions (inputs a few low bits apart) of
    # one sample were measurably not jointly uniform.
    return mix32(h + _GOLDEN)


@wp.func
def hash_key(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32) -> wp.uint32:
    return key_from_prefix(hash_prefix(seed, pixel, index), dim)


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


# splitmix64's finalizer (Stafford's mix 13): 64 well-mixed bits for the cost of one mix32. (uint64
# constants are emitted as unsigned 64-bit literals: no need to stay below 2**31.)
_S1 = wp.constant(wp.uint64(0xBF58476D1CE4E5B9))
_S2 = wp.constant(wp.uint64(0x94D049BB133111EB))
# Salts of the two words of a wide key.
_W0 = wp.constant(wp.uint64(0x9E3779B97F4A7C15))
_W1 = wp.constant(wp.uint64(0xD1B54A32D192ED03))
_RM = wp.constant(wp.uint32(0x5851F42D))
# Up to this many bits (n <= 64) a Feistel round is a lookup in 24 bits of the key.
TABLE_BITS = 6
_TABLE_SHIFT = wp.constant(wp.uint64(24))
_TOP = wp.constant(wp.uint64(48))


@wp.func
def mix64(z: wp.uint64) -> wp.uint64:
    z = (z ^ (z >> wp.uint64(30))) * _S1
    z = (z ^ (z >> wp.uint64(27))) * _S2
    return z ^ (z >> wp.uint64(31))


@wp.func
def wide_key(h: wp.uint32, dim: wp.uint32) -> wp.vec2ul:
    """128 key bits for `permute_wide` from a hash and a dimension: two mix64 side by side (no
    round of one waits on the other's)."""
    z = (wp.uint64(h) << wp.uint64(32)) | wp.uint64(dim)
    return wp.vec2ul(mix64(z ^ _W0), mix64(z ^ _W1))


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
def _lookup(table: wp.uint64, v: wp.uint32, out_bits: int) -> wp.uint32:
    return wp.uint32(table >> wp.uint64(v * wp.uint32(out_bits))) & \
        ((wp.uint32(1) << wp.uint32(out_bits)) - wp.uint32(1))


@wp.func
def div_mod(a: wp.uint32, n: wp.uint32) -> wp.vec2ui:
    """(a div n, a mod n), n >= 1, by a float64 multiply: (a + 1/2) / n lies at least 1 / (2 n)
    from an integer, and the product's rounding error, below (a / n) 2^-52 <= 2^-20 / n, cannot
    cross it. 1 / n is the same for every sample of a pixel (the compiler hoists it); an integer
    division costs ~25 cycles, and a branch around it (a < n) kept the compiler from hoisting the
    hash of (seed, pixel, block) out of a render's bounce loop (stratified: 2.9x an independent draw,
    not 1.5x, before its permutation)."""
    q = wp.uint32((wp.float64(a) + wp.float64(0.5)) * (wp.float64(1.0) / wp.float64(n)))
    return wp.vec2ui(q, a - q * n)


@wp.func
def permute_wide(i: wp.uint32, n: wp.uint32, key: wp.vec2ul) -> wp.uint32:
    """A keyed pseudo-random bijection of [0, n): i's image under the permutation of 128 key bits."""
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
    k0 = key[0]
    k1 = key[1]
    x = i
    spin = wp.uint32(0)
    # One copy of each round function: every get1d / get2d call site of a render kernel inlines
    # this, and a power-of-2 pass beside the cycle-walking loop (rounds written out 4 times more),
    # though ~1 ns a permutation cheaper in profile_kernels pointsets, made a stratified render of
    # aa-edges 0.155 -> 0.176 s (128 x 96, 64 spp, 1 thread).
    if bits <= TABLE_BITS:
        # Up to 6 bits a round function (3 bits -> 3 bits) is a random table of 2^3 x 3 = 24 key
        # bits, looked up by a shift: a Feistel network of random functions, the Luby-Rackoff
        # ideal, at a few instructions a round (pbrt-v4's and Kensler's hash permutations cost a
        # multiply chain per element); 4 tables take 96 of the 128 bits, the rotation the top 32.
        t1 = k0 >> _TABLE_SHIFT
        t3 = k1 >> _TABLE_SHIFT
        done = int(0)
        while done == 0:
            high = x >> wp.uint32(a)
            low = x & amask
            high = high ^ _lookup(k0, low, b)
            low = low ^ _lookup(t1, high, a)
            high = high ^ _lookup(k1, low, b)
            low = low ^ _lookup(t3, high, a)
            x = (high << wp.uint32(a)) | low
            if x < n:
                done = 1
        spin = wp.uint32(k0 >> _TOP) | (wp.uint32(k1 >> _TOP) << wp.uint32(16))
    else:
        # The four 32-bit quarters of the key are the round keys; the rotation gets a hash of its own.
        r0 = wp.uint32(k0)
        r1 = wp.uint32(k0 >> wp.uint64(32))
        r2 = wp.uint32(k1)
        r3 = wp.uint32(k1 >> wp.uint64(32))
        done = int(0)
        while done == 0:
            high = x >> wp.uint32(a)
            low = x & amask
            high = high ^ _round(low, r0, b)
            low = low ^ _round(high, r1, a)
            high = high ^ _round(low, r2, b)
            low = low ^ _round(high, r3, a)
            x = (high << wp.uint32(a)) | low
            if x < n:
                done = 1
        spin = mix32(r0 ^ r3 ^ _GOLDEN)
    # A keyed rotation makes every position uniform over keys, and its carries mix the halves: a
    # 4-round network of 3-bit halves alone pairs the rows of two 64-sample dimensions measurably
    # ((n - 1) E[r^2] = 1.07 between s div 8 and another dimension's s; 0.99 with the rotation).
    # r = floor(spin n / 2^32) (Lemire's multiply-shift, no division; exactly uniform for a
    # power-of-2 n, within n / 2^32 otherwise). x and r are below n: one conditional subtraction
    # is the "% n" of their sum.
    r = wp.uint32((wp.uint64(spin) * wp.uint64(n)) >> wp.uint64(32))
    y = x + r
    if y >= n:
        y = y - n
    return y


@wp.func
def permute(i: wp.uint32, n: wp.uint32, key: wp.uint32) -> wp.uint32:
    """permute_wide with the 128 key bits spread from 32 (a set whose key is a hash_key)."""
    return permute_wide(i, n, wide_key(key, wp.uint32(0)))
