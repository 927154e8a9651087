"""Kernel factory: one compiled render kernel per scene feature set.

`build_kernel(features, pointset, strategy)` returns a Warp kernel in which everything the scene does
not use (material kinds, light kinds, shape kinds, roulette) is removed at code generation by
`wp.static`. The integrator (`features.integrator`: a built-in of kernels/integrators/ or a
plugin's) is built by its `make(api)` from the variant's estimator API (kernels/integrators/api.py)
and called once per camera sample. Four features cost only a branch per sample, hit or shape test and
are runtime switches instead (a thin lens: aperture > 0; motion: SceneData.moving; checker
textures: per material; a background: drt's last segment), so that scenes differing only in them
share one compiled variant (`Features.code_key`): half the cold compiles of a study.

The kernel renders `count` samples (indices index0 ... index0 + count - 1) of every pixel of one tile,
for each seed of a batch (`sums.seeds`), and adds their float64 sum to `sums.total` (and, with `Features.moments`, the sum of their squares
to `sums.squares`; otherwise that is never touched). A sample's random numbers come only from the
point set keyed by (seed, pixel, sample index, dimension), so tiles, threads and launch order cannot
change the image.
Tracers are loops with a throughput weight (Warp kernels cannot recurse); radiance is traced in
float32 and summed per pixel in float64.
"""
from __future__ import annotations

import warp as wp

from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import grid_columns
from drtlab.estimators.strategies import Strategy
from drtlab.kernels.camera import grid_ray_dir
from drtlab.kernels.device_scene import SceneData
from drtlab.estimators import dimensions as dims
from drtlab.kernels.features import REPEAT_CAMERA, Features, grown_margin
from drtlab.kernels.integrators import integrator_factory
from drtlab.kernels.integrators.api import make_api


@wp.struct
class PixelSums:
    """The kernel's per-repetition seeds and its outputs, per repetition and pixel (repetition r's
    pixel p at r * width * height + p). In a struct rather than as array arguments: Warp compiles a
    kernel whose arguments include only 1D arrays twice (once for unit strides), which doubles the
    compile time of these large kernels for no measurable gain."""
    seeds: wp.array(dtype=wp.uint32)
    total: wp.array(dtype=wp.vec3d)
    squares: wp.array(dtype=wp.vec3d)
    # Splatting only (else one element each): this pass's samples of every pixel of the image grown
    # by the filter's margin, their radiance and the filter's profile at their offsets from the
    # 2 margin + 1 columns' and rows' centres around them (kernels/splat.py gathers them), and each
    # pixel's sum of filter weights.
    splat_f: wp.array(dtype=float)
    splat_L: wp.array(dtype=wp.vec3)
    weight: wp.array(dtype=wp.float64)


def build_kernel(f: Features, pointset: PointSet, strategy: Strategy):
    WHITTED = f.whitted
    make, own_dimensions = integrator_factory(f.integrator)
    api = make_api(f, pointset, strategy, own_dimensions)
    pixel_filter = api.pixel_filter
    sample_ray = api.camera_ray
    FIS = pixel_filter is not None and not f.splat
    SPLAT = pixel_filter is not None and f.splat
    K = 2 * f.filter_def.margin + 1 if SPLAT else 1
    # The grid's growth beyond the image: none when the filter is cut at the film's edge.
    MARGIN = grown_margin(f)
    reach = pixel_filter.reach if SPLAT else None
    get2d = pointset.get2d
    trace = make(api)
    pixel_key = pointset.pixel_key
    count_word = pointset.count_word
    TWICE_CAMERA = REPEAT_CAMERA in f.faults

    @wp.kernel(enable_backward=False, module="unique")
    def render_tile(sd: SceneData, index0: int, count: int, spp: int,
                    x0: int, y0: int, tile_w: int, tile_h: int, sums: PixelSums):
        # One thread per (repetition, pixel of the tile): a batch of seeds fills a launch, and each
        # repetition sums exactly the samples, in the order, that a render of its seed alone sums.
        tid = wp.tid()
        rep = tid / (tile_w * tile_h)
        local = tid - rep * tile_w * tile_h
        px = x0 + local % tile_w
        py = y0 + local / tile_w
        # Splatting renders the image grown by the filter's margin (tiles of the grown grid, pixels
        # keyed in it): the samples of pixels outside the image reach the pixels at its border
        # (unless the filter is cut at the film's edge: then no sample lies beyond it).
        grown_w = sd.width + 2 * wp.static(MARGIN)
        grown_h = sd.height + 2 * wp.static(MARGIN)
        if px >= grown_w or py >= grown_h:
            return
        seed = sums.seeds[rep]
        pixel = rep * grown_w * grown_h + py * grown_w + px
        pix = pixel_key(px, py, grown_w)
        if wp.static(SPLAT):
            px = px - wp.static(MARGIN)
            py = py - wp.static(MARGIN)
        uspp = wp.uint32(spp)
        # What the point set derives from spp alone (the stratified grid), once per pixel and pass.
        word = count_word(uspp)
        total = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
        total2 = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
        nx = int(1)
        if wp.static(WHITTED):
            # Whitted samples the same nx x ny sub-pixel grid as the stratified point set.
            nx = int(grid_columns(uspp))
        for k in range(count):
            idx = wp.uint32(index0 + k)
            if wp.static(WHITTED):
                d = grid_ray_dir(sd, px, py, (index0 + k) % spp, nx, spp / nx)
                Ls = trace(sd, seed, pix, idx, word, sd.camera.position, d, 0.0)
            else:
                ray = sample_ray(sd, seed, pix, idx, word, px, py)
                Ls = trace(sd, seed, pix, idx, word, ray.o, ray.d, ray.dt)
                if wp.static(TWICE_CAMERA):     # the profile's probe (features.REPEATS)
                    Ls += 1.0e-30 * sample_ray(sd, seed, pix, idx + wp.uint32(1), word, px, py).d
                if wp.static(FIS):
                    Ls = Ls * ray.w
                if wp.static(SPLAT):
                    # The pixel position again (a pure function of the sample's key) -> the filter's
                    # profile at its offsets from the neighbour pixels' centres, kept for the gather.
                    u = get2d(seed, pix, idx, wp.uint32(wp.static(dims.PIXEL)), word)
                    fx = reach(u[0])
                    fy = reach(u[1])
                    base = (pixel * count + k) * wp.static(2 * K)
                    for i in range(wp.static(K)):
                        sums.splat_f[base + i] = fx[i]
                        sums.splat_f[base + wp.static(K) + i] = fy[i]
                    sums.splat_L[pixel * count + k] = Ls
            x = wp.vec3d(wp.float64(Ls[0]), wp.float64(Ls[1]), wp.float64(Ls[2]))
            total += x
            if wp.static(f.moments):
                total2 += wp.cw_mul(x, x)
        if wp.static(SPLAT):
            return
        sums.total[pixel] = sums.total[pixel] + total
        if wp.static(f.moments):
            sums.squares[pixel] = sums.squares[pixel] + total2

    return render_tile
