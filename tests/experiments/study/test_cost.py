"""The calibrated render cost reproduces: two fresh runs of one small real-renderer experiment (same
seeds, so bit-identical errors) give speed-ups within ±15% of each other, each inside the other's
95% interval; and the cost model on the fake renderer's synthetic (exactly linear) timings."""
import json
import textwrap

import numpy as np
import pytest

from drtlab.experiments.study.run_store import CostModel, fit_cost_models



def test_cost_model_recovers_a_linear_law():
    pixels, per, over = 192, 2e-8, 3e-3
    recs = {s: [{"spp": n, "width": 16, "height": 12, "render_seconds": over + per * pixels * n}
                for n in (1, 4, 16) for _ in range(3)] for s in ("a", "b")}
    cal = {f"g__{s}": {"spp": 40000, "pixels": pixels, "seconds": [over + per * pixels * 40000] * 4,
                       "low_spp": 1, "low_seconds": [over + per * pixels] * 4} for s in ("a", "b")}
    models = fit_cost_models(recs, cal, "g")
    for m in models.values():
        assert isinstance(m, CostModel) and m.calibrated
        assert m.mean == pytest.approx(per, rel=1e-6) and m.overhead == pytest.approx(over, rel=1e-6)
        assert m.seconds(64) == pytest.approx(over + per * pixels * 64, rel=1e-6)


def test_calibrated_speedups_reproduce(tmp_path):
    from drtlab.experiments.study.backend import default_backend
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.runner import run_experiment
    p = tmp_path / "cost.toml"
    p.write_text(textwrap.dedent("""
        [experiment]
        description = "cost reproducibility"
        seed = 3
        spp = [1, 4, 16]
        repetitions = 2
        resolution = [16, 12]
        gt_spp = 256
        gt_batch_spp = 64

        [[study]]
        name = "imp"
        scenes = ["glossy"]
        samplers = ["uniform", "importance"]
        baseline = "uniform"
    """))
    exp = load_experiment(str(p))
    speeds = []
    for i in range(2):
        out = tmp_path / f"out{i}"
        run_experiment(exp, out_dir=out, gt_root=tmp_path / "gt", backend=default_backend(),
                       threads=2, progress=False, log=lambda m: None)
        speeds.append(json.loads((out / "summary.json").read_text())["studies"][0]["scenes"][0]["speed"])
        assert (out / "calibration.json").is_file()
    (a, b), s = speeds, "importance"
    pa, pb = a["speedup_vs_baseline"][s], b["speedup_vs_baseline"][s]
    assert np.isfinite(pa) and np.isfinite(pb)
    assert abs(pb / pa - 1) <= 0.15, (a, b)
    assert a["speedup_lo"][s] <= pb <= a["speedup_hi"][s], (a, b)
    assert b["speedup_lo"][s] <= pa <= b["speedup_hi"][s], (a, b)
