"""The one-pass batch sums (kernels/error_sums.py): the moments a cell keeps against float64 numpy,
their stability on a large mean, and independence of the thread count."""
import math

import numpy as np
import pytest

from drtlab.kernels.error_sums import CHUNK_PIXELS, batch_sums


def _batch(rng, reps=7, h=37, w=29, offset=0.0, sd=0.3):
    # 37 x 29 = 1073 pixels: three chunks, the last one partial.
    assert h * w > 2 * CHUNK_PIXELS
    return offset + sd * rng.standard_normal((reps, h, w, 3))


@pytest.mark.parametrize("offset, sd", [(0.5, 0.3), (1e4, 1e-3)])
def test_moments_equal_numpy_even_on_a_large_mean(offset, sd):
    # (1e4, 1e-3): E[x^2] / Var = 1e14, where sum(x^2) - n mean^2 would lose every digit; the
    # running update keeps the deviations' sum to 1e-9 of itself.
    rng = np.random.default_rng(11)
    x = _batch(rng, offset=offset, sd=sd)
    s = batch_sums(x, np.zeros(x.shape[1:]), None, 1.0)
    mean = x.mean(axis=0)
    assert np.allclose(s.mean, mean, rtol=1e-13, atol=0)
    assert math.isclose(s.m2, float(np.sum(np.square(x - mean))), rel_tol=1e-9)


def test_sums_and_moments_do_not_depend_on_the_thread_count():
    rng = np.random.default_rng(12)
    x = _batch(rng)
    ref = rng.uniform(0.0, 1.0, x.shape[1:])
    one = batch_sums(x, ref, None, 1e-2, threads=1)
    for threads in (2, 3):
        other = batch_sums(x, ref, None, 1e-2, threads=threads)
        assert np.array_equal(one.sums, other.sums) and np.array_equal(one.mean, other.mean)
        assert one.m2 == other.m2


def test_squared_error_sums_equal_numpy():
    rng = np.random.default_rng(13)
    x = _batch(rng)
    ref = rng.uniform(0.0, 1.0, x.shape[1:])
    s = batch_sums(x, ref, None, 1e-2)
    assert np.allclose(s.sums[:, 1], np.sum(np.square(x - ref), axis=(1, 2, 3)), rtol=1e-12, atol=0)
    assert np.allclose(s.sums[:, 0], np.sum(x - ref, axis=(1, 2, 3)), rtol=1e-9, atol=1e-9)
    assert np.all(s.sums[:, 5] == 0.0)                 # no reference Lab: no colour difference
