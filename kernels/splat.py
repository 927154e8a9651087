"""Splatting with weighted accumulation, as a gather: deterministic and independent of tiles.

The render kernel (kernels/render_kernel.py, Features.splat) traces each pass's samples of every
pixel of the image grown by the filter's margin and stores each sample's radiance and the filter's
separable profile at its offsets from the 2 margin + 1 neighbour columns' and rows' centres (2K
values where the gather would evaluate K^2 products of two); after the pass, `make_gather(filter)`'s kernel has each image pixel q read the
samples of the (2 margin + 1)^2 pixels around it, in a fixed order (rows, columns, sample index),
and add sum f(x - c_q) L and sum f(x - c_q) to its float64 sums: no pixel writes another's sums, so
threads and tiles cannot change the image. The pixel is the ratio of the two sums (kernels/render.py).

What it estimates: the pixel's samples are uniform in its own square, so over the grown image the
samples cover the filter's support uniformly and both sums, divided by the samples per pixel, are
unbiased for integral f L and integral f: their ratio is consistent for the filter-weighted pixel
(kernels/filters.py), with a bias of order 1/spp (a ratio of two noisy sums). With the filter cut
at the film's edge (Features.filter_clip, Mitsuba's films without sample_border) the image is not
grown: a border pixel's neighbours beyond the image have no samples, so both sums cover only the
film and the ratio is consistent for the cut filter's pixel, exactly Mitsuba's ImageBlock estimate.
"""
from __future__ import annotations

import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import Features, grown_margin
from drtlab.kernels.render_kernel import PixelSums


def make_gather(f: Features):
    """The gather kernel of `f.filter` (it depends on nothing else of the scene or the sampler)."""
    MARGIN = f.filter_def.margin
    K = 2 * MARGIN + 1
    GROW = grown_margin(f)

    @wp.kernel(enable_backward=False, module="unique")
    def gather_tile(sd: SceneData, count: int, x0: int, y0: int, tile_w: int, tile_h: int,
                    sums: PixelSums):
        tid = wp.tid()
        rep = tid / (tile_w * tile_h)
        local = tid - rep * tile_w * tile_h
        qx = x0 + local % tile_w
        qy = y0 + local / tile_w
        if qx >= sd.width or qy >= sd.height:
            return
        grown_w = sd.width + 2 * wp.static(GROW)
        grown_h = sd.height + 2 * wp.static(GROW)
        fl = wp.vec3d(wp.float64(0.0), wp.float64(0.0), wp.float64(0.0))
        fw = wp.float64(0.0)
        for j in range(wp.static(K)):
            for i in range(wp.static(K)):
                # Source pixel q + (i - margin, j - margin), at (qx + i, qy + j) in the grown grid;
                # its samples' profile values at q's column and row are their i-th and j-th.
                sx = qx + i - wp.static(MARGIN - GROW)
                sy = qy + j - wp.static(MARGIN - GROW)
                n = count
                if wp.static(GROW < MARGIN):
                    # Cut at the film's edge: the grid is the image, and beyond it are no samples.
                    if sx < 0 or sy < 0 or sx >= grown_w or sy >= grown_h:
                        n = 0
                        sx = 0
                        sy = 0
                src = (rep * grown_h + sy) * grown_w + sx
                for k in range(n):
                    s = src * count + k
                    w = sums.splat_f[s * wp.static(2 * K) + i] * sums.splat_f[s * wp.static(2 * K) + wp.static(K) + j]
                    if w != 0.0:
                        L = sums.splat_L[s]
                        fl += wp.vec3d(wp.float64(w * L[0]), wp.float64(w * L[1]), wp.float64(w * L[2]))
                        fw += wp.float64(w)
        pixel = rep * sd.width * sd.height + qy * sd.width + qx
        sums.total[pixel] = sums.total[pixel] + fl
        sums.weight[pixel] = sums.weight[pixel] + fw

    return gather_tile
