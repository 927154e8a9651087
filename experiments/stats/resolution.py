"""When a cell's mean error is resolved: its interval can be trusted to cover, so a comparison built
on it may make a claim.

No interval of a mean covers at its stated level for every law (Bahadur & Savage 1956): a sample
that has not yet met a rare, huge value looks precise. The log-t interval (`intervals.positive_mean_ci`)
covers 0.94-0.96 for light-tailed and gamma-like per-run errors at any number of runs, but
polynomial tails (Pareto alpha = 2.5: 0.81 with 5 runs, 0.92 with 320; alpha = 4: 0.84 with 5) and
log-normal sigma >= 1 undercover whatever the run count a study can afford. So a cell is *not
resolved* when

* it has fewer than `MIN_RUNS` runs, or its mean is not positive (below the noise floor);
* its largest run carries more than `MAX_SHARE` of its summed error, or dropping that run moves the
  mean below the interval's lower end (the interval would not survive it);
* its sampler's errors have a heavy upper tail: the generalized Pareto shape xi of the largest
  `TAIL_FRACTION` = 40% of the sampler's runs, pooled over its cells as multiples of their cell's
  mean, is above `XI_MAX` = 0.05. A Pareto (Lomax) law has its shape at every threshold, so a low
  threshold only adds exceedances, while a light tail's fitted shape falls further below 0 the lower
  it starts: on a ladder of 320/80/20/5 runs (600 simulated ladders each) the shape exceeds 0.05 for
  0% of gamma laws of CV 0.05 and 0.3, 98% of log-normal sigma = 1 and 99.8% of Pareto alpha = 2.5;
  with the top 20% and a threshold of 0.1, 5% of Pareto ladders escaped (their resolved cells
  covered 0.86) and 0.5% of CV 0.3 were flagged. On the default study the light-tailed samplers'
  shapes lie between -0.43 and -0.07, the heavy ones' (uniform and stratified on glossy and
  drt-showcase) between 0.98 and 2.2. The shape needs `TAIL_MIN_RUNS` pooled runs; with fewer the
  tail is not assessed and the report says so;
* or its sampler's runs scatter about the fitted convergence law by more than `ERRATIC_SIGMA` in log
  RMSE (`slopes.fit_rmse_slope`'s sigma: a factor 1.28): log-normal-like errors, whose tail shape
  can look light on a few hundred runs (log-normal sigma = 1 escapes the shape test on 17% of
  ladders, and its log-t intervals then cover 0.87) but whose scatter cannot.

`tests/experiments/stats/test_resolution.py` and `drtlab audit-intervals` measure what this buys.
"""
from __future__ import annotations

import math
import warnings

import numpy as np

MIN_RUNS = 3
MAX_SHARE = 0.5
XI_MAX = 0.05
TAIL_FRACTION = 0.4
TAIL_MIN_EXCEEDANCES = 10
TAIL_MIN_RUNS = 50
ERRATIC_SIGMA = 0.25        # sd of a run's log RMSE about the fitted line: pixel noise gives ~0.05


def tail_shape(cells) -> dict:
    """Generalized Pareto shape of the pooled upper tail of per-run errors: `cells` is a list of
    arrays (one per cell), each divided by its own mean before pooling. Returns `xi` (NaN when not
    assessed), `runs` (pooled), `exceedances`, `heavy` (xi > XI_MAX) and `assessed`."""
    from scipy import stats
    rel = [np.asarray(v, dtype=np.float64) for v in cells]
    rel = [v[np.isfinite(v)] for v in rel]
    rel = [v / v.mean() for v in rel if v.size >= 2 and v.mean() > 0]
    x = np.sort(np.concatenate(rel)) if rel else np.zeros(0)
    out = {"xi": float("nan"), "runs": int(x.size), "exceedances": 0, "heavy": False, "assessed": False}
    if x.size < TAIL_MIN_RUNS:
        return out
    k = max(TAIL_MIN_EXCEEDANCES, int(TAIL_FRACTION * x.size))
    excess = x[-k:] - x[-k - 1]
    if not np.any(excess > 0):
        out.update(xi=-1.0, exceedances=k, assessed=True)      # a bounded, flat top: no tail at all
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        xi, _, _ = stats.genpareto.fit(excess, floc=0.0)
    out.update(xi=float(xi), exceedances=int(k), heavy=bool(xi > XI_MAX), assessed=True)
    return out


def cell_resolution(values, lo: float, heavy_tail: bool = False,
                    erratic: bool = False) -> tuple[bool, str | None]:
    """(resolved, why not) for a cell's per-run errors `values` whose mean has the interval lower end
    `lo`; `heavy_tail` is its sampler's `tail_shape(...)["heavy"]`, `erratic` whether its sampler's
    fitted sigma exceeds ERRATIC_SIGMA."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size < MIN_RUNS:
        return False, f"fewer than {MIN_RUNS} runs"
    total = float(v.sum())
    if not total > 0:
        return False, "mean at or below the noise floor"
    top = float(v.max())
    if top / total > MAX_SHARE:
        return False, f"its largest run carries {top / total:.0%} of its error"
    if math.isfinite(lo) and (total - top) / (v.size - 1) < lo:
        return False, "dropping its largest run moves the mean below its interval"
    if heavy_tail:
        return False, f"heavy-tailed errors (generalized Pareto shape above {XI_MAX:g})"
    if erratic:
        return False, (f"its sampler's errors scatter by more than a factor {math.exp(ERRATIC_SIGMA):.2f} "
                       f"about the fitted law (log-normal-like tail)")
    return True, None
