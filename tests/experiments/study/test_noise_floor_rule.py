"""The reference's noise floor: the error its subtraction leaves in an MSE has the standard deviation
`GroundTruth.correction_sd` says, and the warning fires on that error against the narrowest cell
interval, not on a fixed share of the smallest MSE."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from drtlab.experiments.study.ground_truth import GroundTruth
from drtlab.experiments.study.noise_floor import NOISE_FLOOR_SHARE, noise_floor
from synthetic_study import synthetic_cell


def _gt(stderr: np.ndarray, batches: int) -> GroundTruth:
    return GroundTruth(mean=np.zeros_like(stderr), stderr=stderr, spp=512 * batches, batches=batches,
                       directory=Path("."), manifest={})


def test_correction_sd_is_the_spread_of_what_the_subtraction_leaves():
    # A reference of B Gaussian batches per pixel (its three channels one draw, scaled): against it a
    # run's MSE holds mean(e^2), and the analysis subtracts mean(stderr^2) estimated from the batches.
    # Over 3000 references the leftover D's sd matches correction_sd (of the true stderr) within 6%;
    # the sd of a sample sd of 3000 such draws is ~1.6%, so this fails by chance with p < 1e-3.
    rng = np.random.default_rng(5)
    h, w, b, trials = 12, 16, 8, 3000
    sigma = rng.gamma(0.5, 1.0, size=(h, w, 1)) * np.array([1.0, 0.7, 0.4])   # heteroscedastic
    batches = rng.standard_normal((trials, b, h, w, 1)) * sigma               # batch-mean errors
    mean_err = batches.mean(axis=1)
    v_hat = batches.var(axis=1, ddof=1) / b
    d = np.square(mean_err).mean(axis=(1, 2, 3)) - v_hat.mean(axis=(1, 2, 3))
    want = _gt(sigma * np.ones((h, w, 3)) / np.sqrt(b), b).correction_sd
    assert abs(d.mean()) < 4 * want / np.sqrt(trials)                          # unbiased
    assert abs(d.std(ddof=1) / want - 1) < 0.06, (d.std(ddof=1), want)


def test_the_warning_follows_the_leftover_error_not_the_variance_share():
    cells = {(s, n): synthetic_cell(s, n, 0.01 * n ** -0.5, 1e-3 * n) for s in ("a", "b") for n in (1, 4, 16)}
    half = min((c.mse.hi - c.mse.lo) / 2 for c in cells.values())
    smallest = min(c.mse.mean for c in cells.values())
    h, w = 12, 16
    # Var_GT at 5% of the smallest MSE, spread evenly over many pixels: D is tiny, no warning.
    even = _gt(np.full((h, w, 3), np.sqrt(0.05 * smallest)), 8)
    nf = noise_floor(cells, even, "even")
    assert nf.fraction_of_smallest_mse > 0.04 and not nf.warning
    assert nf.share_of_half_width < NOISE_FLOOR_SHARE
    # Var_GT at 0.8% of it, all in one pixel: D is as large as that pixel's noise, a warning.
    one = np.zeros((h, w, 3))
    one[0, 0] = np.sqrt(0.008 * smallest * h * w)
    nf = noise_floor(cells, _gt(one, 8), "one")
    assert nf.fraction_of_smallest_mse < 0.01 and nf.warning
    assert np.isclose(nf.share_of_half_width, 1.96 * nf.correction_sd / half)
