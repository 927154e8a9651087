"""Inputs that ended in a Python traceback, or in a line that named the wrong thing (issue 42): each
now is one `drtlab: FIELD: ...` line, exit code 2, nothing left on disk; and a render whose work is
done is never lost to the writing of its files. Each test failed before its fix."""
from __future__ import annotations

import os
import subprocess

import numpy as np
import pytest

from drtlab.cli import main

from cli_util import GOOD_SCENE, assert_one_line_error, run_bad
from repo_paths import DRTLAB


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "scenes" / "good.toml"
    path.parent.mkdir()
    path.write_text(GOOD_SCENE)
    return path


@pytest.fixture
def out_dir(tmp_path):
    d = tmp_path / "out"
    d.mkdir()
    return d


def _entries(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# ---------------------------------------------------------------------------------------------------
# A seed past 2^31 (the documented range is [0, 2^32 - 1]) crashed writing the EXR's metadata
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [2**31, 2**32 - 1])
def test_a_seed_past_int32_renders_and_reads_back(seed, good, out_dir, capsys):
    from drtlab.kernels.imageio import read_exr
    out = out_dir / "x.exr"
    assert main(["render", str(good), "--seed", str(seed), "--spp", "2", "--out", str(out)]) == 0
    assert _entries(out_dir) == ["x.exr", "x.png"]
    meta = read_exr(out)[1]
    assert meta["seed"] == seed and isinstance(meta["seed"], int)
    assert main(["info", str(out)]) == 0
    assert f"drtlab:seed = {seed}" in capsys.readouterr().out


# ---------------------------------------------------------------------------------------------------
# Output names checked before the render: a sibling that is a folder, a name too long
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("sibling,extra", [("x.png", []), ("x.stderr.exr", ["--variance"]),
                                           ("x.exr", [])])
def test_an_output_name_that_is_a_folder_is_one_line_before_the_render(sibling, extra, good,
                                                                        out_dir, capsys):
    (out_dir / sibling).mkdir()
    run_bad(["render", str(good), "--out", str(out_dir / "x.exr"), *extra], "--out",
            out_dir / sibling, capsys)
    assert _entries(out_dir) == [sibling]


@pytest.mark.parametrize("name", ["a" * 300 + ".exr", "a" * 252 + ".exr", "b" * 300 + "/x.exr"])
def test_a_file_name_too_long_is_one_line(name, good, out_dir, capsys):
    # 256 bytes is one over the limit; the control below writes a name of 255.
    run_bad(["render", str(good), "--out", str(out_dir / name)], "--out", out_dir, capsys)


def test_a_long_name_that_fits_is_written_without_temporary_files(good, out_dir, capsys):
    name = "a" * 251 + ".exr"          # 255 bytes: the file system's limit, its temporary name less
    assert main(["render", str(good), "--out", str(out_dir / name)]) == 0
    assert _entries(out_dir) == sorted([name, name[:-4] + ".png"])


def test_export_checks_every_mesh_file_before_writing(tmp_path, out_dir, capsys):
    scene = tmp_path / "meshes.toml"
    disks = "".join('\n[[shapes]]\nkind = "mesh"\nmaterial = "grey"\ngenerate = "disk"\n' for _ in range(2))
    scene.write_text(GOOD_SCENE.replace("spp = 1", 'spp = 1\nintegrator = "path"') + disks)
    (out_dir / "x-mesh3.ply").mkdir()        # shapes 0 and 1 are the sphere and the light
    run_bad(["export", str(scene), str(out_dir / "x.xml")], "OUT", out_dir / "x-mesh3.ply", capsys)
    assert _entries(out_dir) == ["x-mesh3.ply"]
    (out_dir / "x-mesh3.ply").rmdir()
    assert main(["export", str(scene), str(out_dir / "x.xml")]) == 0
    assert _entries(out_dir) == ["x-mesh2.ply", "x-mesh3.ply", "x.xml"]
