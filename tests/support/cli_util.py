"""What the CLI tests share: a valid scene file, and the check of a bad-input failure."""
from __future__ import annotations

from pathlib import Path

from drtlab.cli import main

GOOD_SCENE = """
[scene]
description = "cli test"
resolution = [8, 6]
spp = 1

[camera]
position = [0.0, 1.0, 4.0]
look_at = [0.0, 0.5, 0.0]

[materials.grey]
kind = "diffuse"
albedo = [0.5, 0.5, 0.5]

[materials.light]
kind = "emitter"
emission = [5.0, 5.0, 5.0]

[[shapes]]
kind = "sphere"
material = "grey"
center = [0.0, 0.5, 0.0]
radius = 0.5

[[shapes]]
kind = "quad"
material = "light"
origin = [-0.5, 2.0, -0.5]
edge_u = [1.0, 0.0, 0.0]
edge_v = [0.0, 0.0, 1.0]
"""


def assert_one_line_error(err: str, field: str):
    lines = err.splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{err}"
    assert err.endswith("\n")
    assert lines[0].startswith(f"drtlab: {field}: "), lines[0]
    assert "Traceback" not in err
    assert len(lines[0]) > len(f"drtlab: {field}: ") + 5, "the message says what is wrong"


def run_bad(argv, field, out_dir: Path, capsys):
    rc = main(argv)
    captured = capsys.readouterr()
    assert rc == 2
    assert captured.out == ""
    assert_one_line_error(captured.err, field)
    assert list(out_dir.iterdir()) == [], "no output or temporary file may be left"
