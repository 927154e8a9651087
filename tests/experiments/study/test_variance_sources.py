"""A study that asks for its scenes' variance decompositions (`variance_sources`): the files, the
report's section, reuse on a rerun, and the setting's bad values."""
from __future__ import annotations

import json

import pytest

import drtlab
from drtlab.errors import InputError

EXPERIMENT = {
    "experiment": {"description": "tiny study with its variance sources", "seed": 5, "spp": [1, 4],
                   "repetitions": 2, "resolution": [16, 12], "gt_spp": 256, "gt_batch_spp": 64,
                   "variance_sources": 8},
    "study": [{"name": "strat", "scenes": ["soft-shadows"], "samplers": ["importance", "stratified+importance"]}],
}


def test_a_study_reports_where_its_scenes_variance_lives(tmp_path):
    out = tmp_path / "out"
    drtlab.run_experiment(EXPERIMENT, name="tiny-sources", out_dir=out, gt_root=tmp_path / "gt",
                          progress=False)
    stem = out / "sources" / "soft-shadows__importance__drt__mse"
    src = json.loads(stem.with_suffix(".json").read_text())
    assert src["samples_per_pixel"] == 8 and src["resolution"] == [16, 12]
    assert src["sampler"] == "pickfreeze+importance"
    light = next(g for g in src["groups"] if g["group"] == "light")
    assert light["total"] > 0.3               # soft shadows: the light's area (0.5 here, 0.9 at 96x72)
    report = (out / "report.md").read_text()
    assert "**Where the variance comes from**" in report
    assert "sources/soft-shadows__importance__drt__mse.png" in report
    assert stem.with_suffix(".png").read_bytes()[:4] == b"\x89PNG"
    before = stem.with_suffix(".json").stat().st_mtime_ns
    drtlab.run_experiment(EXPERIMENT, name="tiny-sources", out_dir=out, gt_root=tmp_path / "gt",
                          progress=False)
    assert stem.with_suffix(".json").stat().st_mtime_ns == before     # reused


@pytest.mark.parametrize("value", [1, 0, "8", 2.5, True])
def test_bad_setting_names_the_field(value):
    bad = {**EXPERIMENT, "experiment": {**EXPERIMENT["experiment"], "variance_sources": value}}
    with pytest.raises(InputError) as e:
        drtlab.load_experiment(bad, "quick", name="bad")
    assert "variance_sources" in e.value.field
