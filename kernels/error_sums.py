"""One pass over a batch of images against one reference: the per-repetition error sums that every
per-run metric of a study (MSE, relMSE, MAE, mean error, finiteness, CIEDE2000) is a mean of, and
the batch's per-pixel moments (mean image, summed squared deviations: what a cell keeps). Scoring a
batch with numpy took one temporary per term, the moments three more passes, and with the colour
difference as long as rendering a 1-spp batch; here each pixel of each image is read once.

The pixels are cut into fixed chunks of CHUNK_PIXELS. A chunk's sums of repetition r are summed in
pixel order in float64 and the chunks added in order, so they depend on image r alone: a batch's row
equals the same image scored alone, bit for bit, whatever the thread count. A chunk's moments follow
its pixels through the batch in repetition order (Welford's update), so they depend on the batch
alone.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import warp as wp

from drtlab.kernels.colour_difference import ciede2000, displayed_lab, srgb_constants
from drtlab.kernels.launch_pool import cpu_threads, launch_pool
from drtlab.warp_runtime import warp as _wp

# The sums of one row, in this order (columns of `BatchSums.sums`).
REL_EPS = 1e-2          # relMSE = (x - y)^2 / (y^2 + eps), as in Rousselle et al. 2011
SUMS = ("error", "squared", "weighted_squared", "absolute", "non_finite", "ciede2000")
# Small enough that a 96x72 batch splits over the cores and a chunk's running moments stay in cache.
CHUNK_PIXELS = 512

F = wp.float64


class BatchSums(NamedTuple):
    sums: np.ndarray            # (R, len(SUMS)) float64
    mean: np.ndarray            # (H, W, 3) float64: the repetitions' per-pixel mean
    m2: float                   # sum over pixels, channels and repetitions of (x - mean)^2


@wp.func
def _non_finite(x: wp.vec3d) -> wp.float64:
    if wp.isfinite(x[0]) and wp.isfinite(x[1]) and wp.isfinite(x[2]):
        return F(0.0)
    return F(1.0)


@wp.kernel(enable_backward=False)
def _batch_sums_kernel(images: wp.array2d(dtype=wp.vec3d), ref: wp.array(dtype=wp.vec3d),
                       ref_lab: wp.array(dtype=wp.vec3d), rel_eps: wp.float64, m: wp.mat33d,
                       white: wp.vec3d, colour_rows: int, chunk0: int,
                       out: wp.array3d(dtype=wp.float64), mean: wp.array(dtype=wp.vec3d),
                       dev2: wp.array(dtype=wp.vec3d), m2: wp.array(dtype=wp.float64)):
    c = chunk0 + wp.tid()
    start = c * wp.static(CHUNK_PIXELS)
    end = wp.min(start + wp.static(CHUNK_PIXELS), ref.shape[0])
    for p in range(start, end):
        mean[p] = wp.vec3d()
        dev2[p] = wp.vec3d()
    for r in range(images.shape[0]):
        inv = F(1.0) / F(r + 1)
        s_err = F(0.0)
        s_sq = F(0.0)
        s_wsq = F(0.0)
        s_abs = F(0.0)
        s_bad = F(0.0)
        s_de = F(0.0)
        for p in range(start, end):
            x = images[r, p]
            g = ref[p]
            for k in range(3):
                d = x[k] - g[k]
                d2 = d * d
                s_err += d
                s_sq += d2
                s_wsq += d2 / (g[k] * g[k] + rel_eps)
                s_abs += wp.abs(d)
            s_bad += _non_finite(x)
            if r < colour_rows:
                s_de += ciede2000(displayed_lab(x, m, white), ref_lab[p])
            delta = x - mean[p]
            mu = mean[p] + delta * inv
            mean[p] = mu
            dev2[p] = dev2[p] + wp.cw_mul(delta, x - mu)
        out[r, c, 0] = s_err
        out[r, c, 1] = s_sq
        out[r, c, 2] = s_wsq
        out[r, c, 3] = s_abs
        out[r, c, 4] = s_bad
        out[r, c, 5] = s_de
    s = F(0.0)
    for p in range(start, end):
        v = dev2[p]
        s += v[0] + v[1] + v[2]
    m2[c] = s


def batch_sums(images: np.ndarray, ref: np.ndarray, ref_lab: np.ndarray | None, rel_eps: float,
               colour_rows: int | None = None, threads: int | None = None) -> BatchSums:
    """The sums of each of the (R, H, W, 3) `images` against `ref` (H, W, 3), over the pixels (and
    channels, for the first five): error, its square, its square over (ref^2 + rel_eps), its
    absolute value, non-finite pixels, and for the first `colour_rows` images (default: all; none
    without `ref_lab`, the reference's CIELAB as `colour_difference.lab_of` gives it) the CIEDE2000
    of each displayed pixel (else 0); and the batch's moments. The chunks are shared out over
    `threads` CPU launches (each releases the GIL)."""
    _wp()
    x = np.ascontiguousarray(images, dtype=np.float64)
    R = x.shape[0]
    P = int(np.prod(x.shape[1:-1]))
    chunks = -(-P // CHUNK_PIXELS)
    k = 0 if ref_lab is None else R if colour_rows is None else max(0, min(int(colour_rows), R))
    m, white = srgb_constants() if k else (wp.mat33d(), wp.vec3d())
    src = wp.array(x.reshape(R, P, 3), dtype=wp.vec3d, device="cpu", copy=False)
    g = wp.array(np.ascontiguousarray(ref, dtype=np.float64).reshape(P, 3), dtype=wp.vec3d, device="cpu")
    lab = g if not k else wp.array(
        np.ascontiguousarray(ref_lab, dtype=np.float64).reshape(P, 3), dtype=wp.vec3d, device="cpu")
    out = wp.empty((R, chunks, len(SUMS)), dtype=wp.float64, device="cpu")
    mean = wp.empty(P, dtype=wp.vec3d, device="cpu")
    dev2 = wp.empty(P, dtype=wp.vec3d, device="cpu")
    m2 = wp.empty(chunks, dtype=wp.float64, device="cpu")
    n = max(1, min(cpu_threads() if threads is None else threads, chunks))
    bounds = [chunks * i // n for i in range(n + 1)]

    def run(i):
        wp.launch(_batch_sums_kernel, dim=bounds[i + 1] - bounds[i],
                  inputs=[src, g, lab, rel_eps, m, white, k, bounds[i], out, mean, dev2, m2],
                  device="cpu")

    if n == 1:
        run(0)
    else:
        list(launch_pool(n).map(run, range(n)))
    per_chunk = out.numpy()
    total = per_chunk[:, 0].copy()
    for c in range(1, chunks):                   # chunks added in order: thread-count independent
        total += per_chunk[:, c]
    dev = 0.0
    for v in m2.numpy():
        dev += float(v)
    return BatchSums(total, mean.numpy().reshape(x.shape[1:]), dev)
