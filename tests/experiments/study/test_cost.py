"""The cost of a cell: a model (per call + per repetition + per sample) fitted to every timed batch
of a sampler, its t interval, its draws and the load-shift test of its residuals; timing-only batches
exactly for the cells whose own batches were too short to time. (How well speed-ups reproduce between
fresh runs is a measurement of the machine, not a test: the closing notes and `make bench` report it.)

Statistical checks: fixed seeds, each at the stated binomial level (two-sided 99.9% bands, so the
file's five checks together falsely fail with probability under 0.5%)."""
import textwrap

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.stats.cost_model import PROCESS_SD, fit_cost_model, load_shift
from drtlab.experiments.study.run_store import MIN_TIMED_SECONDS, load_calibration
from drtlab.experiments.study.config import load_experiment
from drtlab.experiments.study.runner import run_experiment
from fakes import fake_backend

PIXELS = 96 * 72
CALL, REP, SAMPLE = 3e-3, 5e-4, 150e-9


def _batches(rng, noise: float, spp=(1, 4, 16, 64), reps=((107, 107, 106), (27, 27, 26), (10, 10), (3, 2))):
    seconds, r, samples = [], [], []
    # one process factor per sweep (cost_model.PROCESS_SD), then each batch's own noise
    process = rng.lognormal(-0.5 * PROCESS_SD ** 2, PROCESS_SD) if noise else 1.0
    for n, cuts in zip(spp, reps):
        for k in cuts:
            true = CALL + k * (REP + SAMPLE * n * PIXELS)
            seconds.append(true * process * (rng.lognormal(-0.5 * noise ** 2, noise) if noise else 1.0))
            r.append(k)
            samples.append(n * PIXELS)
    return seconds, r, samples


def _band(p: float, n: int, level: float = 0.999) -> tuple[float, float]:
    return stats.binom.ppf((1 - level) / 2, n, p) / n, stats.binom.ppf(1 - (1 - level) / 2, n, p) / n


def test_exact_batches_give_the_exact_model():
    m = fit_cost_model(*_batches(None, 0.0))
    assert m.coef == pytest.approx((CALL, REP, SAMPLE), rel=1e-9)
    # one repetition as the study renders it: its work and its share of its batch's call (N = 64's
    # batches hold 3 and 2 repetitions here: a share of (1/3 + 1/2) / 2)
    share = (1 / 3 + 1 / 2) / 2
    assert m.seconds(64 * PIXELS) == pytest.approx(REP + SAMPLE * 64 * PIXELS + CALL * share, rel=1e-9)
    assert m.seconds(32 * PIXELS) > m.seconds(16 * PIXELS)          # between the ladder's counts
    assert m.dof == 7 and m.batches == 10


def test_terms_the_batches_cannot_separate_leave_the_fit():
    # One sample count and one batch size: only a per-repetition cost is measurable, and the model
    # keeps the per-sample term (the cost at that count is the same either way).
    one = fit_cost_model([1.0, 1.1, 0.9], [2, 2, 2], [1000, 1000, 1000])
    assert one.coef[0] == 0.0 and one.coef[1] == 0.0 and one.coef[2] > 0 and one.dof == 2
    assert one.seconds(1000) == pytest.approx(0.5, rel=0.02)        # relative weights: near the mean
    # Two batch sizes at one sample count: the call overhead separates, the per-repetition term not
    # (the per-sample term carries it); a repetition pays its mean share of a call, (1/2 + 1/4 + 1/2) / 3.
    two = fit_cost_model([1.0 + 2 * 0.5, 1.0 + 4 * 0.5, 1.0 + 2 * 0.5], [2, 4, 2], [1000] * 3)
    assert two.coef[0] == pytest.approx(1.0) and two.coef[1] == 0.0
    assert two.seconds(1000) == pytest.approx(0.5 + 1.0 * (0.5 + 0.25 + 0.5) / 3)


def test_the_cost_interval_covers_at_its_level():
    # 400 sweeps with 2-10% batch noise: the 95% t interval of one repetition's cost at N = 64 covers
    # the true cost within the 99.9% binomial band around 0.95.
    rng = np.random.default_rng(2)
    truth = REP + SAMPLE * 64 * PIXELS + CALL * (1 / 3 + 1 / 2) / 2     # with its share of a call
    hits = 0
    for _ in range(400):
        m = fit_cost_model(*_batches(rng, rng.uniform(0.02, 0.10)))
        lo, hi = m.seconds_interval(64 * PIXELS)
        hits += lo <= truth <= hi
    lo_b, hi_b = _band(0.95, 400)
    assert lo_b <= hits / 400 <= hi_b, hits / 400


def test_cost_draws_match_the_interval():
    m = fit_cost_model(*_batches(np.random.default_rng(3), 0.05))
    d = m.draw_seconds([64 * PIXELS], np.random.default_rng(4), 4000)[:, 0]
    lo, hi = m.seconds_interval(64 * PIXELS)
    inside = float(np.mean((d >= lo) & (d <= hi)))
    assert _band(0.95, 4000)[0] <= inside <= _band(0.95, 4000)[1], inside


def test_a_load_step_is_found_and_a_steady_machine_is_not_flagged():
    rng = np.random.default_rng(5)
    steady = sum(load_shift(np.arange(40), rng.normal(0, 0.05, 40), seed=i)["shifted"] for i in range(200))
    # p < 0.01 by permutation: false alarms within the 99.9% binomial band of 1%
    assert steady / 200 <= _band(0.01, 200)[1], steady
    step = np.r_[rng.normal(0, 0.05, 20), rng.normal(np.log(1.3), 0.05, 20)]
    out = load_shift(np.arange(40), np.expm1(step), seed=0)
    assert out["shifted"] and out["at"] == 20 and out["ratio"] == pytest.approx(1.3, rel=0.05)


TINY = textwrap.dedent("""
    [experiment]
    description = "which cells get timing-only batches"
    seed = 3
    spp = [1, 16384]
    repetitions = 2
    resolution = [16, 12]
    gt_spp = 256
    gt_batch_spp = 64

    [[study]]
    name = "s"
    scenes = ["glossy"]
    samplers = ["uniform", "stratified"]
""")


def test_only_cells_too_short_to_time_get_timing_batches(tmp_path):
    # The fake renderer's time is 1e-7 s per sample + 1e-4 s per render: at 16x12 pixels two runs at
    # 1 spp take 4e-4 s in all (under MIN_TIMED_SECONDS: timing-only batches), two at 16384 spp
    # 0.63 s (timed by their own batches).
    assert MIN_TIMED_SECONDS == 0.2
    p = tmp_path / "t.toml"
    p.write_text(TINY)
    backend, fake = fake_backend()
    exp = load_experiment(str(p), scene_loader=fake.load_scene)
    out = tmp_path / "out"
    result = run_experiment(exp, out_dir=out, gt_root=tmp_path / "gt", backend=backend,
                            progress=False, log=lambda m: None)
    cal = load_calibration(out)
    assert sorted(cal) == sorted(f"glossy__{s}__drt__16x12__spp00001" for s in ("uniform", "stratified"))
    assert all(len(e["seconds"]) == 4 for e in cal.values())
    for c in result.summary.studies[0].scenes[0].cells:
        assert c.timing_below_resolution == (c.spp == 1)
        # the fake costs 1e-4 s per repetition and 1e-7 s per sample: the model fitted to both cells'
        # batches finds both terms exactly
        assert c.seconds == pytest.approx(1e-7 * 192 * c.spp + 1e-4, rel=1e-6)
