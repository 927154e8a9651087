"""The statistics of bench-compare's matched sampler pairs (experiments/bench/mitsuba/samplers.py), on synthetic
stacks of renders with known per-pixel variance; the renders themselves need Mitsuba and are not tested.

The time to equal RMSE of a (seconds ta, variance va) renderer against a (tb, vb) one is ta va / (tb vb).
With ta = 2, tb = 1, va = 4, vb = 1 (8 renders of 16 x 16 x 3 pixels each, Gaussian, and heavy-tailed:
Student t with 10 dof scaled to those variances) it is 8. Over 100 trials at fixed seeds per noise the
90% interval must cover 8 at a rate a two-sided binomial test does not reject against 0.90, at
alpha = 0.001 / 3 (three tests, Bonferroni), and the point estimates must centre on 8 (mean within
2%). Negative control: the same intervals against a b stack of variance 1.5 (true ratio 5.33) must
exclude 8 at a rate not below 0.90 (same test, one-sided).
"""
import numpy as np
from scipy import stats

import pytest

from drtlab.experiments.bench.mitsuba.samplers import efficiency_ratio, mse_and_variance

ALPHA = 0.001 / 3
TRIALS = 100
SHAPE = (8, 16, 16, 3)
T_DOF = 10


def _noise(rng, var: float, tails: str) -> np.ndarray:
    if tails == "gaussian":
        return rng.normal(0.5, np.sqrt(var), SHAPE)
    return 0.5 + np.sqrt(var * (T_DOF - 2) / T_DOF) * rng.standard_t(T_DOF, SHAPE)


def _trial(k: int, vb: float, tails: str) -> dict:
    rng = np.random.default_rng(1000 + k)
    a, b = _noise(rng, 4.0, tails), _noise(rng, vb, tails)
    return efficiency_ratio(a, 2.0, b, 1.0, np.ones(SHAPE[1:3], dtype=bool))


def test_mse_is_the_mean_per_pixel_variance():
    rng = np.random.default_rng(3)
    stack = rng.normal(0.0, 1.0, (5, 4, 6, 3))
    region = np.zeros((4, 6), dtype=bool)
    region[1:3, 2:5] = True
    want = np.var(stack, axis=0, ddof=1)[region].mean()
    assert mse_and_variance(stack, region)[0] == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize("tails", ["gaussian", "student_t10"])
def test_efficiency_ratio_interval_covers_the_true_ratio(tails):
    runs = [_trial(k, 1.0, tails) for k in range(TRIALS)]
    covered = sum(r["ci90"][0] <= 8.0 <= r["ci90"][1] for r in runs)
    assert stats.binomtest(covered, TRIALS, 0.90).pvalue > ALPHA, covered
    assert abs(np.mean([r["time_ratio"] for r in runs]) / 8.0 - 1.0) < 0.02


def test_negative_control_wrong_variance_is_excluded():
    runs = [_trial(k, 1.5, "gaussian") for k in range(TRIALS)]
    excluded = sum(not r["ci90"][0] <= 8.0 <= r["ci90"][1] for r in runs)
    assert stats.binomtest(excluded, TRIALS, 0.90, alternative="less").pvalue > ALPHA, excluded
