"""The R2 sequence (Roberts 2018) as a drtlab point set, randomly shifted per pixel.

Point i of the 2D sequence is frac(i a1 + s1, i a2 + s2) with (a1, a2) = (1/g, 1/g^2), g the plastic
number (g^3 = g + 1); 1D dimensions use the golden ratio's 1/phi. The shift s (Cranley-Patterson
rotation) is hashed per (seed, pixel, block of spp samples, dimension): every value is uniform, so
the estimator is unbiased, and pixels decorrelate. Every dimension also permutes the pixel's sample
indices by a key of its own (padding, as pbrt-v4's padded samplers): without it sample i would read
the same R2 point in the pixel, lens and light dimensions, and `drtlab check r2` fails its battery
on that correlation (pixel.x against lens.x: (spp - 1) E[r^2] = 12.6 where independent dimensions
give 1; with the pixel's own order left unpermuted, 1.10 +- 0.03 against direction0.x). Load it with
`drtlab --plugin examples/plugins/r2.py ...` or `plugins = ["r2.py"]` in an experiment file.
"""
import warp as wp

import drtlab
from drtlab.estimators.hashing import hash_key, permute, unit_float

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
def _padded(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
            n: wp.uint32) -> wp.float64:
    # The point this sample reads in this dimension: a keyed permutation of the pixel's n indices.
    return wp.float64(permute(index % n, n, hash_key(seed ^ wp.uint32(0x52325232), pixel, index / n, dim)))


@wp.func
def r2_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
          spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    return _frac_shifted(_padded(seed, pixel, index, dim, n), PHI, hash_key(seed, pixel, index / n, dim))


@wp.func
def r2_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
          spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    i = _padded(seed, pixel, index, dim, n)
    block = index / n
    return wp.vec2(_frac_shifted(i, A1, hash_key(seed, pixel, block, dim)),
                   _frac_shifted(i, A2, hash_key(seed, pixel, block, dim + wp.uint32(1))))


drtlab.register_pointset(drtlab.PointSet(
    "r2", "the R2 sequence (Roberts 2018), Cranley-Patterson shifted per pixel and dimension",
    r2_1d, r2_2d))
