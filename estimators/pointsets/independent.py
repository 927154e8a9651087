"""Independent uniform random points: every (seed, pixel, index, dim) hashed on its own."""
import warp as wp

from drtlab.estimators.hashing import hash_key, unit_float
from drtlab.estimators.pointsets.base import PointSet


@wp.func
def independent_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                   spp: wp.uint32) -> float:
    return unit_float(hash_key(seed, pixel, index, dim))


@wp.func
def independent_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
                   spp: wp.uint32) -> wp.vec2:
    return wp.vec2(unit_float(hash_key(seed, pixel, index, dim)),
                   unit_float(hash_key(seed, pixel, index, dim + wp.uint32(1))))


POINTSET = PointSet("independent", "uniform random points, independent across samples and dimensions",
                    independent_1d, independent_2d)
