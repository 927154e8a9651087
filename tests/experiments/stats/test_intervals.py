"""Intervals for means of positive quantities (experiments/stats/intervals.py) stay positive and cover.

Synthetic per-run values with mean exactly 1, each a law a renderer's per-run MSE can follow:
  gaussian: the MSE of 64 Gaussian pixel errors (chi-square(64) / 64);
  bright:   the MSE of 64 pixels at 1 spp whose samples are a Gaussian part (10% of the variance)
            plus a rare very bright sample (probability q per sample, 90% of the variance): most
            runs are small, a few huge;
  gamma2:   a chi-square(4) / 4 law (an MSE dominated by two pixels' worth of error);
  lognormal: sigma 0.5 (moderate skew);
  and the other per-run columns of the report, which share this interval: flip, an image's mean
  HDR-FLIP in [0, 1] (a Beta law of mean 0.2 and CV 0.1, scaled to mean 1), flip_noisy (mean 0.05,
  CV 0.5), de00, a mean CIEDE2000 (a gamma law of CV 0.5); FLIP is scored on a cell's first
  `flip_runs` runs, so down to 2.
Coverage test: with T trials the count of covering intervals is Binomial(T, 0.95) if the interval is
calibrated; a one-sided binomial test (scipy.stats.binomtest, alternative "less") rejects that at
level ALPHA = 0.001. The log-t interval must not be rejected on any of these laws; the plain
Student-t interval of `metrics.mean_ci` (negative control) reaches below zero in 20-45% of the trials
on the skewed ones, covers less than the log-t interval on the same samples, and on gamma2 is
rejected.
"""
import math

import numpy as np
import pytest
from drtlab.experiments.stats.intervals import (
    positive_mean_ci,
    repetitions_for_precision,
    rmse_ci,
)
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

ALPHA = 1e-3
TRIALS = 1000


def bright(rng, n, q=0.02, npix=64, frac=0.9):
    h = math.sqrt(frac / (q * (1 - q)))
    e = rng.standard_normal((n, npix)) * math.sqrt(1 - frac) + h * (rng.binomial(1, q, (n, npix)) - q)
    return np.mean(e * e, axis=1)


LAWS = {
    "gaussian": lambda rng, n: rng.chisquare(64, n) / 64,
    "bright": bright,
    "gamma2": lambda rng, n: rng.chisquare(4, n) / 4,
    "lognormal": lambda rng, n: rng.lognormal(-0.125, 0.5, n),
    "flip": lambda rng, n: rng.beta(79.8, 319.2, n) / 0.2,
    "flip_noisy": lambda rng, n: rng.beta(3.75, 71.25, n) / 0.05,
    "de00": lambda rng, n: rng.gamma(4.0, 0.25, n),
}


def t_interval(v, level=0.95):
    """metrics.mean_ci's interval: mean +- t s / sqrt(n)."""
    h = stats.t.ppf(0.5 + level / 2, len(v) - 1) * np.std(v, ddof=1) / math.sqrt(len(v))
    return np.mean(v) - h, np.mean(v) + h


def calibrated(covered: int, trials: int) -> bool:
    return stats.binomtest(covered, trials, 0.95, alternative="less").pvalue >= ALPHA


@pytest.mark.parametrize("law, n", [("gaussian", 5), ("bright", 5), ("bright", 8), ("gamma2", 5),
                                    ("lognormal", 8)])
def test_log_t_interval_covers_the_mean(law, n):
    rng = np.random.default_rng([11, n, len(law)])
    covered = covered_rmse = 0
    for _ in range(TRIALS):
        v = LAWS[law](rng, n)
        ci = positive_mean_ci(v)
        assert 0 < ci["lo"] <= ci["mean"] <= ci["hi"] and not ci["clipped"]
        covered += ci["lo"] <= 1.0 <= ci["hi"]
        r = rmse_ci(v)                        # the RMSE interval: sqrt of the MSE interval's ends
        covered_rmse += r["lo"] <= 1.0 <= r["hi"]
        assert r["lo"] == pytest.approx(math.sqrt(ci["lo"])) and r["mean"] == pytest.approx(math.sqrt(ci["mean"]))
    assert covered == covered_rmse
    assert calibrated(covered, TRIALS), covered / TRIALS


@pytest.mark.parametrize("law, n", [("flip", 2), ("flip", 4), ("flip_noisy", 4), ("de00", 4), ("de00", 8)])
def test_the_report_s_other_per_run_intervals_cover(law, n):
    """FLIP and CIEDE2000 columns: the same log-t interval, judged by the interval audit's band (its
    coverage not significantly below 0.92, binomial test at ALPHA); negative control: the normal
    quantile in place of Student's t (the audit's own), rejected on the same samples at 2 and 4 runs."""
    rng = np.random.default_rng([14, n, len(law)])
    covered = covered_z = 0
    z = stats.norm.ppf(0.975)
    for _ in range(TRIALS):
        v = LAWS[law](rng, n)
        ci = positive_mean_ci(v)
        covered += ci["lo"] <= 1.0 <= ci["hi"]
        m, se = np.log(np.mean(v)), np.std(v, ddof=1) / np.mean(v) / math.sqrt(n)
        covered_z += math.exp(m - z * se) <= 1.0 <= math.exp(m + z * se)
    band = stats.binomtest(covered, TRIALS, 0.92, alternative="less").pvalue >= ALPHA
    assert band, covered / TRIALS
    if n <= 4 and law != "de00":
        assert stats.binomtest(covered_z, TRIALS, 0.92, alternative="less").pvalue < ALPHA, covered_z / TRIALS


