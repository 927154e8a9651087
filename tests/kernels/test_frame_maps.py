"""Normal and bump maps in the scene files: Mitsuba 3's `normalmap` and `bumpmap` wrappers read into a
material's normal_texture / bump_texture and bump_scale (kernels/scene_model/mitsuba_materials.py),
their defaults (bumpmap's scale 1, flip_invalid_normals and use_shadowing_function true), the
`rawconstant` texture, each refusal one line naming its path; the TOML keys and their errors; the
variant compiling the map code only for a scene with one; and renders: an identity normal map
(0.5, 0.5, 1) gives the unwrapped material's image bit for bit (diffuse and ggx_anisotropic, whose
tangent frame a map also sets), a tilted one a different image."""
from __future__ import annotations

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.features import features_of
from drtlab.kernels.scene_model.mitsuba_export import check_exportable
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

HEAD = ('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/>'
        '<integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>')
OBJ = ("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
       "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n")


@pytest.fixture()
def folder(tmp_path):
    import OpenImageIO as oiio
    codes = (np.arange(4 * 4 * 3, dtype=np.uint8).reshape(4, 4, 3) * 5)
    out = oiio.ImageOutput.create(str(tmp_path / "n.png"))
    assert out.open(str(tmp_path / "n.png"), oiio.ImageSpec(4, 4, 3, oiio.UINT8))
    assert out.write_image(codes)
    out.close()
    (tmp_path / "m.obj").write_text(OBJ)
    return tmp_path


def load(folder, bsdf: str, shape: str = "obj"):
    path = folder / "s.xml"
    name = '<string name="filename" value="m.obj"/>' if shape == "obj" else ""
    path.write_text(f'{HEAD}<shape type="{shape}">{name}{bsdf}</shape></scene>')
    return load_scene(path)


def refused(folder, *args) -> str:
    with pytest.raises(InputError) as e:
        load(folder, *args)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("s.xml: ")
    return msg


NORMALMAP = ('<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><boolean name="raw" value="true"/>'
             '<string name="filename" value="n.png"/></texture>{more}<bsdf type="diffuse"/></bsdf>')
BUMPMAP = ('<bsdf type="bumpmap">{more}<texture name="heights" type="bitmap"><boolean name="raw" value="true"/>'
           '<string name="filename" value="n.png"/></texture><bsdf type="diffuse"/></bsdf>')


def test_normalmap_reads_its_raw_texture_into_the_normal_slot(folder):
    m = load(folder, NORMALMAP.format(more="")).materials[0]
    assert m.kind == "diffuse" and set(m.textures) == {"normal"}
    t = m.textures["normal"]
    assert (t.filter, t.wrap) == ("bilinear", "repeat")
    assert np.allclose(t.pixels[0, 1], np.array([3, 4, 5]) * 5 / 255.0, atol=1e-7)    # raw codes


def test_bumpmap_scale_defaults_to_one(folder):
    m = load(folder, BUMPMAP.format(more="")).materials[0]
    assert set(m.textures) == {"bump"} and m.bump_scale == 1.0          # Mitsuba's default scale
    assert load(folder, BUMPMAP.format(more='<float name="scale" value="0.02"/>')).materials[0].bump_scale == 0.02


def test_rawconstant_and_a_nested_rough_conductor(folder):
    bsdf = ('<bsdf type="normalmap"><texture name="normalmap" type="rawconstant">'
            '<vector name="value" value="0.5, 0.5, 1.0"/></texture>'
            '<bsdf type="roughconductor"><string name="distribution" value="ggx"/></bsdf></bsdf>')
    m = load(folder, bsdf).materials[0]
    assert m.kind == "ggx_separable"
    t = m.textures["normal"]
    assert t.filter == "nearest" and np.array_equal(t.pixels, np.float32([[[0.5, 0.5, 1.0]]]))


@pytest.mark.parametrize("bsdf,shape,words", [
    (NORMALMAP.format(more=""), "rectangle", "a normal or bump map on a rectangle is not supported"),
    (NORMALMAP.format(more='<boolean name="flip_invalid_normals" value="false"/>'), "obj",
     "flip_invalid_normals"),
    (BUMPMAP.format(more='<boolean name="use_shadowing_function" value="false"/>'), "obj",
     "use_shadowing_function"),
    (NORMALMAP.format(more="").replace('name="normalmap" ', 'name="other" '), "obj",
     "texture named 'normalmap'"),
    (NORMALMAP.format(more="").replace('<bsdf type="diffuse"/>', ""), "obj", "exactly one nested bsdf"),
    (NORMALMAP.format(more="").replace('<bsdf type="diffuse"/>', '<bsdf type="dielectric"/>'), "obj",
     "around 'dielectric' is not supported"),
    (BUMPMAP.format(more="").replace('<bsdf type="diffuse"/>', NORMALMAP.format(more="")), "obj",
     "a normalmap inside a bumpmap"),
    ('<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>', "obj", "exactly one texture"),
])
def test_refusals_are_one_line(folder, bsdf, shape, words):
    assert words in refused(folder, bsdf, shape)


ANISO = ('<bsdf type="roughconductor"><string name="distribution" value="{d}"/><string name="material" '
         'value="Al"/><float name="alpha_u" value="0.25"/><float name="alpha_v" value="0.05"/></bsdf>')


