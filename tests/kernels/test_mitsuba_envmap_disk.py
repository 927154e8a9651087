"""Mitsuba 3's envmap emitter and disk shape in drtlab.

envmap -> an image environment with `lookup = "bilinear"` and `to_world` (kernels/scene_model/environment_map.py,
kernels/environment.py): the device lookup against scipy's bilinear interpolation of the image at
Mitsuba's sample positions (negative control: the texel lookup must miss it), a one-texel map
turned by to_world lighting exactly the direction Mitsuba's convention gives (u = atan2(x, -z) /
2 pi, v = acos(y) / pi, columns at their centres, rows at v = r / (H - 1)), Mitsuba itself where it
is installed, and the image sampler of a turned bilinear map by chi-square (alpha = 0.01, Sidak over
N_TESTS; negative control: the undilated tables). disk -> a triangle fan: its area, normal,
flip_normals and power. Refused inputs are one line each.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.ndimage import map_coordinates
from scipy.spatial.transform import Rotation

from drtlab.errors import InputError
from drtlab.experiments.stats import chi2 as C
from drtlab.experiments.stats.chi2.environment_adapter import EnvironmentAdapter, device_tables
from drtlab.kernels.scene_model.environment_map import (EnvironmentMap, direction_pdf, parse_environment,
                                            sampling_tables)
from drtlab.kernels.imageio import write_exr
from drtlab.kernels.scene_model.procedural import DISK_SEGMENTS, disk_area_deficit
from drtlab.kernels.scene_model.scene_checks import scene_warnings
from drtlab.kernels.scene_model.scene_file import load_scene
from drtlab.kernels.scene_upload import emitter_powers

N_TESTS = 2      # the chi-square test and its negative control, at one Sidak-corrected level
CAMERA = """<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
    <rfilter type="box"/></film>
</sensor>"""
TURN = '<rotate y="1" angle="120"/><rotate z="1" angle="30"/>'


def turn_matrix() -> np.ndarray:
    """TURN as a matrix: Mitsuba applies the transforms in the order written."""
    rz = Rotation.from_rotvec([0.0, 0.0, math.radians(30.0)]).as_matrix()
    return rz @ Rotation.from_rotvec([0.0, math.radians(120.0), 0.0]).as_matrix()


def mitsuba_direction(u, v) -> np.ndarray:
    """Mitsuba's envmap frame: the direction of lat-long (u, v) (src/emitters/envmap.cpp)."""
    phi, theta = 2.0 * math.pi * np.asarray(u), math.pi * np.asarray(v)
    return np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)


def envmap_scene(tmp_path, image, transform=TURN, scale=1.0, extra="", name="env.exr"):
    write_exr(tmp_path / "env.exr", image)
    text = (f'<scene version="3.0.0">{CAMERA}<emitter type="envmap"><string name="filename" '
            f'value="{name}"/><float name="scale" value="{scale}"/>'
            f'<transform name="to_world">{transform}</transform></emitter>{extra}'
            '<shape type="sphere"/></scene>')
    (tmp_path / "s.xml").write_text(text)
    return load_scene(tmp_path / "s.xml")


def random_directions(n, seed):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def scipy_bilinear(image, local):
    """Bilinear interpolation (scipy) between samples at column centres (periodic) and at rows
    v = r / (H - 1) (clamped), at map-frame directions in drtlab's lat-long coordinates."""
    h, w = image.shape[:2]
    u = np.mod(np.arctan2(local[:, 2], local[:, 0]) / (2.0 * math.pi), 1.0)
    v = np.arccos(np.clip(local[:, 1], -1.0, 1.0)) / math.pi
    padded = np.concatenate([image[:, -1:], image, image[:, :1]], axis=1)
    coords = np.stack([v * (h - 1), u * w - 0.5 + 1.0])
    return np.stack([map_coordinates(padded[..., k], coords, order=1, mode="nearest")
                     for k in range(3)], axis=-1)


def rough_image(h=8, w=16, seed=3):
    img = np.exp(np.random.default_rng(seed).normal(0.0, 1.0, (h, w, 3)))
    img[5:] = 0.0                   # black rows: the bilinear radiance still reaches into row 5
    img[2, 7] = 40.0
    return img


def test_bilinear_lookup_is_scipy_interpolation_and_texel_lookup_is_not(tmp_path):
    img = rough_image()
    env = envmap_scene(tmp_path, img).environment
    d = random_directions(4000, 1)
    ref = scipy_bilinear(img, env.local(d))
    a = EnvironmentAdapter("uniform")
    ours = a.radiance(device_tables(env), d)
    assert np.max(np.abs(ours - ref)) < 1e-4 * img.max()
    texel = EnvironmentMap("image", img, "test", "texel", env.to_world)
    wrong = a.radiance(device_tables(texel), d)
    assert np.mean(np.abs(wrong - ref) > 1e-2 * img.max()) > 0.1      # the negative control


