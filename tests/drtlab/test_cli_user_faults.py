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
    # 16 samples: at 1, some seeds' 8 x 6 images of the small light are zero everywhere, which the
    # render rightly warns about too.
    argv = ["render", str(good), "--spp", "16", "--out", str(tmp_path / "x.exr"),
            "--set", "shapes[0].velocity=[0.5, 0.0, 0.0]"]
    if shutter is not None:
        argv += ["--set", f"camera.shutter={shutter}"]
    assert main(argv) == 0
    lines = _warnings(capsys.readouterr().err)
    assert len(lines) == (1 if warned else 0), lines
    if warned:
        assert "velocity" in lines[0] and "camera.shutter" in lines[0]


def test_static_scene_has_no_shutter_warning(good, tmp_path, capsys):
    assert main(["render", str(good), "--spp", "16", "--out", str(tmp_path / "x.exr")]) == 0
    assert _warnings(capsys.readouterr().err) == []


def test_scene_format_states_the_loaders_shutter_default():
    from drtlab.kernels.scene_model.scene_file import scene_from_dict
    from repo_paths import REPO
    text = (REPO / "kernels" / "scene_model" / "SCENE_FORMAT.md").read_text()
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


# ---------------------------------------------------------------------------------------------------
# Sampler names, one default sampler, output names
# ---------------------------------------------------------------------------------------------------

def test_every_point_set_name_alone_is_a_sampler_with_the_stated_strategy():
    from drtlab.estimators.registry import POINTSET_STRATEGY, POINTSETS, PRESETS, parse_sampler
    for name in POINTSETS:
        spec = parse_sampler(name)
        expected = PRESETS[name] if name in PRESETS else (name, POINTSET_STRATEGY)
        assert (spec.pointset.name, spec.strategy.name) == expected, name
    # The preset that is also a point set's name agrees with the rule.
    assert PRESETS["stratified"] == ("stratified", POINTSET_STRATEGY)


def test_bad_sampler_message_lists_the_bare_form(capsys):
    from drtlab.errors import InputError
    from drtlab.estimators.registry import parse_sampler
    with pytest.raises(InputError) as e:
        parse_sampler("sobol+nonsense")
    assert "POINTS alone" in e.value.message


def test_one_default_sampler_for_api_cli_and_bench():
    import inspect
    from drtlab.cli import build_parser
    from drtlab.estimators.defaults import DEFAULT_SAMPLER
    from drtlab.experiments.bench import scenes as bench
    import drtlab.kernels.render as R
    for f in (R.render, R.render_with_stats, R.render_batch, R.render_batch_with_stats):
        assert inspect.signature(f).parameters["sampler"].default == DEFAULT_SAMPLER, f.__name__
    render_cmd = build_parser()._subparsers._group_actions[0].choices["render"]
    assert render_cmd.get_default("sampler") == DEFAULT_SAMPLER
    assert bench.build_parser().get_default("sampler") == DEFAULT_SAMPLER


def test_zsobol_at_a_non_power_of_two_says_so(good, tmp_path, capsys):
    assert main(["render", str(good), "--spp", "3", "--sampler", "zsobol+importance",
                 "--out", str(tmp_path / "x.exr")]) == 0
    lines = _warnings(capsys.readouterr().err)
    assert len(lines) == 1 and "3 of each pixel's 4-point net" in lines[0], lines
    assert main(["render", str(good), "--spp", "4", "--sampler", "zsobol",
                 "--out", str(tmp_path / "y.exr")]) == 0
    assert _warnings(capsys.readouterr().err) == []


def test_whitted_records_no_sampler(good, tmp_path, capsys):
    from drtlab.kernels.imageio import read_exr
    out = tmp_path / "w.exr"
    assert main(["render", str(good), "--integrator", "whitted", "--spp", "4", "--out", str(out)]) == 0
    line = capsys.readouterr().out
    assert "stratified" not in line and "whitted" in line, line
    assert read_exr(out)[1]["sampler"] == "none"


def test_default_output_names_differ_in_whatever_changes_the_image(good, tmp_path, capsys,
                                                                   monkeypatch):
    monkeypatch.setenv("DRTLAB_RESULTS", str(tmp_path / "results"))
    runs = [["--res", "8"], ["--res", "16"], ["--integrator", "path"], ["--seed", "1"],
            ["--sampler", "uniform"], ["--set", "camera.fov=30"], ["--spp", "2"]]
    for extra in runs:
        assert main(["render", "aa-edges", "--spp", "1", "--res", "8", *extra]) == 0
    capsys.readouterr()
    exrs = sorted(p.name for p in (tmp_path / "results" / "renders").glob("*.exr"))
    assert len(exrs) == len(runs), exrs          # seven different renders, seven files
    assert "aa-edges-drt-stratified_importance-8x6-1spp-s0.exr" in exrs


