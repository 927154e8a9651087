"""Mitsuba 3 XML textures in (kernels/scene_model/mitsuba_textures.py): a diffuse rectangle's bitmap
or checkerboard reflectance becomes the material's albedo_texture with Mitsuba's parameters (filter,
wrap, raw, to_uv as the 2 x 3 affine map of uv), and each unsupported use is one line naming its
path (another shape, a flipped rectangle, a bad wrap mode, a missing file); export refuses textures.
Loading is pure Python (the lookups and a render: test_textures.py)."""
from __future__ import annotations

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model.mitsuba_export import check_exportable
from drtlab.kernels.scene_model.scene_file import load_scene

HEAD = ('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/>'
        '</film></sensor>')


def write_png(path, codes: np.ndarray) -> None:
    import OpenImageIO as oiio
    h, w, c = codes.shape
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(w, h, c, oiio.UINT8))
    assert out.write_image(codes)
    out.close()


@pytest.fixture()
def folder(tmp_path):
    codes = np.arange(4 * 6 * 3, dtype=np.uint8).reshape(4, 6, 3) * 3
    write_png(tmp_path / "t.png", codes)
    return tmp_path, codes


def load(folder, body: str, shape: str = "rectangle", extra: str = ""):
    path = folder / "s.xml"
    path.write_text(f'{HEAD}{extra}<shape type="{shape}">{body}</shape></scene>')
    return load_scene(path)


BITMAP = """<bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <transform name="to_uv"><scale value="2"/><translate value="-.5,-.5, 0"/></transform>
  <string name="filename" value="t.png"/>{more}</texture></bsdf>"""


def refused(folder, *args, **kw) -> str:
    with pytest.raises(InputError) as e:
        load(folder, *args, **kw)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("s.xml: ")
    return msg


def test_bitmap_reflectance_on_a_rectangle(folder):
    tmp, codes = folder
    more = ('<string name="filter_type" value="nearest"/><string name="wrap_mode" value="mirror"/>'
            '<boolean name="raw" value="true"/>')
    t = load(tmp, BITMAP.format(more=more)).materials[0].textures.get("albedo")
    assert (t.kind, t.filter, t.wrap) == ("bitmap", "nearest", "mirror")
    assert np.array_equal(t.to_uv, [[2.0, 0.0, -0.5], [0.0, 2.0, -0.5]])
    assert np.allclose(t.pixels, codes / 255.0, atol=1e-7)         # raw: the codes, not decoded
    d = load(tmp, BITMAP.format(more="")).materials[0].textures.get("albedo")
    assert (d.filter, d.wrap) == ("bilinear", "repeat")               # Mitsuba's defaults
    assert np.all(d.pixels <= t.pixels + 1e-7) and np.any(d.pixels < t.pixels - 0.05)   # decoded


def test_a_flipped_and_mirrored_rectangle_keeps_its_uv(folder):
    both = ('<boolean name="flip_normals" value="true"/>'
            '<transform name="to_world"><scale x="-1"/></transform>')
    assert load(folder[0], BITMAP.format(more="") + both).materials[0].textures.get("albedo") is not None


def test_checkerboard_through_a_ref(folder):
    tmp, _ = folder
    bsdf = ('<bsdf type="diffuse" id="b"><texture name="reflectance" type="checkerboard">'
            '<transform name="to_uv"><scale x="5" y="5"/></transform>'
            '<rgb name="color0" value="0.8"/></texture></bsdf>')
    t = load(tmp, '<ref id="b"/>', extra=bsdf).materials[0].textures.get("albedo")
    assert t.kind == "checkerboard" and np.array_equal(t.to_uv, [[5.0, 0.0, 0.0], [0.0, 5.0, 0.0]])
    assert np.allclose(t.pixels[0], [[0.8] * 3, [0.2] * 3])          # color1: Mitsuba's default 0.2


@pytest.mark.parametrize("shape,more,flip,words", [
    ("sphere", "", "", "a texture on a sphere is not supported"),
    ("rectangle", "", '<boolean name="flip_normals" value="true"/>', "textured rectangle"),
    ("rectangle", "", '<transform name="to_world"><scale x="-1"/></transform>', "textured rectangle"),
    ("rectangle", '<string name="wrap_mode" value="border"/>', "", "wrap_mode"),
    ("rectangle", '<string name="filter_type" value="cubic"/>', "", "filter_type"),
])
def test_refusals_are_one_line(folder, shape, more, flip, words):
    assert words in refused(folder[0], BITMAP.format(more=more) + flip, shape)


def test_missing_file_and_other_bsdfs(folder):
    tmp, _ = folder
    assert "does not exist" in refused(tmp, BITMAP.format(more="").replace("t.png", "none.png"))
    rough = ('<bsdf type="roughconductor"><texture type="checkerboard" name="specular_reflectance"/>'
             '</bsdf>')
    assert "not supported" in refused(tmp, rough)


def test_export_refuses_textures(folder):
    scene = load(folder[0], BITMAP.format(more=""))
    with pytest.raises(InputError) as e:
        check_exportable(scene)
    assert e.value.field.endswith("albedo_texture")


def test_obj_texture_coordinates_are_read_v_flipped(folder):
    tmp, _ = folder
    (tmp / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.25 0.75\nvt 1 0.5\nvt 0 0\n"
                               "f 1/1 2/2 3/3\n")
    body = BITMAP.format(more="") + '<string name="filename" value="m.obj"/>'
    mesh = load(tmp, body, "obj").shapes[0].mesh
    assert np.allclose(mesh.uvs, [[0.25, 0.25], [1.0, 0.5], [0.0, 1.0]])
    no_flip = body + '<boolean name="flip_tex_coords" value="false"/>'
    assert "flip_tex_coords" in refused(tmp, no_flip, "obj")
