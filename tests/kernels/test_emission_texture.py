"""Textured area lights (a material's `emission_texture`, kernels/emission.py): Mitsuba 3's area
emitter with a bitmap `radiance`, the texture at the surface point's uv.

A square light whose 2 x 1 texture (nearest) is bright on its first half (u < 1/2) and black on the
other must render, by path tracing with MIS (light samples at their point's uv, BSDF-sampled hits
at the hit's uv, the light seen directly), the same image as an untextured light covering that half
alone: block means of 6 seeds each compared by a two-sample z-test, Bonferroni over the blocks and
channels at alpha = 1e-3, for a quad light and for the same square as an OBJ mesh (uv from its
texture coordinates). Negative control: the texture flipped (bright second half) is rejected.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import norm

from drtlab.kernels.imageio import write_exr
from drtlab.kernels.render import render_batch
from drtlab.kernels.scene_model.scene_file import scene_from_dict

W, H, SPP, SEEDS, BLOCK, ALPHA = 24, 16, 32, list(range(1, 7)), 4, 1e-3


def scene(light: dict, material: dict) -> dict:
    return {"scene": {"description": "a textured area light", "resolution": [W, H], "spp": SPP,
                      "integrator": "path", "max_depth": 3},
            "camera": {"position": [0.0, 0.45, 3.0], "look_at": [0.0, 0.4, 0.0], "fov": 55.0},
            "materials": {"floor": {"albedo": [0.5, 0.5, 0.5]},
                          "lamp": {"kind": "emitter", **material}},
            "shapes": [{"kind": "quad", "material": "floor", "origin": [-2.0, 0.0, -2.0],
                        "edge_u": [0.0, 0.0, 4.0], "edge_v": [4.0, 0.0, 0.0]},
                       {"material": "lamp", **light}]}


# The square y = 1, x and z in [-0.5, 0.5], facing down; u along +x.
QUAD = {"kind": "quad", "origin": [-0.5, 1.0, -0.5], "edge_u": [1.0, 0.0, 0.0], "edge_v": [0.0, 0.0, 1.0]}
HALF = {**QUAD, "edge_u": [0.5, 0.0, 0.0]}
EMISSION = [2.0, 1.0, 0.5]


def obj_square(path) -> str:
    """QUAD as an OBJ facing -y whose texture coordinates give u = x + 1/2."""
    path.write_text("v -0.5 1 -0.5\nv 0.5 1 -0.5\nv 0.5 1 0.5\nv -0.5 1 0.5\n"
                    "vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")
    return str(path)


@pytest.fixture(scope="module")
def textures(tmp_path_factory):
    d = tmp_path_factory.mktemp("emission")
    out = {}
    for name, texels in (("left", [[EMISSION, [0.0] * 3]]), ("right", [[[0.0] * 3, EMISSION]])):
        write_exr(d / f"{name}.exr", np.array(texels, dtype=np.float64))
        out[name] = {"file": str(d / f"{name}.exr"), "filter": "nearest"}
    out["obj"] = obj_square(d / "square.obj")
    return out


def blocks(data: dict) -> tuple[np.ndarray, np.ndarray]:
    """(mean, standard error) of each BLOCK x BLOCK block and channel over the seeds."""
    imgs = render_batch(scene_from_dict(data), SEEDS, spp=SPP, sampler="independent")
    b = imgs.reshape(len(SEEDS), H // BLOCK, BLOCK, W // BLOCK, BLOCK, 3).mean(axis=(2, 4))
    return b.mean(axis=0), b.std(axis=0, ddof=1) / np.sqrt(len(SEEDS))


def max_z(a, b) -> float:
    (ma, sa), (mb, sb) = a, b
    return float(np.max(np.abs(ma - mb) / np.sqrt(sa ** 2 + sb ** 2 + (1e-6 * (ma + mb)) ** 2 + 1e-300)))


@pytest.fixture(scope="module")
def reference():
    return blocks(scene(HALF, {"emission": EMISSION}))


@pytest.mark.parametrize("shape", ["quad", "mesh"])
def test_a_half_bright_texture_renders_as_the_half_light(textures, reference, shape):
    light = QUAD if shape == "quad" else {"kind": "mesh", "file": textures["obj"]}
    textured = blocks(scene(light, {"emission_texture": textures["left"]}))
    flipped = blocks(scene(light, {"emission_texture": textures["right"]}))
    z_crit = norm.isf(ALPHA / (2 * reference[0].size))
    assert reference[0].max() > 0.05
    assert max_z(textured, reference) < z_crit
    assert max_z(flipped, reference) > z_crit           # negative control: u flipped


def test_the_emission_multiplies_the_texture_and_features_compile_it_only_where_used(textures):
    from drtlab.kernels.features import features_of
    s = scene_from_dict(scene(QUAD, {"emission_texture": textures["left"], "emission": [1.0, 2.0, 3.0]}))
    lamp = s.materials[[m.name for m in s.materials].index("lamp")]
    assert lamp.emission.tolist() == [1.0, 2.0, 3.0] and "emission" in lamp.textures
    assert features_of(s, "path").emission_textures
    s = scene_from_dict(scene(QUAD, {"emission_texture": textures["left"]}))
    assert s.materials[1].emission.tolist() == [1.0, 1.0, 1.0]     # default 1: the texture's radiance
    assert not features_of(scene_from_dict(scene(QUAD, {"emission": EMISSION})), "path").emission_textures


def mitsuba_emitter(shape: str, texture_file: str) -> str:
    return ('<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>'
            '<transform name="to_world"><lookat origin="0, 3, 1" target="0, 0, 0" up="0, 1, 0"/></transform>'
            '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>'
            f'</film></sensor><integrator type="path"/><shape type="{shape}">'
            '<bsdf type="diffuse"><rgb name="reflectance" value="1"/></bsdf><emitter type="area">'
            f'<texture type="bitmap" name="radiance"><string name="filename" value="{texture_file}"/>'
            '</texture></emitter></shape></scene>')


def test_mitsuba_area_emitter_with_a_bitmap_radiance(tmp_path, textures):
    from drtlab.kernels.scene_model.scene_file import load_scene
    (tmp_path / "a.xml").write_text(mitsuba_emitter("rectangle", textures["left"]["file"]))
    m = load_scene(tmp_path / "a.xml").materials[0]
    assert m.kind == "diffuse" and m.albedo.tolist() == [1.0] * 3 and m.emission.tolist() == [1.0] * 3
    assert np.array_equal(m.textures["emission"].pixels[0, 0], np.float32(EMISSION))
    # A sphere reads Mitsuba's uv too (in its own frame): its emission texture is kept
    (tmp_path / "b.xml").write_text(mitsuba_emitter("sphere", textures["left"]["file"]))
    s = load_scene(tmp_path / "b.xml").materials[0]
    assert np.array_equal(s.textures["emission"].pixels, m.textures["emission"].pixels)

