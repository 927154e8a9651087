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


# ---------------------------------------------------------------------------------------------------
# compare --ref: error images against the reference, z-score images, the KS line's bookkeeping
# ---------------------------------------------------------------------------------------------------

def test_compare_against_a_reference_writes_each_images_errors(tmp_path, capsys):
    from drtlab.cli import main
    from drtlab.kernels.imageio import read_exr, write_exr
    a, b, r = tmp_path / "a.exr", tmp_path / "b.exr", tmp_path / "r.exr"
    deterministic = {"sampler": "none"}             # as a whitted render records: no standard error
    write_exr(a, np.full((4, 6, 3), 0.5), deterministic)
    write_exr(b, np.full((4, 6, 3), 0.375), deterministic)
    write_exr(r, np.full((4, 6, 3), 0.25))
    se_r = np.full((4, 6, 3), 0.125)
    se_r[0, :3] = 0.0                               # 3 pixels x 3 channels without an error
    write_exr(tmp_path / "r.stderr.exr", se_r, {"spp": 5})     # t with 4 dof: sd sqrt(2)
    out = tmp_path / "cmp"
    assert main(["compare", str(a), str(b), "--ref", str(r), "--per-pixel-z", "--out-dir", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{a} vs {r}:") and lines[1].startswith(f"{b} vs {r}:")
    assert "z: mean +2.000, sd 0.000 (expected 1.414)" in lines[0], lines[0]
    assert "z: mean +1.000" in lines[1]
    assert "(63 values; 9 with zero standard error dropped)" in lines[0], lines[0]
    assert np.all(read_exr(out / "a-vs-r.diff.exr")[0] == np.float32(0.25))
    assert np.all(read_exr(out / "b-vs-r.diff.exr")[0] == np.float32(0.125))
    z = read_exr(out / "b-vs-r.z.exr")[0]
    assert np.all(np.isnan(z[0, :3])) and np.all(z[1:] == 1.0)
    assert (out / "a-vs-r.error.png").is_file() and not (out / "a-vs-b.diff.exr").exists()


def test_expected_z_sd_follows_welch_dof():
    from drtlab.experiments.tools.images import z_scores
    shape = (8, 8, 3)
    a, b = np.zeros(shape), np.zeros(shape)
    se = np.full(shape, 0.1)
    assert z_scores(a, b, None, se).sd_expected == pytest.approx(1.0, abs=1e-6)   # unknown: N(0, 1)
    assert z_scores(a, b, None, se, n_b=11).sd_expected == pytest.approx(np.sqrt(10 / 8))
    # Equal errors from 11 values each: Welch dof = (2v)^2 / (2 v^2 / 10) = 20.
    assert z_scores(a, b, se, se, 11, 11).sd_expected == pytest.approx(np.sqrt(20 / 18))


def test_z_ks_test_is_calibrated_and_rejects_a_wrong_error():
    """z of t-distributed differences against t at the right dof: KS accepts (level 0.001, one
    test); the negative control, standard errors half the truth, is rejected."""
    from drtlab.experiments.tools.images import z_scores
    rng = np.random.default_rng(11)
    shape = (64, 64, 3)
    n = 6
    samples = rng.standard_normal((n, *shape))
    mean = samples.mean(axis=0)
    se = samples.std(axis=0, ddof=1) / np.sqrt(n)
    good = z_scores(mean, np.zeros(shape), None, se, n_b=n)
    assert good.ks_pvalue > 0.001 and good.sd == pytest.approx(good.sd_expected, rel=0.05)
    assert z_scores(mean, np.zeros(shape), None, se / 2, n_b=n).ks_pvalue < 1e-6
