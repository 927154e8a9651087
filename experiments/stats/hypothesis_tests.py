"""What every interval and test of the measurements shares: the confidence level, Šidák's correction
of a family of tests, and Welch's degrees of freedom of a difference of two means."""
from __future__ import annotations

import math

import numpy as np

CI_LEVEL = 0.95
# The normal quantile of CI_LEVEL (scipy: 1.95996...) rounded as published tables quote it; the cost
# and ratio intervals were computed with the rounded figure, so it stays (tested against scipy).
Z_CI = 1.96


def sidak(alpha: float, test_count: int) -> float:
    """Per-test level so that `test_count` independent tests falsely reject with probability alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(test_count), 1))


def sidak_adjusted(p_values) -> float:
    """P-value of the smallest of m sub-test p-values under Sidak: 1 - (1 - p_min)^m. Exact for
    independent sub-tests, conservative (Sidak's inequality) for two-sided tests of jointly normal
    statistics; the correlated pair tests of the point-set battery are of that kind or close to it."""
    p = np.asarray(list(p_values), dtype=np.float64)
    if p.size == 0:
        return 1.0
    p_min = float(np.clip(p.min(), 0.0, 1.0))
    return float(-math.expm1(p.size * math.log1p(-p_min))) if p_min < 1.0 else 1.0


def welch_dof(var_a, n_a: int, var_b, n_b: int):
    """Welch-Satterthwaite degrees of freedom of mean(a) - mean(b), from the squared standard errors
    of the two means (`var_a` = s_a^2 / n_a) and the sample sizes; scalars or numpy arrays."""
    return (var_a + var_b) ** 2 / (var_a ** 2 / (n_a - 1) + var_b ** 2 / (n_b - 1))
