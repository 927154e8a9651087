"""Metrics: noise-floor subtraction is unbiased, CIs, colour differences and FLIP behave, time-to-target."""
import math

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.study.metrics import (batch_metrics, cell_bias, ciede2000, flip, flip_map,
                                             image_metrics, mean_ci)
from drtlab.experiments.study.run_store import CellMoments


def test_gt_variance_is_subtracted_without_bias():
    # X = mu + noise(sd 0.05), G = mu + noise(se 0.03): E[MSE] = 0.05^2 + 0.03^2; corrected -> 0.05^2.
    rng = np.random.default_rng(0)
    mu = rng.uniform(0.1, 0.9, (64, 64, 3))
    se = np.full_like(mu, 0.03)
    vals = []
    for _ in range(20):
        g = mu + se * rng.standard_normal(mu.shape)
        x = mu + 0.05 * rng.standard_normal(mu.shape)
        m = image_metrics(x, g, se, colour_diff=False)
        assert math.isclose(m["gt_var"], 0.03 ** 2)
        assert math.isclose(m["mse_corrected"], m["mse"] - m["gt_var"])
        vals.append(m["mse_corrected"])
    assert abs(np.mean(vals) / 0.05 ** 2 - 1) < 0.02
    assert m["rmse_corrected"] == math.sqrt(m["mse_corrected"])


def test_metric_values_on_a_known_error():
    gt = np.full((4, 4, 3), 0.5)
    m = image_metrics(gt + 0.1, gt, np.zeros_like(gt), colour_diff=True)
    assert math.isclose(m["rmse"], 0.1) and math.isclose(m["mae"], 0.1)
    assert math.isclose(m["mean_error"], 0.1)
    assert math.isclose(m["relmse"], 0.01 / (0.25 + 0.01))
    assert m["ciede2000"] > 1.0
    assert ciede2000(gt, gt) == 0.0


def test_flip_is_zero_on_the_reference_and_grows_with_the_noise():
    # One noise pattern at growing amplitudes: the same error, more visible each time. The map is
    # per pixel and its mean is the value.
    rng = np.random.default_rng(7)
    ref = rng.uniform(0.05, 2.0, (24, 32, 3))
    z = rng.standard_normal(ref.shape)
    assert flip(ref, ref) == 0.0 and not flip_map(ref, ref).any()
    values = [flip(np.maximum(ref + s * z * ref, 0), ref) for s in (0.03, 0.1, 0.3, 1.0)]
    assert all(a < b for a, b in zip(values, values[1:])) and 0 < values[0] and values[-1] < 1, values
    m = flip_map(ref + 0.3 * z * ref, ref)
    assert m.shape == (24, 32) and m.dtype == np.float32 and 0 <= m.min() and m.max() <= 1
    assert math.isclose(float(np.mean(m, dtype=np.float64)), flip(ref + 0.3 * z * ref, ref), rel_tol=1e-5)


def test_flip_is_the_hdr_metric_of_linear_radiance():
    # HDR-FLIP takes its exposures from the reference: the pair scaled by 1000 (far past 1, where an
    # LDR metric would see two white images) scores as before.
    rng = np.random.default_rng(8)
    ref = rng.uniform(0.05, 2.0, (24, 32, 3))
    test = ref * rng.exponential(1.0, ref.shape)
    assert math.isclose(flip(1000 * test, 1000 * ref), flip(test, ref), rel_tol=1e-4)


def test_flip_where_it_is_undefined_is_an_error_or_nan_never_an_exit():
    # The library ends the process on a black reference; here it is a ValueError naming why, and in
    # a batch a NaN for that row (as for an image with non-finite pixels) beside the rows it scores.
    rng = np.random.default_rng(9)
    ref = rng.uniform(0.1, 1.0, (12, 16, 3))
    for test, reference, why in ((ref, np.zeros_like(ref), "luminance 0"),
                                 (np.where(ref > 0.9, np.nan, ref), ref, "non-finite"),
                                 (ref[:6], ref, "one shape")):
        with pytest.raises(ValueError, match=why):
            flip(test, reference)
    rows = batch_metrics(np.stack([ref * 1.1, ref * np.inf, ref * 0.9]), ref, np.zeros_like(ref), flip_rows=2)
    assert np.isfinite(rows[0]["flip"]) and np.isnan(rows[1]["flip"]) and np.isnan(rows[2]["flip"])
    assert all(np.isnan(r["flip"]) for r in batch_metrics(ref[None], 0 * ref, 0 * ref, flip_rows=1))


