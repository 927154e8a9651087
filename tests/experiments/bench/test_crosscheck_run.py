"""`make crosscheck` without Mitsuba: its XML test scenes load in drtlab, its scene list, its bad
flags (one line, exit 2, before any render) and its skip path (no mitsuba importable, or no LLVM 19:
one line saying why, a JSON saying skipped, exit 0). No renderer runs here."""
import importlib.util
import json
from pathlib import Path

import pytest
from cli_util import assert_one_line_error

from drtlab.experiments.bench.mitsuba import crosscheck

XML_SCENES = sorted(crosscheck.SCENE_DIR.glob("*.xml"))


def test_the_scene_folder_holds_the_test_scenes():
    assert crosscheck.SCENE_DIR == Path(__file__).resolve().parents[2] / "data" / "mitsuba"
    assert len(XML_SCENES) >= 4


@pytest.mark.parametrize("path", XML_SCENES, ids=lambda p: p.stem)
def test_every_xml_test_scene_loads_small_in_drtlab(path):
    from drtlab.kernels.scene_model.scene_file import load_scene
    s = load_scene(path)
    assert s.integrator in ("path", "direct") and s.width * s.height <= 64 * 48 and s.shapes


def test_the_scene_list_is_the_exportable_built_ins_and_the_xml_files(tmp_path):
    args = crosscheck.build_parser().parse_args(["--out-dir", str(tmp_path)])
    args.builtin_res = (48, 48)
    jobs = crosscheck._scenes(args)
    built_in = [j["name"] for j in jobs if j["overrides"] is not None]
    from drtlab.kernels.scene_model.scene_file import builtin_names
    assert "cornell-box" in built_in
    assert "drt-showcase" in builtin_names() and "drt-showcase" not in built_in   # drt: Mitsuba lacks it
    assert [j["xml"] for j in jobs if j["overrides"] is None] == XML_SCENES


@pytest.mark.parametrize("argv, flag", [
    (["--seeds", "1"], "--seeds"),
    (["--only", "no-such-scene"], "--only"),
    (["--scene-dir", "/no/such/folder"], "--scene-dir"),
    (["--builtin-res", "wide"], "--builtin-res"),
])
def test_bad_flag_is_one_line(capsys, tmp_path, argv, flag):
    out = tmp_path / "out"
    assert crosscheck.main(argv + ["--out-dir", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, flag)
    assert not out.exists()


def _hide_or_fake_mitsuba(monkeypatch, present: bool):
    real = importlib.util.find_spec

    def find_spec(name, *a, **k):
        if name == "mitsuba":
            return importlib.machinery.ModuleSpec("mitsuba", None) if present else None
        return real(name, *a, **k)
    monkeypatch.setattr(importlib.util, "find_spec", find_spec)


@pytest.mark.parametrize("present, why", [
    (False, "mitsuba is not installed"),
    (True, "needs LLVM 19: DRJIT_LIBLLVM_PATH=/no/such/libLLVM-19.so does not exist"),
])
def test_without_mitsuba_or_llvm_it_says_why_and_exits_0(capsys, monkeypatch, tmp_path, present, why):
    _hide_or_fake_mitsuba(monkeypatch, present)
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/no/such/libLLVM-19.so")
    assert crosscheck.main(["--only", "cornell-box", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1 and out[0].startswith("crosscheck: skipped: ") and why in out[0]
    result = json.loads((tmp_path / "crosscheck.json").read_text())
    assert result["skipped"] is True and why in result["reason"]
    assert [s["name"] for s in result["settings"]["scenes"]] == ["cornell-box"]
    assert not (tmp_path / "crosscheck.md").exists()
