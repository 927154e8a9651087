"""Error metrics of one image against a noisy ground truth, and statistics over repetitions.

Noise floor: with X the estimate, G the ground truth (independent of X) and mu the true image,
E[(X - G)^2] = E[(X - mu)^2] + Var(G). The measured MSE is biased up by the mean per-pixel variance of
the ground truth, `gt_var = mean(stderr^2)`, which we report and subtract (`mse_corrected`).
"""
from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL



def reference_lab(ref: np.ndarray) -> np.ndarray:
    """The reference's CIELAB as the CIEDE2000 kernel computes the images' (so an image equal to
    its reference differs by exactly 0): pass it to `ciede2000` / `batch_metrics` as `ref_lab`."""
    from drtlab.kernels.colour_difference import lab_of
    return lab_of(ref)


def ciede2000(img: np.ndarray, ref: np.ndarray, ref_lab: np.ndarray | None = None) -> float:
    """Mean CIEDE2000 difference of the displayed (clipped to [0, 1]) sRGB images; `ref_lab` is
    `reference_lab(ref)` when the caller compares many images with one reference."""
    from drtlab.kernels.colour_difference import delta_e_2000
    lab_ref = reference_lab(ref) if ref_lab is None else ref_lab
    return float(np.mean(delta_e_2000(np.asarray(img)[None], lab_ref).reshape(-1)))


# FLIP's own luminance weights: HDR-FLIP sets its exposures from the reference's brightest pixel,
# and a reference whose brightest luminance is below float32's epsilon leaves them undefined (the
# library then ends the process). Twice epsilon: a margin for its float32 arithmetic.
_FLIP_LUMINANCE = np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
FLIP_MIN_LUMINANCE = 2 * float(np.finfo(np.float32).eps)


def _flip_evaluator():
    """flip_evaluator, its OpenMP workers told to sleep rather than spin between calls (libgomp reads
    OMP_WAIT_POLICY once, when it loads; a user's setting stands): spinning workers burned 8-11 ms of
    CPU after each 96x72 call, charged to the next render, whose process CPU seconds the cost model
    reads. The value does not depend on the thread count (one, two and three threads: equal bits)."""
    if "flip_evaluator" not in sys.modules:
        user = "OMP_WAIT_POLICY" in os.environ
        os.environ.setdefault("OMP_WAIT_POLICY", "passive")
        try:
            import flip_evaluator  # noqa: F401
        finally:
            if not user:
                del os.environ["OMP_WAIT_POLICY"]
    return sys.modules["flip_evaluator"]


def flip_problem(test: np.ndarray, reference: np.ndarray) -> str | None:
    """Why HDR-FLIP is undefined for this pair (non-finite pixels, a black reference), or None."""
    if not np.isfinite(test).all():
        return "the test image has non-finite pixels"
    if not np.isfinite(reference).all():
        return "the reference has non-finite pixels"
    lum = float(np.max(np.maximum(np.asarray(reference, dtype=np.float32), 0) @ _FLIP_LUMINANCE))
    if lum < FLIP_MIN_LUMINANCE:
        return (f"the reference's brightest pixel has luminance {lum:.3g}, below {FLIP_MIN_LUMINANCE:.3g}: "
                f"HDR-FLIP sets its exposures from it")
    return None


def _flip(test: np.ndarray, reference: np.ndarray) -> tuple[np.ndarray, float]:
    """(HDR-FLIP error map, its mean) of linear-RGB (H, W, 3) images; negative values (a pixel
    filter's negative lobes) count as black, as a display shows them."""
    test, reference = np.asarray(test), np.asarray(reference)
    if test.shape != reference.shape or test.ndim != 3 or test.shape[2] != 3:
        raise ValueError(f"FLIP needs two (H, W, 3) images of one shape, got {test.shape} and {reference.shape}")
    why = flip_problem(test, reference)
    if why is not None:
        raise ValueError(f"FLIP is undefined here: {why}")
    ref32, test32 = (np.ascontiguousarray(np.maximum(a, 0), dtype=np.float32) for a in (reference, test))
    error, mean, _ = _flip_evaluator().evaluate(ref32, test32, "HDR", applyMagma=False)
    return error[..., 0], float(mean)


