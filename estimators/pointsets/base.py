"""The point-set interface: a value in [0, 1) for (seed, pixel, sample index, dimension).

A point set provides two Warp functions compiled into the render kernel:
    get1d(seed, pixel, index, dim, spp) -> float
    get2d(seed, pixel, index, dim, spp) -> wp.vec2   (uses dimensions dim and dim + 1 jointly)
`spp` is the number of samples the pixel will take, so a stratified set can lay its strata out;
indices past `spp` start a new, independently permuted block of `spp` samples.
"""
from dataclasses import dataclass

import warp as wp


@dataclass(frozen=True)
class PointSet:
    name: str
    description: str
    get1d: wp.Function
    get2d: wp.Function