def test_wrote_line_gives_every_files_folder(good, tmp_path, capsys):
    out = tmp_path / "sub" / "x.exr"
    assert main(["render", str(good), "--spp", "2", "--variance", "--out", str(out)]) == 0
    line = capsys.readouterr().out
    for p in (out, out.with_suffix(".png"), tmp_path / "sub" / "x.stderr.exr"):
        assert str(p) in line and p.is_file(), (p, line)


# ---------------------------------------------------------------------------------------------------
# Small output faults
# ---------------------------------------------------------------------------------------------------

def _column_of(lines: list[str], texts: list[str]) -> set[int]:
    return {line.index(text) for line, text in zip(lines, texts)}


def test_scenes_and_samplers_align_long_names(capsys):
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
    assert main(["scenes"]) == 0
    lines = capsys.readouterr().out.splitlines()
    names = builtin_names()
    assert max(map(len, names)) > 14                # displaced-sphere: longer than the old column
    assert len(_column_of(lines, [load_scene(n).description for n in names])) == 1
    assert main(["samplers"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("  ")]
    descriptions = [p.description for p in POINTSETS.values()] + \
        [s.description for s in STRATEGIES.values()]
    assert len(_column_of(rows, descriptions)) == 1
    assert max(map(len, POINTSETS)) > 12             # presampled_random
    integrators = rows[-len(INTEGRATORS):]
    assert len(_column_of(integrators, [i.description for i in INTEGRATORS.values()])) == 1


def test_validate_of_a_constant_table_prints_no_scipy_warning():
    import warnings
    from drtlab.experiments.pointsets import validate as V
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        V.validate("presampled", pixels=V.MIN_PIXELS)
    assert [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)] == []


def test_one_panel_figure_keeps_its_title_inside():
    from types import SimpleNamespace as NS
    from drtlab.experiments.study import figures as F
    study = NS(scenes=[NS(scene="aa-edges", cells=[])], samplers=[])
    with pytest.warns(UserWarning):                 # an empty panel's legend
        fig = F.scene_panels(study, None, lambda *a: None, title="stratification: RMSE vs samples "
                        "(points: mean ± 95% CI; lines: likelihood fit ± 95% CrI, where resolved)",
                        xlabel="x", ylabel="y", xscale={"base": 2})
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent(fig.canvas.get_renderer())
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height, box


def test_a_range_of_one_value_is_that_value():
    from drtlab.experiments.study.analysis import span_text
    assert span_text([7.21]) == "7.2" and span_text([7.21, 7.24]) == "7.2"
    assert span_text([3.0, 7.21]) == "3.0-7.2" and span_text([5, 9], "d", "–") == "5–9"


def test_pointset_table_marks_the_squared_discrepancies(tmp_path, capsys):
    assert main(["pointset", "independent", "--n", "16", "--dims", "0,1", "--realisations", "2",
                 "--out", str(tmp_path / "ps")]) == 0
    labels = [line.split()[1] for line in capsys.readouterr().out.splitlines()
              if line.startswith("  discrepancy")]
    assert labels == ["L2-star", "CD^2", "WD^2", "MD^2"]


# ---------------------------------------------------------------------------------------------------
# How long a render takes: said before a long one; a time-budget render
# ---------------------------------------------------------------------------------------------------

def test_a_long_render_says_how_long_from_its_first_launches(good, tmp_path, capsys, monkeypatch):
    """The note is measured on the render itself: no probe render before it (one render call), and
    said once, early (after the first launch here), when the whole will take longer than the bound."""
    import drtlab.cli as cli
    import drtlab.kernels.render as R
    calls, fractions = [], []
    real = R.render_with_stats

    def render_and_count(*a, **k):
        calls.append(k)
        watch = k["watch"]

        def spy(fraction, seconds):
            fractions.append((fraction, capsys.readouterr().err))
            watch(fraction, seconds)
        return real(*a, **{**k, "watch": spy})
    monkeypatch.setattr(R, "render_with_stats", render_and_count)
    monkeypatch.setattr(cli, "NOTE_AFTER_SECONDS", 0.0)
    monkeypatch.setattr(cli, "LONG_RENDER_SECONDS", -1.0)      # every render counts as long
    assert main(["render", str(good), "--spp", "130", "--res", "8", "--tile", "4",
                 "--threads", "1", "--out", str(tmp_path / "x.exr")]) == 0
    assert len(calls) == 1
    # 3 passes (64, 64, 2 spp) x 4 tiles: the note came right after the first launch.
    assert [f for f, _ in fractions] == [(k + 1) / 12 for k in range(12)]
    notes = [line for _, err in fractions for line in err.splitlines()
             if line.startswith("drtlab: note:")]
    notes += [x for x in capsys.readouterr().err.splitlines() if x.startswith("drtlab: note:")]
    (note,) = notes
    assert "this render takes about" in note and "8x6 x 130 spp = 6.24e+03 samples" in note
    assert "--seconds" in note
    # A render shorter than the bound says nothing.
    monkeypatch.setattr(cli, "LONG_RENDER_SECONDS", 120.0)
    calls.clear()
    assert main(["render", str(good), "--spp", "2", "--res", "8", "--out", str(tmp_path / "y.exr")]) == 0
    assert len(calls) == 1 and "note" not in capsys.readouterr().err


