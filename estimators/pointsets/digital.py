"""Base-2 digit tools shared by the digital point sets (sobol, zsobol, pmj02); not a point set itself.

A 32-bit unsigned integer v stands for the binary fraction v / 2^32 (bit 31 is the first digit).

* `reverse_bits(v)`: bit reversal (van der Corput: the radical inverse of an index in base 2).
* `owen_scramble(v, seed)`: hash-based nested uniform (Owen) scrambling of the 32 digits of v, as
  Burley 2020 ("Practical Hash-based Owen Scrambling", his improved Laine-Karras hash, the same as
  pbrt-v4's `FastOwenScrambler`). In the bit-reversed domain every step (x ^= x * even, x += seed,
  x *= odd) only carries information from lower to higher bits, so digit k of the output depends
  on digits 0..k of the input only: a random permutation of each elementary interval's halves,
  nested - it keeps every elementary-interval stratification of the points it is applied to.
  Applied to an integer index instead of a value (Burley's `nested_uniform_scramble` of the index)
  it maps every aligned block [a 2^m, (a+1) 2^m) of indices onto another aligned block, so the
  shuffled order of a (0,2)-sequence is again a (0,2)-sequence (sobol.py says why the padded sets
  shuffle with a random permutation instead).
* `sobol_bits(index, dim)`: the Sobol' sequence's first two dimensions (unscrambled, 32 digits):
  dim 0 is the van der Corput sequence (identity generator matrix), dim 1 the Pascal matrix mod 2
  (direction numbers 1, 3, 5, 15, 17, 51, ...: column j has row i set iff C(j, i) is odd, i.e.
  i & j == i by Lucas' theorem), evaluated as a superset-XOR transform in 5 shift/mask steps.
  Together they are a (0,2)-sequence in base 2: every aligned block of 2^m indices is a (0,m,2)-net.
* `owen_sobol(index, dim, seed)`: owen_scramble(sobol_bits(index, dim), seed), bit for bit, with
  one bit reversal instead of three.
* `morton2(x, y)`: the Morton (Z-curve) code of 16-bit coordinates (bits of x at even positions).

Every multiplier and mask stays below 2^31 so the generated C++ holds it as a plain int32 literal.
"""
import warp as wp

from drtlab.estimators.hashing import bit_length

_M55 = wp.constant(wp.uint32(0x55555555))
_M33 = wp.constant(wp.uint32(0x33333333))
_M0F = wp.constant(wp.uint32(0x0F0F0F0F))
_M00FF = wp.constant(wp.uint32(0x00FF00FF))
_M0000FFFF = wp.constant(wp.uint32(0x0000FFFF))
# Burley 2020's improved Laine-Karras hash constants.
_LK1 = wp.constant(wp.uint32(0x3D20ADEA))
_LK2 = wp.constant(wp.uint32(0x05526C56))
_LK3 = wp.constant(wp.uint32(0x53A22864))


@wp.func
def reverse_bits(v: wp.uint32) -> wp.uint32:
    x = ((v >> wp.uint32(1)) & _M55) | ((v & _M55) << wp.uint32(1))
    x = ((x >> wp.uint32(2)) & _M33) | ((x & _M33) << wp.uint32(2))
    x = ((x >> wp.uint32(4)) & _M0F) | ((x & _M0F) << wp.uint32(4))
    x = ((x >> wp.uint32(8)) & _M00FF) | ((x & _M00FF) << wp.uint32(8))
    return (x >> wp.uint32(16)) | (x << wp.uint32(16))


@wp.func
def _owen_hash(x: wp.uint32, seed: wp.uint32) -> wp.uint32:
    """Laine-Karras style nested-uniform scramble of bit-reversed digits (a bit flips with hashes of
    the bits below it only)."""
    x = x ^ (x * _LK1)
    x = x + seed
    x = x * ((seed >> wp.uint32(16)) | wp.uint32(1))
    x = x ^ (x * _LK2)
    return x ^ (x * _LK3)


@wp.func
def owen_scramble(v: wp.uint32, seed: wp.uint32) -> wp.uint32:
    return reverse_bits(_owen_hash(reverse_bits(v), seed))


@wp.func
def _pascal(index: wp.uint32) -> wp.uint32:
    # y_i = XOR of the index bits j with i & j == i (Pascal mod 2), digit i at bit i.
    y = index
    y = y ^ ((y >> wp.uint32(1)) & _M55)
    y = y ^ ((y >> wp.uint32(2)) & _M33)
    y = y ^ ((y >> wp.uint32(4)) & _M0F)
    y = y ^ ((y >> wp.uint32(8)) & _M00FF)
    y = y ^ ((y >> wp.uint32(16)) & _M0000FFFF)
    return y


@wp.func
def owen_sobol(index: wp.uint32, dim: int, seed: wp.uint32) -> wp.uint32:
    """owen_scramble(sobol_bits(index, dim), seed) without its two bit reversals: sobol_bits ends
    in one and owen_scramble starts with another (pbrt-v4's FastOwenScrambler likewise works on
    the bit-reversed digits), so the hash runs on the index (dim 0) or the Pascal transform of it
    (dim 1) directly; one reversal at the end instead of three."""
    x = index
    if dim != 0:
        x = _pascal(index)
    return reverse_bits(_owen_hash(x, seed))


@wp.func
def sobol_bits(index: wp.uint32, dim: int) -> wp.uint32:
    if dim == 0:
        return reverse_bits(index)
    # Digit i of the Pascal transform -> bit 31 - i.
    return reverse_bits(_pascal(index))


@wp.func
def spread_bits(v: wp.uint32) -> wp.uint32:
    # The 16 low bits of v to the even bit positions.
    x = v & _M0000FFFF
    x = (x | (x << wp.uint32(8))) & _M00FF
    x = (x | (x << wp.uint32(4))) & _M0F
    x = (x | (x << wp.uint32(2))) & _M33
    x = (x | (x << wp.uint32(1))) & _M55
    return x


@wp.func
def morton2(x: wp.uint32, y: wp.uint32) -> wp.uint32:
    return spread_bits(x) | (spread_bits(y) << wp.uint32(1))


@wp.func
def ceil_log2(n: wp.uint32) -> int:
    # No loop: a draw that counted up to log2(spp) paid for it in every dimension.
    if n <= wp.uint32(1):
        return 0
    return bit_length(n - wp.uint32(1))