def test_mean_ci_is_the_student_t_interval():
    v = [1.0, 2.0, 4.0, 3.5]
    ci = mean_ci(v)
    lo, hi = stats.t.interval(0.95, 3, loc=np.mean(v), scale=stats.sem(v))
    assert math.isclose(ci["lo"], lo) and math.isclose(ci["hi"], hi)
    assert mean_ci([float("nan"), 2.0])["n"] == 1


def _cell(rng, gt, bias, reps=6):
    # Two batches merged, as the runner stores a cell (run_store.CellMoments.merged).
    images = gt + bias + 0.05 * rng.standard_normal((reps,) + gt.shape)
    m = CellMoments.of(images[:2]).merged(CellMoments.of(images[2:]))
    errs = [float(np.mean(img - gt)) for img in images]
    return cell_bias(m.n, m.mean, m.pixel_variance(), gt, np.zeros_like(gt), errs)


def test_merged_cell_moments_equal_the_moments_of_all_repetitions():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((9, 4, 5, 3)) * 0.3 + 2.0
    m = CellMoments.of(x[:4]).merged(CellMoments.of(x[4:5])).merged(CellMoments.of(x[5:]))
    assert m.n == 9 and np.allclose(m.mean, x.mean(axis=0), rtol=1e-14, atol=0)
    assert math.isclose(m.pixel_variance(), float(np.mean(x.var(axis=0, ddof=1))), rel_tol=1e-12)


def test_cell_bias_screen_is_calibrated_and_detects_bias():
    # 95% intervals: with no bias about 5% of cells are flagged (accept 1%-10% over 200 cells, a
    # binomial check failing by chance with probability < 0.2%); a bias of 0.02 (with noise sd 0.05
    # per pixel) is flagged every time.
    rng = np.random.default_rng(1)
    gt = rng.uniform(0.2, 0.8, (16, 16, 3))
    cells = [_cell(rng, gt, 0.0) for _ in range(200)]
    flagged = sum(b["lo"] > 0 or b["hi"] < 0 for b in cells) / len(cells)
    assert 0.01 <= flagged <= 0.10, flagged
    assert all(abs(b["pixel_variance"] / 0.05 ** 2 - 1) < 0.2 for b in cells)
    for _ in range(20):
        b = _cell(rng, gt, 0.02)
        assert b["lo"] > 0 and abs(b["rms"] - 0.02) < 0.006


def test_batch_metrics_equal_each_image_s_metrics_exactly():
    # The runner scores a batch in one vectorised pass; every value must be what image_metrics
    # gives that image alone (bit for bit), the noise and colour terms included.
    from drtlab.experiments.study.metrics import batch_metrics
    from drtlab.kernels.colour import to_lab
    rng = np.random.default_rng(5)
    gt = rng.uniform(0.0, 1.5, (9, 13, 3))
    se = rng.uniform(0.0, 0.02, gt.shape)
    images = gt + 0.2 * rng.standard_normal((5,) + gt.shape)
    images[2, 3, 4] = np.nan                                    # a non-finite run is kept as such
    lab = to_lab(gt)
    rows = batch_metrics(images, gt, se, lab)
    for img, row in zip(images, rows):
        single = image_metrics(img, gt, se, lab)
        assert row.keys() == single.keys()
        for k in row:
            assert row[k] == single[k] or (math.isnan(row[k]) and math.isnan(single[k])), k
    assert rows[2]["finite"] is False and rows[0]["finite"] is True
