"""The shared test helpers: the rounded normal quantile matches the confidence level, Sidak's level
and adjusted p-value are each other's inverse, and Welch's dof reduces to the pooled one."""
import math

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL, Z_CI, sidak, sidak_adjusted, welch_dof


def test_z_is_the_rounded_normal_quantile_of_the_level():
    assert Z_CI == round(float(stats.norm.ppf(0.5 + CI_LEVEL / 2)), 2)


@pytest.mark.parametrize("m", [1, 2, 7, 100])
def test_sidak_level_and_adjusted_p_agree(m):
    level = sidak(0.01, m)
    assert sidak_adjusted([level] + [1.0] * (m - 1)) == pytest.approx(0.01, rel=1e-9)
    assert sidak(0.01, 0) == sidak(0.01, 1) == pytest.approx(0.01)
    assert sidak_adjusted([]) == 1.0


def test_welch_dof_of_equal_variances_and_sizes_is_the_pooled_dof():
    n, var = 12, 0.3
    assert welch_dof(var / n, n, var / n, n) == pytest.approx(2 * (n - 1))
    # Elementwise on arrays, as bench/mitsuba and the image tools use it.
    a = welch_dof(np.array([1.0, 2.0]), 5, np.array([1.0, 0.5]), 9)
    assert a.shape == (2,) and all(math.isfinite(x) for x in a)
