"""The pick-freeze estimators (experiments/stats/sobol_indices.py) on integrands with closed-form
Sobol' indices, against SALib, and a wrong group map they must reject.

Significance: every closed-form index must lie in its interval at an overall level of 1% (Sidak over
all the indices checked), fixed seeds."""
import math

import numpy as np
import pytest

from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.experiments.stats.sobol_indices import pick_freeze_terms, sobol_indices

N = 20000


def ishigami(x, a=7.0, b=0.1):
    return np.sin(x[:, 0]) + a * np.sin(x[:, 1]) ** 2 + b * x[:, 2] ** 4 * np.sin(x[:, 0])


def ishigami_indices(a=7.0, b=0.1):
    v1 = 0.5 * (1 + b * math.pi ** 4 / 5) ** 2
    v2 = a ** 2 / 8
    v13 = b ** 2 * math.pi ** 8 * 8 / 225
    v = v1 + v2 + v13
    return [v1 / v, v2 / v, 0.0], [(v1 + v13) / v, v2 / v, v13 / v]


G_A = np.array([0.0, 1.0, 4.5, 9.0])


def g_function(x):
    return np.prod((np.abs(4 * x - 2) + G_A) / (1 + G_A), axis=1)


def g_indices():
    vi = 1 / (3 * (1 + G_A) ** 2)
    v = np.prod(1 + vi) - 1
    return list(vi / v), [vi[i] * np.prod(np.delete(1 + vi, i)) / v for i in range(len(G_A))]


C = np.array([1.0, 2.0, 0.5])


def additive(x):
    return x @ C


def additive_indices():
    s = C ** 2 / np.sum(C ** 2)
    return list(s), list(s)


CASES = [  # function, input dimension, input sampler, closed form
    (ishigami, 3, lambda rng, n: rng.uniform(-math.pi, math.pi, (n, 3)), ishigami_indices()),
    (g_function, 4, lambda rng, n: rng.uniform(0, 1, (n, 4)), g_indices()),
    (additive, 3, lambda rng, n: rng.uniform(0, 1, (n, 3)), additive_indices()),
]
CHECKS = sum(2 * d for _, d, _, _ in CASES)
LEVEL = 1 - sidak(0.01, CHECKS)


def _estimate(f, d, draw, seed, groups=None):
    """Indices of each input (or of each group: a list of input columns per group)."""
    rng = np.random.default_rng(seed)
    a, b = draw(rng, N), draw(rng, N)
    groups = [[i] for i in range(d)] if groups is None else groups
    f_ab = []
    for cols in groups:
        ab = a.copy()
        ab[:, cols] = b[:, cols]
        f_ab.append(f(ab))
    fa, fb = f(a), f(b)
    terms = pick_freeze_terms(fa, fb, np.array(f_ab), centre=float(np.mean(f(draw(rng, 1000)))))
    return sobol_indices(terms, [str(g) for g in groups], level=LEVEL)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_closed_form_indices_lie_in_their_intervals(case):
    f, d, draw, (first, total) = CASES[case]
    est = _estimate(f, d, draw, seed=100 + case)
    for row, s, t in zip(est["groups"], first, total):
        assert row["first_order_lo"] <= s <= row["first_order_hi"], (row, s)
        assert row["total_lo"] <= t <= row["total_hi"], (row, t)
        assert row["total_hi"] - row["total_lo"] < 0.1          # informative, not just wide


def test_additive_function_has_no_interaction():
    est = _estimate(additive, 3, CASES[2][2], seed=7)
    value, lo, hi = est["interaction"]
    assert lo <= 0.0 <= hi and hi - lo < 0.05


def test_a_wrong_group_map_is_rejected():
    # Negative control: Ishigami's inputs 1 and 3 swapped in the map. Input 3's true first-order
    # index is 0, so the group labelled "x1" now reads about 0 and is outside x1's interval.
    f, d, draw, (first, total) = CASES[0]
    est = _estimate(f, d, draw, seed=9, groups=[[2], [1], [0]])
    row = est["groups"][0]
    assert not (row["first_order_lo"] <= first[0] <= row["first_order_hi"])


def test_agrees_with_salib_on_ishigami():
    # SALib's Saltelli sample (A, A_B^i ..., B per base row) and its analysis of the same outputs:
    # the two implementations of Saltelli 2010 / Jansen 1999 differ only in the variance they divide
    # by (SALib: of all outputs of A and B; here: of the (A, B) pairs), a few 1/sqrt(N) apart.
    salib_sample = pytest.importorskip("SALib.sample.sobol")
    salib_analyze = pytest.importorskip("SALib.analyze.sobol")
    problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-math.pi, math.pi]] * 3}
    x = salib_sample.sample(problem, 4096, calc_second_order=False, seed=3)
    y = ishigami(x)
    ref = salib_analyze.analyze(problem, y, calc_second_order=False, print_to_console=False, seed=3)
    rows = y.reshape(-1, 5)
    terms = pick_freeze_terms(rows[:, 0], rows[:, 4], rows[:, 1:4].T)
    est = sobol_indices(terms, problem["names"])
    for i, row in enumerate(est["groups"]):
        assert abs(row["first_order"] - ref["S1"][i]) < 0.02, (row, ref["S1"][i])
        assert abs(row["total"] - ref["ST"][i]) < 0.02, (row, ref["ST"][i])
