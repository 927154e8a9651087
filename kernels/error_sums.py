"""Per-repetition error sums of a batch of images against one reference, in one pass over the pixels:
what every per-run metric of a study (MSE, relMSE, MAE, mean error, finiteness, CIEDE2000) is a mean
of. Scoring a batch with numpy took one temporary per term and, with the colour difference, as long
as rendering a 1-spp batch; here each pixel is read once.

Each row is cut into fixed chunks of CHUNK_PIXELS, each chunk summed in pixel order in float64, and
the chunks added in order: the sums depend on the images alone, not on the thread count, so a batch's
row equals the same image scored alone bit for bit.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from drtlab.kernels.colour_difference import ciede2000, displayed_lab, srgb_constants
from drtlab.warp_runtime import warp as _wp

# The sums of one row, in this order (columns of `error_sums`' result).
SUMS = ("error", "squared", "weighted_squared", "absolute", "non_finite", "ciede2000")
CHUNK_PIXELS = 4096

F = wp.float64


@wp.func
def _non_finite(x: wp.vec3d) -> wp.float64:
    if wp.isfinite(x[0]) and wp.isfinite(x[1]) and wp.isfinite(x[2]):
        return F(0.0)
    return F(1.0)


@wp.kernel(enable_backward=False)
def _error_sums_kernel(images: wp.array2d(dtype=wp.vec3d), ref: wp.array(dtype=wp.vec3d),
                       ref_lab: wp.array(dtype=wp.vec3d), rel_eps: wp.float64, m: wp.mat33d,
                       white: wp.vec3d, colour: int, chunks: int, item0: int,
                       out: wp.array3d(dtype=wp.float64)):
    item = item0 + wp.tid()
    r = item // chunks
    c = item - r * chunks
    pixels = ref.shape[0]
    start = c * wp.static(CHUNK_PIXELS)
    end = wp.min(start + wp.static(CHUNK_PIXELS), pixels)
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
        if colour != 0:
            s_de += ciede2000(displayed_lab(x, m, white), ref_lab[p])
    out[r, c, 0] = s_err
    out[r, c, 1] = s_sq
    out[r, c, 2] = s_wsq
    out[r, c, 3] = s_abs
    out[r, c, 4] = s_bad
    out[r, c, 5] = s_de


def _cpu_threads() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                       # no affinity call (macOS, Windows)
        return os.cpu_count() or 1


def error_sums(images: np.ndarray, ref: np.ndarray, ref_lab: np.ndarray | None, rel_eps: float,
               threads: int | None = None) -> np.ndarray:
    """(R, len(SUMS)) float64 sums over the pixels (and channels, for the first five) of each of the
    (R, H, W, 3) `images` against `ref` (H, W, 3): error, its square, its square over (ref^2 +
    rel_eps), its absolute value, non-finite pixels, and with `ref_lab` (the reference's CIELAB as
    `colour_difference.lab_of` gives it) the CIEDE2000 of each displayed pixel (else 0).
    The rows' chunks are shared out over `threads` CPU launches (each releases the GIL)."""
    _wp()
    x = np.ascontiguousarray(images, dtype=np.float64)
    R = x.shape[0]
    P = int(np.prod(x.shape[1:-1]))
    chunks = -(-P // CHUNK_PIXELS)
    items = R * chunks
    m, white = srgb_constants() if ref_lab is not None else (wp.mat33d(), wp.vec3d())
    src = wp.array(x.reshape(R, P, 3), dtype=wp.vec3d, device="cpu", copy=False)
    g = wp.array(np.ascontiguousarray(ref, dtype=np.float64).reshape(P, 3), dtype=wp.vec3d, device="cpu")
    lab = g if ref_lab is None else wp.array(
        np.ascontiguousarray(ref_lab, dtype=np.float64).reshape(P, 3), dtype=wp.vec3d, device="cpu")
    out = wp.zeros((R, chunks, len(SUMS)), dtype=wp.float64, device="cpu")
    n = max(1, min(_cpu_threads() if threads is None else threads, items))
    bounds = [items * i // n for i in range(n + 1)]

    def run(i):
        wp.launch(_error_sums_kernel, dim=bounds[i + 1] - bounds[i],
                  inputs=[src, g, lab, rel_eps, m, white, int(ref_lab is not None), chunks, bounds[i], out],
                  device="cpu")

    if n == 1:
        run(0)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(run, range(n)))
    per_chunk = out.numpy()
    total = per_chunk[:, 0].copy()
    for c in range(1, chunks):                   # chunks added in order: thread-count independent
        total += per_chunk[:, c]
    return total