@pytest.mark.parametrize("law", ["bright", "gamma2"])
def test_plain_t_interval_fails_on_skewed_laws(law):
    """Negative control: on the same samples (5 runs) the symmetric t-interval reaches below zero
    often and covers less than the log-t interval; on gamma2 the binomial test rejects it."""
    rng = np.random.default_rng([12, len(law)])
    covered = covered_log = negative = 0
    for _ in range(TRIALS):
        v = LAWS[law](rng, 5)
        lo, hi = t_interval(v)
        covered += lo <= 1.0 <= hi
        negative += lo <= 0
        ci = positive_mean_ci(v)
        covered_log += ci["lo"] <= 1.0 <= ci["hi"]
    assert negative / TRIALS > 0.15, negative / TRIALS
    assert covered < covered_log, (covered, covered_log)
    if law == "gamma2":
        assert not calibrated(covered, TRIALS), covered / TRIALS


def test_bca_interval_is_positive_and_covers_with_enough_runs():
    rng = np.random.default_rng(13)
    covered, trials = 0, 300
    for i in range(trials):
        ci = positive_mean_ci(LAWS["gaussian"](rng, 20), method="bca", seed=i, n_resamples=999)
        assert ci["method"] == "bca" and 0 < ci["lo"] <= ci["hi"]
        covered += ci["lo"] <= 1.0 <= ci["hi"]
    assert calibrated(covered, trials), covered / trials
    same = [0.2, 0.2, 0.2]                          # degenerate bootstrap: falls back to log-t
    assert positive_mean_ci(same, method="bca")["method"] == "log-t"
    v = LAWS["bright"](np.random.default_rng(1), 8)
    assert positive_mean_ci(v, method="bca", seed=3) == positive_mean_ci(v, method="bca", seed=3)


finite = st.floats(min_value=-1e3, max_value=1e6, allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=150, deadline=None)
@given(st.lists(finite, min_size=2, max_size=12), st.sampled_from(["log-t", "bca"]))
def test_lower_bounds_are_always_positive(values, method):
    ci = positive_mean_ci(values, method=method, n_resamples=199)
    assert math.isfinite(ci["lo"]) and math.isfinite(ci["hi"])
    assert 0 < ci["floor"] <= ci["lo"] <= ci["hi"]
    r = rmse_ci(values, method=method, n_resamples=199)
    assert 0 < r["lo"] <= r["hi"] and r["mean"] >= 0


def test_noise_floor_corrected_values():
    ci = positive_mean_ci([-1e-4, 2e-4, -3e-4])           # mean < 0: below the noise floor
    assert ci["mean"] < 0 and ci["method"] == "t-upper" and ci["clipped"]
    assert 0 < ci["lo"] == ci["floor"] < ci["hi"]
    assert positive_mean_ci([-1e-4, 2e-4, -3e-4], floor=1e-6)["lo"] == 1e-6
    ci = positive_mean_ci([0.5, 0.7, -0.01, 0.6])         # a slight negative: still the log scale
    assert ci["method"] == "log-t" and 0 < ci["lo"] < ci["mean"] < ci["hi"]
    assert math.isnan(positive_mean_ci([0.3])["lo"]) and positive_mean_ci([])["n"] == 0
    assert positive_mean_ci([0.3, float("nan"), 0.5])["n"] == 2


def test_repetitions_for_precision():
    rng = np.random.default_rng(14)
    v = LAWS["gaussian"](rng, 400)                       # cv = sqrt(2 / 64) = 0.177
    r = repetitions_for_precision(v, rel_halfwidth=0.05)
    k, cv = r["repetitions"], r["cv"]
    t = lambda m: stats.t.ppf(0.975, m - 1) * cv / math.sqrt(m)
    assert t(k) <= 0.05 < t(k - 1)                        # the smallest such count
    assert abs(k - (1.96 * math.sqrt(2 / 64) / 0.05) ** 2) < 10 and r["enough"]
    # A heavy-tailed cell of 5 runs: its cv says it needs far more runs for +-10%.
    h = repetitions_for_precision(bright(np.random.default_rng(2), 5, q=0.005), rel_halfwidth=0.1)
    assert h["n"] == 5 and not h["enough"] and h["repetitions"] > 100
    assert h["current_rel_halfwidth"] > 0.1
    assert repetitions_for_precision([-1.0, 0.5])["repetitions"] is None
    with pytest.raises(ValueError):
        repetitions_for_precision(v, rel_halfwidth=0)
