"""Confidence intervals for means of positive quantities (MSE, relMSE, and RMSE = sqrt(mean MSE)) that
stay positive, and the number of repetitions a stated precision of such a mean needs.

The Student-t interval m +- t s / sqrt(n) of `metrics.mean_ci` is symmetric: on the right-skewed
per-run MSEs of heavy-tailed cells (most runs small, a rare one huge) its lower end goes below zero
(`RMSE 0.268 [0, 0.52]`, `relMSE [-4.95, 9.09]`) and it undercovers, because the true mean usually lies
above the sample mean. Here the default interval is the t-interval on the log scale of the mean
(delta method: sd(log m) ~ cv / sqrt(n)),

    [m exp(-h), m exp(+h)],   h = t_{n-1} * (s / m) / sqrt(n),

positive by construction and longer upwards than downwards. `method="bca"` uses scipy's BCa bootstrap
instead (fixed seed). Measured on the synthetic laws of `tests/experiments/stats/test_intervals.py` (1000 trials each,
nominal 0.95): log-t covers 0.94-0.96 for the MSE of Gaussian pixel errors, of pixels with a rare bright
sample and of a chi-square(4) law with 5 runs, and 0.93 for a log-normal (sigma 0.5) with 8; the
plain t-interval reaches below zero in 23-42% of the skewed cells and covers 0.92-0.93; the BCa
bootstrap undercovers with few runs (0.74-0.89 for n = 3-8; 0.92 for n = 20), as it cannot see a tail
the sample lacks. Very skewed laws (log-normal sigma >= 0.75, chi-square(1)) undercover with every
method at n <= 8 (log-t about 0.9); `repetitions_for_precision` says how many runs the cell needs.

A mean at or below zero (a noise-floor-corrected MSE), or a value below -mean (not a small correction
of a positive quantity), has no log scale: its interval is [floor, max(floor, t upper bound)]. Every lower end is at least `floor` > 0, so error bars stay on a
log axis; `clipped` says when a bound was raised to it.
"""
from __future__ import annotations

import math
import sys
import warnings

import numpy as np
from scipy import stats

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL

METHODS = ("log-t", "bca")
FLOOR_FRACTION = 1e-3      # default floor: this fraction of the mean (or of the largest |value|)


def _clean(values) -> np.ndarray:
    v = np.asarray([x for x in np.ravel(np.asarray(values, dtype=np.float64)) if math.isfinite(x)])
    return v.astype(np.float64)


def _default_floor(v: np.ndarray, mean: float) -> float:
    scale = mean if mean > 0 else (float(np.max(np.abs(v))) if v.size else 0.0)
    return max(FLOOR_FRACTION * scale, float(np.finfo(np.float64).tiny))     # > 0 even for denormals


def _bca(v: np.ndarray, level: float, n_resamples: int, seed: int) -> tuple[float, float]:
    """BCa interval of the mean; NaN where it is undefined (e.g. all values equal)."""
    if np.all(v == v[0]):
        return float("nan"), float("nan")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # degenerate resamples: NaN ends, handled by caller
        res = stats.bootstrap((v,), np.mean, confidence_level=level, method="BCa", vectorized=True,
                              n_resamples=n_resamples, rng=np.random.default_rng(seed))
    return float(res.confidence_interval.low), float(res.confidence_interval.high)