def test_one_texel_map_lights_mitsubas_direction(tmp_path):
    h, w, r, c = 8, 16, 2, 5
    img = np.zeros((h, w, 3))
    img[r, c] = [3.0, 2.0, 1.0]
    env = envmap_scene(tmp_path, img, scale=2.0).environment
    grid = lambda rr, cc: turn_matrix() @ mitsuba_direction((cc + 0.5) / w, rr / (h - 1))   # noqa
    lit = grid(r, c)
    others = [grid(r, c - 1), grid(r, c + 1), grid(r - 1, c), grid(r + 1, c),
              mitsuba_direction((c + 0.5) / w, r / (h - 1)),        # unturned: the control
              turn_matrix() @ mitsuba_direction(1.0 - (c + 0.5) / w, r / (h - 1))]   # u mirrored
    got = EnvironmentAdapter("uniform").radiance(device_tables(env), np.array([lit] + others))
    np.testing.assert_allclose(got[0], [6.0, 4.0, 2.0], rtol=1e-4)
    assert np.all(np.abs(got[1:]) < 1e-4)


def test_envmap_table_the_import_writes(tmp_path):
    img = rough_image()
    env = envmap_scene(tmp_path, img, scale=1.5,
                       transform=TURN + '<translate x="4"/>').environment     # translation: ignored
    assert (env.kind, env.lookup) == ("image", "bilinear")
    np.testing.assert_allclose(env.image, 1.5 * img.astype(np.float32), rtol=1e-7)
    # Mitsuba's map-frame direction of (u, v) goes to the world where drtlab's frame puts (u, v).
    u, v = np.random.default_rng(2).random((2, 50))
    theta, phi = math.pi * v, 2.0 * math.pi * u
    drtlab_local = np.stack([np.sin(theta) * np.cos(phi), np.cos(theta), np.sin(theta) * np.sin(phi)], -1)
    np.testing.assert_allclose(drtlab_local @ env.to_world.T,
                               mitsuba_direction(u, v) @ turn_matrix().T, atol=1e-12)


def test_matches_mitsuba_eval(tmp_path):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    import drjit as dr
    img = rough_image()
    env = envmap_scene(tmp_path, img, scale=0.7).environment
    m = mi.ScalarTransform4f(np.pad(turn_matrix(), ((0, 1), (0, 1))) + np.diag([0, 0, 0, 1.0]))
    em = mi.load_dict({"type": "envmap", "filename": str(tmp_path / "env.exr"), "scale": 0.7,
                       "to_world": m})
    d = random_directions(200, 4)
    ref = []
    for di in d:
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*(-di))
        ref.append(np.array(em.eval(si)))
    ours = EnvironmentAdapter("uniform").radiance(device_tables(env), d)
    assert np.max(np.abs(ours - np.array(ref))) < 1e-4 * 0.7 * img.max()


def test_turned_bilinear_map_samples_its_density():
    img = rough_image()
    rot = turn_matrix()
    env = EnvironmentMap("image", img, "test", "bilinear", rot)
    unturned = EnvironmentMap("image", img, "test", "bilinear")
    a = EnvironmentAdapter("image")
    sd = device_tables(env)

    def test(tables, name):
        s = device_tables(env, tables)
        sampler = lambda n, seed: (lambda x: (x.wi @ rot, x.valid))(a.sample(s, (0, 1, 0), n, seed))  # noqa
        return C.ChiSquareTest(C.LatLongDomain(), sampler,
                               lambda p: direction_pdf(img, p, env=unturned), sample_count=200_000,
                               res=(8 * 4, 16 * 4), seed=11, name=name).run(C.ALPHA, N_TESTS)

    res = test(None, "bilinear-turned")
    assert res.passed, res.summary()
    assert test(sampling_tables(img), "texel-tables").rejected          # the negative control
    # The pdf a sample carries and MIS's env_pdf: the density of what is sampled, in the world.
    s = a.sample(sd, (0, 1, 0), 20_000, seed=3)
    rel = C.relative_error(s.pdf, direction_pdf(img, s.wi, env=env))
    assert np.mean(rel > 1e-4) < 1e-3 and np.median(rel) < 1e-5
    # Every direction the bilinear radiance reaches has density (else next-event estimation alone
    # would be biased); the texel tables do not cover it.
    d = random_directions(20_000, 5)
    lit = a.radiance(sd, d).max(axis=1) > 0.0
    assert np.all(a.pdf(sd, (0, 1, 0))(d)[lit] > 0.0)
    narrow = device_tables(env, sampling_tables(img))
    assert np.any(a.pdf(narrow, (0, 1, 0))(d)[lit] == 0.0)


