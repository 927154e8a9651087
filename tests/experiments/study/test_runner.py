"""The experiment runner end to end: on the fake renderer (known error laws, deterministic), resume
after an interruption or a `kill -9` (batches are the commit unit: the table stays whole), and once
on the real renderer with a tiny scene."""
import csv
import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path
import time

import numpy as np
import pytest

from drtlab.experiments.study.config import load_experiment
from repo_paths import SUPPORT
from fakes import fake_backend, tiny_real_experiment
from drtlab.experiments.study.run_store import CSV_COLUMNS, TIMING_COLUMNS, first_image, load_records
from drtlab.experiments.study.output_dir import RECORD
from drtlab.experiments.study.runner import plan_runs, run_experiment

TINY = """
[experiment]
description = "tiny sweep on the fake renderer"
seed = 11
spp = [1, 4, 16, 64]
repetitions = 3
resolution = [16, 12]
gt_spp = 8192
gt_batch_spp = 1024

[[study]]
name = "strat"
scenes = ["aa-edges", "glossy"]
samplers = ["uniform", "stratified"]
"""


class Clock:
    """Deterministic stand-in for time.perf_counter: every call advances by 0.5 s (exact in binary)."""

    def __init__(self):
        self.t = 0.0

    def __call__(self):
        self.t += 0.5
        return self.t


def tiny_experiment(tmp_path, text=TINY):
    p = tmp_path / "tiny.toml"
    p.write_text(text)
    _, fake = fake_backend()
    return load_experiment(str(p), scene_loader=fake.load_scene)


def run(exp, out, gt, fake_kw=None, analyze=False, **kw):
    backend, fake = fake_backend(**(fake_kw or {}))
    s = run_experiment(exp, out_dir=out, gt_root=gt, backend=backend, progress=False,
                       clock=Clock(), log=lambda m: None, analyze=analyze, **kw)
    return s, fake


def test_the_sweep_compiles_every_variant_it_needs_first(tmp_path):
    # One precompile call before any render, with each (scene, sampler, integrator) the plan and its
    # ground truths need exactly once; its facts reach the manifest.
    from dataclasses import replace
    from drtlab.experiments.study.ground_truth import GT_SAMPLER
    exp = tiny_experiment(tmp_path)
    backend, fake = fake_backend()
    seen = []

    def precompile(jobs, threads):
        seen.append(([(scene.name, sampler, integ) for scene, sampler, integ in jobs], fake.calls))
        return {"variants": len(jobs), "compiled": 0, "wall_seconds": 1.5, "compile_seconds": 0.0,
                "threads": 2}

    run_experiment(exp, out_dir=tmp_path / "out", gt_root=tmp_path / "gt",
                   backend=replace(backend, precompile=precompile), progress=False, clock=Clock(),
                   log=lambda m: None, analyze=True)
    assert len(seen) == 1 and seen[0][1] == 0           # once, before the first render
    want = {(scene, sampler, "drt") for scene in ("aa-edges", "glossy")
            for sampler in ("uniform", "stratified", GT_SAMPLER)}
    assert sorted(seen[0][0]) == sorted(want)
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert m["runs"]["kernel_precompile"]["variants"] == 6
    # The metrics' kernels are compiled (or loaded) then too, and their seconds count as compiling.
    metric_s = m["runs"]["kernel_precompile"]["metric_kernels_seconds"]
    assert metric_s > 0 and abs(m["wall_seconds"]["kernel_precompile"] - (1.5 + metric_s)) < 2e-3


REL_STUDY = """
[[study]]
name = "rel"
scenes = ["glossy"]
samplers = ["uniform", "stratified"]
metric = "relmse"
"""


