"""The Python API on bad arguments (issue 42): an `InputError` naming the argument, as the docstrings
promise, and nothing created first; not a TypeError, ValueError, AttributeError or OSError from deep
inside. Each case failed before its fix."""
from __future__ import annotations

import os

import numpy as np
import pytest

import drtlab
from drtlab.errors import InputError

IMAGE = np.full((4, 6, 3), 0.25)


@pytest.fixture
def here(tmp_path, monkeypatch):
    """An empty working folder: relative paths land in it, and nothing may be left there."""
    d = tmp_path / "cwd"
    d.mkdir()
    monkeypatch.chdir(d)
    return d


@pytest.mark.parametrize("call,argument", [
    (lambda: drtlab.write_exr("sub/a.exr", np.zeros((4, 4))), "image"),
    (lambda: drtlab.write_exr("sub/a.exr", np.zeros((1, 4, 4, 3))), "image"),
    (lambda: drtlab.write_exr("sub/a.exr", None), "image"),
    (lambda: drtlab.write_exr("sub/a.exr", np.zeros((0, 0, 3))), "image"),
    (lambda: drtlab.write_exr("sub/a.exr", np.array([["a", "b"]], dtype=object)[..., None]), "image"),
    (lambda: drtlab.write_exr(42, IMAGE), "path"),
    (lambda: drtlab.write_exr(None, IMAGE), "path"),
    (lambda: drtlab.write_exr("sub/a", IMAGE), "path"),
    (lambda: drtlab.write_exr("sub/a.png", IMAGE), "path"),
    (lambda: drtlab.write_exr("sub/" + "a" * 300 + ".exr", IMAGE), "path"),
    (lambda: drtlab.write_exr("sub/a.exr", IMAGE, 42), "metadata"),
    (lambda: drtlab.write_exr("sub/a.exr", IMAGE, {1: "x"}), "metadata"),
    (lambda: drtlab.read_exr(42), "path"),
    (lambda: drtlab.read_exr("missing.exr"), "path"),
    (lambda: drtlab.run_experiment(42), "experiment"),
    (lambda: drtlab.load_experiment(42), "experiment"),
    (lambda: drtlab.load_experiment(None), "experiment"),
    (lambda: drtlab.open_results(None), "path"),
    (lambda: drtlab.open_results(42), "path"),
    (lambda: drtlab.open_results(""), "path"),
    (lambda: drtlab.run_experiment("stratified", out_dir=42), "out_dir"),
    (lambda: drtlab.run_experiment("stratified", out_dir="r", gt_root=42), "gt_root"),
])
def test_a_bad_argument_is_an_input_error_naming_it(call, argument, here):
    with pytest.raises(InputError) as e:
        call()
    assert e.value.field == argument, e.value
    assert list(here.iterdir()) == [], "nothing may be created before the argument is checked"


def test_a_folder_or_fifo_is_named_as_such(here):
    (here / "folder.exr").mkdir()
    os.mkfifo(here / "fifo.exr")
    with pytest.raises(InputError, match="is a folder") as e:
        drtlab.write_exr(here / "folder.exr", IMAGE)
    assert e.value.field == "path"
    with pytest.raises(InputError, match="is a folder"):
        drtlab.read_exr(here / "folder.exr")
    with pytest.raises(InputError, match="is a FIFO"):     # reading one waited for a writer for ever
        drtlab.read_exr(here / "fifo.exr")
    assert sorted(p.name for p in here.iterdir()) == ["fifo.exr", "folder.exr"]


@pytest.mark.parametrize("value", [2**31, 2**32 - 1, 2**40, -2**31 - 1, -2**63, 2**31 - 1, -2**31])
def test_integer_metadata_of_any_size_reads_back_exactly(value, tmp_path):
    path = tmp_path / "a.exr"
    drtlab.write_exr(path, IMAGE, {"n": value, "seed": 7, "name": "x"})
    pixels, meta = drtlab.read_exr(path)
    assert meta == {"n": value, "seed": 7, "name": "x"}
    assert isinstance(meta["n"], int)
    assert np.array_equal(pixels, IMAGE.astype(np.float32))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr"]


def test_a_single_channel_image_writes_as_h_w_1(tmp_path):
    # The control for the shape cases: (H, W, 1) is the way to write one channel.
    drtlab.write_exr(tmp_path / "a.exr", np.full((4, 6, 1), 0.5))
    assert drtlab.read_exr(tmp_path / "a.exr")[0].shape == (4, 6, 1)


def test_a_failed_write_leaves_no_temporary_file(tmp_path, monkeypatch):
    import OpenImageIO as oiio
    monkeypatch.setattr(oiio.ImageOutput, "create", staticmethod(lambda name: None))
    with pytest.raises(OSError):
        drtlab.write_exr(tmp_path / "a.exr", IMAGE)
    assert list(tmp_path.iterdir()) == []


def _deep_list(depth: int) -> list:
    out = inner = []
    for _ in range(depth):
        inner.append([])
        inner = inner[0]
    return out


def _deep_dict(depth: int) -> dict:
    out = inner = {}
    for _ in range(depth):
        inner["a"] = {}
        inner = inner["a"]
    return out


@pytest.mark.parametrize("call,argument", [
    (lambda: drtlab.load_scene(_deep_dict(3000)), "scene"),
    (lambda: drtlab.load_experiment(_deep_dict(3000)), "experiment"),
    (lambda: drtlab.load_scene("cornell-box", {"camera.fov": _deep_dict(3000)}), "overrides"),
    (lambda: drtlab.points("sobol", 4, 2, seed=_deep_list(3000)), "seed"),
    (lambda: drtlab.write_exr("a.exr", _deep_list(3000)), "image"),
    (lambda: drtlab.write_exr("a.exr", [[1.0, 2.0], [3.0]]), "image"),
])
def test_a_deeply_nested_or_ragged_argument_is_an_input_error(call, argument, here):
    # RecursionError (in a copy, or in the repr of the message) or numpy's ValueError before.
    with pytest.raises(InputError) as e:
        call()
    assert e.value.field == argument, e.value
    assert list(here.iterdir()) == []


def test_a_point_table_that_is_a_folder_or_fifo_says_so(here):
    (here / "folder.npy").mkdir()
    os.mkfifo(here / "fifo.npy")
    for name, words in (("folder.npy", "is a folder"), ("fifo.npy", "is a FIFO")):
        with pytest.raises(InputError, match=words) as e:
            drtlab.pointset_from_table("tabled", name)
        assert e.value.field == "points"


def test_a_render_result_checks_both_its_files_before_writing(here):
    result = drtlab.render("cornell-box", spp=2, res=[8, 6], stats=True, variance=True)
    with pytest.raises(InputError) as e:
        result.write_exr(42)
    assert e.value.field == "path"
    (here / "x.stderr.exr").mkdir()
    with pytest.raises(InputError, match="is a folder") as e:
        result.write_exr("x.exr")
    assert e.value.field == "path"
    assert [p.name for p in here.iterdir()] == ["x.stderr.exr"]   # no x.exr without its stderr
    (here / "x.stderr.exr").rmdir()
    assert [p.name for p in result.write_exr("x.exr")] == ["x.exr", "x.stderr.exr"]
