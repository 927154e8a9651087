"""The cost of a cell: the mean over its batches of each batch's seconds per repetition (the faster
half), with a t interval and the systematic term; timing-only batches exactly for the cells whose
own batches were too short to time, and then those timings instead. (How well speed-ups reproduce
between fresh runs is a measurement of the machine, not a test: `make bench` reports it.)"""
import math
import textwrap

import numpy as np
import pytest

from drtlab.experiments.study.run_store import (MIN_TIMED_SECONDS, SYSTEMATIC, CellTiming,
                                                cell_timing, load_calibration)
from drtlab.experiments.study.config import load_experiment
from drtlab.experiments.study.runner import run_experiment
from fakes import fake_backend


def recs(per_batch: dict) -> list:
    """Records of one cell: batch id -> (seconds per repetition, repetitions)."""
    return [{"batch": b, "cpu_seconds": s, "render_seconds": 2 * s, "batch_reps": n}
            for b, (s, n) in per_batch.items() for _ in range(n)]


def test_a_cell_costs_the_mean_of_its_faster_batches():
    # Load from other jobs only slows a batch down: the faster half of the batches measures it.
    t = cell_timing(recs({"a": (1.0, 3), "b": (1.2, 3), "c": (5.0, 2), "d": (1.1, 3)}), None, cpu=True)
    assert not t.calibrated and sorted(t.samples) == [1.0, 1.1]
    assert t.mean == pytest.approx(1.05)
    h = t.t_halfwidth()
    sd = np.std([1.0, 1.1], ddof=1) / math.sqrt(2)
    from scipy import stats
    assert h == pytest.approx(math.hypot(stats.t.ppf(0.975, 1) * sd, SYSTEMATIC * 1.05))
    # wall clock: the records' render seconds
    assert cell_timing(recs({"a": (1.0, 2), "b": (1.0, 2)}), None, cpu=False).mean == 2.0
    # one batch: no t interval, the systematic term alone
    one = cell_timing(recs({"a": (0.5, 4)}), None, cpu=True)
    assert one.t_halfwidth() == pytest.approx(SYSTEMATIC * 0.5)


def test_timing_only_batches_replace_the_cell_s_own():
    entry = {"seconds": [0.30, 0.31, 0.9, 0.32], "clock": "cpu"}
    t = cell_timing(recs({"a": (0.001, 2)}), entry, cpu=True)
    assert t.calibrated and t.mean == pytest.approx(0.305)


def test_cost_draws_follow_the_interval():
    t = CellTiming(np.array([1.0, 1.1, 0.9, 1.05]))
    rng = np.random.default_rng(0)
    d = np.array([t.draw(rng) for _ in range(4000)])
    lo, hi = t.mean - t.t_halfwidth(), t.mean + t.t_halfwidth()
    inside = np.mean((d >= lo) & (d <= hi))
    assert 0.9 <= inside <= 0.99, inside            # about 95% of draws inside the 95% interval


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
        # a batch of the fake costs 1e-4 s per render and 1e-7 s per sample, shared over its runs
        assert c.seconds == pytest.approx(1e-7 * 192 * c.spp + 1e-4)
