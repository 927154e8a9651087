"""A finished results folder read back (`drtlab.open_results`, `Summary.from_json`): the same typed
summary, the same tables and figure as the run that wrote it, NaN where the JSON has null; bad
folders are one-line InputErrors naming the path; `result.comparisons` holds one row per sampler
against the baseline at N with a claim."""
from __future__ import annotations

import json
import math
from dataclasses import fields, is_dataclass

import pandas as pd
import pytest

import drtlab
from drtlab.errors import InputError
from drtlab.experiments.files import clean_json
from drtlab.experiments.study.config import load_experiment
from drtlab.experiments.study.results import Summary
from drtlab.experiments.study.runner import run_experiment
from fakes import fake_backend

TINY = """
[experiment]
description = "a tiny analysed sweep on the fake renderer"
seed = 3
spp = [1, 4, 16]
repetitions = 3
resolution = [16, 12]
gt_spp = 1024
gt_batch_spp = 128

[[study]]
name = "strat"
scenes = ["aa-edges", "glossy"]
samplers = ["uniform", "stratified"]
"""
CLAIMS = {"better", "worse", "no difference", "not resolved"}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """(the ExperimentResult of an analysed tiny sweep, its results folder)."""
    tmp = tmp_path_factory.mktemp("open-results")
    (tmp / "tiny.toml").write_text(TINY)
    backend, fake = fake_backend()
    exp = load_experiment(str(tmp / "tiny.toml"), scene_loader=fake.load_scene)
    result = run_experiment(exp, out_dir=tmp / "out", gt_root=tmp / "gt", backend=backend,
                            progress=False, log=lambda m: None, analyze=True)
    return result, tmp / "out"


def same(a, b, where="summary"):
    """Equal field by field, NaN equal to NaN, but None never equal to NaN (a null must come back
    as what it was written from)."""
    if is_dataclass(a):
        assert type(a) is type(b), where
        for f in fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for k in a:
            same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, float) and math.isnan(a):
        assert isinstance(b, float) and math.isnan(b), f"{where}: {b!r} for NaN"
    else:
        assert a == b and (a is None) == (b is None), f"{where}: {a!r} != {b!r}"


def tables(result) -> dict:
    return {"cells": result.cells, "slopes": result.slopes, "comparisons": result.comparisons}


def test_summary_round_trips_through_json(finished):
    result, _ = finished
    summary = result.summary
    back = Summary.from_json(json.loads(json.dumps(clean_json(summary.to_json()))))
    for study, study_back in zip(summary.studies, back.studies):
        for scene, scene_back in zip(study.scenes, study_back.scenes):
            # costs come back as the plain dicts CostModel.to_json wrote (it leaves the covariance out)
            assert scene_back.costs == clean_json({s: m.to_json() for s, m in scene.costs.items()})
            for name in ("cells", "slopes", "comparisons", "speed", "vs_baseline", "efficiency",
                         "noise_floor"):
                same(getattr(scene, name), getattr(scene_back, name), f"{scene.scene}.{name}")
    same(summary.chains, back.chains)
    same(summary.noise_floor, back.noise_floor)
    assert clean_json(back.to_json()) == clean_json(summary.to_json())
    rebuilt = type(result)(stats={}, wall_seconds=0.0, summary=back, out_dir=result.out_dir)
    for name, frame in tables(result).items():
        pd.testing.assert_frame_equal(getattr(rebuilt, name), frame, obj=name)


def test_a_null_comes_back_as_nan(finished):
    # The JSON writer turns NaN into null; a float field reads it back as NaN, an optional one
    # that was None as None.
    result, _ = finished
    data = clean_json(result.summary.to_json())
    scene = data["studies"][0]["scenes"][0]
    scene["comparisons"][0]["speedup"] = None
    scene["cells"][0]["run_rmse"]["mean"] = None
    scene["cells"][0]["seconds_ci"] = None
    back = Summary.from_json(data).studies[0].scenes[0]
    assert math.isnan(back.comparisons[0].speedup) and math.isnan(back.cells[0].rmse.mean)
    assert back.cells[0].seconds_ci is None


