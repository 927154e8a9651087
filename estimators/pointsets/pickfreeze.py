"""Pick-freeze points for a variance decomposition (Sobol' 1993; Saltelli et al. 2010): independent
points in which the seed's top byte chooses which dimension group (`dimensions.GROUPS`) is drawn from
a second, independent seed, so that f(A), f(B) and every f(A_B^g) come from one kernel and one batch.

    seed = base | code << 24, base < 2^24:
        code 0           A: every dimension from `base` (= `independent` at seed `base`)
        code 1 ... G     A_B^g, g = code - 1: group g's dimensions from B's seed, the others from A's
        code 255         B: every dimension from B's seed, a hash of `base`
        other codes      `independent` at the whole seed (so that every seed gives its own points)
Any code gives independent uniform values in every dimension, so the set is an unbiased point set
like `independent` (the registry's tests run it as one).
"""
import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.hashing import hash_key, mix32, unit_float
from drtlab.estimators.pointsets.base import PointSet

CODE_SHIFT = 24
BASE_LIMIT = 1 << CODE_SHIFT       # bases are below this
CODE_B = 255
_B_SALT = wp.constant(wp.uint32(0x2545F491))


dimension_group = dims.warp_functions().group        # dimensions.group_of in Warp


def pick_freeze_seed(base: int, code: int) -> int:
    """The seed that renders sample `base` of matrix A (code 0), B (CODE_B) or A_B^g (g + 1)."""
    return (code << CODE_SHIFT) | base


def make_pick_freeze(group, name: str, description: str) -> PointSet:
    """The pick-freeze set whose dimension -> group map is the Warp function `group` (tests build one
    with a wrong map: the decomposition's negative control)."""

    @wp.func(module="unique")
    def stream(seed: wp.uint32, dim: wp.uint32) -> wp.uint32:
        code = int(seed >> wp.uint32(wp.static(CODE_SHIFT)))
        if code == 0 or (code > wp.static(len(dims.GROUPS)) and code != wp.static(CODE_B)):
            return seed
        base = seed & wp.uint32(wp.static(BASE_LIMIT - 1))
        if code == wp.static(CODE_B) or group(dim) == code - 1:
            return mix32(base ^ _B_SALT)
        return base

    @wp.func(module="unique")
    def get1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
        return unit_float(hash_key(stream(seed, dim), pixel, index, dim))

    @wp.func(module="unique")
    def get2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
        s = stream(seed, dim)              # a 2D pair never straddles two groups
        return wp.vec2(unit_float(hash_key(s, pixel, index, dim)),
                       unit_float(hash_key(s, pixel, index, dim + wp.uint32(1))))

    return PointSet(name, description, get1d, get2d)


POINTSET = make_pick_freeze(
    dimension_group, "pickfreeze",
    "independent points whose seed's top byte draws one dimension group from a second seed "
    "(the variance decomposition of `drtlab sources`)")
