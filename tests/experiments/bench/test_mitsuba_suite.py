"""Mitsuba 3's own render-test scenes (`make crosscheck-suite`): every scene drtlab loads agrees with
Mitsuba's reference image at 32 spp (the tolerance scales with spp: the L1 Mitsuba's own 32-spp
renders have, suite_baseline.json; the channel means' z Sidak-corrected over every scene's three
at ALPHA); a scene drtlab refuses is one line naming the element, listed, not a failure. The pass
rule itself is checked on synthetic images with known noise: an unbiased image passes, a 3% bias
and a biased block are rejected (the negative controls). Skipped where the suite's folder is absent.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from drtlab.experiments.bench.mitsuba import suite, suite_baseline
from drtlab.experiments.stats.hypothesis_tests import sidak
from stats_util import ALPHA

SPP = 32
RUNS = 2        # renders per scene whose mean block L1 is judged (the report's 4 cost make test a minute)
ROOT = suite.suite_dir()
HAVE_SUITE = (ROOT / "tests" / "scenes").is_dir()
JOBS = suite.scenes(ROOT) if HAVE_SUITE else []
# What this version of drtlab loads of the suite (all but various_shapes, whose shapes include an
# sdfgrid): a scene dropping out of
# it is a regression.
REFUSED = {"test_various_shapes_path"}
LOADS = {j["name"] for j in JOBS} - REFUSED


def synthetic(seed: int, spp: int = SPP):
    """A reference with a per-pixel sample variance and one unbiased spp-sample render of it."""
    rng = np.random.default_rng(seed)
    ref = rng.uniform(0.2, 1.0, (48, 64, 3))
    var = rng.uniform(0.1, 2.0, (48, 64, 3))
    image = ref + rng.standard_normal(ref.shape) * np.sqrt(var / spp)
    return image, var, ref


def test_predicted_l1_is_the_l1_of_gaussian_noise():
    _, var, ref = synthetic(1)
    ratios = []
    for seed in range(20):
        noise = np.random.default_rng(seed).standard_normal(ref.shape) * np.sqrt(var / SPP)
        ratios.append(suite.judge(ref + noise, suite.channel_se(var, SPP), SPP, ref, var)["l1_ratio"])
    # 20 independent renders: the mean ratio is 1 within its Monte Carlo error (about 0.005 here).
    assert abs(np.mean(ratios) - 1.0) < 0.03


def test_a_measured_baseline_replaces_the_prediction():
    image, var, ref = synthetic(3)
    se = suite.channel_se(var, SPP)
    predicted = suite.judge(image, se, SPP, ref, var)
    measured = suite.judge(image, se, SPP, ref, var, measured=2 * predicted["mitsuba_l1_predicted"])
    assert measured["mitsuba_l1_source"] == "measured" and predicted["mitsuba_l1_source"] == "predicted"
    assert measured["l1_ratio"] == pytest.approx(predicted["l1_ratio"] / 2, rel=1e-12)


@pytest.mark.skipif(not HAVE_SUITE, reason=f"Mitsuba 3's test scenes are not at {ROOT} "
                                           "(set DRTLAB_MITSUBA_TESTS)")
def test_the_baseline_has_every_scene_and_falls_with_spp():
    """Mitsuba's measured L1 (suite_baseline.json) covers the whole suite at both spp, and every
    scene's falls from 32 to 256 spp (its noise part shrinks by sqrt(8); the reference's stays)."""
    base = suite.read_baseline()
    assert set(base) == set(suite_baseline.SPPS)
    for spp in suite_baseline.SPPS:
        assert set(base[spp]) == {j["name"] for j in JOBS}
    assert all(base[256][n] < base[32][n] for n in base[32])


def test_unbiased_render_agrees_and_biased_ones_do_not():
    image, var, ref = synthetic(2)
    se = suite.channel_se(var, SPP)
    assert suite.judge(image, se, SPP, ref, var)["agrees"]
    biased = suite.judge(image * 1.03, se, SPP, ref, var)          # 3% too bright everywhere
    assert not biased["agrees"] and "mean" in biased["why_not"]
    block = image.copy()
    block[:16, :16] += 0.5                                           # one wrong region
    wrong = suite.judge(block, se, SPP, ref, var)
    assert not wrong["agrees"] and "block L1" in wrong["why_not"]


@pytest.mark.skipif(not HAVE_SUITE, reason=f"Mitsuba 3's test scenes are not at {ROOT} "
                                           "(set DRTLAB_MITSUBA_TESTS)")
@pytest.mark.parametrize("job", JOBS, ids=[j["name"] for j in JOBS])
def test_suite_scene(job):
    # 3 channel means of every scene: a Sidak-corrected z at the suite's family alpha; the rule's 1%
    # is for 256 spp, and a 32-spp render's noise is sqrt(8) times as large (heavy tails make the
    # sample variance low in some renders: roughplastic_nonlinear's B at seed 0, 1.01% and z -5.9)
    row = suite.run_scene(job, SPP, z_tol=float(norm.ppf(1 - sidak(ALPHA, 3 * len(JOBS)) / 2)),
                          rel_tol=suite.REL_TOL * math.sqrt(256 / SPP), runs=RUNS)
    if job["name"] in LOADS:
        assert row["loaded"], row["refusal"]
    if not row["loaded"]:
        assert "\n" not in row["refusal"] and row["refusal"]
        print(f"{job['name']}: refused: {row['refusal']}")
        return
    print(f"{job['name']}: block L1 {row['l1_ratio']:.2f}x Mitsuba's ({row['mitsuba_l1_source']})")
    assert row["agrees"], f"{job['name']}: {row['why_not']}"
    assert all(math.isfinite(c["drtlab"]) for c in row["channels"])


@pytest.mark.skipif(not HAVE_SUITE, reason=f"Mitsuba 3's test scenes are not at {ROOT} "
                                           "(set DRTLAB_MITSUBA_TESTS)")
def test_an_environment_five_percent_too_bright_is_rejected():
    """The negative control on a real scene: the same render with its environment map 5% too bright
    (the scene's main light) must fail the rule that the correct one passes (test_suite_scene)."""
    from drtlab.kernels.imageio import read_linear
    from drtlab.kernels.render import render_with_stats
    job = next(j for j in JOBS if j["name"] == "test_roughplastic_linear_path")
    scene, refusal = suite.load(job)
    assert refusal is None
    scene.environment.image = scene.environment.image * 1.05
    stats = render_with_stats(scene, spp=SPP, sampler=suite.SAMPLER, seed=0, progress=False, variance=True)
    ref, var = (read_linear(job[k])[0][..., :3].astype(np.float64) for k in ("ref", "var"))
    verdict = suite.judge(stats.image, suite.channel_se(stats.variance, SPP), SPP, ref, var)
    assert not verdict["agrees"] and "mean" in verdict["why_not"]


# Mitsuba's own float32 BT.709 matrices (include/mitsuba/core/spectrum.h: srgb_to_xyz; Bitmap's XYZ ->
# RGB conversion uses the inverse one), kept here to reproduce its rounding bit for bit.
MI_SRGB_TO_XYZ = np.array([[0.412453, 0.357580, 0.180423], [0.212671, 0.715160, 0.072169],
                           [0.019334, 0.119193, 0.950227]], np.float32)
MI_XYZ_TO_SRGB = np.array([[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556],
                           [0.055648, -0.204043, 1.057311]], np.float32)
MI_REFERENCE_SPP = 32000     # src/render/tests/test_renders.py: the reference generator's --spp default


def mitsuba_film_mean(rgb, spp: int, dtype=np.float32) -> np.ndarray:
    """The pixel Mitsuba's `moment` film develops from spp identical samples of `rgb`: each sample's
    XYZ (and weight 1) added one after another in `dtype`, divided, converted back to RGB."""
    xyz = (MI_SRGB_TO_XYZ @ np.asarray(rgb, np.float32)).astype(dtype)
    sums = [np.cumsum(np.full(spp, v, dtype), dtype=dtype)[-1] for v in (*xyz, dtype(1.0))]
    return MI_XYZ_TO_SRGB.astype(np.float64) @ (np.array(sums[:3], np.float64) / float(sums[3]))


@pytest.mark.skipif(not HAVE_SUITE, reason=f"Mitsuba 3's test scenes are not at {ROOT} "
                                           "(set DRTLAB_MITSUBA_TESTS)")
def test_orthographic_reference_background_is_float32_rounding_of_one():
    """The orthographic scene's background sees Mitsuba's `constant` emitter directly: radiance 1 in
    every channel (its RGB default, a `uniform` 1), which drtlab renders exactly. Mitsuba's reference
    there reads (1.00108, 0.99971, 0.99970), and that is its film's float32 sum of 32000 identical
    samples (XYZ per sample, the reference generator's spp), reproduced here to 1e-6; the exact mean
    (float64 sums) is 1 to 1e-6, 1e-3 away from the reference in red (the negative control). So the
    reference's background carries a 1e-3 bias no correct renderer (Mitsuba's own at 256 spp
    included) reproduces."""
    from drtlab.kernels.imageio import read_linear
    from drtlab.kernels.render import render_with_stats
    job = next(j for j in JOBS if j["name"] == "test_orthographic_path")
    ref = read_linear(job["ref"])[0][..., :3].astype(np.float64)
    corner = ref[0, 0]
    assert np.abs(ref[:20] - corner).max() < 1e-6           # the whole top band: one value
    assert np.abs(mitsuba_film_mean([1, 1, 1], MI_REFERENCE_SPP) - corner).max() < 1e-6
    exact = mitsuba_film_mean([1, 1, 1], MI_REFERENCE_SPP, np.float64)
    assert np.abs(exact - 1.0).max() < 1e-6 and abs(corner[0] - exact[0]) > 1e-3
    assert np.abs(mitsuba_film_mean([1, 1, 1], 256) - 1.0).max() < 1e-5   # Mitsuba's own 256 spp
    scene, refusal = suite.load(job)
    assert refusal is None
    stats = render_with_stats(scene, spp=4, sampler=suite.SAMPLER, seed=0, progress=False)
    assert np.all(stats.image[:20] == 1.0)
