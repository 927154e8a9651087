"""What the everyday commands import. `drtlab render` of a small scene, `scenes`, `samplers`, `info`
and `--help` load none of the heavy libraries: each of them costs a tiny render's whole start-up
again (`import colour` alone ~2 s, as colour-science's `__init__` loads matplotlib and scipy), and
the render needs none of them. The listings and the image tools import no Warp either. How long
start-up takes is measured by `make bench` (its `startup` entry), not asserted here. And the `drtlab`
program, which ends its process without Python's teardown (`cli.run`), still delivers all of its
output and the command's exit code."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from drtlab.cli import main

from cli_util import GOOD_SCENE
from repo_paths import DRTLAB

HEAVY = ("colour", "matplotlib", "scipy", "pandas", "pyarrow", "emcee", "dask", "distributed",
         "trimesh")

# Runs one command in a fresh interpreter and reports its exit code and the top-level packages it
# imported; `preload` is imported first (the negative control).
_PROBE = """
import contextlib, io, json, sys
for name in json.loads(sys.argv[2]):
    __import__(name)
from drtlab.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        rc = main(json.loads(sys.argv[1]))
    except SystemExit as e:            # --help
        rc = e.code
print(json.dumps({"rc": rc, "packages": sorted({m.split(".")[0] for m in sys.modules})}))
"""


def imported_by(argv: list[str], preload: tuple[str, ...] = ()) -> set[str]:
    proc = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(argv), json.dumps(preload)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert out["rc"] == 0, proc.stderr
    return set(out["packages"])


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("startup")
    (folder / "good.toml").write_text(GOOD_SCENE)
    from drtlab.kernels.imageio import write_exr
    write_exr(folder / "image.exr", np.full((6, 8, 3), 0.5), {"scene": "s"})
    return folder


def test_a_render_imports_warp_and_nothing_heavy(files):
    out = files / "render.exr"
    packages = imported_by(["render", str(files / "good.toml"), "--spp", "1", "--out", str(out)])
    assert out.is_file() and out.with_suffix(".png").is_file()
    assert "warp" in packages and "OpenImageIO" in packages
    assert packages.isdisjoint(HEAVY), sorted(packages & set(HEAVY))


def test_a_builtin_scene_render_imports_nothing_heavy(files):
    out = files / "aa-edges.exr"
    packages = imported_by(["render", "aa-edges", "--spp", "1", "--res", "16x12", "--out", str(out)])
    assert out.is_file()
    assert packages.isdisjoint(HEAVY), sorted(packages & set(HEAVY))


@pytest.mark.parametrize("argv,warp", [(["scenes"], False), (["samplers"], True),
                                       (["info", "IMAGE"], False), (["--help"], False),
                                       (["render", "--help"], False)])
def test_listings_and_tools_import_nothing_heavy(argv, warp, files):
    # `samplers` reads each point set's description from its module, which defines Warp functions.
    packages = imported_by([str(files / "image.exr") if a == "IMAGE" else a for a in argv])
    assert packages.isdisjoint(HEAVY), sorted(packages & set(HEAVY))
    assert ("warp" in packages) == warp


def test_the_probe_sees_a_heavy_import():
    # The control: the same probe, with matplotlib imported before the command, reports it.
    assert "matplotlib" in imported_by(["scenes"], preload=("matplotlib",))


@pytest.mark.parametrize("argv", [["scenes"], ["samplers"]])
def test_the_program_prints_what_main_prints(argv, capsys):
    assert main(argv) == 0
    expected = capsys.readouterr().out
    proc = subprocess.run([str(DRTLAB), *argv], capture_output=True, text=True, timeout=120)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, expected, "")
