"""The CLI on bad input: exactly one line on stderr naming the field, exit code 2, nothing written
(no .exr, no .png, no temporary file). Plus `drtlab scenes` and `drtlab samplers` listings."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from drtlab.estimators.integrators import INTEGRATORS
from drtlab.estimators.registry import POINTSETS, PRESETS
from drtlab.estimators.strategies import STRATEGIES
from drtlab.cli import main
from drtlab.kernels.scene_model.scene_file import builtin_names

from cli_util import GOOD_SCENE, assert_one_line_error, run_bad

from repo_paths import REPO, DRTLAB

# name -> scene file text (each a single mistake in GOOD_SCENE), expected field
BAD_SCENES = {
    "malformed-toml": (GOOD_SCENE.replace("radius = 0.5", "radius = = 0.5"), "scene"),
    "missing-field": (GOOD_SCENE.replace("radius = 0.5\n", ""), "shapes[0].radius"),
    "wrong-type": (GOOD_SCENE.replace("radius = 0.5", 'radius = "big"'), "shapes[0].radius"),
    "nan-parameter": (GOOD_SCENE.replace("radius = 0.5", "radius = nan"), "shapes[0].radius"),
    "inf-parameter": (GOOD_SCENE.replace("center = [0.0, 0.5, 0.0]", "center = [0.0, inf, 0.0]"),
                      "shapes[0].center"),
    "zero-area-light": (GOOD_SCENE.replace("edge_v = [0.0, 0.0, 1.0]", "edge_v = [2.0, 0.0, 0.0]"),
                        "shapes[1].edge_v"),
    "unknown-key": (GOOD_SCENE.replace("radius = 0.5", "radius = 0.5\nradios = 0.5"),
                    "shapes[0].radios"),
}


@pytest.fixture
def folders(tmp_path):
    """(scene folder with good.toml and the bad scenes, an empty output folder)."""
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (scenes / "good.toml").write_text(GOOD_SCENE)
    for name, (text, _) in BAD_SCENES.items():
        (scenes / f"{name}.toml").write_text(text)
    out = tmp_path / "out"
    out.mkdir()
    return scenes, out


# (extra argv, expected field); every case renders `good.toml` unless it names another scene
CLI_CASES = {
    "unknown-scene": (["no-such-scene"], "scene"),
    "missing-scene-file": (["{scenes}/nope.toml"], "scene"),
    "unknown-sampler": (["{good}", "--sampler", "sobel"], "sampler"),
    "bad-sampler-combination": (["{good}", "--sampler", "independent+magic"], "sampler"),
    "unknown-integrator": (["{good}", "--integrator", "bdpt"], "integrator"),
    "spp-zero": (["{good}", "--spp", "0"], "--spp"),
    "spp-negative": (["{good}", "--spp", "-3"], "--spp"),
    "spp-not-a-number": (["{good}", "--spp", "abc"], "--spp"),
    "seed-negative": (["{good}", "--seed", "-1"], "--seed"),
    "threads-zero": (["{good}", "--threads", "0"], "--threads"),
    "res-zero": (["{good}", "--res", "0x5"], "--res"),
    "res-garbage": (["{good}", "--res", "big"], "--res"),
    "res-three-parts": (["{good}", "--res", "4x4x4"], "--res"),
    "device-tpu": (["{good}", "--device", "tpu"], "device"),
    "unknown-filter-estimator": (["{good}", "--sampler", "stratified+splatter"], "sampler"),
    "unknown-filter": (["{good}", "--set", "camera.filter=lanczos"], "camera.filter"),
    "filter-with-whitted": (["{good}", "--set", "camera.filter=gaussian", "--integrator", "whitted"],
                            "camera.filter"),
    **{f"scene-{name}": ([f"{{scenes}}/{name}.toml"], field) for name, (_, field) in BAD_SCENES.items()},
}


@pytest.mark.parametrize("case", list(CLI_CASES))
def test_bad_render_input(case, folders, capsys):
    scenes, out_dir = folders
    extra, field = CLI_CASES[case]
    extra = [a.format(scenes=scenes, good=scenes / "good.toml") for a in extra]
    out = out_dir / "frame.exr"
    run_bad(["render", *extra, "--out", str(out)], field, out_dir, capsys)
    assert not out.exists() and not out.with_suffix(".png").exists()


@pytest.mark.parametrize("suffix", [".png", ".exr.tmp", ""])
def test_bad_out_suffix(suffix, folders, capsys):
    scenes, out_dir = folders
    out = out_dir / f"frame{suffix}"
    run_bad(["render", str(scenes / "good.toml"), "--out", str(out)], "--out", out_dir, capsys)
    assert not out.exists()


def test_unknown_subcommand(folders, capsys):
    _, out_dir = folders
    run_bad(["frobnicate"], "command", out_dir, capsys)


def test_missing_subcommand_and_scene(folders, capsys):
    _, out_dir = folders
    run_bad([], "command", out_dir, capsys)
    run_bad(["render"], "scene", out_dir, capsys)


def test_unknown_option(folders, capsys):
    scenes, out_dir = folders
    rc = main(["render", str(scenes / "good.toml"), "--bogus", "3"])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.splitlines()) == 1 and "--bogus" in err and "Traceback" not in err
    assert "unknown option" in err


def test_a_value_too_many_is_named_as_such(folders, capsys):
    """`--res 32 24` (for 32x24): the stray 24 is no option, and the line says which it is."""
    scenes, out_dir = folders
    rc = main(["render", str(scenes / "good.toml"), "--res", "32", "24", "--out", str(out_dir / "x.exr")])
    err = capsys.readouterr().err
    assert rc == 2 and list(out_dir.iterdir()) == []
    assert_one_line_error(err, "24")
    assert "unexpected argument" in err and "unknown option" not in err, err


def test_good_input_writes_the_files(folders, capsys):
    # The control for the cases above: the same command line without the mistake succeeds.
    scenes, out_dir = folders
    out = out_dir / "frame.exr"
    # 16 samples: at the scene's 1, some seeds' 8 x 6 images of its small light are zero everywhere,
    # which the render rightly warns about (no warning is the point here).
    assert main(["render", str(scenes / "good.toml"), "--out", str(out), "--res", "8x6",
                 "--spp", "16"]) == 0
    assert capsys.readouterr().err == ""
    assert sorted(p.name for p in out_dir.iterdir()) == ["frame.exr", "frame.png"]


def _subprocess_env():
    return dict(os.environ, WARP_CACHE_PATH=os.environ.get("WARP_CACHE_PATH",
                                                           str(REPO / ".warp-cache")))


@pytest.mark.parametrize("argv,field", [
    (["render", "{scenes}/nan-parameter.toml", "--out", "{out}/frame.exr"], "shapes[0].radius"),
    (["render", "{scenes}/good.toml", "--spp", "abc", "--out", "{out}/frame.exr"], "--spp"),
])
def test_real_process_exit_code_and_single_stderr_line(argv, field, folders):
    scenes, out_dir = folders
    argv = [a.format(scenes=scenes, out=out_dir) for a in argv]
    proc = subprocess.run([str(DRTLAB), *argv], capture_output=True, text=True, timeout=120,
                          env=_subprocess_env(), cwd=out_dir)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert_one_line_error(proc.stderr, field)
    assert list(out_dir.iterdir()) == []


# ---------------------------------------------------------------------------------------------------
# Listings
# ---------------------------------------------------------------------------------------------------

def first_words(text: str) -> list[str]:
    return [line.split()[0] for line in text.splitlines() if line.strip()]


def test_scenes_lists_all_builtins(capsys):
    assert main(["scenes"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    names = first_words(captured.out)
    assert names and len(set(names)) == len(names)
    assert names == builtin_names()


def test_samplers_lists_every_point_set_and_strategy(capsys):
    assert main(["samplers"]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    words = first_words(captured.out)
    for name in [*POINTSETS, *STRATEGIES, *PRESETS, *INTEGRATORS]:
        assert name in words, f"{name} missing from `drtlab samplers`"
    # Each in its own section.
    sections = {}
    current = None
    for line in captured.out.splitlines():
        if not line.startswith(" "):
            current = line.split(":")[0]
            sections[current] = []
        elif line.strip():
            sections[current].append(line.split()[0])
    assert sections["point sets"] == list(POINTSETS)
    assert sections["strategies"] == list(STRATEGIES)
    assert sections["integrators"] == list(INTEGRATORS)


def test_samplers_states_each_point_sets_measured_draw_cost(capsys):
    # Every registered set has a measured cost (a new set needs `profile_kernels pointsets --write`),
    # and the listing states it on the set's line, marking the ones above draw_costs.CHEAP.
    from drtlab.estimators import draw_costs
    ratio = draw_costs.load()["ratio"]
    assert set(ratio) == set(POINTSETS) and ratio["independent"] == 1.0
    assert main(["samplers"]) == 0
    listing = capsys.readouterr().out.split("\nstrategies:")[0]
    lines = {line.split()[0]: line for line in listing.splitlines() if line.startswith("  ")}
    for name, r in ratio.items():
        note = f"draw {r:.1f}x independent"
        assert note in lines[name], (name, lines[name])
        assert ("(above 3x)" in lines[name]) == (r > draw_costs.CHEAP), lines[name]
        # A set above it says why (PointSet.cost_note), and the reason shows only there.
        why = POINTSETS[name].cost_note
        assert why or r <= draw_costs.CHEAP, f"{name} costs {r}x and says not why"
        if why:
            assert (f"(above 3x): {why}" in lines[name]) == (r > draw_costs.CHEAP), lines[name]
