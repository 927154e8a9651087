"""The orthographic camera (`camera.ortho_height`, Mitsuba's `orthographic` sensor): rays along the
view axis from a film of that height, so an emitter's image is its parallel projection whatever its
distance. Exact closed forms on a 16 x 8 film; the perspective camera at the same place is the
negative control (its image of the same emitter shrinks with distance). The Mitsuba import: the
film's extent and position from to_world and near_clip, exactly."""
from __future__ import annotations

import math

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

W, H = 16, 8


def strip_scene(distance: float, ortho: bool) -> dict:
    """An emitting quad x in [-2, 0], y in [-5, 5] at z = -distance, seen from the origin along -z by a
    camera whose film is 4 wide and 2 high (orthographic) or of a 2 x atan(1 / distance) vertical fov."""
    cam = {"position": [0.0, 0.0, 0.0], "look_at": [0.0, 0.0, -1.0], "up": [0.0, 1.0, 0.0],
           "fov": 2 * math.degrees(math.atan(1.0 / 4.0))}
    if ortho:
        cam["ortho_height"] = 2.0
    return {"scene": {"description": "a strip lamp", "resolution": [W, H], "spp": 4, "integrator": "path",
                      "max_depth": 1},
            "camera": cam,
            "materials": {"lamp": {"kind": "emitter", "emission": [2.0, 2.0, 2.0]}},
            "shapes": [{"kind": "quad", "material": "lamp", "origin": [-2.0, -5.0, -distance],
                        "edge_u": [2.0, 0.0, 0.0], "edge_v": [0.0, 10.0, 0.0]}]}


@pytest.mark.parametrize("distance", [4.0, 40.0])
def test_orthographic_image_is_the_parallel_projection(distance):
    img = render(scene_from_dict(strip_scene(distance, True)), spp=4, seed=1, sampler="independent")
    # The film spans x in [-2, 2]: the left half of the columns sees the lamp, the right half nothing.
    want = np.zeros((H, W, 3))
    want[:, : W // 2] = 2.0
    np.testing.assert_array_equal(img, want)


def test_perspective_at_the_same_place_is_not_orthographic():
    near = render(scene_from_dict(strip_scene(4.0, False)), spp=4, seed=1, sampler="independent")
    far = render(scene_from_dict(strip_scene(40.0, False)), spp=4, seed=1, sampler="independent")
    assert near[:, : W // 2].mean() == 2.0 and far[:, : W // 2].mean() < 2.0 * 0.2


def test_ortho_height_with_a_lens_is_refused():
    data = strip_scene(4.0, True)
    data["camera"].update(aperture_radius=0.1, focus_distance=1.0)
    with pytest.raises(InputError, match="orthographic camera has no lens"):
        scene_from_dict(data)


def test_mitsuba_orthographic_sensor_imports_exactly(tmp_path):
    (tmp_path / "o.xml").write_text(
        '<scene version="2.0.0"><sensor type="orthographic"><float name="near_clip" value="1"/>'
        '<transform name="to_world"><scale x="1.5" y="1.5"/><lookat target="0, 0, 1" origin="-5, 0, 1" '
        'up="0, 0, 1"/></transform><film type="hdrfilm"><integer name="width" value="200"/><integer '
        'name="height" value="120"/><rfilter type="box"/></film></sensor><shape type="sphere"/></scene>')
    cam = load_scene(tmp_path / "o.xml").camera
    # Film x in [-1.5, 1.5], y in [-1.5 / (200 / 120), ...]: 1.8 high; rays start at near_clip.
    assert cam.ortho_height == pytest.approx(1.8, rel=1e-15)
    np.testing.assert_allclose(cam.position, [-4.0, 0.0, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(cam.look_at - cam.position, [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(cam.up, [0.0, 0.0, 1.0], atol=1e-15)


def test_mitsuba_orthographic_stretched_film_is_refused(tmp_path):
    (tmp_path / "o.xml").write_text(
        '<scene version="3.0.0"><sensor type="orthographic"><transform name="to_world"><scale x="2" y="1"/>'
        '</transform></sensor><shape type="sphere"/></scene>')
    with pytest.raises(InputError, match="equal x and y scale"):
        load_scene(tmp_path / "o.xml")


def test_whitted_and_export_refuse_an_orthographic_camera(tmp_path):
    from drtlab.kernels.scene_model.mitsuba_export import check_exportable
    scene = scene_from_dict(strip_scene(4.0, True))
    with pytest.raises(InputError, match="orthographic camera renders with drt or path"):
        render(scene, spp=1, integrator="whitted")
    with pytest.raises(InputError, match="orthographic camera is not exported"):
        check_exportable(scene)