def test_end_to_end_on_fake_renderer(tmp_path, monkeypatch):
    from drtlab.experiments.study import noise_floor, runner
    monkeypatch.setattr(runner, "FLUSH_SECONDS", 0.0)         # a commit after every batch
    # A noisy reference, 8 stratified batches of 128 spp: what its subtraction leaves is ~4-6% of the
    # narrowest cell's half-width, so a 2% limit trips (below) and the warning reaches the report.
    monkeypatch.setattr(noise_floor, "NOISE_FLOOR_SHARE", 0.02)
    tiny = TINY.replace("gt_spp = 8192\ngt_batch_spp = 1024", "gt_spp = 1024\ngt_batch_spp = 128")
    exp = tiny_experiment(tmp_path, tiny + REL_STUDY)        # the second study shares its runs
    out, gt = tmp_path / "out", tmp_path / "gt"
    s, fake = run(exp, out, gt, analyze=True)
    for name in ("runs.csv", "summary.json", "report.md", "manifest.json"):
        assert (out / name).is_file(), name
    rows = list(csv.DictReader(open(out / "runs.csv")))
    assert len(rows) == 2 * 2 * 4 * 3 and tuple(rows[0]) == CSV_COLUMNS
    assert len({r["run_id"] for r in rows}) == len(rows)
    summary = json.loads((out / "summary.json").read_text())
    for sc in summary["studies"][0]["scenes"]:
        for sampler, truth in (("uniform", -0.5), ("stratified", -0.75)):
            f = sc["slopes"][sampler]
            assert f["ok"] and f["converged"]
            assert f["slope_lo"] - 0.03 <= truth <= f["slope_hi"] + 0.03, (sc["scene"], sampler, f)
        assert sc["speed"]["speedup_vs_baseline"]["stratified"] > 1.5
        assert sc["efficiency"]["stratified"]["relative"] > 2
        assert len(sc["cells"]) == 8
        c = sc["cells"][0]
        assert {"run_rmse", "run_relmse", "run_mae", "run_ciede2000", "rmse_of_mean_mse", "bias",
                "pixel_variance", "efficiency"} <= set(c)
        assert c["run_rmse"]["lo"] <= c["run_rmse"]["mean"] <= c["run_rmse"]["hi"]
    rel = summary["studies"][1]
    assert rel["metric"] == "relmse" and rel["scenes"][0]["cells"][0]["study_error"] == \
        rel["scenes"][0]["cells"][0]["rrmse_of_mean_relmse"]
    f = rel["scenes"][0]["slopes"]["stratified"]
    assert f["slope_lo"] - 0.03 <= -0.75 <= f["slope_hi"] + 0.03
    assert summary["chains"]["converged"] == summary["chains"]["fits"] == 6
    # Commits in mid-group write plain npz; every cell file is compressed once its group is done.
    import zipfile
    cell_files = list((out / "cells").glob("*.npz"))
    assert len(cell_files) == 2 * 2 * 4 and all(
        i.compress_type == zipfile.ZIP_DEFLATED for f in cell_files for i in zipfile.ZipFile(f).infolist())
    # The stratified runs at 64 spp are narrower than the 1024-spp reference's noise allows at 2%.
    assert summary["warnings"] and "ground-truth variance" in summary["warnings"][0]
    plots = sorted(p.name for p in (out / "plots").iterdir())
    assert plots == [f"{s}-{k}.png" for s in ("rel", "strat")
                     for k in ("efficiency", "rmse-vs-seconds", "rmse-vs-spp")]
    assert sorted(p.name for p in (out / "images").iterdir()) == [
        "rel--glossy.png", "strat--aa-edges.png", "strat--glossy.png"]
    report = (out / "report.md").read_text()
    assert "![strat: RMSE vs samples per pixel](plots/strat-rmse-vs-spp.png)" in report
    assert "images/strat--aa-edges.png" in report and "noise floor" in report
    assert "relative RMSE" in report
    m = json.loads((out / "manifest.json").read_text())
    assert {"git", "packages", "machine", "seeds", "wall_seconds"} <= set(m)
    assert m["packages"]["emcee"] and m["seeds"]["roots"] == {"strat": 11, "rel": 11}
    # The table is one Parquet file whose rows are runs.csv's; each cell keeps its first
    # repetition's image, which that run's seed reproduces alone.
    import pandas as pd
    table = pd.read_parquet(out / "runs.parquet")
    assert list(table["run_id"]) == [r["run_id"] for r in rows]
    assert np.allclose(table["mse"], [float(r["mse"]) for r in rows], rtol=0, atol=0)
    r0 = next(r for r in rows[4:] if r["rep"] == "0")
    img = fake.render(fake.load_scene(r0["scene"]), spp=int(r0["spp"]), sampler=r0["sampler"],
                      integrator="drt", seed=int(r0["seed"]), res=(16, 12)).image
    cell = table.set_index("run_id").loc[r0["run_id"], "cell"]
    assert np.array_equal(first_image(out, cell), img.astype(np.float32).astype(np.float64))
    # Files: the table, one array file per cell, and the few outputs; no file per run.
    assert len(list((out / "cells").iterdir())) == 2 * 2 * 4 and not (out / "runs").exists()

    # A rerun renders nothing and rewrites the same runs.csv.
    before = (out / "runs.csv").read_bytes()
    s2, fake2 = run(exp, out, gt)
    assert fake2.calls == 0
    assert (out / "runs.csv").read_bytes() == before


