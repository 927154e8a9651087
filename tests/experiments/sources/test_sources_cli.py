"""`drtlab sources SCENE`: its files and table, the Python API's DataFrame, and bad input (one line
naming the flag, exit 2, nothing written)."""
from __future__ import annotations

import json

import pytest
from cli_util import run_bad

import drtlab
from drtlab.cli import main
from drtlab.estimators.dimensions import GROUPS


def test_writes_the_table_json_and_figure(tmp_path, capsys):
    out = tmp_path / "ss"
    assert main(["sources", "soft-shadows", "--spp", "8", "--res", "24x18", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert all(f"  {g} " in printed for g in GROUPS) and "1 - sum S" in printed
    summary = json.loads((out / "sources.json").read_text())
    assert [r["group"] for r in summary["groups"]] == list(GROUPS)
    assert summary["samples_per_pixel"] == 8 and summary["resolution"] == [24, 18]
    assert (out / "sources.png").read_bytes()[:4] == b"\x89PNG"
    assert json.loads((out / "manifest.json").read_text())["what"] == "drtlab sources"


def test_python_api_returns_one_row_per_group():
    df = drtlab.variance_sources("soft-shadows", spp=4, res=(16, 12), groups=["light", "pixel"])
    assert list(df["group"]) == ["pixel", "light"]
    assert {"first_order", "first_order_lo", "first_order_hi", "total", "total_lo", "total_hi"} <= set(df)


@pytest.mark.parametrize("argv, field", [
    (["sources", "nosuch"], "scene"),
    (["sources", "dof", "--groups", "pixel,shutter"], "--groups"),
    (["sources", "dof", "--groups", "pixel,pixel"], "--groups"),
    (["sources", "dof", "--spp", "1"], "--spp"),
    (["sources", "dof", "--seed", "-1"], "--seed"),
    (["sources", "dof", "--res", "0x4"], "--res"),
    (["sources", "dof", "--strategy", "magic"], "--strategy"),
    (["sources", "dof", "--metric", "rmse"], "--metric"),
    (["sources", "dof", "--integrator", "whitted"], "integrator"),
    (["sources", "dof", "--integrator", "kajiya"], "integrator"),
])
def test_bad_input(argv, field, tmp_path, capsys):
    run_bad(argv + ["--out", str(tmp_path / "o")], field, tmp_path, capsys)
