"""The everyday CLI surface: output locations checked before any rendering, overrides, version,
help defaults, warnings for scenes that render nothing, file modes, and the image tools (`info`,
`compare`) on images with exactly known statistics."""
from __future__ import annotations

import os
import stat

import numpy as np
import pytest

import drtlab.kernels.render as render_mod
from drtlab.cli import main
from drtlab.experiments.files import atomic_write_text
from drtlab.kernels.imageio import write_exr

from cli_util import GOOD_SCENE, assert_one_line_error


@pytest.fixture
def good(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(GOOD_SCENE)
    return path


@pytest.fixture
def no_render(monkeypatch):
    """Fails the test if a render starts: bad input must be caught before any long work."""
    def refuse(*args, **kwargs):
        raise AssertionError("render started before the bad input was reported")
    monkeypatch.setattr(render_mod, "render_with_stats", refuse)


@pytest.mark.parametrize("where", ["/proc/nope/x.exr", "/sys/x.exr", "FILE/x.exr", "FILE/sub/x.exr"])
def test_unwritable_out_is_one_line_before_rendering(where, good, tmp_path, capsys, no_render):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    out = where.replace("FILE", str(blocker))
    assert main(["render", str(good), "--out", out]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert_one_line_error(captured.err, "--out")
    assert "cannot write" in captured.err
    assert blocker.read_text() == "not a folder"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file", "good.toml"]


def test_out_in_new_folders_leaves_nothing_when_the_render_fails(good, tmp_path, capsys):
    out = tmp_path / "new" / "deeper" / "x.exr"
    assert main(["render", str(good), "--out", str(out), "--sampler", "nonsense"]) == 2
    assert not (tmp_path / "new").exists(), "probe folders are removed again"
    assert_one_line_error(capsys.readouterr().err, "sampler")


def test_missing_scene_file_says_so(tmp_path, capsys, no_render):
    assert main(["render", str(tmp_path / "nothere.toml")]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "scene")
    assert "does not exist" in err and "built-ins" not in err


@pytest.mark.parametrize("argv,field", [
    (["ground-truth", "aa-edges", "--res", "0"], "--res"),
    (["ground-truth", "aa-edges", "--res", "32x"], "--res"),
    (["render", "aa-edges", "--res", "3x0"], "--res"),
])
def test_one_resolution_parser_names_the_flag_once(argv, field, capsys, no_render):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, field)
    assert err.count("--res") == 1


def test_unknown_profile_lists_the_files_profiles(capsys):
    assert main(["experiment", "stratified", "--profile", "fast"]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "profile")
    assert "quick" in err and "full" in err


@pytest.mark.parametrize("pair,field", [("camera.fov", "--set"), ("=3", "--set"),
                                        ("camera.fov=500", "camera.fov"),
                                        ("camera.nope=1", "camera.nope")])
def test_bad_set_overrides(pair, field, good, capsys, no_render):
    assert main(["render", str(good), "--set", pair]) == 2
    assert_one_line_error(capsys.readouterr().err, field)


def test_set_override_changes_the_image(good, tmp_path, capsys):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    assert main(["render", str(good), "--spp", "2", "--out", str(a)]) == 0
    assert main(["render", str(good), "--spp", "2", "--out", str(b), "--set", "materials.grey.albedo=[0.9, 0.1, 0.1]"]) == 0
    capsys.readouterr()
    from drtlab.kernels.imageio import read_exr
    (pa, ma), (pb, mb) = read_exr(a), read_exr(b)
    assert ma["scene_hash"] != mb["scene_hash"] and not np.array_equal(pa, pb)


def test_version_and_help_defaults(capsys):
    from drtlab import __version__
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"drtlab {__version__}"
    with pytest.raises(SystemExit):
        main(["render", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "(default: stratified+importance)" in text and "(default: 0)" in text


LIGHT_QUAD = GOOD_SCENE.split("[[shapes]]\nkind = \"quad\"")[0]


def _scene_with_light_edges(eu, ev) -> str:
    return LIGHT_QUAD + ("[[shapes]]\nkind = \"quad\"\nmaterial = \"light\"\n"
                         f"origin = [-0.5, 2.0, -0.5]\nedge_u = {eu}\nedge_v = {ev}\n")


@pytest.mark.parametrize("edges,warned", [(("[1.0, 0.0, 0.0]", "[0.0, 0.0, 1.0]"), False),
                                          (("[0.0, 0.0, 1.0]", "[1.0, 0.0, 0.0]"), True)])
def test_emitter_facing_away_warns_once(edges, warned, tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(_scene_with_light_edges(*edges))
    # 16 spp: at 1 spp the lit scene can come out black by chance and warn of that instead.
    assert main(["render", str(scene), "--spp", "16", "--out", str(tmp_path / "x.exr")]) == 0
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "warning" in line]
    assert len(lines) == (1 if warned else 0), err
    if warned:
        assert "edge_u" in lines[0] and "light" in lines[0]


def test_all_zero_image_warns(good, tmp_path, capsys):
    # The camera looks away from the whole scene into a black background.
    assert main(["render", str(good), "--spp", "1", "--set", "camera.look_at=[0.0, 1.0, 10.0]",
                 "--out", str(tmp_path / "x.exr")]) == 0
    err = capsys.readouterr().err
    assert err.count("warning") == 1 and "zero everywhere" in err


def test_result_files_follow_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "report.md", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "report.md").stat().st_mode) == 0o644


# ---------------------------------------------------------------------------------------------------
# Image tools on images with exactly known statistics
# ---------------------------------------------------------------------------------------------------

def test_info_counts_and_metadata(tmp_path, capsys):
    img = np.full((3, 4, 3), 0.5, dtype=np.float32)
    img[0, 0, 0] = np.nan
    img[1, 1, 1] = np.inf
    img[2, 2, 2] = -1.0
    path = tmp_path / "i.exr"
    write_exr(path, img, {"scene": "made-up", "spp": 7})
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "4x3, 3 channels" in out
    rows = {line.split()[0]: line.split() for line in out.splitlines()[2:5]}
    assert rows["R"][4:] == ["1", "0", "0"] and rows["G"][4:] == ["0", "1", "0"]
    assert rows["B"][4:] == ["0", "0", "1"] and float(rows["B"][1]) == -1.0
    assert "drtlab:scene = made-up" in out and "drtlab:spp = 7" in out


def test_compare_exact_numbers(tmp_path, capsys):
    a, b, se = tmp_path / "a.exr", tmp_path / "b.exr", tmp_path / "b.stderr.exr"
    write_exr(a, np.full((4, 6, 3), 0.5, dtype=np.float32))
    write_exr(b, np.full((4, 6, 3), 0.25, dtype=np.float32))
    write_exr(se, np.full((4, 6, 3), 0.125, dtype=np.float32))
    out_dir = tmp_path / "cmp"
    # A noisy image without its standard error: its noise would count as a difference.
    assert main(["compare", str(a), str(b), "--per-pixel-z", "--out-dir", str(out_dir)]) == 2
    assert_one_line_error(capsys.readouterr().err, "--per-pixel-z")
    assert not out_dir.exists()
    write_exr(a, np.full((4, 6, 3), 0.5, dtype=np.float32), {"sampler": "none"})   # deterministic
    assert main(["compare", str(a), str(b), "--per-pixel-z", "--out-dir", str(out_dir)]) == 0
    out = capsys.readouterr().out
    assert "RMSE 0.25," in out and "MAE 0.25," in out and "mean error +0.25" in out
    assert f"relMSE {0.0625 / 0.0725:.6g}," in out
    assert "z: mean +2.000, sd 0.000" in out          # (0.5 - 0.25) / 0.125 everywhere
    from drtlab.kernels.imageio import read_exr
    diff, _ = read_exr(out_dir / "a-vs-b.diff.exr")
    assert np.all(diff == np.float32(0.25))
    assert (out_dir / "a-vs-b.error.png").is_file()


def test_compare_identical_images_is_zero_and_sizes_must_match(tmp_path, capsys):
    a, c = tmp_path / "a.exr", tmp_path / "c.exr"
    rng = np.random.default_rng(1)
    write_exr(a, rng.random((5, 7, 3)).astype(np.float32))
    write_exr(c, np.zeros((5, 8, 3), dtype=np.float32))
    assert main(["compare", str(a), str(a), "--out-dir", str(tmp_path / "o")]) == 0
    assert "RMSE 0, relMSE 0, MAE 0, CIEDE2000 0," in capsys.readouterr().out
    assert main(["compare", str(a), str(c), "--out-dir", str(tmp_path / "o")]) == 2
    assert_one_line_error(capsys.readouterr().err, "B")
    assert main(["compare", str(a), str(tmp_path / "none.exr")]) == 2
    assert_one_line_error(capsys.readouterr().err, "B")
    assert main(["compare", str(a), str(a), "--per-pixel-z"]) == 2
    assert_one_line_error(capsys.readouterr().err, "--per-pixel-z")


@pytest.mark.parametrize("res", ["100000x100000", "20000x20000"])
def test_huge_resolution_is_refused_before_rendering(res, good, capsys, no_render):
    assert main(["render", str(good), "--res", res, "--spp", "1"]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "--res")
    assert "GiB" in err and "limits" in err


def test_variance_image_matches_independent_renders(good, tmp_path, capsys):
    """`--variance` writes each pixel's standard error; the mean image is bit-identical to a render
    without it. Check against 24 independent renders of 16 spp (independent point set, so
    sqrt(sample variance / spp) is the exact standard error): per pixel (green channel), the
    predicted variance of the mean and the observed variance of the 24 means are both unbiased for
    the same value, so the ratio of their sums over pixels is 1: its 99.9% bootstrap interval over
    independent pixels (one test, level 0.001) must hold 1. Negative control: the per-sample
    variance (not divided by spp, ratio 16) must fall outside it."""
    from scipy.stats import bootstrap
    from drtlab.kernels.imageio import read_exr
    from drtlab.kernels.render import render, render_with_stats
    out = tmp_path / "v.exr"
    args = dict(spp=16, sampler="uniform", res="32x24")
    assert main(["render", str(good), "--spp", "16", "--sampler", "uniform", "--res", "32x24",
                 "--variance", "--out", str(out)]) == 0
    capsys.readouterr()
    se, _ = read_exr(tmp_path / "v.stderr.exr")
    plain = render(str(good), **args)
    assert np.array_equal(plain, render_with_stats(str(good), variance=True, **args).image)
    reps = np.stack([render(str(good), seed=100 + i, **args) for i in range(24)])
    observed = reps.var(axis=0, ddof=1)[..., 1].ravel()
    predicted = np.square(se.astype(np.float64))[..., 1].ravel()
    ci = bootstrap((predicted, observed), lambda p, o: np.sum(p) / np.sum(o), paired=True,
                   vectorized=False, confidence_level=0.999, n_resamples=2000,
                   random_state=np.random.default_rng(5)).confidence_interval
    assert ci.low < 1.0 < ci.high, ci
    assert not ci.low < 16.0 < ci.high
