"""Inputs that ended in a Python traceback, or in a line that named the wrong thing (issue 42): each
now is one `drtlab: FIELD: ...` line, exit code 2, nothing left on disk; and a render whose work is
done is never lost to the writing of its files. Each test failed before its fix."""
from __future__ import annotations

import json
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


def _bad(argv, field, out_dir, capsys) -> str:
    """`run_bad`'s checks (one line naming `field`, exit 2, nothing written); the line."""
    rc = main(argv)
    captured = capsys.readouterr()
    assert rc == 2 and captured.out == "", captured
    assert_one_line_error(captured.err, field)
    assert list(out_dir.iterdir()) == []
    return captured.err


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


# ---------------------------------------------------------------------------------------------------
# Deep nesting: RecursionError in the TOML parser, the XML reader, the messages
# ---------------------------------------------------------------------------------------------------

def _nested(depth: int) -> str:
    return "[" * depth + "1" + "]" * depth


@pytest.mark.parametrize("depth", [100, 3000])
def test_a_deeply_nested_set_value_is_one_line(depth, good, out_dir, capsys):
    run_bad(["render", str(good), "--set", f"camera.fov={_nested(depth)}", "--out",
             str(out_dir / "x.exr")], "--set", out_dir, capsys)


@pytest.mark.parametrize("depth", [100, 3000])
def test_a_deeply_nested_scene_file_is_one_line(depth, tmp_path, out_dir, capsys):
    scene = tmp_path / "deep.toml"
    scene.write_text(GOOD_SCENE.replace("radius = 0.5", f"radius = {_nested(depth)}"))
    run_bad(["render", str(scene), "--out", str(out_dir / "x.exr")], "scene", out_dir, capsys)


def test_a_deeply_nested_xml_scene_is_one_line(tmp_path, out_dir, capsys):
    scene = tmp_path / "deep.xml"
    scene.write_text('<scene version="3.0.0">' + "<a>" * 5000 + "</a>" * 5000 + "</scene>")
    run_bad(["render", str(scene), "--out", str(out_dir / "x.exr")], "scene", out_dir, capsys)


def test_a_deeply_nested_experiment_file_is_one_line(tmp_path, out_dir, capsys):
    exp = tmp_path / "deep.toml"
    exp.write_text(f'[experiment]\ndescription = "d"\nx = {_nested(3000)}\n')
    run_bad(["experiment", str(exp), "--out", str(out_dir / "e")], "deep.toml", out_dir, capsys)


def test_nesting_within_the_limit_reaches_the_field_check(good, out_dir, capsys):
    # The control: a list nested a few levels is still judged by the field it is given to.
    run_bad(["render", str(good), "--set", f"camera.fov={_nested(3)}", "--out",
             str(out_dir / "x.exr")], "camera.fov", out_dir, capsys)


# ---------------------------------------------------------------------------------------------------
# Existing things called missing; files of the wrong kind
# ---------------------------------------------------------------------------------------------------

@pytest.fixture
def things(tmp_path):
    """A folder, a FIFO and a text file, each under a name that suits every use."""
    d = tmp_path / "things"
    d.mkdir()
    for name in ("folder", "folder.obj", "folder.exr", "folder.py", "folder.toml"):
        (d / name).mkdir()
    for name in ("fifo", "fifo.obj", "fifo.exr", "fifo.toml"):
        os.mkfifo(d / name)
    (d / "notes.txt").write_text("hello\n")
    return d


@pytest.mark.parametrize("argv,field,words", [
    (["render", "/dev/null"], "scene", "is a device"),
    (["render", "{d}/folder"], "scene", "is a folder"),
    (["render", "{d}/fifo.toml"], "scene", "is a FIFO"),
    (["render", ""], "scene", "got ''"),
    (["info", "{d}/folder"], "FILE", "is a folder"),
    (["info", "{d}/fifo"], "FILE", "is a FIFO"),
    (["info", "/dev/null"], "FILE", "is a device"),
    (["info", ""], "FILE", "got ''"),
    (["compare", "{d}/fifo.exr", "{d}/folder.exr"], "A", "is a FIFO"),
    (["render", "GOOD", "--set", 'shapes[0]={kind="mesh",material="grey",file="{d}/folder.obj"}'],
     "shapes[0].file", "is a folder"),
    (["render", "GOOD", "--set", 'shapes[0]={kind="mesh",material="grey",file="{d}/fifo.obj"}'],
     "shapes[0].file", "is a FIFO"),
    (["render", "GOOD", "--set", 'environment={kind="image",file="{d}/folder.exr"}'],
     "environment.file", "is a folder"),
    # A FIFO as an environment map waited for a writer for ever.
    (["render", "GOOD", "--set", 'environment={kind="image",file="{d}/fifo.exr"}'],
     "environment.file", "is a FIFO"),
    (["scenes", "--plugin", "{d}/folder.py"], "--plugin", "is a folder"),
    (["scenes", "--plugin", "{d}/notes.txt"], "--plugin", "not a Python file"),
    (["scenes", "--plugin", "os.nothing"], "--plugin", "no plugin module"),
])
def test_a_thing_that_is_no_file_of_its_kind_says_what_it_is(argv, field, words, things, good,
                                                              out_dir, capsys):
    argv = [a.replace("{d}", str(things)).replace("GOOD", str(good)) for a in argv]
    err = _bad([*argv, *(["--out", str(out_dir / "x.exr")] if argv[0] == "render" else [])], field,
               out_dir, capsys)
    assert words in err and "does not exist" not in err


