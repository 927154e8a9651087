"""The R2 sequence (Roberts 2018) as a drtlab point set, randomly shifted per pixel.

Point i of the 2D sequence is frac(i a1 + s1, i a2 + s2) with (a1, a2) = (1/g, 1/g^2), g the plastic
number (g^3 = g + 1); 1D dimensions use the golden ratio's 1/phi. The shift s (Cranley-Patterson
rotation) is hashed per (seed, pixel, block of spp samples, dimension): every value is uniform, so
the estimator is unbiased, and pixels and dimensions decorrelate. Load it with
`drtlab --plugin examples/plugins/r2.py ...` or `plugins = ["r2.py"]` in an experiment file.
"""
import warp as wp

import drtlab
from drtlab.estimators.hashing import hash_key, unit_float

A1 = wp.constant(wp.float64(0.7548776662466927))      # 1 / g
A2 = wp.constant(wp.float64(0.5698402909980532))      # 1 / g^2
PHI = wp.constant(wp.float64(0.6180339887498949))     # 1 / phi


@wp.func
def _frac_shifted(i: wp.float64, a: wp.float64, key: wp.uint32) -> float:
    # float64: i a loses no digits for the 2^20 samples of a pixel; the result rounds down to float32
    # and never reaches 1.
    x = i * a + wp.float64(unit_float(key))
    return wp.min(float(x - wp.floor(x)), 0.99999994)


@wp.func
def r2_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
          spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    return _frac_shifted(wp.float64(index % n), PHI, hash_key(seed, pixel, index / n, dim))


@wp.func
def r2_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
          spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    i = wp.float64(index % n)
    block = index / n
    return wp.vec2(_frac_shifted(i, A1, hash_key(seed, pixel, block, dim)),
                   _frac_shifted(i, A2, hash_key(seed, pixel, block, dim + wp.uint32(1))))


drtlab.register_pointset(drtlab.PointSet(
    "r2", "the R2 sequence (Roberts 2018), Cranley-Patterson shifted per pixel and dimension",
    r2_1d, r2_2d))
