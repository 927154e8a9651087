"""Mitsuba 3's projector and a spot's projected texture (`[[lights]] kind = "projector"`, a spot's
`texture`; kernels/projection.py, kernels/scene_model/light_projection.py).

An image of a tilted projector (and of a textured spot) over a diffuse plane, seen straight down by an
orthographic camera, against the closed form L = rho / pi I(d) cos_p / dist^2 per pixel, with I(d)
transcribed here from Mitsuba's source: the projector's pi scale E(uv) / cos^3 theta inside its
frustum with uv from perspective_projection's matrix chain (include/mitsuba/render/sensor.h), the
spot's intensity x falloff x texture(uv) with spot.cpp's direction_to_uv. A z-test per pixel whose
footprint lies within one texel (or wholly outside), Bonferroni over the pixels at alpha = 1e-3; the
negative controls it must reject: the cos^3 factor dropped, u flipped, v flipped. The importer's
defaults against Mitsuba's (parse_fov's own test values), bad input in one line.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from drtlab.errors import InputError
from drtlab.kernels.imageio import write_exr
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.light_projection import FOCAL_LENGTH_MM, focal_length_fov, fov_x
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

H, N, FILM, SPP, Q = 1.0, 32, 3.2, 64, 16
ALBEDO, ALPHA = 0.5, 1e-3
TILT = math.radians(12.0)
AXIS = np.array([math.sin(TILT), -math.cos(TILT), 0.0])
UP = np.array([0.0, 0.0, 1.0])
# A 4 x 3 texture of distinct texels (row 0 the image's top), looked up nearest.
TEXELS = (np.arange(12, dtype=np.float32).reshape(3, 4)[..., None] * np.array([1.0, 0.5, 0.25], np.float32)
          + np.float32(1.0))


def mitsuba_frame():
    """Mitsuba's look_at frame (transform.h): left = normalize(up x dir), new_up = dir x left."""
    z = AXIS / np.linalg.norm(AXIS)
    x = np.cross(UP, z)
    x /= np.linalg.norm(x)
    return x, np.cross(z, x), z


def perspective_uv(local: np.ndarray, fov: float, aspect: float) -> np.ndarray:
    """uv of camera-space points (..., 3) by Mitsuba's camera_to_sample = scale(-0.5, -0.5 aspect, 1)
    translate(-1, -1 / aspect, 0) perspective(fov, near, far), then the projective divide."""
    near, far = 1e-4, 1e4
    cot = 1.0 / math.tan(math.radians(fov / 2.0))
    persp = np.array([[cot, 0, 0, 0], [0, cot, 0, 0], [0, 0, far / (far - near), -near * far / (far - near)],
                      [0, 0, 1, 0]])
    translate = np.eye(4)
    translate[:3, 3] = [-1.0, -1.0 / aspect, 0.0]
    scale = np.diag([-0.5, -0.5 * aspect, 1.0, 1.0])
    m = scale @ translate @ persp
    p = np.concatenate([local, np.ones(local.shape[:-1] + (1,))], axis=-1) @ m.T
    return p[..., :2] / p[..., 3:4]


def spot_uv(local: np.ndarray, cutoff: float) -> np.ndarray:
    """spot.cpp's direction_to_uv: 0.5 + 0.5 (x, y) / (z tan(cutoff))."""
    f = math.tan(math.radians(cutoff))
    return 0.5 + 0.5 * local[..., :2] / (local[..., 2:3] * f)