@pytest.mark.parametrize("content,words", [
    (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\x90\xff\xfe f 1 2 3\n", "not UTF-8"),
])
def test_a_binary_obj_is_named_as_such(content, words, tmp_path, good, out_dir, capsys):
    mesh = tmp_path / "garbage.obj"
    mesh.write_bytes(content)
    err = _bad(["render", str(good), "--set", f'shapes[0]={{kind="mesh",material="grey",file="{mesh}"}}',
                "--out", str(out_dir / "x.exr")], "shapes[0].file", out_dir, capsys)
    assert words in err


PLY_HEAD = (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            b"property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n")


@pytest.mark.parametrize("content", [PLY_HEAD + b"0 0 0\n1 0", PLY_HEAD.replace(b"property float y\n", b"")
                                     + b"0\n1\n2\n3 0 1 2\n"])
def test_a_truncated_or_corrupt_ply_says_so(content, tmp_path, good, out_dir, capsys):
    mesh = tmp_path / "broken.ply"
    mesh.write_bytes(content)
    err = _bad(["render", str(good), "--set", f'shapes[0]={{kind="mesh",material="grey",file="{mesh}"}}',
                "--out", str(out_dir / "x.exr")], "shapes[0].file", out_dir, capsys)
    assert "not a readable PLY file, truncated or corrupt" in err


# ---------------------------------------------------------------------------------------------------
# compare: images of 1 and 2 channels, output names
# ---------------------------------------------------------------------------------------------------

@pytest.fixture
def images(tmp_path):
    from drtlab.kernels.imageio import write_exr
    d = tmp_path / "images"
    d.mkdir()
    for name, channels in (("rgb", 3), ("two", 2), ("two2", 2), ("grey", 1)):
        write_exr(d / f"{name}.exr", np.full((12, 16, channels), 0.5))
    return d


@pytest.mark.parametrize("a,b,field", [("two", "two2", "A"), ("rgb", "two", "B"), ("two", "rgb", "A")])
def test_compare_of_a_two_channel_image_says_how_many_channels(a, b, field, images, out_dir, capsys):
    err = _bad(["compare", str(images / f"{a}.exr"), str(images / f"{b}.exr"), "--out-dir",
                str(out_dir)], field, out_dir, capsys)
    assert "2 channels" in err and "resolution" not in err


def test_compare_reads_a_grey_image_as_r_g_b(images, out_dir, capsys):
    assert main(["compare", str(images / "grey.exr"), str(images / "rgb.exr"), "--out-dir",
                 str(out_dir)]) == 0
    assert "RMSE 0," in capsys.readouterr().out
    assert _entries(out_dir) == ["grey-vs-rgb.diff.exr", "grey-vs-rgb.error.png"]


def test_compare_checks_its_output_names_before_the_work(images, out_dir, capsys):
    (out_dir / "rgb-vs-grey.error.png").mkdir()
    _bad(["compare", str(images / "rgb.exr"), str(images / "grey.exr"), "--out-dir", str(out_dir)],
         "--out-dir", out_dir / "rgb-vs-grey.error.png", capsys)
    assert _entries(out_dir) == ["rgb-vs-grey.error.png"]


# ---------------------------------------------------------------------------------------------------
# check --out into a folder that does not exist yet
# ---------------------------------------------------------------------------------------------------

def test_check_writes_its_card_into_a_new_folder(tmp_path, monkeypatch, capsys):
    from drtlab.experiments.checks import light_selection
    from drtlab.experiments.checks.scorecard import Line, Scorecard
    # The scorecard itself is not the point (it takes 30 s): the write after it is, which raised
    # FileNotFoundError once the whole card was done.
    card = Scorecard("uniform", 0.01, 0, [Line("pmf sums to 1", True, "1")])
    monkeypatch.setattr(light_selection, "check", lambda name, seed, level: card)
    out = tmp_path / "new" / "deeper" / "card.txt"
    assert main(["check", "uniform", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["name"] == "uniform"
    assert _entries(out.parent) == ["card.txt"]


def test_check_refuses_a_folder_as_its_card_before_the_work(tmp_path, monkeypatch, out_dir, capsys):
    from drtlab.experiments.checks import light_selection
    monkeypatch.setattr(light_selection, "check", lambda *a, **k: pytest.fail("the check ran"))
    (out_dir / "card.json").mkdir()
    _bad(["check", "uniform", "--out", str(out_dir / "card.json")], "--out", out_dir / "card.json",
         capsys)


# ---------------------------------------------------------------------------------------------------
# The process's surroundings: Warp's cache folder, closed or full standard streams
# ---------------------------------------------------------------------------------------------------

def _program(argv, redirect: str, tmp_path, env=None) -> tuple[int, str, str]:
    """(exit code, stdout, stderr) of the drtlab program under a shell redirection of its streams."""
    import shlex
    report = tmp_path / "rc.txt"
    out, err = tmp_path / "stdout.txt", tmp_path / "stderr.txt"
    line = " ".join(shlex.quote(a) for a in [str(DRTLAB), *argv])
    script = f"{{ {line} {redirect}; echo $? > {shlex.quote(str(report))}; }} > {out} 2> {err}"
    subprocess.run(["bash", "-c", script], timeout=300, env=env or os.environ.copy(), check=True)
    return int(report.read_text()), out.read_text(), err.read_text()


@pytest.mark.parametrize("cache", ["a-file", "a-file/below", "/proc/no-such-folder"])
def test_an_unusable_warp_cache_is_one_line(cache, good, tmp_path, out_dir):
    (tmp_path / "a-file").write_text("not a folder")
    path = cache if cache.startswith("/") else str(tmp_path / cache)
    env = dict(os.environ, WARP_CACHE_PATH=path)
    rc, out, err = _program(["render", str(good), "--out", str(out_dir / "x.exr")], "", tmp_path, env)
    assert rc == 2 and out == ""
    assert_one_line_error(err, "WARP_CACHE_PATH")
    assert list(out_dir.iterdir()) == []


@pytest.mark.parametrize("argv", [["scenes"], ["render", "GOOD", "--out", "OUT/x.exr"], ["--version"]])
def test_a_closed_stdout_is_refused_before_the_work(argv, good, tmp_path, out_dir):
    argv = [a.replace("GOOD", str(good)).replace("OUT", str(out_dir)) for a in argv]
    rc, out, err = _program(argv, ">&-", tmp_path)
    assert rc == 2
    assert_one_line_error(err, "stdout")
    assert list(out_dir.iterdir()) == []


@pytest.mark.parametrize("argv", [["scenes"], ["info", "IMAGE"], ["render", "GOOD", "--out", "OUT/x.exr"],
                                  ["--version"], ["--help"], ["render", "--help"]])
def test_a_full_stdout_is_one_line_and_keeps_the_work(argv, good, images, tmp_path, out_dir):
    argv = [a.replace("GOOD", str(good)).replace("OUT", str(out_dir))
            .replace("IMAGE", str(images / "rgb.exr")) for a in argv]
    rc, out, err = _program(argv, "> /dev/full", tmp_path)
    assert rc == 2
    assert_one_line_error(err, "stdout")
    assert "No space left" in err
    if argv[0] == "render" and "--help" not in argv:
        assert _entries(out_dir) == ["x.exr", "x.png"]


@pytest.mark.parametrize("redirect", ["2>&-", "2> /dev/full"])
def test_a_broken_stderr_keeps_errors_off_stdout_and_the_exit_code(redirect, tmp_path, good, out_dir):
    rc, out, err = _program(["render", "no-such-scene", "--out", str(out_dir / "x.exr")], redirect,
                            tmp_path)
    assert (rc, out) == (2, "")
    # The control: a good render under the same stderr writes its files and says so on stdout.
    rc, out, err = _program(["render", str(good), "--out", str(out_dir / "x.exr")], redirect, tmp_path)
    assert rc == 0 and out.startswith("wrote ") and _entries(out_dir) == ["x.exr", "x.png"]


MITSUBA_HEAD = ('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">'
                '<integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>')


@pytest.mark.parametrize("element,thing,words", [
    ('<shape type="ply"><string name="filename" value="{f}"/></shape>', "folder.ply", "is a folder"),
    ('<shape type="ply"><string name="filename" value="{f}"/></shape>', "fifo.ply", "is a FIFO"),
    ('<emitter type="envmap"><string name="filename" value="{f}"/></emitter>', "folder.exr", "is a folder"),
    ('<emitter type="envmap"><string name="filename" value="{f}"/></emitter>', "fifo.exr", "is a FIFO"),
])
def test_a_mitsuba_file_reference_that_is_no_file_says_what_it_is(element, thing, words, things,
                                                                   tmp_path, out_dir, capsys):
    if not (things / thing).exists():
        (things / thing).mkdir() if thing.startswith("folder") else os.mkfifo(things / thing)
    scene = things / "scene.xml"
    scene.write_text(MITSUBA_HEAD + element.format(f=thing) + "</scene>")
    err = _bad(["render", str(scene), "--out", str(out_dir / "x.exr")], "scene.xml", out_dir, capsys)
    assert words in err and "does not exist" not in err


@pytest.mark.parametrize("thing,words", [("folder", "is a folder"), ("fifo", "is a FIFO"),
                                         ("fifo.toml", "is a FIFO"), ("/dev/null", "is a device")])
@pytest.mark.parametrize("how", ["argument", "include"])
def test_an_experiment_file_that_is_no_file_says_what_it_is(thing, words, how, things, tmp_path,
                                                            out_dir, capsys):
    path = thing if thing.startswith("/") else str(things / thing)
    if how == "include":
        exp = tmp_path / "outer.toml"
        exp.write_text(f'[experiment]\ndescription = "d"\ninclude = ["{path}"]\n')
        field, path = "experiment.include[0]", str(exp)
    else:
        field = "experiment"
    err = _bad(["experiment", path, "--out", str(out_dir / "e")], field, out_dir, capsys)
    assert words in err and "no experiment file" not in err


def test_a_binary_included_experiment_is_named_once(tmp_path, out_dir, capsys):
    (tmp_path / "binary.toml").write_bytes(b"\xba\xff\x00 not text")
    exp = tmp_path / "outer.toml"
    exp.write_text('[experiment]\ndescription = "d"\ninclude = ["binary.toml"]\n')
    err = _bad(["experiment", str(exp), "--out", str(out_dir / "e")], "binary.toml", out_dir, capsys)
    assert "binary.toml:binary.toml" not in err and "UTF-8" in err


@pytest.mark.parametrize("argv,name", [
    (["pointset", "sobol", "--n", "64"], "scatter.png"),
    (["pointset", "sobol", "--n", "64"], "manifest.json"),
    (["lobe", "diffuse"], "lobe.json"),
    (["sources", "GOOD", "--spp", "8"], "sources.png"),
])
def test_a_folder_output_whose_file_is_a_folder_is_one_line_before_the_work(argv, name, good,
                                                                             out_dir, capsys):
    (out_dir / name).mkdir()
    argv = [str(good) if a == "GOOD" else a for a in argv]
    _bad([*argv, "--out", str(out_dir)], "--out", out_dir / name, capsys)
    assert _entries(out_dir) == [name]


def test_a_write_that_fails_after_the_render_keeps_the_image(good, out_dir, tmp_path, monkeypatch,
                                                             capsys):
    import errno
    import tempfile

    from drtlab.kernels import imageio
    from drtlab.kernels.imageio import read_exr

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(imageio, "write_png", full)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    rc = main(["render", str(good), "--spp", "4", "--out", str(out_dir / "x.exr")])
    err = capsys.readouterr().err
    assert rc == 2
    assert_one_line_error(err, "--out")
    assert "No space left" in err and "the render is kept in" in err
    rescued = err.split("the render is kept in ")[1].strip()
    assert read_exr(rescued)[1]["spp"] == 4 and rescued.startswith(str(tmp_path))


@pytest.mark.parametrize("argv,field", [
    (["scenes", "--plugin", "LONG.py"], "--plugin"),
    (["scenes", "--plugin", "LONG"], "--plugin"),
    (["experiment", "LONG.toml"], "experiment"),
    (["experiment", "LONG"], "experiment"),
    (["render", "LONG.toml"], "scene"),
    (["info", "LONG.exr"], "FILE"),
])
def test_an_input_name_too_long_is_one_line(argv, field, out_dir, capsys, monkeypatch):
    monkeypatch.chdir(out_dir)
    argv = [a.replace("LONG", "l" * 260) for a in argv]
    _bad(argv, field, out_dir, capsys)


@pytest.mark.parametrize("command", ["render", "check"])
def test_an_output_that_is_a_fifo_is_refused_not_replaced(command, good, out_dir, monkeypatch, capsys):
    # It was renamed over: `check --out /dev/null` run as root replaced the device with a file.
    from drtlab.experiments.checks import light_selection
    monkeypatch.setattr(light_selection, "check", lambda *a, **k: pytest.fail("the check ran"))
    fifo = out_dir / "out.exr"
    os.mkfifo(fifo)
    argv = ["render", str(good)] if command == "render" else ["check", "uniform"]
    rc = main([*argv, "--out", str(fifo)])
    captured = capsys.readouterr()
    assert rc == 2 and captured.out == ""
    assert_one_line_error(captured.err, "--out")
    assert "not a regular file" in captured.err
    assert _entries(out_dir) == ["out.exr"] and not fifo.is_file()
