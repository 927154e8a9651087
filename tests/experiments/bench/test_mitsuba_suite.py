"""Mitsuba 3's own render-test scenes (`make crosscheck-suite`): every scene drtlab loads agrees with
Mitsuba's reference image at 32 spp (the tolerance scales with spp: the L1 Mitsuba's own 32-spp
renders have, suite_baseline.json); a scene drtlab refuses is one line naming the element, listed, not a failure. The pass
rule itself is checked on synthetic images with known noise: an unbiased image passes, a 3% bias
and a biased block are rejected (the negative controls). Skipped where the suite's folder is absent.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from drtlab.experiments.bench.mitsuba import suite, suite_baseline

SPP = 32
ROOT = suite.suite_dir()
HAVE_SUITE = (ROOT / "tests" / "scenes").is_dir()
JOBS = suite.scenes(ROOT) if HAVE_SUITE else []
# What this version of drtlab loads of the suite: a scene dropping out of it is a regression.
LOADS = {"test_roughdielectric_path", "test_roughplastic_linear_path",
         "test_roughplastic_nonlinear_path", "test_directional_direct", "scene_path",
         "test_instancing_path", "test_texture_interp_direct", "test_textured_diffuse_path",
         "test_orthographic_path"}


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
    row = suite.run_scene(job, SPP)
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
