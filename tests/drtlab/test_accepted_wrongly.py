"""Inputs that passed validation and rendered NaN/Inf or something other than what was asked, and
flags or values drtlab took without a word. Each test failed before its fix."""
from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest

from drtlab.cli import main
from drtlab.errors import InputError, NonFiniteImageWarning

from cli_util import GOOD_SCENE, assert_one_line_error


def _scene(**light) -> dict:
    """GOOD_SCENE as a dict, its quad light (shapes[1]) changed by `light`."""
    d = tomllib.loads(GOOD_SCENE)
    d["shapes"][1].update(light)
    return d


def _refused(d: dict, field: str) -> str:
    import drtlab
    with pytest.raises(InputError) as e:
        drtlab.load_scene(d)
    assert e.value.field == field, e.value
    return e.value.message


# ---------------------------------------------------------------------------------------------------
# Derived quantities checked against float32 at validation
# ---------------------------------------------------------------------------------------------------

def test_a_light_quad_whose_area_float32_cannot_hold_is_refused():
    # 1e-20 x 1e-20: area 1e-40, below float32's smallest normal number; it rendered NaN pixels.
    msg = _refused(_scene(edge_u=[1e-20, 0, 0], edge_v=[0, 0, 1e-20]), "shapes[1].edge_v")
    assert "float32" in msg and "1e-40" in msg


def test_a_quad_scaled_to_nothing_is_refused_at_its_transform():
    msg = _refused(_scene(transform={"scale": 1e-30}), "shapes[1].transform")
    assert "float32" in msg


@pytest.mark.parametrize("edge, ok", [(1e-10, False), (1e-5, True)])
def test_an_emitter_too_small_for_its_squared_density_is_refused(edge, ok):
    # Measured: edges of 1e-10 two units from the sphere rendered 6 NaN pixels of 48 (MIS squares
    # d^2 / A = 4e20), 1e-9 none; the bound is relative to the scene's extent.
    import drtlab
    d = _scene(edge_u=[edge, 0, 0], edge_v=[0, 0, edge])
    if ok:
        drtlab.load_scene(d)
    else:
        assert "squared in float32" in _refused(d, "shapes[1].edge_v")


@pytest.mark.parametrize("exponent, ok", [(1e15, False), (1e9, False), (2.0 ** 24, True), (1e6, True)])
def test_a_phong_exponent_beyond_float32_cosines_is_refused(exponent, ok):
    import drtlab
    d = tomllib.loads(GOOD_SCENE)
    d["materials"]["grey"] = {"kind": "glossy", "exponent": exponent}
    if ok:
        drtlab.load_scene(d)
    else:
        assert "16777216" in _refused(d, "materials.grey.exponent")


def test_the_largest_phong_exponent_renders_finite_pixels():
    import drtlab
    d = tomllib.loads(GOOD_SCENE)
    d["materials"]["grey"] = {"kind": "glossy", "exponent": 2.0 ** 24}
    for sampler in ("importance", "independent+bsdf"):
        with warnings.catch_warnings():
            warnings.simplefilter("error", NonFiniteImageWarning)
            image = drtlab.render(drtlab.load_scene(d), spp=16, sampler=sampler)
        assert np.isfinite(image).all()


@pytest.mark.parametrize("environment", [
    {"kind": "constant", "radiance": [1e15, 1e15, 1e15], "scale": 1e15},
    {"kind": "image", "file": "HUGE", "scale": 10.0},
])
def test_environment_radiance_times_scale_is_checked(environment, tmp_path):
    from drtlab.kernels.imageio import write_exr
    if environment.get("file") == "HUGE":
        write_exr(tmp_path / "huge.exr", np.full((4, 8, 3), 3e38))
        environment["file"] = str(tmp_path / "huge.exr")
    d = tomllib.loads(GOOD_SCENE)
    d["environment"] = environment
    assert "at most 1e+15" in _refused(d, "environment.scale")


# ---------------------------------------------------------------------------------------------------
# A render with NaN or Inf pixels never reports success silently
# ---------------------------------------------------------------------------------------------------

@pytest.fixture
def nan_render(monkeypatch):
    """The real render, with two pixels of its image made NaN and Inf (what an overflow gives)."""
    from drtlab.kernels import render as R
    real = R.render_with_stats

    def poisoned(*args, **kwargs):
        stats = real(*args, **kwargs)
        stats.image[0, 0, 1] = np.nan
        stats.image[1, 2, :] = np.inf
        return stats
    monkeypatch.setattr(R, "render_with_stats", poisoned)