def positive_mean_ci(values, level: float = CI_LEVEL, *, method: str = "log-t", floor: float | None = None,
                     n_resamples: int = 4999, seed: int = 0) -> dict:
    """Mean of per-run values (>= 0 in expectation; slightly negative ones allowed) with a confidence
    interval whose ends are never below `floor` > 0.

    Returns `metrics.mean_ci`'s keys (mean, lo, hi, sd, n) plus `method` (the one used: "t-upper"
    when there is no log scale, i.e. the mean is <= 0 or a value is below -mean; "log-t" also when
    the bootstrap is degenerate), `floor` and `clipped`. The mean is the plain sample mean (it may be
    <= 0 for a noise-floor-corrected MSE); lo and hi are NaN for fewer than 2 finite values. `floor`
    defaults to 1e-3 x the mean (1e-3 x the largest |value| when the mean is <= 0).
    """
    if method not in METHODS:
        raise ValueError(f"method {method!r}: expected one of {METHODS}")
    v = _clean(values)
    n = int(v.size)
    nan = float("nan")
    mean = float(v.mean()) if n else nan
    sd = float(v.std(ddof=1)) if n > 1 else nan
    out = {"mean": mean, "lo": nan, "hi": nan, "sd": sd, "n": n, "method": method,
           "floor": nan, "clipped": False}
    if n < 2:
        return out
    floor = float(floor) if floor is not None and floor > 0 else _default_floor(v, mean)
    t = float(stats.t.ppf(0.5 + level / 2, n - 1))
    lo = hi = nan
    if mean <= 0 or float(v.min()) < -mean:
        # No log scale: the mean is not that of a positive quantity with a small correction.
        # Only the upper end is informative.
        method, hi = "t-upper", mean + t * sd / math.sqrt(n)
    elif method == "bca":
        lo, hi = _bca(v, level, n_resamples, seed)
    if not (math.isfinite(lo) and math.isfinite(hi)) and method != "t-upper":
        method = "log-t"                             # also the fallback of a degenerate bootstrap
        h = min(t * sd / mean / math.sqrt(n), 700.0)
        lo, hi = mean * math.exp(-h), min(mean * math.exp(h), sys.float_info.max)
    clipped = not (lo >= floor and hi >= floor)            # NaN lo (t-upper) counts as clipped
    out.update({"lo": max(lo, floor) if math.isfinite(lo) else floor, "hi": max(hi, floor),
                "floor": floor, "clipped": bool(clipped), "method": method})
    return out


def rmse_ci(mse_values, level: float = CI_LEVEL, **kwargs) -> dict:
    """RMSE = sqrt(mean MSE) over runs, with the square roots of `positive_mean_ci`'s MSE interval
    ends as its interval (a monotone map keeps the coverage). `mse` holds the MSE interval."""
    ci = positive_mean_ci(mse_values, level, **kwargs)
    root = lambda x: math.sqrt(x) if math.isfinite(x) else float("nan")
    return {"mean": math.sqrt(max(ci["mean"], 0.0)) if math.isfinite(ci["mean"]) else float("nan"),
            "lo": root(ci["lo"]), "hi": root(ci["hi"]), "n": ci["n"], "method": ci["method"],
            "clipped": ci["clipped"], "mse": ci}


def repetitions_for_precision(values, rel_halfwidth: float = 0.1, level: float = CI_LEVEL,
                              max_repetitions: int = 10 ** 9) -> dict:
    """How many repetitions would bring the relative half-width of the mean's interval to
    `rel_halfwidth`: the smallest n with t_{n-1} * cv / sqrt(n) <= rel_halfwidth, cv = s / mean the
    sample's coefficient of variation (n >= 2).

    Returns `repetitions` (None when the mean is <= 0 or fewer than 2 values are finite; capped at
    `max_repetitions`), `cv`, `n` (repetitions now), `current_rel_halfwidth` and `enough`. A heavy-
    tailed sample usually underestimates its cv (its rare huge values are missing), so `repetitions`
    is then a lower bound.
    """
    if not rel_halfwidth > 0:
        raise ValueError("rel_halfwidth must be > 0")
    v = _clean(values)
    n = int(v.size)
    out: dict = {"repetitions": None, "cv": float("nan"), "n": n, "rel_halfwidth": rel_halfwidth,
                 "level": level, "current_rel_halfwidth": float("nan"), "enough": False}
    mean = float(v.mean()) if n else float("nan")
    if n < 2 or not mean > 0:
        out["reason"] = "fewer than 2 values" if n < 2 else "mean <= 0"
        return out
    cv = float(v.std(ddof=1)) / mean

    def half(k: int) -> float:
        return float(stats.t.ppf(0.5 + level / 2, k - 1)) * cv / math.sqrt(k)

    # half(k) decreases with k, and t > z puts the answer at or above the normal-theory count:
    # double up from there until it is reached, then bisect down to the smallest such k.
    z = float(stats.norm.ppf(0.5 + level / 2))
    lo = hi = min(max(2, math.ceil((z * cv / rel_halfwidth) ** 2)), max_repetitions)
    while hi < max_repetitions and half(hi) > rel_halfwidth:
        lo, hi = hi, min(2 * hi, max_repetitions)
    while lo < hi:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if half(mid) <= rel_halfwidth else (mid + 1, hi)
    k = hi
    out.update({"repetitions": int(k), "cv": cv, "current_rel_halfwidth": half(n),
                "enough": bool(half(n) <= rel_halfwidth)})
    return out
