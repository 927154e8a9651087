"""Mitsuba 3's anisotropic roughconductor in (kernels/scene_model/mitsuba_materials.py: anisotropy):
alpha_u and alpha_v as numbers or float textures become the kind beckmann_conductor_anisotropic
with Mitsuba's defaults (material none: eta 0, k 1); equal numbers stay the isotropic kinds; each
unsupported use is one line naming its path (one alpha of the two, alpha beside them, GGX, a shape
whose uv is not Mitsuba's, an alpha out of range, a colour where a number is read). The TOML side:
the kind's keys and the range of its roughness textures. Pure Python, no render."""
from __future__ import annotations

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

HEAD = ('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/>'
        '</film></sensor>')
CHECKER = ('<texture name="{name}" type="checkerboard"><transform name="to_uv"><scale x="25" y="25"/>'
           '</transform><float name="color0" value="{c0}"/><float name="color1" value="{c1}"/></texture>')


def load(tmp_path, bsdf_body: str, shape: str = "rectangle", distribution: str = ""):
    path = tmp_path / "s.xml"
    path.write_text(f'{HEAD}<shape type="{shape}"><bsdf type="roughconductor">{distribution}{bsdf_body}'
                    '</bsdf></shape></scene>')
    return load_scene(path)


def refused(tmp_path, *args, **kw) -> str:
    with pytest.raises(InputError) as e:
        load(tmp_path, *args, **kw)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("s.xml: "), msg
    return msg


def test_numbers_give_the_anisotropic_kind_with_mitsubas_defaults(tmp_path):
    m = load(tmp_path, '<float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/>').materials[0]
    assert (m.kind, m.alpha_u, m.alpha_v) == ("beckmann_conductor_anisotropic", 0.05, 0.4)
    assert np.array_equal(m.eta, [0, 0, 0]) and np.array_equal(m.k, [1, 1, 1])     # material "none"
    assert np.array_equal(m.albedo, [1, 1, 1]) and not m.textures


def test_equal_numbers_stay_isotropic(tmp_path):
    m = load(tmp_path, '<float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/>').materials[0]
    assert (m.kind, m.roughness) == ("beckmann", 0.2)


def test_checkerboard_alphas_and_a_named_metal(tmp_path):
    body = (CHECKER.format(name="alpha_u", c0=0.05, c1=0.3) + CHECKER.format(name="alpha_v", c0=0.3, c1=0.05)
            + '<string name="material" value="Au"/>')
    m = load(tmp_path, body, shape="rectangle").materials[0]
    assert m.kind == "beckmann_conductor_anisotropic" and set(m.textures) == {"alpha_u", "alpha_v"}
    u, v = m.textures["alpha_u"], m.textures["alpha_v"]
    assert np.allclose(u.pixels[0], [[0.05] * 3, [0.3] * 3]) and np.allclose(v.pixels[0], [[0.3] * 3, [0.05] * 3])
    assert np.array_equal(u.to_uv, [[25.0, 0.0, 0.0], [0.0, 25.0, 0.0]])
    assert not np.array_equal(m.eta, [0, 0, 0])


def test_one_texture_and_one_number(tmp_path):
    body = CHECKER.format(name="alpha_u", c0=0.1, c1=0.2) + '<float name="alpha_v" value="0.3"/>'
    m = load(tmp_path, body).materials[0]
    assert set(m.textures) == {"alpha_u"} and m.alpha_v == 0.3


@pytest.mark.parametrize("body,shape,distribution,words", [
    ('<float name="alpha_u" value="0.1"/>', "rectangle", "", ["alpha_u and alpha_v"]),
    ('<float name="alpha" value="0.1"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/>',
     "rectangle", "", ["alpha_u and alpha_v"]),
    ('<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/>', "rectangle",
     '<string name="distribution" value="phong"/>', ["'phong' is not supported", "beckmann, ggx"]),
    ('<float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/>', "sphere", "",
     ["anisotropic roughness on a sphere"]),
    ('<float name="alpha_u" value="1.5"/><float name="alpha_v" value="0.2"/>', "rectangle", "", ["alpha_u", "1]"]),
    (CHECKER.format(name="alpha_u", c0=0.1, c1=2.0) + '<float name="alpha_v" value="0.2"/>', "rectangle", "",
     ["alpha_u_texture", "alphas in"]),
    ('<texture name="alpha_u" type="checkerboard"><rgb name="color0" value="0.1, 0.2, 0.3"/></texture>'
     '<float name="alpha_v" value="0.2"/>', "rectangle", "", ["alpha_u_texture", "grey"]),
], ids=["one alpha", "alpha beside", "ggx", "sphere", "range", "texture range", "colour"])
def test_refusals_are_one_line(tmp_path, body, shape, distribution, words):
    msg = refused(tmp_path, body, shape=shape, distribution=distribution)
    assert all(w in msg for w in words), msg


def _scene(material: dict) -> dict:
    return {"scene": {"description": "an anisotropic metal", "resolution": [8, 6], "integrator": "path"},
            "camera": {"position": [0.0, 1.0, 4.0], "look_at": [0.0, 0.5, 0.0], "fov": 40.0},
            "materials": {"m": material, "lamp": {"kind": "emitter", "emission": [3.0, 3.0, 3.0]}},
            "shapes": [{"kind": "quad", "material": "m", "origin": [-1, 0, -1], "edge_u": [2, 0, 0],
                        "edge_v": [0, 0, 2]},
                       {"kind": "quad", "material": "lamp", "origin": [-1, 3, -1], "edge_u": [2, 0, 0],
                        "edge_v": [0, 0, 2]}]}


def test_toml_kind_defaults_and_keys():
    m = scene_from_dict(_scene({"kind": "beckmann_conductor_anisotropic"})).materials[0]
    assert (m.alpha_u, m.alpha_v) == (0.1, 0.1) and np.array_equal(m.k, [1, 1, 1])
    with pytest.raises(InputError) as e:
        scene_from_dict(_scene({"kind": "beckmann_conductor_anisotropic", "roughness": 0.2}))
    assert e.value.field == "materials.m.roughness" and "\n" not in str(e.value)
    with pytest.raises(InputError) as e:
        scene_from_dict(_scene({"kind": "beckmann_conductor_anisotropic", "alpha_v": 0}))
    assert e.value.field == "materials.m.alpha_v" and "\n" not in str(e.value)
