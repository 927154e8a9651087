"""Variance-based sensitivity indices from pick-freeze samples (Sobol' 1993/2001): for each group g of
the inputs, the first-order index S_g = Var(E[f | X_g]) / Var f by Saltelli et al. 2010's estimator
and the total index T_g = E[Var(f | X_~g)] / Var f by Jansen 1999's, with delta-method intervals.

The inputs are f(A) and f(B) at N independent input points A_n, B_n, and f(A_B^g): A_n with group
g's inputs taken from B_n. Each estimate is a ratio of means over n of per-sample terms, summed over
whatever the outputs carry besides n (a render's pixels and channels: the image-level indices then
decompose the mean per-pixel variance, i.e. the MSE of a render):
    variance      v_n   = (f(A) - f(B))^2 / 2                       E v   = Var f
    first order   s_n^g = (f(B) - c) (f(A_B^g) - f(A))              E s^g = Var(E[f | X_g])
    total         t_n^g = (f(A) - f(A_B^g))^2 / 2                   E t^g = E[Var(f | X_~g)]
c is any value independent of the samples (E[f(A_B^g) - f(A)] = 0 for every c); one near the mean
(a pilot estimate) removes most of the first-order estimator's variance when f's mean is large.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL


@dataclass
class PickFreezeTerms:
    """Per-sample terms (their means are the variances above); add more samples with `merged`."""
    variance: np.ndarray      # (N,)
    first: np.ndarray         # (G, N)
    total: np.ndarray         # (G, N)

    def merged(self, other: "PickFreezeTerms") -> "PickFreezeTerms":
        return PickFreezeTerms(np.concatenate([self.variance, other.variance]),
                               np.concatenate([self.first, other.first], axis=1),
                               np.concatenate([self.total, other.total], axis=1))


def pick_freeze_terms(f_a: np.ndarray, f_b: np.ndarray, f_ab: np.ndarray, centre=0.0) -> PickFreezeTerms:
    """The terms of N samples: f_a, f_b (N, ...), f_ab (G, N, ...); everything past the sample axis
    is summed. `centre` broadcasts against one sample's outputs."""
    a = np.asarray(f_a, dtype=np.float64)
    b = np.asarray(f_b, dtype=np.float64)
    ab = np.asarray(f_ab, dtype=np.float64)
    axes = tuple(range(1, a.ndim))
    d = ab - a[None]
    return PickFreezeTerms(
        variance=np.mean(0.5 * np.square(a - b), axis=axes) if axes else 0.5 * np.square(a - b),
        first=np.mean((b - centre)[None] * d, axis=tuple(range(2, ab.ndim))) if axes else (b - centre)[None] * d,
        total=np.mean(0.5 * np.square(d), axis=tuple(range(2, ab.ndim))) if axes else 0.5 * np.square(d))


def _ratio(x: np.ndarray, v: np.ndarray, z: float) -> tuple[float, float, float]:
    """mean(x) / mean(v) and its delta-method interval (x, v paired samples)."""
    n = x.size
    mv = float(np.mean(v))
    if n < 2 or mv <= 0.0:
        return float("nan"), float("nan"), float("nan")
    r = float(np.mean(x)) / mv
    se = float(np.std(x - r * v, ddof=1)) / (mv * np.sqrt(n))
    return r, r - z * se, r + z * se


def sobol_indices(terms: PickFreezeTerms, groups, level: float = CI_LEVEL) -> dict:
    """{"groups": [{group, first_order, first_order_lo, first_order_hi, total, total_lo, total_hi}],
    "interaction": (value, lo, hi) of 1 - sum of S_g, "variance": (value, lo, hi) of Var f, "n"}."""
    from scipy.special import ndtri
    z = float(ndtri(0.5 + level / 2))
    v = terms.variance
    rows = []
    for g, name in enumerate(groups):
        s, s_lo, s_hi = _ratio(terms.first[g], v, z)
        t, t_lo, t_hi = _ratio(terms.total[g], v, z)
        rows.append({"group": name, "first_order": s, "first_order_lo": s_lo, "first_order_hi": s_hi,
                     "total": t, "total_lo": t_lo, "total_hi": t_hi})
    s_sum, lo, hi = _ratio(terms.first.sum(axis=0), v, z)
    n = v.size
    sd = float(np.std(v, ddof=1)) if n > 1 else float("nan")
    mv = float(np.mean(v))
    return {"groups": rows, "interaction": (1.0 - s_sum, 1.0 - hi, 1.0 - lo),
            "variance": (mv, mv - z * sd / np.sqrt(n), mv + z * sd / np.sqrt(n)), "n": int(n)}
