"""The environment light (kernels/scene_model/environment_map.py, environment.py, environment_lighting.py):
closed forms rendered by every environment sampler, the light choice among the environment and area
lights, the [environment] table's errors, image files, and features off when absent.

Closed forms (tests/support/scene_util.py), a diffuse plane of albedo rho alone under:
  * a constant environment L (the furnace): every pixel rho L;
  * a two-level environment (upper hemisphere L1, lower L2), the plane facing up: irradiance pi L1,
    pixel rho L1; tilted by a from +y: E = pi [L1 (1 + cos a) + L2 (1 - cos a)] / 2 (the half-space
    y > 0 fills the fraction (1 + cos a) / 2 of the plane's projected solid angle);
  * light_over_plane's sphere light over a plane with its uniform background given as a constant
    environment instead (identical radiance everywhere, so the same closed form): the light choice
    between the environment and the area light, by power (importance) and uniformly (uniform).
Samplers: the three environment samplers with MIS (env-uniform, env-cosine, importance = image) and
the non-MIS strategies (uniform: uniform sphere without MIS; light: image, light samples only).
Each comparison is the suite's one test (tests/support/stats_util.py): RUNS renders x SPP, 12
regions of 4 x 4 pixels, Welch t -> chi-square, Sidak over M_TESTS at family-wise alpha = 0.01;
every case also asserts no non-finite and no negative pixel. Tiers: fast 8 x 64, full 16 x 256.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.experiments.stats.chi2 import sidak
from drtlab.kernels.features import features_of
from drtlab.kernels.imageio import write_exr
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import scene_from_dict

import scene_util as su
from stats_util import ALPHA, compare, render_estimate, tier

BLOCK = 4
RUNS = tier(8, 16)
SPP = tier(64, 256)
ENV_SAMPLERS = ("importance", "independent+env-uniform", "independent+env-cosine")
ALL = ENV_SAMPLERS + ("uniform", "independent+light")
TWO = dict(kind="two_level", upper=[2.0, 2.0, 2.0], lower=[0.3, 0.3, 0.3])

CASES = {
    "furnace": (lambda: su.environment_over_plane(dict(kind="constant", radiance=[1.5] * 3),
                                                  su.two_level_irradiance(1.5, 1.5, 0.0),
                                                  name="furnace"), ALL),
    "two-level-up": (lambda: su.environment_over_plane(TWO, su.two_level_irradiance(2.0, 0.3, 0.0),
                                                       name="two-level-up"), ALL),
    "two-level-tilted-60": (lambda: su.environment_over_plane(
        TWO, su.two_level_irradiance(2.0, 0.3, 60.0), tilt_deg=60.0, name="two-level-60"), ALL),
    "two-level-tilted-60-drt": (lambda: su.environment_over_plane(
        TWO, su.two_level_irradiance(2.0, 0.3, 60.0), tilt_deg=60.0, integrator="drt",
        name="two-level-60-drt"), ENV_SAMPLERS),
    "sphere-light-and-environment": (lambda: _with_environment(su.light_over_plane(
        "sphere", bg=0.25, name="light-and-environment")), ALL),
}
M_TESTS = sum(len(s) for _, s in CASES.values())
ALPHA_TEST = sidak(ALPHA, M_TESTS)


def _with_environment(cf: su.ClosedForm) -> su.ClosedForm:
    """The closed form with its uniform background as a constant environment of the same radiance."""
    scene = dict(cf.scene, scene=dict(cf.scene["scene"]))
    bg = scene["scene"].pop("background")
    scene["environment"] = dict(kind="constant", radiance=bg)
    return su.ClosedForm(cf.name, scene, cf.truth)


@functools.lru_cache(maxsize=None)
def closed_form(name: str) -> su.ClosedForm:
    return CASES[name][0]()


@pytest.mark.parametrize("name,sampler", [pytest.param(n, s, id=f"{n}-{s}")
                                          for n, (_, ss) in CASES.items() for s in ss])
def test_closed_form(name, sampler):
    cf = closed_form(name)
    sc = cf.load()
    est = render_estimate(sc, sampler, sc.integrator, SPP, RUNS, ("environment", name, sampler),
                          block=BLOCK)
    c = compare(est, cf.region_truth(BLOCK), ALPHA_TEST)
    msg = f"{name}/{sampler}: {c.summary()}"
    assert est.nonfinite == 0 and est.negative == 0, msg
    assert not c.rejected, msg


def test_closed_forms_are_what_they_say():
    # Upward plane: E = pi L1 whatever L2; the tilted plane sees some of the lower level.
    assert su.two_level_irradiance(2.0, 0.3, 0.0) == pytest.approx(np.pi * 2.0)
    assert su.two_level_irradiance(2.0, 0.3, 90.0) == pytest.approx(np.pi * 1.15)
    # The texel irradiances of a whole upper hemisphere add up to pi.
    h, w = 16, 32
    assert sum(su.texel_irradiance(h, w, r) for r in range(h // 2)) * w == pytest.approx(np.pi)


# ---------------------------------------------------------------------------------------------------
# The scene format
# ---------------------------------------------------------------------------------------------------
def _scene(env, background=None):
    cf = su.environment_over_plane(dict(kind="constant"), np.pi)
    d = dict(cf.scene, environment=env)
    if background is not None:
        d["scene"] = dict(d["scene"], background=background)
    return d


@pytest.mark.parametrize("env,field,words", [
    (dict(kind="sky"), "environment.kind", ["constant", "two_level", "gradient", "image"]),
    (dict(radiance=[1, 1, 1]), "environment.kind", ["required"]),
    (dict(kind="constant", upper=[1, 1, 1]), "environment", ["upper", "radiance"]),
    (dict(kind="constant", radiance=[1, -1, 1]), "environment.radiance", [">= 0"]),
    (dict(kind="two_level", resolution=[8, 5]), "environment.resolution", ["even"]),
    (dict(kind="gradient", sun_direction=[0, 0, 0], sun_radiance=[9, 9, 9]),
     "environment.sun_direction", ["non-zero"]),
    (dict(kind="gradient", sun_direction=[0, 1, 0]), "environment.sun_radiance", ["required"]),
    (dict(kind="image"), "environment.file", ["required"]),
    (dict(kind="image", file="/nonexistent/sky.exr"), "environment.file", ["does not exist"]),
    (dict(kind="constant", scale=-1), "environment.scale", [">= 0"]),
    ([1, 2], "environment", ["table"]),
])
def test_bad_environment_is_one_clear_error(env, field, words):
    with pytest.raises(InputError) as e:
        scene_from_dict(_scene(env))
    text = str(e.value)
    assert "\n" not in text and text.startswith(field), text
    for w in words:
        assert w in text, text


def test_background_and_environment_exclude_each_other():
    with pytest.raises(InputError, match="scene.background"):
        scene_from_dict(_scene(dict(kind="constant"), background=[0.1, 0.1, 0.1]))


def test_image_file_is_read_as_the_lat_long_map(tmp_path):
    rng = np.random.default_rng(3)
    img = rng.uniform(0.0, 2.0, (4, 8, 3)).astype(np.float32)
    write_exr(tmp_path / "sky.exr", img)
    sc = scene_from_dict(_scene(dict(kind="image", file=str(tmp_path / "sky.exr"), scale=2.0)))
    assert np.array_equal(sc.environment.image, 2.0 * img.astype(np.float64))
    # The file's contents enter the scene's hash (the TOML text alone cannot see them).
    write_exr(tmp_path / "sky.exr", img * 0.5)
    other = scene_from_dict(_scene(dict(kind="image", file=str(tmp_path / "sky.exr"), scale=2.0)))
    assert other.content_hash() != sc.content_hash()


def test_sun_is_one_texel():
    sc = scene_from_dict(_scene(dict(kind="constant", radiance=[1, 1, 1], resolution=[16, 8],
                                     sun_direction=[1, 1, 0], sun_radiance=[100, 100, 100])))
    hot = np.argwhere(sc.environment.image[..., 0] > 1.0)
    assert hot.tolist() == [[2, 0]]     # 45 degrees up (row 2 of 8), phi = 0 (column 0)


def test_features_compile_the_environment_out_when_absent():
    with_env = features_of(scene_from_dict(_scene(dict(kind="constant"))), "path")
    assert with_env.environment and "environment" in with_env.key()
    plain = features_of(su.light_over_plane("sphere").load(), "path")
    assert not plain.environment and "environment" not in plain.key()


def test_black_environment_renders_zero():
    sc = scene_from_dict(_scene(dict(kind="constant", radiance=[0, 0, 0])))
    for sampler in ALL:
        img = render(sc, spp=8, sampler=sampler, progress=False)
        assert np.all(img == 0.0), sampler


def test_negative_control_is_rejected():
    # The same test must see a wrong estimator through the environment's code: drop_cosine (the
    # BSDF's cosine lost in light samples and scattering) on the furnace.
    cf = closed_form("furnace")
    est = render_estimate(cf.load(), "importance", "path", SPP, RUNS, ("environment-control",),
                          block=BLOCK, faults=("drop_cosine",))
    c = compare(est, cf.region_truth(BLOCK), ALPHA_TEST)
    assert c.rejected, c.summary()


def test_image_file_is_found_beside_the_scene_file(tmp_path):
    from drtlab.kernels.scene_model.scene_file import load_scene
    write_exr(tmp_path / "sky.exr", np.full((2, 4, 3), 0.5, dtype=np.float32))
    (tmp_path / "s.toml").write_text(
        '[scene]\ndescription = "d"\n[camera]\nposition = [0, 1, 5]\nlook_at = [0, 0, 0]\n'
        '[materials.m]\n[[shapes]]\nkind = "sphere"\nmaterial = "m"\ncenter = [0, 0, 0]\n'
        'radius = 1\n[environment]\nkind = "image"\nfile = "sky.exr"\n')
    assert load_scene(tmp_path / "s.toml").environment.image.shape == (2, 4, 3)


def test_a_truncated_image_is_one_line_wherever_it_is_read(tmp_path):
    """An EXR cut in half keeps a whole header, so it opens and used to read as a 0-d array (an
    IndexError later). Every reader goes through imageio._read, which refuses it."""
    from drtlab.experiments.tools.images import read_image
    from drtlab.kernels.imageio import read_exr
    rng = np.random.default_rng(4)
    write_exr(tmp_path / "sky.exr", rng.uniform(0.0, 2.0, (40, 80, 3)).astype(np.float32))
    data = (tmp_path / "sky.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[: len(data) // 2])
    with pytest.raises(OSError, match="truncated or corrupt"):
        read_exr(tmp_path / "cut.exr")
    with pytest.raises(InputError) as e:
        scene_from_dict(_scene(dict(kind="image", file=str(tmp_path / "cut.exr"))))
    assert e.value.field == "environment.file" and "truncated" in e.value.message
    with pytest.raises(InputError) as e:
        read_image(tmp_path / "cut.exr", "A")
    assert e.value.field == "A" and "truncated" in e.value.message
    assert read_exr(tmp_path / "sky.exr")[0].shape == (40, 80, 3)
