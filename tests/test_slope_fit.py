"""The emcee convergence-slope fit recovers known slopes, and its 95% interval covers the truth in about
95% of seeded trials.

Synthetic data: at each N of a powers-of-4 ladder, a few repetitions of the RMSE of 64 Gaussian pixel
errors with standard deviation 0.3 * N^-beta, beta in {0.5, 0.75} (plain Monte Carlo and the
stratified rate on edges).

Coverage test: with T trials the count of covering intervals is Binomial(T, 0.95) if the intervals are
calibrated; we accept coverage >= 0.85 (default tier, T = 60: probability of a false failure
< 0.1%) and also require the intervals to be as wide as the exact Student-t intervals of least
squares (+-12%), which catches intervals that cover by being too wide.
"""
import math
import os

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.parallel import pmap
from drtlab.experiments.slopes import fit_slope, ols

FULL = os.environ.get("DRTLAB_TEST_TIER") == "full"
LADDER = (1, 4, 16, 64, 256)


def synth(beta, rng, reps=3, npix=64, sigma=0.3):
    n, r = [], []
    for N in LADDER:
        for _ in range(reps):
            z = rng.standard_normal(npix) * sigma * N ** -beta
            n.append(N)
            r.append(math.sqrt(np.mean(z * z)))
    return np.array(n, dtype=float), np.array(r)


def t_interval(n, r, level=0.95):
    x, y = np.log(n), np.log(r)
    _, b, s = ols(x, y)
    se = s / math.sqrt(np.sum((x - x.mean()) ** 2))
    h = stats.t.ppf(0.5 + level / 2, len(x) - 2) * se
    return b - h, b + h


@pytest.mark.parametrize("beta", [0.5, 0.75])
def test_recovers_known_slope(beta):
    rng = np.random.default_rng(123)
    n, r = synth(beta, rng, reps=4)
    f = fit_slope(n, r, seed=1)
    assert f["ok"] and f["converged"]
    assert f["slope_lo"] < -beta < f["slope_hi"]
    assert abs(f["slope"] + beta) < 0.03
    assert 0.15 <= f["acceptance_fraction"] <= 0.8
    assert len(f["autocorr_time"]) == 3 and max(f["autocorr_time"]) * 50 <= f["steps"] - f["burn"]
    assert abs(f["slope"] - f["ols_slope"]) < 0.01
    # The fit is reproducible: a fixed seed gives the same numbers.
    g = fit_slope(n, r, seed=1)
    assert (g["slope"], g["slope_lo"], g["slope_hi"]) == (f["slope"], f["slope_lo"], f["slope_hi"])
    # The fitted noise term is close to the scatter of log RMSE (about 1/sqrt(2*64)).
    assert 0.5 / math.sqrt(128) < f["sigma"] < 2.0 / math.sqrt(128)


def test_credible_interval_coverage():
    trials = 400 if FULL else 60
    rng = np.random.default_rng(2024)
    data = [synth(0.5 if i % 2 else 0.75, rng) for i in range(trials)]
    fits = pmap([(fit_slope, (n, r), {"seed": i, "nsteps": 600, "burn": 150})
                 for i, (n, r) in enumerate(data)])
    covered, width_ratio = 0, []
    for i, ((n, r), f) in enumerate(zip(data, fits)):
        beta = 0.5 if i % 2 else 0.75
        covered += f["slope_lo"] <= -beta <= f["slope_hi"]
        lo, hi = t_interval(n, r)
        width_ratio.append((f["slope_hi"] - f["slope_lo"]) / (hi - lo))
    coverage = covered / trials
    assert coverage >= (0.92 if FULL else 0.85), coverage
    assert abs(np.mean(width_ratio) - 1.0) < 0.12, np.mean(width_ratio)


def test_drops_unusable_points_and_reports_too_few():
    n = [1, 1, 4, 4, 16, 16]
    r = [0.3, 0.31, 0.15, -1.0, 0.075, float("nan")]
    f = fit_slope(n, r, seed=0)
    assert f["ok"] and f["dropped"] == 2 and f["n_points"] == 4
    g = fit_slope([1, 4], [0.3, 0.15], seed=0)
    assert not g["ok"] and "fewer than 3" in g["reason"]
