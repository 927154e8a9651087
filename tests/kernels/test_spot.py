"""Mitsuba 3's spot light (`[[lights]] kind = "spot"`, kernels/spot.py): its falloff against Mitsuba's
formula transcribed here from src/emitters/spot.cpp at many angles (to float32 rounding), an image of
a spot above a diffuse plane (path, direct, drt) against the closed form ρ I falloff(θ) h / (π r³) per pixel (a z-test,
Bonferroni over the pixels), the negative controls both must reject (no transition band, linear in
cos θ instead of θ, the angles read as radians), the loader's refusals, Mitsuba's XML in and out.
A spot's projected texture: tests/kernels/test_projection.py."""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy.stats import norm

from drtlab.errors import InputError
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene import PointLight
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict
from drtlab.kernels.spot import spot_cone, spot_falloff

EPS32 = float(np.finfo(np.float32).eps)


def mitsuba_falloff(cos_theta, cutoff_deg, beam_deg):
    """spot.cpp's falloff_curve, float64: 1 where cos θ >= cos(beam), 0 where cos θ <= cos(cutoff),
    else (cutoff - acos(cos θ)) / (cutoff - beam), the angles converted from degrees."""
    c, b = math.radians(cutoff_deg), math.radians(beam_deg)
    ct = np.asarray(cos_theta, dtype=np.float64)
    ramp = (c - np.arccos(np.clip(ct, -1.0, 1.0))) / (c - b) if c > b else np.zeros_like(ct)
    return np.where(ct > math.cos(c), np.where(ct >= math.cos(b), 1.0, ramp), 0.0)


