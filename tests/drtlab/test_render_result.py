"""The Python surface of one render (issue 20): `drtlab.render(..., stats=True)` returns a documented
RenderResult with the same image, the standard error, timings and the EXR's metadata, and
`drtlab.write_exr` / `drtlab.read_exr` round-trip it."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import drtlab
from drtlab.errors import InputError

from cli_util import GOOD_SCENE


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(GOOD_SCENE)
    return path


def test_render_result_matches_render_and_the_cli_metadata(good, tmp_path, capsys):
    from drtlab.cli import main
    args = dict(spp=4, seed=3, res="16x12")
    plain = drtlab.render(str(good), **args)
    r = drtlab.render(str(good), stats=True, variance=True, **args)
    assert isinstance(r, drtlab.RenderResult)
    assert np.array_equal(r.image, plain)
    assert r.stderr.shape == plain.shape and np.all(np.isfinite(r.stderr)) and np.any(r.stderr > 0)
    assert r.seconds > 0 and r.wall_seconds >= r.seconds and r.compile_seconds >= 0
    assert r.samples_per_second == pytest.approx(16 * 12 * 4 / r.seconds)
    assert r.spp == 4 and r.metadata["sampler"] == drtlab.DEFAULT_SAMPLER
    out = tmp_path / "cli.exr"
    assert main(["render", str(good), "--spp", "4", "--seed", "3", "--res", "16x12", "--variance",
                 "--out", str(out)]) == 0
    capsys.readouterr()
    pixels, meta = drtlab.read_exr(out)
    assert np.array_equal(pixels, plain.astype(np.float32))
    timing = {"wall_seconds", "render_seconds", "compile_seconds"}
    assert {k: v for k, v in meta.items() if k not in timing} == \
        {k: v for k, v in r.metadata.items() if k not in timing}
    se, _ = drtlab.read_exr(tmp_path / "cli.stderr.exr")
    assert np.array_equal(se, r.stderr.astype(np.float32))


def test_render_result_from_a_dict_and_its_own_writer(tmp_path):
    import tomllib
    r = drtlab.render(tomllib.loads(GOOD_SCENE), spp=2, stats=True, variance=True,
                      overrides={"scene.resolution": [8, 6]})
    written = r.write_exr(tmp_path / "a.exr")
    assert [p.name for p in written] == ["a.exr", "a.stderr.exr"]
    pixels, meta = drtlab.read_exr(written[0])
    assert pixels.shape == (6, 8, 3) and meta["spp"] == 2 and meta["resolution"] == "8x6"


def test_write_exr_read_exr_round_trip(tmp_path):
    img = np.random.default_rng(0).random((5, 7, 3)).astype(np.float32)
    drtlab.write_exr(tmp_path / "x.exr", img, {"note": "hello", "n": 3})
    pixels, meta = drtlab.read_exr(tmp_path / "x.exr")
    assert np.array_equal(pixels, img) and meta == {"note": "hello", "n": 3}


def test_variance_without_stats_is_one_clear_error():
    with pytest.raises(InputError) as e:
        drtlab.render("aa-edges", spp=1, variance=True)
    assert e.value.field == "variance" and "stats=True" in e.value.message


def test_import_drtlab_still_loads_no_warp_or_render_code():
    code = ("import sys, drtlab; drtlab.RenderResult; drtlab.DEFAULT_SAMPLER; "
            "print('warp' in sys.modules, 'drtlab.kernels.render' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