def texel_of(uv: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """The nearest texel's flat index of uv (bitmap.cpp: floor(uv res), wrapped), -1 where not lit."""
    h, w = TEXELS.shape[:2]
    ix = np.floor(uv[..., 0] * w).astype(int) % w
    iy = np.floor(uv[..., 1] * h).astype(int) % h
    return np.where(inside, iy * w + ix, -1)


def footprint(edges: bool = False):
    """The q x q midpoints of every pixel on the plane y = 0: (N, Q, N, Q, 3), or with `edges` q + 1
    points from edge to edge; the camera looks down -y with up -z, so column j runs along +x and
    row i along +z."""
    step = FILM / N
    q = Q + 1 if edges else Q
    offs = np.arange(q) / Q if edges else (np.arange(Q) + 0.5) / Q
    c = (np.arange(N)[:, None] * step + offs[None, :] * step).ravel() - FILM / 2
    Z, X = np.meshgrid(c, c, indexing="ij")
    return np.stack([X, np.zeros_like(X), Z], axis=-1).reshape(N, q, N, q, 3)


def expected(kind: str, wrong: str = ""):
    """(mean, std over the footprint, clean, texels) per pixel of L = rho / pi I cos_p / dist^2 (RGB),
    clean where the whole pixel (its points edge to edge) lies within one texel or outside the light."""
    mean, std, _ = radiance(footprint(), kind, wrong)
    _, _, tex = radiance(footprint(edges=True), kind, wrong)
    clean = np.all(tex == tex[:, :1, :, :1], axis=(1, 3))
    return mean, std, clean, tex


def radiance(p: np.ndarray, kind: str, wrong: str):
    """(mean, std, texel indices) of the closed form at the points p (N, q, N, q, 3)."""
    d = p - np.array([0.0, H, 0.0])
    dist = np.linalg.norm(d, axis=-1)
    d = d / dist[..., None]
    x, y, z = mitsuba_frame()
    local = np.stack([d @ x, d @ y, d @ z], axis=-1)
    if kind == "projector":
        uv = perspective_uv(local, FOV_X, TEXELS.shape[1] / TEXELS.shape[0])
        inside = (local[..., 2] > 0) & np.all((uv >= 0) & (uv <= 1), axis=-1)
        intensity = math.pi * SCALE / np.where(wrong == "no_cos3", 1.0, local[..., 2] ** 3)
    else:
        uv = spot_uv(local, CUTOFF)
        inside = local[..., 2] > math.cos(math.radians(CUTOFF))      # the spot's beam = its cutoff
        intensity = np.full(local.shape[:-1], SPOT_INTENSITY)
    if wrong == "flip_u":
        uv[..., 0] = 1.0 - uv[..., 0]
    if wrong == "flip_v":
        uv[..., 1] = 1.0 - uv[..., 1]
    tex = texel_of(uv, inside)
    colour = np.where(tex[..., None] >= 0, TEXELS.reshape(-1, 3)[np.maximum(tex, 0)], 0.0)
    L = ALBEDO / math.pi * (intensity * H / dist ** 3)[..., None] * colour
    return L.mean(axis=(1, 3)), L.std(axis=(1, 3)), tex


FOV_X, SCALE, CUTOFF, SPOT_INTENSITY = 70.0, 1.5, 35.0, 2.0


@pytest.fixture(scope="module")
def texture_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("proj") / "t.exr"
    write_exr(path, TEXELS.astype(np.float64))
    return str(path)


def plane_scene(light: dict) -> dict:
    return {"scene": {"description": "a projection onto a plane", "resolution": [N, N], "spp": SPP,
                      "integrator": "path", "max_depth": 2},
            "camera": {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
                       "fov": 30.0, "ortho_height": FILM},
            "materials": {"floor": {"albedo": [ALBEDO] * 3}},
            "shapes": [{"kind": "quad", "material": "floor", "origin": [-3.0, 0.0, -3.0],
                        "edge_u": [0.0, 0.0, 6.0], "edge_v": [6.0, 0.0, 0.0]}],
            "lights": [{"position": [0.0, H, 0.0], "direction": AXIS.tolist(), "up": UP.tolist(), **light}]}


def projector(texture_file: str | None) -> dict:
    light = {"kind": "projector", "fov": FOV_X, "scale": SCALE}
    if texture_file is not None:
        light["irradiance_texture"] = {"file": texture_file, "filter": "nearest"}
    return light


def spot(texture_file: str) -> dict:
    return {"kind": "spot", "intensity": [SPOT_INTENSITY] * 3, "cutoff_angle": CUTOFF, "beam_width": CUTOFF,
            "texture": {"file": texture_file, "filter": "nearest"}}


def max_z(img: np.ndarray, kind: str, wrong: str = "") -> float:
    mean, std, clean, _ = expected(kind, wrong)
    sigma = np.sqrt(std ** 2 / SPP + (1e-5 * mean) ** 2) + 1e-30
    z = np.where(mean > 0, (img - mean) / sigma, np.where(img == 0.0, 0.0, np.inf))
    return float(np.max(np.abs(z[clean])))


@pytest.fixture(scope="module")
def images(texture_file):
    return {kind: render(scene_from_dict(plane_scene(make(texture_file))), spp=SPP, seed=5,
                         sampler="independent")
            for kind, make in (("projector", projector), ("spot", spot))}


@pytest.mark.parametrize("kind", ["projector", "spot"])
def test_projection_matches_mitsubas_formula(images, kind):
    img = images[kind]
    mean, _, clean, tex = expected(kind)
    z_crit = norm.isf(ALPHA / (2 * clean.sum() * 3))
    # most texels land somewhere clean (the spot's round cone cuts the corner ones), the dark
    # surround is exactly black
    texels = {int(t) for t in np.unique(tex[:, 0, :, 0][clean])}
    assert -1 in texels and len(texels) >= 11 - 2 * (kind == "spot")
    assert np.all(img[clean & np.all(mean == 0, axis=-1)] == 0.0)
    assert max_z(img, kind) < z_crit
    # negative controls: u flipped, v flipped (and, for the projector, the cos^3 dropped)
    for wrong in ("flip_u", "flip_v") + (("no_cos3",) if kind == "projector" else ()):
        assert max_z(img, kind, wrong) > z_crit, wrong


def test_a_constant_projector_lights_a_facing_plane_evenly():
    # Facing the plane at height h: irradiance pi scale E / h^2 inside the frustum, radiance of a
    # diffuse plane rho scale E / h^2 (exactly: every sample sees the same value), black outside.
    data = plane_scene({"kind": "projector", "fov": 60.0, "scale": 2.0, "irradiance": [1.0, 2.0, 3.0]})
    data["lights"][0]["direction"] = [0.0, -1.0, 0.0]
    img = render(scene_from_dict(data), spp=4, seed=1, sampler="independent")
    half = math.tan(math.radians(30.0))
    c = (np.arange(N) + 0.5) * FILM / N - FILM / 2
    inside = (np.abs(c)[:, None] < half - FILM / N) & (np.abs(c)[None, :] < half - FILM / N)
    outside = (np.abs(c)[:, None] > half + FILM / N) | (np.abs(c)[None, :] > half + FILM / N)
    want = ALBEDO * 2.0 * np.array([1.0, 2.0, 3.0]) / H ** 2
    assert inside.sum() > 50 and outside.sum() > 50
    assert np.allclose(img[inside], want, rtol=1e-5, atol=0.0)
    assert np.all(img[outside] == 0.0)


def test_fov_is_mitsubas_parse_fov():
    # src/render/tests/test_sensor.py's values: a 50 mm lens at aspects 0.5, 1, 1.5; 25 mm at 1
    for mm, aspect, want in ((50.0, 0.5, 21.90213966369629), (50.0, 1.0, 34.02204132080078),
                             (50.0, 1.5, 39.597713470458984), (25.0, 1.0, 62.923526763916016)):
        # (Mitsuba's test: dr.allclose, relative 1e-5; its values are float32)
        assert math.isclose(fov_x(focal_length_fov(mm), "diagonal", aspect), want, rel_tol=1e-5)
    assert fov_x(35.0, "x", 2.0) == 35.0
    assert math.isclose(fov_x(35.0, "y", 2.0), math.degrees(2 * math.atan(2 * math.tan(math.radians(17.5)))))
    assert fov_x(35.0, "smaller", 2.0) == fov_x(35.0, "y", 2.0)
    assert fov_x(35.0, "larger", 0.5) == fov_x(35.0, "y", 0.5)


def test_projector_defaults_are_mitsubas(texture_file):
    light = scene_from_dict(plane_scene({"kind": "projector"})).point_lights[0]
    # no fov: a 50 mm lens along the diagonal of a 1 x 1 image (a constant's resolution); scale 1,
    # irradiance 1
    assert light.projector and not light.spot and FOCAL_LENGTH_MM == 50.0
    assert math.isclose(light.fov_x, 34.02204132080078, rel_tol=1e-6)
    assert light.intensity.tolist() == [1.0, 1.0, 1.0] and light.texture is None
    light = scene_from_dict(plane_scene({"kind": "projector", "fov": 40.0,
                                         "irradiance_texture": {"file": texture_file}})).point_lights[0]
    assert light.fov_x == 40.0          # fov_axis x by default
    light = scene_from_dict(plane_scene({"kind": "projector", "fov": 40.0, "fov_axis": "y",
                                         "irradiance_texture": {"file": texture_file}})).point_lights[0]
    assert math.isclose(light.fov_x, fov_x(40.0, "y", 4 / 3))


@pytest.mark.parametrize("light,field,words", [
    ({"kind": "projector", "fov": 0}, "lights[0].fov", "(0, 180)"),
    ({"kind": "projector", "fov_axis": "y"}, "lights[0].fov_axis", "applies to a given fov"),
    ({"kind": "projector", "fov": 30, "fov_axis": "z"}, "lights[0].fov_axis", "x, y, diagonal"),
    ({"kind": "projector", "irradiance": [1, 1, 1], "irradiance_texture": {"file": "x.exr"}},
     "lights[0].irradiance_texture", "not both"),
    ({"kind": "projector", "scale": -1}, "lights[0].scale", ">= 0"),
    ({"kind": "projector", "up": AXIS.tolist()}, "lights[0].up", "not parallel"),
    ({"kind": "projector", "intensity": [1, 1, 1]}, "lights[0].intensity", ""),
    ({"kind": "spot", "intensity": [1, 1, 1], "texture": "t.png"}, "lights[0].texture", "table"),
])
def test_bad_projections_are_one_line_naming_the_field(light, field, words):
    with pytest.raises(InputError) as e:
        scene_from_dict(plane_scene(light))
    msg = str(e.value)
    assert field in msg and words in msg and "\n" not in msg


def test_scenes_without_projections_compile_none():
    from drtlab.kernels.features import features_of
    data = plane_scene({"kind": "spot", "intensity": [1, 1, 1]})
    assert not features_of(scene_from_dict(data), "path").projections
    assert features_of(scene_from_dict(plane_scene({"kind": "projector"})), "path").projections


# ---- Mitsuba 3 XML ----
def mitsuba_scene(emitter: str) -> str:
    return ('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
            '<transform name="to_world"><lookat origin="0, 3, 1" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>'
            f'</film></sensor><integrator type="path"/>{emitter}'
            '<shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform>'
            '</shape></scene>')


LOOKAT = '<transform name="to_world"><lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform>'


def test_mitsuba_projector_imports_frame_and_defaults(tmp_path, texture_file):
    (tmp_path / "a.xml").write_text(mitsuba_scene(f'<emitter type="projector">{LOOKAT}</emitter>'))
    light = load_scene(tmp_path / "a.xml").point_lights[0]
    assert light.projector and light.position.tolist() == [0.0, 1.0, 0.0]
    assert np.allclose(light.direction, [0, -1, 0], atol=1e-15) and np.allclose(light.up, [0, 0, 1], atol=1e-15)
    assert math.isclose(light.fov_x, 34.02204132080078, rel_tol=1e-6)   # focal_length 50mm
    assert light.intensity.tolist() == [1.0] * 3
    (tmp_path / "b.xml").write_text(mitsuba_scene(
        f'<emitter type="projector">{LOOKAT}<float name="scale" value="3"/><float name="fov" value="30"/>'
        '<string name="fov_axis" value="y"/><texture type="bitmap" name="irradiance">'
        f'<string name="filename" value="{texture_file}"/></texture></emitter>'))
    light = load_scene(tmp_path / "b.xml").point_lights[0]
    assert light.intensity.tolist() == [3.0] * 3 and light.texture.pixels.shape == (3, 4, 3)
    assert math.isclose(light.fov_x, fov_x(30.0, "y", 4 / 3))


@pytest.mark.parametrize("emitter,words", [
    ('<emitter type="projector"><transform name="to_world"><scale value="2"/></transform></emitter>',
     "rotation and a translation"),
    ('<emitter type="projector"><float name="fov" value="30"/><string name="focal_length" value="20mm"/>'
     '</emitter>', "either fov or focal_length"),
    ('<emitter type="spot"><transform name="to_world"><scale x="-1" y="1" z="1"/></transform>'
     '<texture type="bitmap" name="texture"><string name="filename" value="TEX"/></texture></emitter>',
     "must not mirror"),
])
def test_mitsuba_projection_refusals_are_one_line(tmp_path, texture_file, emitter, words):
    (tmp_path / "s.xml").write_text(mitsuba_scene(emitter.replace("TEX", texture_file)))
    with pytest.raises(InputError) as e:
        load_scene(tmp_path / "s.xml")
    assert words in str(e.value) and "\n" not in str(e.value)


def test_projections_are_not_exported(tmp_path):
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    data = plane_scene({"kind": "projector"})
    data["camera"].pop("ortho_height")
    with pytest.raises(InputError) as e:
        export_mitsuba(scene_from_dict(data), tmp_path / "s.xml")
    assert "lights[0]" in str(e.value) and "not exported" in str(e.value)
    assert not (tmp_path / "s.xml").exists()
