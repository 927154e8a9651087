"""Point-set helpers shared by the estimator and experiment tests: evaluating a PointSet's Warp
functions from numpy, Python references of the hashing (hashing.py), and the fake point sets
(negative controls) with the registered sets' known defects."""
from __future__ import annotations

import numpy as np
import warp as wp

from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.independent import independent_1d
from drtlab.estimators.pointsets.stratified import stratified_1d, stratified_2d
from drtlab.warp_runtime import warp as _wp

_KERNELS: dict = {}


def eval_kernel(pointset: PointSet):
    """A kernel evaluating the point set's get1d and get2d at arrays of (pixel, index, dim)."""
    _wp()                                  # Warp initialised once, quietly
    if pointset.name not in _KERNELS:
        get1d, get2d = pointset.get1d, pointset.get2d

        @wp.kernel(enable_backward=False, module="unique")
        def evaluate(seed: wp.uint32, spp: wp.uint32, pixel: wp.array(dtype=wp.uint32),
                     index: wp.array(dtype=wp.uint32), dim: wp.array(dtype=wp.uint32),
                     out1: wp.array(dtype=float), out2: wp.array(dtype=wp.vec2)):
            i = wp.tid()
            out1[i] = get1d(seed, pixel[i], index[i], dim[i], spp)
            out2[i] = get2d(seed, pixel[i], index[i], dim[i], spp)

        _KERNELS[pointset.name] = evaluate
    return _KERNELS[pointset.name]


def evaluate(pointset: PointSet, seed: int, spp: int, pixel, index, dim):
    """(1D values (n,), 2D values (n, 2)) as float32 numpy arrays."""
    pixel, index, dim = np.broadcast_arrays(np.asarray(pixel, dtype=np.uint32),
                                            np.asarray(index, dtype=np.uint32),
                                            np.asarray(dim, dtype=np.uint32))
    n = pixel.size
    arrays = [wp.array(np.ascontiguousarray(a.ravel()), dtype=wp.uint32, device="cpu")
              for a in (pixel, index, dim)]
    out1 = wp.zeros(n, dtype=float, device="cpu")
    out2 = wp.zeros(n, dtype=wp.vec2, device="cpu")
    wp.launch(eval_kernel(pointset), dim=n, device="cpu",
              inputs=[wp.uint32(seed), wp.uint32(spp), *arrays, out1, out2])
    return out1.numpy(), out2.numpy()


M32 = 0xFFFFFFFF
M1, M2, M3, GOLDEN = 0x7FEB352D, 0x2C1B3C6D, 0x297A2D39, 0x1E3779B9


def py_mix32(x: int) -> int:
    h = (x ^ (x >> 16)) & M32
    h = (h * M1) & M32
    h ^= h >> 15
    h = (h * M2) & M32
    h ^= h >> 16
    return h


def py_hash_prefix(seed: int, pixel: int, index: int) -> int:
    h = py_mix32((seed + GOLDEN) & M32)
    h = py_mix32(h ^ ((pixel + M3) & M32))
    return py_mix32(h ^ ((index + GOLDEN) & M32))


def py_hash_key(seed: int, pixel: int, index: int, dim: int) -> int:
    h = py_mix32(py_hash_prefix(seed, pixel, index) ^ ((dim + M1) & M32))
    return py_mix32((h + GOLDEN) & M32)


M64 = (1 << 64) - 1


def py_mix64(z: int) -> int:
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return z ^ (z >> 31)


def py_wide_key(h: int, dim: int) -> tuple[int, int]:
    z = (h << 32) | dim
    return py_mix64(z ^ 0x9E3779B97F4A7C15), py_mix64(z ^ 0xD1B54A32D192ED03)


def _py_round(v: int, k: int, out_bits: int) -> int:
    h = ((v ^ k) * 0x5851F42D) & M32
    h ^= h >> 15
    h = (h * M2) & M32
    return h >> (32 - out_bits)