def test_open_results_reads_the_folder_without_running(finished, monkeypatch):
    result, out = finished
    from drtlab.experiments.study import runner
    monkeypatch.setattr(runner, "run_experiment", lambda *a, **k: pytest.fail("re-ran the study"))
    opened = drtlab.open_results(out)
    assert opened.out_dir == out
    for name, frame in tables(result).items():
        pd.testing.assert_frame_equal(getattr(opened, name), frame, obj=name)
    pd.testing.assert_frame_equal(opened.runs, result.runs)
    assert clean_json(opened["studies"]) == clean_json(result["studies"])
    manifest = json.loads((out / "manifest.json").read_text())
    assert opened.stats == manifest["runs"]
    assert opened.wall_seconds == manifest["wall_seconds"]["this_invocation"] > 0
    assert len(opened.plot_convergence("strat").axes) >= 2
    pd.testing.assert_frame_equal(drtlab.open_results(out / "summary.json").comparisons,
                                  opened.comparisons)


def test_comparisons_one_row_per_sampler_against_the_baseline_at_each_n(finished):
    frame = drtlab.open_results(finished[1]).comparisons
    for column in ("study", "scene", "sampler", "baseline", "spp", "mse_ratio", "mse_ratio_lo",
                   "mse_ratio_hi", "efficiency", "efficiency_lo", "efficiency_hi", "speedup",
                   "speedup_lo", "speedup_hi", "resolved", "claim", "speedup_resolved",
                   "extrapolated", "target_rmse", "claim_on", "p_adjusted", "mse_claim", "why"):
        assert column in frame.columns, column
    assert len(frame) == 2 * 1 * 3                      # scenes x (samplers - baseline) x spp
    assert set(frame.sampler) == {"stratified"} and set(frame.baseline) == {"uniform"}
    assert set(frame.claim) <= CLAIMS and set(frame.mse_claim) <= CLAIMS
    assert (frame.loc[~frame.resolved, "claim"] == "not resolved").all()
    ok = frame[frame.resolved]
    assert (ok.mse_ratio_lo <= ok.mse_ratio).all() and (ok.mse_ratio <= ok.mse_ratio_hi).all()


def _broken_summary(tmp_path, text: str):
    (tmp_path / "summary.json").write_text(text)
    return tmp_path


@pytest.mark.parametrize("make, says", [
    (lambda tmp: tmp / "missing", "no such folder"),
    (lambda tmp: (tmp / "file.txt").write_text("x") and tmp / "file.txt", "not a folder"),
    (lambda tmp: tmp, "no summary.json"),
    (lambda tmp: _broken_summary(tmp, "{not json"), "does not parse"),
    (lambda tmp: _broken_summary(tmp, '{"experiment": "old", "studies": []}'), "incompatible"),
])
def test_bad_folder_is_one_line_naming_the_path(tmp_path, make, says):
    path = make(tmp_path)
    with pytest.raises(InputError) as e:
        drtlab.open_results(path)
    assert e.value.field == str(path) and says in e.value.message
    assert len(str(e.value).splitlines()) == 1


def test_an_older_summary_names_what_is_missing(finished, tmp_path):
    data = json.loads((finished[1] / "summary.json").read_text())
    del data["studies"][0]["scenes"][1]["cells"][2]["run_rmse"]
    (tmp_path / "summary.json").write_text(json.dumps(data))
    with pytest.raises(InputError) as e:
        drtlab.open_results(tmp_path)
    assert "studies[0].scenes[1].cells[2]: no 'run_rmse'" in e.value.message
    assert "drtlab experiment tiny" in e.value.message and len(str(e.value).splitlines()) == 1


def test_a_results_folder_given_as_an_experiment_points_to_open_results(finished):
    out = finished[1]
    with pytest.raises(InputError) as e:
        drtlab.load_experiment(str(out))
    assert "drtlab.open_results" in e.value.message and len(str(e.value).splitlines()) == 1