def test_anisotropic_ggx_roughconductor(folder):
    m = load(folder, ANISO.format(d="ggx")).materials[0]
    assert (m.kind, m.alpha_u, m.alpha_v) == ("ggx_anisotropic", 0.25, 0.05)
    assert np.all(m.k > 1.0)                                      # Al's index, applied by the kind
    assert load(folder, ANISO.format(d="beckmann")).materials[0].kind == "beckmann_conductor_anisotropic"
    assert "not supported" in refused(folder, ANISO.format(d="ggx"), "cube")


def test_export_refuses_maps(folder):
    with pytest.raises(InputError) as e:
        check_exportable(load(folder, BUMPMAP.format(more="")))
    assert e.value.field.endswith("bump_texture")


def scene_dict(folder, material: dict) -> dict:
    return {"scene": {"description": "a map test", "resolution": [8, 8], "spp": 4, "max_depth": 2},
            "camera": {"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 60},
            "materials": {"m": material, "light": {"kind": "emitter", "emission": [1, 1, 1]}},
            "shapes": [{"kind": "mesh", "file": str(folder / "m.obj"), "material": "m"},
                       {"kind": "sphere", "center": [0, 0, 4], "radius": 0.5, "material": "light"}]}


def constant(v):
    return {"kind": "constant", "value": v}


@pytest.mark.parametrize("material,field", [
    ({"normal_texture": constant([0.5, 0.5, 1]), "bump_texture": constant(0.5)}, "materials.m.bump_texture"),
    ({"bump_scale": 2.0}, "materials.m.bump_scale"),
    ({"bump_texture": constant(0.5), "bump_scale": "x"}, "materials.m.bump_scale"),
    ({"normal_texture": {"kind": "constant"}}, "materials.m.normal_texture.value"),
    ({"kind": "ggx_anisotropic", "alpha_v": 0.0}, "materials.m.alpha_v"),
    ({"alpha_v": 0.2}, "materials.m.alpha_v"),
])
def test_toml_errors_name_the_field(folder, material, field):
    with pytest.raises(InputError) as e:
        scene_from_dict(scene_dict(folder, {"kind": "diffuse", **material}))
    assert e.value.field == field


def test_the_alphas_default_to_0_1(folder):
    m = scene_from_dict(scene_dict(folder, {"kind": "ggx_anisotropic"})).materials[0]
    assert (m.alpha_u, m.alpha_v) == (0.1, 0.1)


def test_map_code_only_in_a_variant_with_a_map(folder):
    plain = scene_from_dict(scene_dict(folder, {"kind": "diffuse"}))
    mapped = scene_from_dict(scene_dict(folder, {"kind": "diffuse", "normal_texture": constant([0.5, 0.5, 1])}))
    assert not features_of(plain, "path").frame_maps
    assert features_of(mapped, "path").frame_maps and "frame_maps" in features_of(mapped, "path").key()


@pytest.mark.parametrize("base", [{"kind": "diffuse", "albedo": [0.7, 0.7, 0.7]},
                                  {"kind": "ggx_anisotropic", "alpha_u": 0.25, "alpha_v": 0.05}])
def test_identity_map_renders_bit_identically_and_a_tilted_one_does_not(folder, base):
    from drtlab.kernels.render import render
    images = {}
    for name, extra in (("plain", {}), ("identity", {"normal_texture": constant([0.5, 0.5, 1.0])}),
                        ("tilted", {"normal_texture": constant([0.8, 0.5, 0.9])})):
        images[name] = render(scene_from_dict(scene_dict(folder, {**base, **extra})), sampler="independent",
                              seed=3)
    assert np.array_equal(images["identity"], images["plain"])
    assert np.abs(images["tilted"] - images["plain"]).max() > 1e-3


def test_wrong_maps_are_rejected_on_mitsubas_scenes():
    """Negative controls on Mitsuba's own scenes (test_suite_scene renders the correct ones): the
    normal map read without its 2 rgb - 1 decode, the bump map's scale 0 (no bump) and the rough
    conductor's alphas swapped (its tangent frame turned 90 degrees) each fail the suite's rule."""
    from drtlab.experiments.bench.mitsuba import suite
    from drtlab.kernels.imageio import read_linear
    from drtlab.kernels.render import render_with_stats
    if not (suite.suite_dir() / "tests" / "scenes").is_dir():
        pytest.skip(f"Mitsuba 3's test scenes are not at {suite.suite_dir()} (set DRTLAB_MITSUBA_TESTS)")
    jobs = {j["name"]: j for j in suite.scenes(suite.suite_dir())}

    def undecoded(m):
        m.textures["normal"].pixels = (m.textures["normal"].pixels + 1.0) / 2.0

    def swapped(m):
        m.alpha_u, m.alpha_v = m.alpha_v, m.alpha_u
    for name, wrong in (("test_normalmap_path", undecoded),
                        ("test_bumpmap_path", lambda m: setattr(m, "bump_scale", 0.0)),
                        ("test_normalmap_roughconductor_path", swapped)):
        job = jobs[name]
        scene, refusal = suite.load(job)
        assert refusal is None
        wrong(scene.materials[0])
        stats = render_with_stats(scene, spp=32, sampler=suite.SAMPLER, seed=0, progress=False, variance=True)
        ref, var = (read_linear(job[k])[0][..., :3].astype(np.float64) for k in ("ref", "var"))
        verdict = suite.judge(stats.image, suite.channel_se(stats.variance, 32), 32, ref, var)
        assert not verdict["agrees"], name