def py_permute_wide(i: int, n: int, key: tuple[int, int]) -> int:
    """Python reference of hashing.permute_wide: a 4-round alternating Feistel on ceil(log2 n) bits
    (24-bit table rounds up to 6 bits, hashed rounds beyond), cycle-walking, and a multiply-shift
    rotation."""
    if n <= 1:
        return 0
    bits = (n - 1).bit_length()
    a = bits // 2
    b = bits - a
    k0, k1 = key
    if bits <= 6:
        tables = [k0, k0 >> 24, k1, k1 >> 24]
        rounds = [lambda v, o, t=t: (t >> (v * o)) & ((1 << o) - 1) for t in tables]
        spin = (k0 >> 48) | ((k1 >> 48) << 16)
    else:
        keys = [k0 & M32, k0 >> 32, k1 & M32, k1 >> 32]
        rounds = [lambda v, o, k=k: _py_round(v, k, o) for k in keys]
        spin = py_mix32(keys[0] ^ keys[3] ^ GOLDEN)
    x = i
    while True:
        high, low = x >> a, x & ((1 << a) - 1)
        high ^= rounds[0](low, b)
        low ^= rounds[1](high, a)
        high ^= rounds[2](low, b)
        low ^= rounds[3](high, a)
        x = (high << a) | low
        if x < n:
            break
    return (x + ((spin * n) >> 32)) % n


def py_permute(i: int, n: int, key: int) -> int:
    """Python reference of hashing.permute."""
    return py_permute_wide(i, n, py_wide_key(key, 0))


@wp.func
def copied_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
    # dimension d + 1 is a copy of dimension d (d even)
    return independent_1d(seed, pixel, index, dim - dim % wp.uint32(2), spp)


@wp.func
def copied_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
    return wp.vec2(copied_1d(seed, pixel, index, dim, spp),
                   copied_1d(seed, pixel, index, dim + wp.uint32(1), spp))


@wp.func
def half_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
            spp: wp.uint32) -> float:
    return 0.5 * stratified_1d(seed, pixel, index, dim, spp)


@wp.func
def half_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
            spp: wp.uint32) -> wp.vec2:
    return 0.5 * stratified_2d(seed, pixel, index, dim, spp)


FAKE_CORRELATED = PointSet("fake-correlated", "dimension d+1 copies dimension d", copied_1d,
                           copied_2d)
FAKE_HALF = PointSet("fake-half", "stratified, but every value in [0, 0.5)", half_1d, half_2d)

# What uniformity each registered set promises; any other set must not be worse than i.i.d.
EXPECT = {"independent": "iid", "stratified": "better", "cmj": "better", "sobol": "better",
          "zsobol": "better", "pmj02": "better"}

KNOWN_DEFECTS: dict = {
    # pbrt-v4's ZSobolSampler, faithfully: each dimension permutes the base-4 digits of the sample
    # index by a nested (hierarchical) permutation, so samples that are index siblings in one
    # dimension are siblings in every other: within a pixel two dimensions correlate more than
    # independent ones, (spp - 1) E[r^2] ~ 1.29 at spp = 64 (unbiased all the same: every sample
    # is uniform and the pooled and joint tests pass). sobol and pmj02 pair dimensions by a random
    # permutation instead and pass (estimators/pointsets/zsobol.py, sobol.py).
    ("per_pixel_correlation", "zsobol"): "pbrt-v4 ZSobol's nested digit permutations pair the "
                                         "samples of two dimensions hierarchically",
}
# Not listed: Cook's randomised table (presampled_random). Its bounce directions come in blocks of 16
# (one 4 x 4 jittered table per block), each randomised on its own; their block means are all ~ 1/2
# (stratified), so at spp = 64 the 4 blocks' within-block products dominate and (spp - 1) E[r^2]
# ~ 63/60 = 1.05 for two direction dimensions (unbiased all the same). The per-pixel test's bound at
# 2^14 pixels is 1 + 4.5 SE = 1.054: the defect sits at its edge (1.045 and 1.051 measured as
# hashing.permute's rounds changed, above the bound with the first Feistel), so no test asserts it.