@pytest.mark.parametrize("transform, words", [
    ('<scale value="2"/>', "must be a rotation"),
    ('<scale x="-1"/>', "must be a rotation"),
])
def test_envmap_needs_a_rotation(tmp_path, transform, words):
    with pytest.raises(InputError) as e:
        envmap_scene(tmp_path, np.ones((4, 8, 3)), transform=transform)
    assert "\n" not in str(e.value) and words in str(e.value) and "to_world" in str(e.value)


@pytest.mark.parametrize("name, extra, words", [
    ("missing.exr", "", "does not exist"),
    ("env.png", "", "must name an .exr or .hdr image"),
    ("env.exr", '<emitter type="constant"/>', "a second environment emitter"),
])
def test_refused_envmaps(tmp_path, name, extra, words):
    with pytest.raises(InputError) as e:
        envmap_scene(tmp_path, np.ones((4, 8, 3)), name=name, extra=extra)
    assert "\n" not in str(e.value) and words in str(e.value)


def test_maps_mitsuba_pads_are_refused(tmp_path):
    with pytest.raises(InputError, match="has 8 x 2 texels; at least 2 x 3"):
        envmap_scene(tmp_path, np.ones((2, 8, 3)))


@pytest.mark.parametrize("table, field", [
    ({"to_world": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}, "environment.to_world"),
    ({"to_world": [[0, 1, 0], [1, 0, 0], [0, 0, 1]]}, "environment.to_world"),      # a mirror
    ({"to_world": "up"}, "environment.to_world"),
    ({"lookup": "nearest"}, "environment.lookup"),
])
def test_bad_environment_keys(tmp_path, table, field):
    write_exr(tmp_path / "e.exr", np.ones((4, 8, 3)))
    with pytest.raises(InputError) as e:
        parse_environment({"kind": "image", "file": str(tmp_path / "e.exr"), **table})
    assert str(e.value).startswith(field) and "\n" not in str(e.value)


DISKS = """<shape type="disk" id="floor"><bsdf type="diffuse"/>
  <transform name="to_world"><scale value="2"/><rotate x="1" angle="-90"/></transform></shape>
<shape type="disk" id="lamp"><boolean name="flip_normals" value="true"/>
  <emitter type="area"><rgb name="radiance" value="8, 7, 6"/></emitter>
  <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="-90"/><translate y="2"/></transform></shape>"""


def test_disk_area_normal_flip_and_power(tmp_path):
    (tmp_path / "s.xml").write_text(f'<scene version="3.0.0">{CAMERA}{DISKS}</scene>')
    scene = load_scene(tmp_path / "s.xml")
    floor, lamp = (next(s for s in scene.shapes if s.name == n) for n in ("floor", "lamp"))
    for shape, radius, normal in ((floor, 2.0, [0, 1, 0]), (lamp, 0.5, [0, -1, 0])):
        v, f = shape.mesh.vertices, shape.mesh.faces
        assert len(f) == DISK_SEGMENTS
        n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        np.testing.assert_allclose(n / np.linalg.norm(n, axis=1, keepdims=True),
                                   np.broadcast_to(normal, n.shape), atol=1e-12)
        rel = shape.area() / (math.pi * radius ** 2)
        assert abs(rel - (1.0 - disk_area_deficit(DISK_SEGMENTS))) < 1e-12 and 1.0 - rel < 1e-5
        assert np.allclose(v[:, 0] ** 2 + v[:, 2] ** 2 <= radius ** 2 * (1 + 1e-12), True)
    lum = 0.2126 * 8 + 0.7152 * 7 + 0.0722 * 6
    (power,) = emitter_powers(scene)
    assert abs(power / (math.pi * lum * math.pi * 0.25) - 1.0) < 1e-5      # pi A L of the circle
    (line,) = scene_warnings(scene)
    assert "tessellated into 1024 triangles" in line and "6.3e-06" in line


def test_flip_normals_only_on_rectangle_or_disk(tmp_path):
    (tmp_path / "s.xml").write_text(f'<scene version="3.0.0">{CAMERA}<shape type="sphere">'
                                    '<boolean name="flip_normals" value="true"/></shape></scene>')
    with pytest.raises(InputError, match="only on a rectangle or a disk"):
        load_scene(tmp_path / "s.xml")


def test_generated_disk_segments_are_checked():
    from drtlab.kernels.scene_model.scene_file import scene_from_dict
    base = {"scene": {"description": "d"}, "camera": {"position": [0, 1, 5], "look_at": [0, 0, 0]},
            "materials": {"m": {}}}
    shape = {"kind": "mesh", "material": "m", "generate": "disk", "radius": 2.0, "segments": 3}
    scene = scene_from_dict({**base, "shapes": [shape]})
    assert math.isclose(scene.shapes[0].area(), 3.0 * math.sqrt(3.0), rel_tol=1e-12)   # 3 sqrt(3) r^2 / 4
    with pytest.raises(InputError, match=r"in \[3, 65536\]") as e:
        scene_from_dict({**base, "shapes": [{**shape, "segments": 2}]})
    assert e.value.field == "shapes[0].segments"