@wp.kernel
def _falloffs(cos_theta: wp.array(dtype=float), cone: wp.vec4, out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = spot_falloff(cos_theta[i], cone)


def kernel_falloff(cos_theta: np.ndarray, cutoff_deg: float, beam_deg: float) -> np.ndarray:
    light = PointLight(position=np.zeros(3), intensity=np.ones(3), direction=np.array([0.0, 0.0, 1.0]),
                       cutoff_angle=cutoff_deg, beam_width=beam_deg)
    c = wp.array(cos_theta.astype(np.float32), dtype=float, device="cpu")
    out = wp.zeros(len(cos_theta), dtype=float, device="cpu")
    wp.launch(_falloffs, dim=len(cos_theta), inputs=[c, wp.vec4(*spot_cone(light)), out], device="cpu")
    return out.numpy().astype(np.float64)


def falloff_tolerance(cutoff_deg: float, beam_deg: float) -> float:
    # float32 rounds the angles (cutoff, acos) by ~1 ulp of the cutoff each; the ramp multiplies by
    # 1 / (cutoff - beam): 8 ulps of that scale.
    c, b = math.radians(cutoff_deg), math.radians(beam_deg)
    return 8.0 * EPS32 * c / (c - b)


def no_transition(ct, cutoff_deg, beam_deg):
    return np.where(np.asarray(ct) > math.cos(math.radians(cutoff_deg)), 1.0, 0.0)


def linear_in_cos(ct, cutoff_deg, beam_deg):
    cc, cb = math.cos(math.radians(cutoff_deg)), math.cos(math.radians(beam_deg))
    return np.clip((np.asarray(ct, dtype=np.float64) - cc) / (cb - cc), 0.0, 1.0)


CONES = [(20.0, 15.0), (20.0, 0.75 * 20.0), (45.0, 5.0), (90.0, 60.0), (170.0, 100.0), (30.0, 0.0)]


@pytest.mark.parametrize("cutoff,beam", CONES)
def test_falloff_is_mitsubas_to_float32_rounding(cutoff, beam):
    theta = np.radians(np.linspace(0.0, min(180.0, cutoff * 1.3), 4001))
    ct = np.cos(theta).astype(np.float32)
    got = kernel_falloff(ct, cutoff, beam)
    want = mitsuba_falloff(ct, cutoff, beam)
    tol = falloff_tolerance(cutoff, beam)
    assert np.max(np.abs(got - want)) <= tol
    band = (want > 0.0) & (want < 1.0)
    assert band.sum() > 100 and np.all(got[want == 0.0] == 0.0) and np.all(got[want == 1.0] == 1.0)
    # negative controls: the same comparison rejects a hard edge, a ramp linear in cos θ, and the
    # angles read as radians
    for wrong in (no_transition, linear_in_cos):
        assert np.max(np.abs(got - wrong(ct, cutoff, beam))) > 100 * tol
    assert np.max(np.abs(kernel_falloff(ct, math.radians(cutoff), math.radians(beam)) - want)) > 0.5


def test_a_point_light_cone_is_exactly_one_everywhere():
    ct = np.cos(np.linspace(0.0, math.pi, 1001)).astype(np.float32)
    light = PointLight(position=np.zeros(3), intensity=np.ones(3))
    c = wp.array(ct, dtype=float, device="cpu")
    out = wp.zeros(len(ct), dtype=float, device="cpu")
    wp.launch(_falloffs, dim=len(ct), inputs=[c, wp.vec4(*spot_cone(light)), out], device="cpu")
    assert np.all(out.numpy() == 1.0)


# ---- a spot at height H above a diffuse plane, seen straight down by an orthographic camera ----
H, N, FILM, SPP = 1.0, 24, 1.7, 256
ALBEDO, INTENSITY, CUTOFF, BEAM = 0.5, np.array([2.0, 3.0, 4.0]), 30.0, 20.0


def plane_scene(spot: dict) -> dict:
    return {"scene": {"description": "a spot over a plane", "resolution": [N, N], "spp": SPP,
                      "integrator": "path", "max_depth": 2},
            "camera": {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
                       "fov": 30.0, "ortho_height": FILM},
            "materials": {"floor": {"albedo": [ALBEDO] * 3}},
            "shapes": [{"kind": "quad", "material": "floor", "origin": [-2.0, 0.0, -2.0],
                        "edge_u": [0.0, 0.0, 4.0], "edge_v": [4.0, 0.0, 0.0]}],
            "lights": [{"kind": "spot", "position": [0.0, H, 0.0], "intensity": INTENSITY.tolist(),
                        **spot}]}


def pixel_moments(falloff, q: int = 32):
    """Each pixel's mean and standard deviation of L = ρ I falloff(θ) h / (π r³) over its footprint
    (q x q midpoints): what one uniform sample in the pixel estimates, and its spread."""
    step = FILM / N
    offs = (np.arange(q) + 0.5) / q * step
    x = (np.arange(N)[:, None] * step + offs[None, :]).ravel() - FILM / 2       # N*q positions
    X, Z = np.meshgrid(x, x)
    r = np.sqrt(X ** 2 + Z ** 2 + H ** 2)
    L = ALBEDO / math.pi * falloff(H / r, CUTOFF, BEAM) * H / r ** 3
    L = L.reshape(N, q, N, q)
    return L.mean(axis=(1, 3)), L.std(axis=(1, 3)), mitsuba_falloff(H / r, CUTOFF, BEAM).reshape(N, q, N, q)


@pytest.fixture(scope="module", params=["path", "direct", "drt"])
def plane_image(request):
    return render(scene_from_dict(plane_scene({"direction": [0.0, -2.0, 0.0], "cutoff_angle": CUTOFF,
                                               "beam_width": BEAM})),
                  spp=SPP, seed=3, sampler="independent", integrator=request.param)


def z_scores(img, falloff):
    mean, std, _ = pixel_moments(falloff)
    # float32 rounding of the estimate: 1e-5 of the value beside the sampling spread
    sigma = np.sqrt(std ** 2 / SPP + (1e-5 * mean) ** 2)
    want = mean[..., None] * INTENSITY
    z = (img - want) / np.maximum(sigma[..., None] * INTENSITY, 1e-30)
    return np.where(want > 0, z, np.where(img == 0.0, 0.0, np.inf))


def test_spot_over_a_plane_matches_the_closed_form(plane_image):
    alpha = 1e-3
    z_crit = norm.isf(alpha / (2 * plane_image.size))
    z = z_scores(plane_image, mitsuba_falloff)
    _, _, f = pixel_moments(mitsuba_falloff)
    beam = np.all(f == 1.0, axis=(1, 3))
    band = np.all((f > 0.0) & (f < 1.0), axis=(1, 3))
    dark = np.all(f == 0.0, axis=(1, 3))
    assert beam.sum() >= 20 and band.sum() >= 20 and dark.sum() >= 20
    assert np.all(plane_image[dark] == 0.0)
    assert np.max(np.abs(z)) < z_crit
    # negative controls: a hard edge at the cutoff and a ramp linear in cos θ are rejected
    for wrong in (no_transition, linear_in_cos):
        assert np.max(np.abs(z_scores(plane_image, wrong))) > z_crit


def test_look_at_and_direction_give_the_same_image():
    a, b = ({"look_at": [0.0, -5.0, 0.0]}, {"direction": [0.0, -2.0, 0.0]})
    a, b = (render(scene_from_dict(plane_scene({**x, "cutoff_angle": CUTOFF, "beam_width": BEAM})),
                   spp=4, seed=3, sampler="independent") for x in (a, b))
    assert np.array_equal(a, b) and a.max() > 0.0


def test_defaults_are_mitsubas():
    s = scene_from_dict(plane_scene({"direction": [0.0, -1.0, 0.0]}))
    light = s.point_lights[0]
    assert light.spot and light.cutoff_angle == 20.0 and light.beam_width == 15.0
    s = scene_from_dict(plane_scene({"direction": [0.0, -1.0, 0.0], "cutoff_angle": 40}))
    assert s.point_lights[0].beam_width == 30.0


@pytest.mark.parametrize("spot,field,words", [
    ({}, "lights[0].direction", "either direction or look_at"),
    ({"direction": [0, -1, 0], "look_at": [0, 0, 0]}, "lights[0].direction", "not both"),
    ({"direction": [0, 0, 0]}, "lights[0].direction", "non-zero"),
    ({"look_at": [0.0, H, 0.0]}, "lights[0].look_at", "non-zero"),
    ({"direction": [0, -1, 0], "cutoff_angle": 0}, "lights[0].cutoff_angle", "(0, 180]"),
    ({"direction": [0, -1, 0], "cutoff_angle": 200}, "lights[0].cutoff_angle", "(0, 180]"),
    ({"direction": [0, -1, 0], "cutoff_angle": 20, "beam_width": 25}, "lights[0].beam_width",
     "cutoff_angle = 20"),
    ({"direction": [0, -1, 0], "beam_width": -1}, "lights[0].beam_width", "[0,"),
    ({"direction": [0, -1, 0], "texture": "x.png"}, "lights[0]", "texture"),
])
def test_bad_spots_are_one_line_naming_the_field(spot, field, words):
    with pytest.raises(InputError) as e:
        scene_from_dict(plane_scene(spot))
    msg = str(e.value)
    assert field in msg and words in msg and "\n" not in msg


def test_scenes_without_spots_compile_no_spot_code():
    from drtlab.kernels.features import features_of
    point = plane_scene({})
    point["lights"][0]["kind"] = "point"
    assert not features_of(scene_from_dict(point), "path").spot_lights
    assert features_of(scene_from_dict(plane_scene({"direction": [0, -1, 0]})), "path").spot_lights


# ---- Mitsuba 3 XML in and out ----
def mitsuba_spot(body: str, transform: str = '<lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/>') -> str:
    tw = f'<transform name="to_world">{transform}</transform>' if transform else ""
    return ('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
            '<transform name="to_world"><lookat origin="0, 3, 1" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>'
            '</film></sensor><integrator type="path"/>'
            f'<emitter type="spot">{tw}{body}</emitter>'
            '<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform>'
            '</shape></scene>')


def test_mitsuba_spot_imports_its_frame_angles_and_defaults(tmp_path):
    (tmp_path / "a.xml").write_text(mitsuba_spot('<rgb name="intensity" value="5"/>'
                                                 '<float name="cutoff_angle" value="25"/>'
                                                 '<float name="beam_width" value="10"/>'))
    light = load_scene(tmp_path / "a.xml").point_lights[0]
    assert light.spot and light.position.tolist() == [0.0, 1.0, 0.0]
    assert np.allclose(light.direction, [0.0, -1.0, 0.0], atol=1e-15)
    assert (light.cutoff_angle, light.beam_width, light.intensity.tolist()) == (25.0, 10.0, [5.0] * 3)
    # Mitsuba's defaults: no to_world (at the origin along +z), intensity 1, cutoff 20, beam 3/4 of it
    (tmp_path / "b.xml").write_text(mitsuba_spot("", transform=""))
    light = load_scene(tmp_path / "b.xml").point_lights[0]
    assert (light.position.tolist(), light.direction.tolist()) == ([0.0] * 3, [0.0, 0.0, 1.0])
    assert (light.cutoff_angle, light.beam_width, light.intensity.tolist()) == (20.0, 15.0, [1.0] * 3)
    (tmp_path / "c.xml").write_text(mitsuba_spot('<float name="cutoff_angle" value="40"/>'))
    assert load_scene(tmp_path / "c.xml").point_lights[0].beam_width == 30.0
    (tmp_path / "d.xml").write_text(mitsuba_spot('<float name="beam_width" value="18"/>'))  # cutoff 20
    assert load_scene(tmp_path / "d.xml").point_lights[0].beam_width == 18.0


@pytest.mark.parametrize("body,transform,words", [
    ('<texture name="texture" type="srgb"><rgb name="color" value="0.5"/></texture>', None,
     "texture(srgb): a spot's texture must be a bitmap or checkerboard"),
    ('<texture name="texture" type="bitmap"><string name="filename" value="t.png"/></texture>', None,
     "texture file 't.png' does not exist"),
    ('', '<scale x="2" y="1" z="1"/>', "uniform scale"),
    ('<float name="cutoff_angle" value="0"/>', None, "cutoff_angle"),
    ('<float name="beam_width" value="21"/>', None, "cutoff_angle = 20"),
    ('', '<scale value="0"/>', "singular"),
    ('<float name="cutoff_angle" value="10"/><float name="beam_width" value="12"/>', None, "cutoff_angle = 10"),
])
def test_mitsuba_spot_refusals_are_one_line(tmp_path, body, transform, words):
    text = mitsuba_spot(body) if transform is None else mitsuba_spot(body, transform)
    (tmp_path / "s.xml").write_text(text)
    with pytest.raises(InputError) as e:
        load_scene(tmp_path / "s.xml")
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_spot_exports_and_imports_back_exactly(tmp_path):
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    data = plane_scene({"direction": [0.3, -2.0, 0.1], "cutoff_angle": 33.3, "beam_width": 7.7})
    data["camera"].pop("ortho_height")
    data["lights"].append({"kind": "point", "position": [0.5, 1.0, 0.0], "intensity": [1.0, 1.0, 1.0]})
    a = scene_from_dict(data)
    export_mitsuba(a, tmp_path / "s.xml")
    b = load_scene(tmp_path / "s.xml")
    for x, y in zip(a.point_lights, b.point_lights, strict=True):
        assert x.spot == y.spot and x.cutoff_angle == y.cutoff_angle and x.beam_width == y.beam_width
        assert np.array_equal(x.position, y.position) and np.array_equal(x.intensity, y.intensity)
        assert x.direction is None or np.array_equal(x.direction, y.direction)
    assert np.array_equal(render(a, spp=2, seed=4, res=(8, 6)), render(b, spp=2, seed=4, res=(8, 6)))


def test_the_suite_scene_loads_with_its_texture_and_frame():
    from drtlab.experiments.bench.mitsuba.suite import suite_dir
    suite = suite_dir()
    xml = suite / "tests" / "scenes" / "spot_light" / "test_spot_direct.xml"
    if not xml.is_file():
        pytest.skip(f"Mitsuba's test scenes are not at {suite} (set DRTLAB_MITSUBA_TESTS)")
    light = load_scene(xml).point_lights[0]
    assert light.spot and light.texture.pixels.shape == (1080, 1920, 3)
    assert light.direction.tolist() == [0.0, 0.0, 1.0] and np.allclose(light.up, [0.0, 1.0, 0.0])


def test_whitted_lights_a_spot_as_path_does():
    # Whitted's fixed sub-pixel grid and path's random pixel samples estimate the same pixel integrals:
    # image means within 1% (the plane's image is smooth but for the cone's kinks); a point light in
    # the spot's place (no cone) is the negative control, far off.
    data = plane_scene({"direction": [0.0, -1.0, 0.0], "cutoff_angle": CUTOFF, "beam_width": BEAM})
    data["camera"].pop("ortho_height")
    data["camera"]["fov"] = 70.0
    spot = scene_from_dict(data)
    point = {**data, "lights": [{"kind": "point", "position": [0.0, H, 0.0], "intensity": INTENSITY.tolist()}]}
    w = render(spot, spp=16, seed=2, integrator="whitted").mean(axis=(0, 1))
    p = render(spot, spp=16, seed=2, integrator="path", sampler="independent").mean(axis=(0, 1))
    wp_ = render(scene_from_dict(point), spp=16, seed=2, integrator="whitted").mean(axis=(0, 1))
    assert np.all(np.abs(w / p - 1.0) < 0.01), (w, p)
    assert np.all(wp_ / p > 1.5)
