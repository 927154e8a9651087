"""The statistical test procedure of the estimator checks (test_unbiased, test_analytic,
test_hard_cases): tiers, seeds, estimates from renders and their comparison. The scenes with
closed-form pixel values are in tests/support/scene_util.py, their building blocks in tests/support/scene_pieces.py.
The estimates and their comparison are experiments/stats/region_tests.py (`drtlab check INTEGRATOR`
uses the same test).

The one statistical test every estimator check uses
---------------------------------------------------
An estimate is K independent renders (distinct fixed seeds) of the same scene, each at low spp. Each
render is reduced to region values: the image is cut into `block` x `block` pixel regions and a
region's value is the mean over its pixels (and the K runs) of R + G + B. Aggregating many pixels x
spp samples into one number per region is what gives the test power and makes it close to normal.
The variance of a region's mean comes from the per-pixel spread over the K runs (pixels and runs are
independent), with Satterthwaite's effective degrees of freedom (Estimate.from_images).

Two estimates (or an estimate and an exact value) are compared region by region with Welch's t:
    t_r = (mean_a - mean_b) / sqrt(var_a + var_b + floor_r^2),  Welch-Satterthwaite dof,
each t_r is mapped to the standard normal deviate z_r with the same two-sided p-value (so a small K
does not inflate the false-alarm rate the way treating t as z would), and the regions are combined by
    X = sum_r z_r^2  ~  chi-square(R)   under H0 (regions are disjoint pixels: independent).
The null (no bias) is rejected when P(chi2_R >= X) < alpha_test, where alpha_test is the Sidak
correction of ALPHA = 0.01 over the family of tests of the calling module (`sidak` of
drtlab.experiments.stats.chi2):
    alpha_test = 1 - (1 - ALPHA)^(1 / m).
`floor_r` = 1e-5 * |reference| + 1e-9 absorbs float32 rounding of the tracer (the renders trace in
float32) and the quadrature error of closed forms (< 1e-7 relative, 2e-6 for the thin lens); it is
far below every standard error the tests reach, so it never hides a bias the test could see.
"""
from __future__ import annotations

import math
import os
import zlib

import numpy as np

from drtlab.experiments.stats.region_tests import (ABS_FLOOR, REL_FLOOR, Comparison, Estimate,  # noqa: F401
                                                   compare, region_values)
from drtlab.kernels.render import render

# ---------------------------------------------------------------------------------------------------
# Tiers
# ---------------------------------------------------------------------------------------------------

TIER = os.environ.get("DRTLAB_TEST_TIER", "fast").strip().lower() or "fast"
FULL = TIER == "full"
ALPHA = 0.01


def tier(fast, full):
    """The fast-tier value, or the full-tier one under DRTLAB_TEST_TIER=full."""
    return full if FULL else fast



# Part of every seed. The suite's seeds are fixed (salt 0); DRTLAB_TEST_SEED_SALT=N re-draws all of
# them, which is how the tests were calibrated (a correct estimator must pass for most salts: each
# test's false-alarm rate is its Sidak alpha). Never set it for a real run.
SEED_SALT = int(os.environ.get("DRTLAB_TEST_SEED_SALT", "0"))


def seed_for(*key) -> int:
    """A fixed 32-bit seed derived from a readable key (so every test is reproducible alone)."""
    return zlib.crc32(repr((SEED_SALT,) + key).encode()) & 0xFFFFFFFF


def render_estimate(scene, sampler: str, integrator: str, spp: int, runs: int, key,
                    res=None, block: int = 8, faults=()) -> Estimate:
    """`runs` independent renders (seeds derived from `key`) reduced to an Estimate of region means."""
    imgs, nonfinite, negative, lo, hi = [], 0, 0, math.inf, -math.inf
    for k in range(runs):
        img = render(scene, spp=spp, sampler=sampler, integrator=integrator,
                     seed=seed_for(key, k), res=res, progress=False, faults=tuple(faults))
        finite = np.isfinite(img)
        nonfinite += int(img.size - finite.sum())
        negative += int(np.sum(img[finite] < 0))
        if finite.any():
            lo = min(lo, float(img[finite].min()))
            hi = max(hi, float(img[finite].max()))
        imgs.append(np.where(finite, img, 0.0).sum(axis=2))
    return Estimate.from_images(np.array(imgs), block, nonfinite=nonfinite, negative=negative,
                                min_value=lo, max_value=hi)
