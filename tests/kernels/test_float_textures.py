"""Float textures (kernels/materials/texture.py: texture_scalar), Mitsuba 3's eval_1, as the
anisotropic conductor's roughness slots read them: a checkerboard gives color1 where its colour
lookup (texture_value, eval) gives color0 (checkerboard.cpp's eval_1 compares the two fractions with
!=), a bitmap the luminance of its linear RGB. Exact against numpy at uv points off the checks' edges;
negative control: the eval order is not what eval_1 gives."""
from __future__ import annotations

import numpy as np
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.materials.texture import SLOT, texture_scalar, texture_value
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from drtlab.kernels.scene_model.texture import LUMINANCE
from drtlab.kernels.scene_upload import upload

TO_UV = [[25.0, 0.0, 0.0], [0.0, 25.0, 0.0]]


@wp.kernel
def _lookups(sd: SceneData, t: int, uv: wp.array(dtype=wp.vec2), out1: wp.array(dtype=float),
             out3: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out1[i] = texture_scalar(sd, t, uv[i])
    out3[i] = texture_value(sd, t, uv[i])


def _scene(alpha_u_texture: dict) -> dict:
    return {"scene": {"description": "a rough metal quad", "resolution": [4, 4]},
            "camera": {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0]},
            "materials": {"m": {"kind": "beckmann_conductor_anisotropic", "alpha_u_texture": alpha_u_texture}},
            "shapes": [{"kind": "quad", "material": "m", "origin": [-1.0, 0.0, -1.0], "edge_u": [0.0, 0.0, 2.0],
                        "edge_v": [2.0, 0.0, 0.0]}]}


def lookup(texture: dict, uv: np.ndarray):
    sd = upload(scene_from_dict(_scene(texture)), "cpu")
    t = int(sd.materials.tex.numpy()[SLOT["alpha_u"]])
    a = wp.array(uv.astype(np.float32), dtype=wp.vec2, device="cpu")
    out1 = wp.zeros(len(uv), dtype=float, device="cpu")
    out3 = wp.zeros(len(uv), dtype=wp.vec3, device="cpu")
    wp.launch(_lookups, dim=len(uv), inputs=[sd, t, a, out1, out3], device="cpu")
    return out1.numpy().astype(np.float64), out3.numpy().astype(np.float64)


def test_checkerboard_eval_1_swaps_the_colours():
    uv = np.random.default_rng(4).random((20000, 2))
    got, rgb = lookup({"kind": "checkerboard", "color0": 0.05, "color1": 0.3, "to_uv": TO_UV}, uv)
    f = 25.0 * uv.astype(np.float32).astype(np.float64)
    frac = f - np.floor(f)
    keep = np.all(np.abs(frac - 0.5) > 1e-4, axis=1) & np.all(np.minimum(frac, 1 - frac) > 1e-4, axis=1)
    same = (frac[:, 0] > 0.5) == (frac[:, 1] > 0.5)
    want = np.where(same, np.float32(0.3), np.float32(0.05))
    assert np.array_equal(got[keep], want[keep])
    eval_order = rgb[:, 0]                                     # the colour lookup: color0 where same
    assert np.array_equal(eval_order[keep], np.where(same, np.float32(0.05), np.float32(0.3))[keep])
    assert not np.array_equal(got[keep], eval_order[keep])


def test_bitmap_eval_1_is_the_luminance(tmp_path):
    import OpenImageIO as oiio
    px = np.array([[[0.1, 0.5, 0.9], [0.3, 0.2, 0.1]], [[0.6, 0.6, 0.6], [0.05, 0.9, 0.4]]], np.float32)
    path = tmp_path / "rough.exr"
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(2, 2, 3, oiio.FLOAT))
    assert out.write_image(px)
    out.close()
    uv = np.random.default_rng(5).random((5000, 2))
    got, rgb = lookup({"kind": "bitmap", "file": str(path)}, uv)
    grey = np.all(rgb == rgb[:, :1], axis=1)
    np.testing.assert_allclose(got[~grey], (rgb @ np.array(LUMINANCE))[~grey], rtol=1e-6, atol=1e-7)
    assert np.array_equal(got[grey], rgb[grey, 0])              # a grey texel is itself
    assert np.abs(got - rgb.mean(axis=1)).max() > 0.01         # not the mean of the channels