def flip_map(test: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Per-pixel HDR-FLIP error ((H, W) float32 in [0, 1]) of `test` against `reference`, both
    linear RGB (H, W, 3), at FLIP's default viewing (67 pixels per degree) and ACES tone mapping;
    ValueError where `flip_problem` says it is undefined."""
    return _flip(test, reference)[0]


def flip(test: np.ndarray, reference: np.ndarray) -> float:
    """Mean HDR-FLIP error of `test` against `reference` (see `flip_map`)."""
    return _flip(test, reference)[1]


def image_metrics(img: np.ndarray, gt: np.ndarray, gt_stderr: np.ndarray,
                  gt_lab: np.ndarray | None = None, colour_diff: bool = True, with_flip: bool = False) -> dict:
    """The per-run metrics of one image against a noisy ground truth (see `batch_metrics`); without
    `colour_diff` CIEDE2000 is NaN, without `with_flip` FLIP."""
    img = np.asarray(img, dtype=np.float64)
    if img.shape != np.shape(gt):
        raise ValueError(f"image shape {img.shape} != ground truth shape {np.shape(gt)}")
    return batch_metrics(img[None], gt, gt_stderr, gt_lab, colour_diff, flip_rows=int(with_flip))[0]


def t_quantile(n: int, level: float = CI_LEVEL) -> float:
    """Two-sided Student-t quantile for a mean of n values (scipy.special: far lighter than stats)."""
    from scipy.special import stdtrit
    return float(stdtrit(n - 1, 0.5 + level / 2)) if n > 1 else float("inf")


def mean_ci(values, level: float = CI_LEVEL) -> dict:
    """Mean and Student-t confidence interval over repetitions."""
    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=np.float64)
    n = len(v)
    if n == 0:
        return {"mean": float("nan"), "lo": float("nan"), "hi": float("nan"), "sd": float("nan"), "n": 0}
    m = float(v.mean())
    if n == 1:
        return {"mean": m, "lo": float("nan"), "hi": float("nan"), "sd": float("nan"), "n": 1}
    sd = float(v.std(ddof=1))
    h = t_quantile(n, level) * sd / math.sqrt(n)
    return {"mean": m, "lo": m - h, "hi": m + h, "sd": sd, "n": n}


def cell_bias(n: int, mean: np.ndarray, pixel_variance: float, gt: np.ndarray,
              gt_stderr: np.ndarray, mean_errors, level: float = CI_LEVEL) -> dict:
    """Bias of the estimator from a cell's n repetitions (their per-pixel `mean` image and the mean
    over pixels of their per-pixel sample variance): mean image - GT, as a signed mean with its CI
    and a debiased RMS.

    signed: mean over pixels of (mean image - GT). Its CI is the Student-t interval of the
         repetitions' signed mean errors (`mean_errors`, which carries pixel correlations),
         widened by the uncertainty of the GT's own pixel mean.
    rms: sqrt(mean((mean image - GT)^2) - pixel_var / n - gt_var), clipped at 0: the per-pixel
         bias energy left after removing what the noise alone would give.
    """
    P = mean.size
    b = mean - gt
    se2 = np.square(np.asarray(gt_stderr, dtype=np.float64))
    gvar = float(np.mean(se2))
    ci = mean_ci(mean_errors, level)
    signed = float(np.mean(b))
    z = t_quantile(10 ** 6, level)
    h_gt = z * math.sqrt(float(np.sum(se2))) / P
    h_rep = (ci["hi"] - ci["mean"]) if ci["n"] > 1 else float("nan")
    h = math.sqrt(h_rep ** 2 + h_gt ** 2)
    ms = float(np.mean(np.square(b))) - pixel_variance / n - gvar
    return {"signed": signed, "lo": signed - h, "hi": signed + h,
            "rms": math.sqrt(max(ms, 0.0)), "pixel_variance": pixel_variance}


def compile_metric_kernels() -> float:
    """Score a 1-pixel image once, so that the Warp kernels of the metrics (error sums, CIEDE2000,
    the reference's Lab) are compiled or loaded; returns the seconds it took."""
    t0 = time.perf_counter()
    one = np.full((1, 1, 3), 0.5)
    batch_metrics(one[None], one, np.zeros_like(one))
    return time.perf_counter() - t0


def batch_metrics(images: np.ndarray, gt: np.ndarray, gt_stderr: np.ndarray,
                  gt_lab: np.ndarray | None = None, colour_diff: bool = True,
                  colour_rows: int | None = None, flip_rows: int = 0) -> list[dict]:
    """The metrics of each image of an (R, H, W, 3) batch against the reference `gt` with per-pixel
    standard error `gt_stderr`, from one pass over the pixels (`kernels/error_sums.py`), whose sums
    depend on each image alone: an image scores the same in any batch, bit for bit. `gt_lab` is
    `reference_lab(gt)` when the caller scores many batches against one reference. CIEDE2000 (NaN
    where not computed) for the first `colour_rows` images (default: all; none without
    `colour_diff`); HDR-FLIP against `gt` (NaN where not computed or undefined: `flip_problem`) for
    the first `flip_rows` (each costs tens of milliseconds: none by default)."""
    return score_batch(images, gt, gt_stderr, gt_lab, colour_diff, colour_rows, flip_rows)[0]


def _first_rows(limit: int | None, count: int) -> int:
    """How many of a batch's first rows a per-run limit (None: all) scores."""
    return count if limit is None else max(0, min(int(limit), count))


def score_batch(images: np.ndarray, gt: np.ndarray, gt_stderr: np.ndarray,
                gt_lab: np.ndarray | None = None, colour_diff: bool = True,
                colour_rows: int | None = None, flip_rows: int = 0):
    """(`batch_metrics`' rows, the batch's `error_sums.BatchSums`: its moments come from the same
    pass over the pixels)."""
    from drtlab.kernels.error_sums import REL_EPS, SUMS, batch_sums
    x = np.asarray(images, dtype=np.float64)
    gt = np.asarray(gt, dtype=np.float64)
    if x.shape[1:] != gt.shape:
        raise ValueError(f"image shape {x.shape[1:]} != ground truth shape {gt.shape}")
    se2 = np.square(np.asarray(gt_stderr, dtype=np.float64))
    gvar = float(np.mean(se2))
    relmse_gt = float(np.mean(se2 / (np.square(gt) + REL_EPS)))
    k = _first_rows(colour_rows, x.shape[0]) if colour_diff else 0
    flips = [flip(x[r], gt) if flip_problem(x[r], gt) is None else float("nan")
             for r in range(_first_rows(flip_rows, x.shape[0]))]
    lab_ref = (reference_lab(gt) if gt_lab is None else gt_lab) if k else None
    bs = batch_sums(x, gt, lab_ref, REL_EPS, colour_rows=k)
    sums = dict(zip(SUMS, bs.sums.T))
    n = gt.size
    out = []
    for r in range(x.shape[0]):
        mse = float(sums["squared"][r]) / n
        relmse = float(sums["weighted_squared"][r]) / n
        out.append({"mse": mse, "rmse": math.sqrt(mse), "gt_var": gvar, "mse_corrected": mse - gvar,
                    "rmse_corrected": math.sqrt(max(mse - gvar, 0.0)),
                    "relmse": relmse, "relmse_corrected": relmse - relmse_gt,
                    "mae": float(sums["absolute"][r]) / n, "mean_error": float(sums["error"][r]) / n,
                    "finite": bool(sums["non_finite"][r] == 0),
                    "ciede2000": float(sums["ciede2000"][r]) / (n // 3) if r < k else float("nan"),
                    "flip": flips[r] if r < len(flips) else float("nan")})
    return out, bs