def test_render_with_non_finite_pixels_says_how_many_and_fails(nan_render, tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(GOOD_SCENE)
    assert main(["render", str(scene), "--out", str(tmp_path / "x.exr")]) == 1
    err = capsys.readouterr().err
    line = [x for x in err.splitlines() if x.startswith("drtlab: image:")]
    assert len(line) == 1 and "2 of 48 pixels are NaN or Inf" in line[0], err


def test_render_of_finite_pixels_succeeds(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(GOOD_SCENE)
    assert main(["render", str(scene), "--out", str(tmp_path / "x.exr")]) == 0
    assert "drtlab: image:" not in capsys.readouterr().err


def test_python_render_warns_of_non_finite_pixels(nan_render):
    import drtlab
    with pytest.warns(NonFiniteImageWarning, match="2 of 48 pixels"):
        result = drtlab.render(tomllib.loads(GOOD_SCENE), stats=True)
    assert np.isnan(result.image[0, 0, 1])       # the image is returned as rendered


def test_nonfinite_note_counts_pixels_not_values():
    from drtlab.kernels.imageio import nonfinite_note
    image = np.zeros((3, 4, 3))
    assert nonfinite_note(image) is None
    image[0, 0, :] = np.nan
    image[2, 3, 0] = -np.inf
    assert nonfinite_note(image) == "2 of 12 pixels are NaN or Inf"


@pytest.mark.parametrize("image, words", [
    (np.full((2, 2, 3), 1 + 2j), "real numbers"),
    (np.full((2, 2, 3), 1e39), "exceed float32"),
])
def test_write_exr_refuses_what_float32_cannot_store(image, words, tmp_path):
    import drtlab
    with warnings.catch_warnings():
        warnings.simplefilter("error")           # no numpy warning on the way
        with pytest.raises(InputError) as e:
            drtlab.write_exr(tmp_path / "x.exr", image)
    assert e.value.field == "image" and words in e.value.message
    assert list(tmp_path.iterdir()) == []


def test_write_exr_keeps_nan_and_inf_it_is_given(tmp_path):
    import drtlab
    image = np.array([[[np.nan, np.inf, 1.0]]])
    drtlab.write_exr(tmp_path / "x.exr", image)
    back, _ = drtlab.read_exr(tmp_path / "x.exr")
    assert np.isnan(back[0, 0, 0]) and np.isinf(back[0, 0, 1]) and back[0, 0, 2] == 1.0


# ---------------------------------------------------------------------------------------------------
# Environment maps of 2 channels, Mitsuba area emitters of nothing
# ---------------------------------------------------------------------------------------------------

def _env_file(tmp_path, channels: int):
    from drtlab.kernels.imageio import write_exr
    path = tmp_path / f"env{channels}.exr"
    write_exr(path, np.linspace(0.1, 2.0, 4 * 8 * channels).reshape(4, 8, channels))
    return path


def test_a_two_channel_environment_map_is_refused(tmp_path):
    d = tomllib.loads(GOOD_SCENE)
    d["environment"] = {"kind": "image", "file": str(_env_file(tmp_path, 2))}
    msg = _refused(d, "environment.file")
    assert "2 channels (R, G)" in msg and "Mitsuba" in msg


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_grey_rgb_and_rgba_environment_maps_read_as_mitsuba_reads_them(channels, tmp_path):
    import drtlab
    from drtlab.kernels.imageio import read_exr
    path = _env_file(tmp_path, channels)
    d = tomllib.loads(GOOD_SCENE)
    d["environment"] = {"kind": "image", "file": str(path)}
    image = drtlab.load_scene(d).environment.image
    pixels = read_exr(path)[0].astype(np.float64)
    want = np.repeat(pixels, 3, axis=2) if channels == 1 else pixels[..., :3]
    np.testing.assert_array_equal(image, want)


def test_a_two_channel_mitsuba_envmap_is_refused(tmp_path, capsys):
    _env_file(tmp_path, 2).rename(tmp_path / "env.exr")
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">'
        '<integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>'
        '<emitter type="envmap"><string name="filename" value="env.exr"/></emitter>'
        '<shape type="sphere"/></scene>')
    assert main(["render", str(tmp_path / "s.xml"), "--out", str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err
    assert "2 channels (R, G)" in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "x.exr").exists()


def test_a_mitsuba_area_emitter_of_no_radiance_is_refused(tmp_path, capsys):
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">'
        '<integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>'
        '<shape type="sphere"/><shape type="rectangle"><emitter type="area">'
        '<rgb name="radiance" value="0, 0, 0"/></emitter></shape></scene>')
    assert main(["render", str(tmp_path / "s.xml"), "--out", str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err
    assert "radiance" in err and "at least one channel > 0" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x.exr").exists()


# ---------------------------------------------------------------------------------------------------
# Flags that would change nothing are refused, as --variance with whitted already was
# ---------------------------------------------------------------------------------------------------

def _write_images(tmp_path, **images) -> dict:
    from drtlab.kernels.imageio import write_exr
    paths = {}
    for name, pixels in images.items():
        paths[name] = tmp_path / f"{name}.exr"
        write_exr(paths[name], pixels)
    return paths


@pytest.mark.parametrize("argv, field, words", [
    (["ground-truth", "aa-edges", "--profile", "full"], "--profile", "--experiment"),
    (["render", "aa-edges", "--integrator", "whitted", "--seed", "3"], "--seed", "deterministic"),
    (["render", "aa-edges", "--integrator", "whitted", "--sampler", "uniform"], "--sampler",
     "deterministic"),
])
def test_a_flag_that_changes_nothing_is_refused(argv, field, words, tmp_path, capsys):
    out = (["--out", str(tmp_path / "x.exr")] if argv[0] == "render"
           else ["--gt-dir", str(tmp_path / "gt")])
    assert main(argv + out) == 2
    assert_one_line_error(capsys.readouterr().err, field)
    assert list(tmp_path.iterdir()) == []


def test_compare_stderr_without_per_pixel_z_is_refused(tmp_path, capsys):
    rng = np.random.default_rng(1)
    p = _write_images(tmp_path, a=rng.random((4, 6, 3)), b=rng.random((4, 6, 3)),
                      se=rng.random((4, 6, 3)))
    assert main(["compare", str(p["a"]), str(p["b"]), "--stderr", str(p["se"]),
                 "--out-dir", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "--stderr")
    assert "--per-pixel-z" in err and not (tmp_path / "cmp").exists()


def test_whitted_renders_without_seed_or_sampler(tmp_path, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(GOOD_SCENE)
    assert main(["render", str(scene), "--integrator", "whitted", "--out", str(tmp_path / "w.exr")]) == 0
    assert main(["render", str(scene), "--seed", "3", "--sampler", "uniform",
                 "--out", str(tmp_path / "d.exr")]) == 0


# ---------------------------------------------------------------------------------------------------
# compare: standard errors, channels, non-finite pixels
# ---------------------------------------------------------------------------------------------------

def test_a_negative_standard_error_is_refused(tmp_path, capsys):
    rng = np.random.default_rng(2)
    se = rng.random((4, 6, 3))
    se[1, 2, 0] = -0.5
    p = _write_images(tmp_path, a=rng.random((4, 6, 3)), b=rng.random((4, 6, 3)), se=se)
    assert main(["compare", str(p["a"]), str(p["b"]), "--per-pixel-z", "--stderr", str(p["se"]),
                 "--out-dir", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "--stderr")
    assert "1 values" in err and ">= 0" in err and not (tmp_path / "cmp").exists()


def test_compare_of_two_and_three_channels_names_the_channels(tmp_path, capsys):
    rng = np.random.default_rng(3)
    p = _write_images(tmp_path, a=rng.random((12, 16, 3)), two=rng.random((12, 16, 2)))
    assert main(["compare", str(p["a"]), str(p["two"]), "--out-dir", str(tmp_path / "cmp")]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "B")
    assert "2 channels" in err and "3" in err and "resolution" not in err


@pytest.mark.parametrize("which", ["A", "B"])
def test_compare_of_an_image_with_inf_is_one_line(which, tmp_path, capsys):
    rng = np.random.default_rng(4)
    images = {"a": rng.random((4, 6, 3)), "b": rng.random((4, 6, 3))}
    images[which.lower()][0, 0, 0] = np.inf
    p = _write_images(tmp_path, **images)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rc = main(["compare", str(p["a"]), str(p["b"]), "--out-dir", str(tmp_path / "cmp")])
    captured = capsys.readouterr()
    assert rc == 2 and "nan" not in captured.out.lower()
    assert_one_line_error(captured.err, which)
    assert "1 of 24 pixels are NaN or Inf" in captured.err


# ---------------------------------------------------------------------------------------------------
# Values that start with a minus reach their own checks
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, field, shown", [
    (["render", "aa-edges", "--res", "-16x12"], "--res", "'-16x12'"),
    (["lobe", "diffuse", "--albedo", "-1,0,0"], "--albedo", "'-1,0,0'"),
    (["render", "aa-edges", "--spp", "-3"], "--spp", "-3"),
])
def test_a_negative_value_is_checked_as_a_value(argv, field, shown, tmp_path, capsys):
    assert main(argv + ["--out", str(tmp_path / ("x.exr" if argv[0] == "render" else "l"))]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, field)
    assert "expected one argument" not in err and shown in err


# ---------------------------------------------------------------------------------------------------
# sources --seed: the range said is the range enforced
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("spp", [2, 8, 64])
def test_sources_seed_range_said_is_enforced(spp, tmp_path, capsys):
    import re
    from drtlab.experiments.sources.decompose import check_seed, max_seed
    assert main(["sources", "aa-edges", "--spp", str(spp), "--seed", str(1 << 30),
                 "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, "--seed")
    low, high = map(int, re.search(r"in \[(\d+), (\d+)\]", err).groups())
    assert (low, high) == (0, max_seed(spp))
    assert check_seed(high, spp) == high               # the last value said is accepted
    with pytest.raises(InputError):
        check_seed(high + 1, spp)                      # and the next one refused
    from drtlab.estimators.pointsets.pickfreeze import BASE_LIMIT
    assert high + spp + 1 < BASE_LIMIT                 # the pilot's base, seed + spp, fits too


# ---------------------------------------------------------------------------------------------------
# Plugins that end the program
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("code", ["", "0", "3"])
def test_a_plugin_that_exits_at_import_is_one_line(code, tmp_path, capsys):
    plugin = tmp_path / f"quits{code}.py"
    plugin.write_text(f"import sys\nsys.exit({code})\n")
    assert main(["samplers", "--plugin", str(plugin)]) == 2
    err = capsys.readouterr().err
    assert_one_line_error(err, f"--plugin {plugin.name}")
    assert "sys.exit" in err


def test_registers_nothing_names_every_registration(tmp_path, capsys):
    plugin = tmp_path / "empty.py"
    plugin.write_text("x = 1\n")
    assert main(["samplers", "--plugin", str(plugin)]) == 2
    err = capsys.readouterr().err
    for call in ("register_pointset", "register_light_selection", "register_lobe_sampler",
                 "register_strategy", "register_metric"):
        assert call in err


def test_plugin_help_names_every_kind_of_registration(capsys):
    with pytest.raises(SystemExit):
        main(["render", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "lobe samplers" in text and "light selections" in text and "error metrics" in text


@pytest.mark.parametrize("value, ok", [(1e10, False), (1e15, False), (3e9, True), (4.0, True)])
def test_a_conductor_whose_fresnel_float32_cannot_hold_is_refused(value, ok):
    # Found trying further inputs: eta = k = 1e10 (each within 1e15) rendered 5 NaN pixels of 48.
    import drtlab
    d = tomllib.loads(GOOD_SCENE)
    d["materials"]["grey"] = {"kind": "conductor", "eta": [value] * 3, "k": [value] * 3}
    if ok:
        with warnings.catch_warnings():
            warnings.simplefilter("error", NonFiniteImageWarning)
            assert np.isfinite(drtlab.render(drtlab.load_scene(d), spp=16)).all()
    else:
        assert "eta^2 + k^2" in _refused(d, "materials.grey.k")


def test_check_pixels_for_a_routine_without_a_battery_is_refused(tmp_path, capsys):
    # Found trying further inputs: --pixels sizes a point set's battery; a light selection's card
    # has none, and the flag was ignored.
    assert main(["check", "power", "--pixels", "512", "--out", str(tmp_path / "card.json")]) == 2
    assert_one_line_error(capsys.readouterr().err, "--pixels")
    assert list(tmp_path.iterdir()) == []