def test_time_budget_renders_whole_passes_and_says_how_many(good, tmp_path, capsys):
    from drtlab.kernels.imageio import read_exr
    out = tmp_path / "t.exr"
    assert main(["render", str(good), "--seconds", "0.5", "--res", "8", "--out", str(out)]) == 0
    capsys.readouterr()
    pixels, meta = read_exr(out)
    spp = meta["spp"]
    assert spp >= 64 and spp % 64 == 0 and meta["seconds_budget"] == 0.5
    # The image is exactly that spp's.
    again = tmp_path / "n.exr"
    assert main(["render", str(good), "--spp", str(spp), "--res", "8", "--out", str(again)]) == 0
    assert np.array_equal(read_exr(again)[0], pixels)


@pytest.mark.parametrize("argv,field", [(["--seconds", "0"], "--seconds"),
                                        (["--seconds", "-3"], "--seconds"),
                                        (["--seconds", "soon"], "--seconds"),
                                        (["--seconds", "1e9"], "--seconds"),
                                        (["--seconds", "2", "--spp", "4"], "--spp")])
def test_bad_time_budget_is_one_line(argv, field, good, tmp_path, capsys):
    from cli_util import run_bad
    out = tmp_path / "out"
    out.mkdir()
    run_bad(["render", str(good), *argv, "--out", str(out / "x.exr")], field, out, capsys)


def test_python_time_budget_result():
    import drtlab
    r = drtlab.render("aa-edges", res=8, seconds=0.3, stats=True)
    assert r.spp % 64 == 0 and r.metadata["seconds_budget"] == 0.3 and r.metadata["spp"] == r.spp


@pytest.mark.parametrize("which", ["--stderr", "beside A"])
def test_a_standard_error_of_another_size_is_one_line_before_any_file(tmp_path, capsys, which):
    from drtlab.kernels.imageio import write_exr
    rng = np.random.default_rng(5)
    for name in ("a", "b"):
        write_exr(tmp_path / f"{name}.exr", rng.random((12, 16, 3)))
    write_exr(tmp_path / "b.stderr.exr" if which == "beside A" else tmp_path / "se.exr", rng.random((6, 8, 3)))
    if which == "beside A":
        (tmp_path / "b.stderr.exr").rename(tmp_path / "a.stderr.exr")
        write_exr(tmp_path / "b.stderr.exr", rng.random((12, 16, 3)))
    argv = ["compare", str(tmp_path / "a.exr"), str(tmp_path / "b.exr"), "--per-pixel-z",
            "--out-dir", str(tmp_path / "cmp")] + (["--stderr", str(tmp_path / "se.exr")] if which == "--stderr" else [])
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    field = "--stderr" if which == "--stderr" else "A"
    assert err.startswith(f"drtlab: {field}: the standard error") and "8x6" in err and "\n" not in err
    assert not (tmp_path / "cmp").exists()


@pytest.mark.parametrize("argv, field, words", [
    (["lobe", "glossy", "--strategy", "importance-ggxd"], "--strategy", "glossy has none"),
    (["lobe", "diffuse", "--exponent", "20"], "--exponent", "diffuse does not read it"),
    (["lobe", "ggx", "--ior", "2"], "--ior", "ggx does not read it"),
    (["render", "aa-edges", "--integrator", "whitted", "--variance", "--spp", "1"], "--variance",
     "deterministic"),
    (["sources", "soft-shadows", "--strategy", "env-uniform"], "--strategy", "soft-shadows has none"),
])
def test_a_flag_that_would_change_nothing_is_refused(tmp_path, capsys, argv, field, words):
    out = ["--out", str(tmp_path / ("x.exr" if argv[0] == "render" else "x"))]
    assert main(argv + out) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"drtlab: {field}: ") and words in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_lobe_flags_a_kind_reads_still_work(tmp_path, capsys):
    assert main(["lobe", "glossy", "--exponent", "30", "--samples", "20000", "--incident", "30",
                 "--out", str(tmp_path / "l")]) == 0
    assert "glossy" in capsys.readouterr().out
