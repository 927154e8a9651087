"""Two samplers compared (stats/comparisons.py): the Welch log-t interval of a ratio of mean MSEs
covers on few runs where the delta method with the normal quantile does not (negative control),
draws reproduce an interval, and Benjamini-Hochberg claims.

Fixed seeds; coverage checked against the two-sided 99.9% binomial band around 0.95."""
import math

import numpy as np
from scipy import stats

from drtlab.experiments.stats.comparisons import (assign_claims, draw_log_ratio, interval_of_draws,
                                                  mean_ratio, samples_to_reach)

TRIALS = 800
BAND = stats.binom.ppf([0.0005, 0.9995], TRIALS, 0.95) / TRIALS


def _naive(a, b):
    """The method before: delta method on the log scale with z = 1.96 (no t, no resolution)."""
    ma, mb = np.mean(a), np.mean(b)
    s = math.sqrt(np.var(a, ddof=1) / ma ** 2 / a.size + np.var(b, ddof=1) / mb ** 2 / b.size)
    r = ma / mb
    return r * math.exp(-1.96 * s), r * math.exp(1.96 * s)


def test_the_mse_ratio_interval_covers_and_the_naive_one_does_not():
    rng = np.random.default_rng(0)
    k = 1 / 0.3 ** 2
    ours = naive = 0
    for _ in range(TRIALS):
        a = rng.gamma(k, 2.0 / k, size=5)          # baseline mean 2
        b = rng.gamma(k, 1.0 / k, size=3)          # sampler mean 1: true ratio 2
        r = mean_ratio(a, b)
        ours += r["lo"] <= 2.0 <= r["hi"]
        lo, hi = _naive(a, b)
        naive += lo <= 2.0 <= hi
    assert BAND[0] <= ours / TRIALS <= BAND[1], ours / TRIALS
    assert naive / TRIALS < BAND[0], naive / TRIALS


def test_draws_reproduce_the_t_interval():
    r = mean_ratio([2.0, 2.2, 1.8, 2.1, 1.9], [1.0, 1.2, 0.9, 1.1])
    d = draw_log_ratio(r, np.random.default_rng(1), 20000)
    got = interval_of_draws(d, r["ratio"])
    assert math.isclose(got["lo"], r["lo"], rel_tol=0.02) and math.isclose(got["hi"], r["hi"], rel_tol=0.02)
    assert got["p"] < 0.01 and r["p"] < 0.01


def test_samples_to_reach_a_target():
    line = np.array([[math.log(0.1), -0.5], [math.log(0.1), 0.1]])
    n = samples_to_reach(line, 0.01)
    assert math.isclose(n[0], 100.0) and n[1] == np.inf


def test_claims_are_corrected_and_unresolved_make_none():
    tests = [{"p": 0.001, "resolved": True, "direction": 1.0},
             {"p": 0.03, "resolved": True, "direction": -1.0},
             {"p": 0.04, "resolved": True, "direction": 1.0},
             {"p": 1e-9, "resolved": False, "direction": 1.0}]
    out = assign_claims(tests)
    # BH over the three resolved: adjusted 0.003, 0.04, 0.04 -> all below 0.05
    assert [t["claim"] for t in out] == ["better", "worse", "better", "not resolved"]
    assert math.isclose(out[1]["p_adjusted"], 0.04) and math.isnan(out[3]["p_adjusted"])
    out = assign_claims([dict(t, p=0.2) for t in tests[:3]])
    assert [t["claim"] for t in out] == ["no difference"] * 3