def test_resume_after_interruption_gives_the_same_runs_csv(tmp_path):
    exp = tiny_experiment(tmp_path)
    ref_out, gt = tmp_path / "ref", tmp_path / "gt"
    run(exp, ref_out, gt)
    reference = (ref_out / "runs.csv").read_bytes()

    out = tmp_path / "out"
    committed = 0
    for stop in (5, 17, 12):                       # interrupted three times, mid-batch
        with pytest.raises(KeyboardInterrupt):
            run(exp, out, gt, fake_kw={"fail_after": stop})
        done = load_records(out)
        # An interrupted batch commits nothing: whole batches of the renders done before the stop.
        assert committed < len(done) <= committed + stop
        committed = len(done)
    _, fake = run(exp, out, gt)
    assert fake.calls == 48 - committed
    assert (out / "runs.csv").read_bytes() == reference


KILL_SCRIPT = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, sys.argv[5])                # tests/, where the fakes live
    from drtlab.experiments.study.config import load_experiment
    from fakes import fake_backend
    from drtlab.experiments.study.runner import run_experiment
    backend, fake = fake_backend()
    slow = fake.render
    def render(*a, **k):
        time.sleep(float(sys.argv[4]))
        return slow(*a, **k)
    backend.render = render                        # Backend.batch renders a batch through it
    class Clock:
        t = 0.0
        def __call__(self):
            self.t += 0.5
            return self.t
    exp = load_experiment(sys.argv[1], scene_loader=fake.load_scene)
    run_experiment(exp, out_dir=sys.argv[2], gt_root=sys.argv[3], backend=backend, progress=False,
                   clock=Clock(), log=lambda m: None, analyze=False)
