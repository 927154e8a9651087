"""Commands that could overwrite or misplace the user's files: outputs of one command that would share
a name, empty paths (which Python reads as the current folder), and long commands that state their
cost first and refuse past a limit unless told."""
import numpy as np
import pytest

from cli_util import assert_one_line_error
from drtlab.cli import main


def test_compare_of_two_images_of_one_name_writes_both_pairs(tmp_path, capsys):
    from drtlab.kernels.imageio import read_exr, write_exr
    for d, v in (("same1", 0.5), ("same2", 0.375)):
        (tmp_path / d).mkdir()
        write_exr(tmp_path / d / "img.exr", np.full((4, 6, 3), v), {"sampler": "none"})
    write_exr(tmp_path / "c.exr", np.full((4, 6, 3), 0.25))
    out = tmp_path / "cmp"
    a, b = tmp_path / "same1" / "img.exr", tmp_path / "same2" / "img.exr"
    assert main(["compare", str(a), str(b), "--ref", str(tmp_path / "c.exr"), "--out-dir", str(out)]) == 0
    wrote = capsys.readouterr().out.splitlines()[-1]
    names = wrote.removeprefix("wrote ").split(", ")
    assert len(names) == len(set(names)) == 4
    assert np.all(read_exr(out / "same1_img-vs-c.diff.exr")[0] == np.float32(0.25))
    assert np.all(read_exr(out / "same2_img-vs-c.diff.exr")[0] == np.float32(0.125))
    assert sorted(p.name for p in out.iterdir()) == sorted(
        f"same{i}_img-vs-c.{k}" for i in (1, 2) for k in ("diff.exr", "error.png"))


def test_compare_of_one_image_twice_against_a_reference_is_refused(tmp_path, capsys):
    from drtlab.kernels.imageio import write_exr
    write_exr(tmp_path / "img.exr", np.full((4, 6, 3), 0.5), {"sampler": "none"})
    write_exr(tmp_path / "c.exr", np.full((4, 6, 3), 0.25))
    out = tmp_path / "cmp"
    img = str(tmp_path / "img.exr")
    assert main(["compare", img, img, "--ref", str(tmp_path / "c.exr"), "--out-dir", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and not out.exists()
    assert_one_line_error(captured.err, "B")
