"""The point-set interface: a value in [0, 1) for (seed, pixel, sample index, dimension).

A point set provides two Warp functions compiled into the render kernel:
    get1d(seed, pixel, index, dim, spp) -> float
    get2d(seed, pixel, index, dim, spp) -> wp.vec2   (uses dimensions dim and dim + 1 jointly)
`pixel` is the set's `pixel_key(px, py, width)` (the scanline index unless the set says otherwise).
`spp` is the number of samples the pixel will take, so a stratified set can lay its strata out;
indices past `spp` start a new, independently permuted block of `spp` samples. A render passes it
as the set's `count_word(spp)` (the bare count unless the set packs more into it).
"""
from dataclasses import dataclass

import warp as wp


@wp.func
def linear_pixel_key(px: int, py: int, width: int) -> wp.uint32:
    """The pixel key most sets see: the scanline index (any bijection of pixels would do)."""
    return wp.uint32(py * width + px)


@wp.func
def bare_count(spp: wp.uint32) -> wp.uint32:
    """The count word of a set that needs nothing but spp: spp itself."""
    return spp


@dataclass(frozen=True)
class PointSet:
    name: str
    description: str
    get1d: wp.Function
    get2d: wp.Function
    # True when the set is biased BY DESIGN: some dimension's values are not uniform over pixels and
    # seeds (e.g. `presampled` reuses one fixed table of directions for every pixel and seed, like
    # Cook 1984's pre-computed reflection tables), so an estimator built on it converges to a wrong
    # value. Tests that require unbiasedness or uniformity skip such sets (the per-pixel contract -
    # a pure function of seed, pixel, index, dim - still holds); the unbiasedness test must reject it.
    biased: bool = False
    # The key get1d/get2d receive as `pixel`, from the pixel's (px, py) and the image width: a set
    # whose samples are laid out over pixels (zsobol: a Morton curve, so neighbouring pixels share
    # nets) chooses its own. The image accumulates at the scanline index whatever the key.
    pixel_key: wp.Function = linear_pixel_key
    # The set whose values this one returns in every dimension but the bounce directions (Cook's
    # tables: "stratified"); None for a set of its own. Studies of the pixel dimensions skip such sets.
    same_as_outside_directions: str | None = None
    # What a render passes as `spp`, from the sample count, once per pixel and pass: a set that
    # derives something costly from spp alone (the stratified grid) packs it in; get1d and get2d
    # must give the same values for the word as for the bare count.
    count_word: wp.Function = bare_count
    # Why a draw stays above draw_costs.CHEAP times an independent draw, where it does (work the set
    # cannot make cheap without changing what it is); `drtlab samplers` prints it beside the ratio.
    cost_note: str | None = None
    # A hash of what the set's functions compile from where the package's own code version does not
    # cover it (a plugin's source, a table's points): part of every kernel and run key, so an edited
    # plugin recompiles and re-renders and an unchanged one does not. "" for the built-ins.
    fingerprint: str = ""