""")


def test_kill_9_mid_sweep_then_resume(tmp_path):
    exp_path = tmp_path / "tiny.toml"
    exp_path.write_text(TINY)
    exp = tiny_experiment(tmp_path)
    ref, gt = tmp_path / "ref", tmp_path / "gt"
    run(exp, ref, gt)                              # also makes the ground truth
    script = tmp_path / "sweep.py"
    script.write_text(KILL_SCRIPT)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, str(script), str(exp_path), str(out), str(gt), "0.02",
                             str(SUPPORT)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.time() + 60
    while time.time() < deadline:
        if len(load_records(out)) >= 12:
            break
        assert proc.poll() is None, proc.stderr.read()
        time.sleep(0.01)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    # Whatever is on disk reads back: a whole table, every committed run once, and the cell files of
    # every committed batch (a batch whose cell file the kill stopped is not counted).
    done = load_records(out)
    assert 12 <= len(done) < 48
    _, fake = run(exp, out, gt)
    assert fake.calls == 48 - len(done)
    assert (out / "runs.csv").read_bytes() == (ref / "runs.csv").read_bytes()
    import pandas as pd
    a, b = pd.read_parquet(out / "runs.parquet"), pd.read_parquet(ref / "runs.parquet")
    assert a.drop(columns=list(TIMING_COLUMNS)).equals(b.drop(columns=list(TIMING_COLUMNS)))
    assert not [p for d in (out, out / "cells") for p in d.iterdir()
                if p.name.startswith(".") and p.name not in (".lock", RECORD)]   # no temp file left


def test_fresh_starts_over_and_keeps_ground_truth(tmp_path):
    exp = tiny_experiment(tmp_path)
    out, gt = tmp_path / "out", tmp_path / "gt"
    run(exp, out, gt)
    _, fake = run(exp, out, gt, fresh=True)
    assert fake.calls == 48                        # every run again, no ground-truth batch


def test_plan_dedupes_runs_shared_between_studies(tmp_path):
    text = TINY + '\n[[study]]\nname = "again"\nscenes = ["glossy"]\nsamplers = ["stratified"]\n'
    exp = tiny_experiment(tmp_path, text)
    backend, _ = fake_backend()
    plan = plan_runs(exp, backend)
    assert len(plan) == 48
    shared = [r for r in plan if r.scene.label == "glossy" and r.sampler == "stratified"]
    assert shared and all(r.studies == ("strat", "again") for r in shared)


# --------------------------------------------------------------------------------------------

def test_real_renderer_tiny_scene_end_to_end(tmp_path):
    p = tmp_path / "real.toml"
    p.write_text(tiny_real_experiment("real renderer, tiny", ["soft-shadows"]))
    exp = load_experiment(str(p))
    out, gt = tmp_path / "out", tmp_path / "gt"
    from drtlab.experiments.study.backend import default_backend
    s = run_experiment(exp, out_dir=out, gt_root=gt, backend=default_backend(), threads=2,
                       progress=False, log=lambda m: None)
    rows = list(csv.DictReader(open(out / "runs.csv")))
    assert len(rows) == 2 * 2 * 2
    assert all(float(r["rmse"]) > 0 and np.isfinite(float(r["ciede2000"])) for r in rows)
    assert all(np.isfinite(float(r["flip"])) == (r["rep"] == "0") for r in rows)     # flip_runs: 1
    assert all(float(r["render_seconds"]) > 0 for r in rows)
    for name in ("summary.json", "report.md", "manifest.json", "images/soft-shadows.png"):
        assert (out / name).is_file(), name
    assert "## Where the runs rendered\n\n`local`: 8 runs." in (out / "report.md").read_text()
    gt_dirs = list(gt.iterdir())
    assert len(gt_dirs) == 1
    man = json.loads((gt_dirs[0] / "manifest.json").read_text())
    from drtlab.experiments.study.ground_truth import GT_SAMPLER
    assert man["spp"] == 256 and man["estimator"]["sampler"] == GT_SAMPLER
    assert (gt_dirs[0] / "mean.exr").is_file() and (gt_dirs[0] / "stderr.exr").is_file()
    from drtlab.kernels import CODE_VERSION
    assert man["code_version"] == CODE_VERSION
    assert s["studies"][0]["scenes"][0]["cells"][0]["run_rmse"]["mean"] > 0


def test_a_second_sweep_into_the_same_folder_is_refused(tmp_path):
    from drtlab.experiments.study.output_dir import lock_output
    from drtlab.errors import InputError
    exp = tiny_experiment(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    held = lock_output(out)
    try:
        with pytest.raises(InputError) as e:
            run(exp, out, tmp_path / "gt")
        assert e.value.field == "--out"
    finally:
        held.close()
    run(exp, out, tmp_path / "gt")


def test_colour_difference_and_flip_of_the_first_runs_of_each_cell_only(tmp_path):
    # colour_difference_runs = 2, flip_runs = 1: CIEDE2000 for repetitions 0 and 1 of every cell,
    # FLIP for repetition 0 (NaN after them), every other metric for all; the cells' means come from
    # those runs, and the report's cell table shows both.
    exp = tiny_experiment(tmp_path, TINY.replace("repetitions = 3",
                                                 "repetitions = 3\ncolour_difference_runs = 2\nflip_runs = 1"))
    out = tmp_path / "out"
    run(exp, out, tmp_path / "gt", analyze=True)
    rows = list(csv.DictReader(open(out / "runs.csv")))
    assert len(rows) == 2 * 2 * 4 * 3
    for r in rows:
        assert np.isfinite(float(r["ciede2000"])) == (int(r["rep"]) < 2), r["run_id"]
        assert np.isfinite(float(r["flip"])) == (int(r["rep"]) < 1), r["run_id"]
        assert np.isfinite(float(r["mse"])) and np.isfinite(float(r["mae"]))
    assert all(0 < float(r["flip"]) < 1 for r in rows if r["rep"] == "0")
    summary = json.loads((out / "summary.json").read_text())
    assert all(c["run_ciede2000"]["n"] == 2 and c["run_flip"]["n"] == 1 and c["run_mse"]["n"] == 3
               for sc in summary["studies"][0]["scenes"] for c in sc["cells"])
    assert "| MAE | ΔE00 | FLIP | Bias (mean error) |" in (out / "report.md").read_text()


def test_an_image_too_large_for_the_machine_is_refused_before_anything_is_written(tmp_path):
    from drtlab.errors import InputError
    exp = tiny_experiment(tmp_path, TINY.replace("resolution = [16, 12]", "resolution = [100000, 100000]"))
    with pytest.raises(InputError) as e:
        run(exp, tmp_path / "out", tmp_path / "gt")
    assert e.value.field == "resolution (study strat, scene aa-edges)" and "100000x100000" in e.value.message
    assert not (tmp_path / "out").exists() and not (tmp_path / "gt").exists()


def test_a_sweep_says_what_it_will_do_before_it_starts_and_at_each_scene(tmp_path):
    """Without a progress bar (output to a file), the log is the only sign of life: the plan first,
    then a line per scene, then the analysis."""
    exp = tiny_experiment(tmp_path)
    lines = []
    backend, _ = fake_backend()
    run_experiment(exp, out_dir=tmp_path / "out", gt_root=tmp_path / "gt", backend=backend, progress=False,
                   clock=Clock(), log=lines.append, analyze=True)
    assert lines[0].startswith(f"{exp.name} (quick): 48 runs in 16 cells of 2 scene(s)")
    scenes = [i for i, x in enumerate(lines) if "its reference, then" in x]
    assert [lines[i].split(" ")[0] for i in scenes] == ["aa-edges", "glossy"]
    assert any(x.startswith("analysis:") for x in lines[scenes[-1]:])


def test_repetitions_beyond_a_cells_limit_are_refused_at_load(tmp_path):
    from drtlab.errors import InputError
    with pytest.raises(InputError) as e:
        tiny_experiment(tmp_path, TINY.replace("repetitions = 3", "repetitions = 100000000"))
    assert e.value.field == "experiment.repetitions" and "at most 4096" in e.value.message
