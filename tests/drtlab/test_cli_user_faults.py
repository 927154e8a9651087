"""What a new user tripped on (issue 20): a velocity under a closed shutter, tracebacks on a closed
pipe, compare across encodings, sampler names, colliding default output names, small output faults.
Each test failed before its fix."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from drtlab.cli import main

from cli_util import GOOD_SCENE


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(GOOD_SCENE)
    return path


def _warnings(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.startswith("drtlab: warning:")]


@pytest.mark.parametrize("shutter,warned", [(None, True), ("[0.5, 0.5]", True), ("[0.0, 1.0]", False)])
def test_velocity_under_a_closed_shutter_warns_once(shutter, warned, good, tmp_path, capsys):
    argv = ["render", str(good), "--spp", "1", "--out", str(tmp_path / "x.exr"),
            "--set", "shapes[0].velocity=[0.5, 0.0, 0.0]"]
    if shutter is not None:
        argv += ["--set", f"camera.shutter={shutter}"]
    assert main(argv) == 0
    lines = _warnings(capsys.readouterr().err)
    assert len(lines) == (1 if warned else 0), lines
    if warned:
        assert "velocity" in lines[0] and "camera.shutter" in lines[0]


def test_static_scene_has_no_shutter_warning(good, tmp_path, capsys):
    assert main(["render", str(good), "--spp", "1", "--out", str(tmp_path / "x.exr")]) == 0
    assert _warnings(capsys.readouterr().err) == []


def test_scene_format_states_the_loaders_shutter_default():
    from drtlab.kernels.scene_file import scene_from_dict
    from repo_paths import REPO
    text = (REPO / "kernels" / "SCENE_FORMAT.md").read_text()
    line = next(x for x in text.splitlines() if x.startswith("shutter ="))
    documented = eval(line.split("=", 1)[1].split("#")[0])
    scene = scene_from_dict({"scene": {"description": "d"},
                             "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
                             "materials": {"m": {}},
                             "shapes": [{"kind": "sphere", "material": "m", "center": [0, 0, 0],
                                         "radius": 1}]})
    assert list(scene.camera.shutter) == documented


# ---------------------------------------------------------------------------------------------------
# A reader that closes the pipe early (`drtlab scenes | head -1`)
# ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def small_exr(tmp_path_factory):
    from drtlab.kernels.imageio import write_exr
    path = tmp_path_factory.mktemp("pipe") / "x.exr"
    write_exr(path, np.full((4, 6, 3), 0.25), {"scene": "s"})
    return path


@pytest.mark.parametrize("argv", [["scenes"], ["samplers"], ["info", "EXR"], ["render", "--help"],
                                  ["--help"]])
def test_a_closed_pipe_ends_quietly(argv, small_exr):
    from repo_paths import DRTLAB
    argv = [str(small_exr) if a == "EXR" else a for a in argv]
    # The read end is closed before the command writes a byte: its first write or flush fails.
    p = subprocess.Popen([str(DRTLAB), *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    rc = p.wait(timeout=120)
    assert err == "", err
    assert rc in (0, 141)           # argparse's help swallows the error itself and exits 0


# ---------------------------------------------------------------------------------------------------
# compare and info across encodings
# ---------------------------------------------------------------------------------------------------

def _rmse(out: str) -> float:
    return float(out.split("RMSE ")[1].split(",")[0])


def test_compare_png_with_its_exr_is_quantisation_only(tmp_path, capsys):
    from drtlab.kernels.imageio import write_exr, write_png
    rng = np.random.default_rng(3)
    img = rng.random((12, 16, 3))               # within [0, 1]: nothing clips in the PNG
    write_exr(tmp_path / "a.exr", img)
    write_png(tmp_path / "a.png", img)
    assert main(["compare", str(tmp_path / "a.png"), str(tmp_path / "a.exr"),
                 "--out-dir", str(tmp_path / "cmp")]) == 0
    rmse = _rmse(capsys.readouterr().out)
    # 8-bit sRGB codes: half a code step in the brightest channel is 0.5 / 255 * 2.4 ~ 0.005 linear.
    assert rmse < 0.004, rmse
    assert main(["compare", str(tmp_path / "a.png"), str(tmp_path / "a.png"),
                 "--out-dir", str(tmp_path / "cmp")]) == 0
    assert _rmse(capsys.readouterr().out) == 0.0


def test_info_says_the_files_real_pixel_type(tmp_path, capsys):
    from drtlab.kernels.imageio import write_exr, write_png
    img = np.full((3, 4, 3), 0.5)
    write_exr(tmp_path / "a.exr", img)
    write_png(tmp_path / "a.png", img)
    assert main(["info", str(tmp_path / "a.png")]) == 0
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert "uint8" in first and "sRGB" in first and "float32" not in first, first
    mean = float(out.splitlines()[2].split()[3])
    assert abs(mean - 0.5) < 0.003, "info shows the linear values a PNG encodes"
    assert main(["info", str(tmp_path / "a.exr")]) == 0
    assert "(float32)" in capsys.readouterr().out.splitlines()[0]
