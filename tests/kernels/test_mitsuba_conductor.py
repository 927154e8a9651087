"""Mitsuba 3 conductors with a complex index of refraction and Beckmann rough glass, as the importer
reads them (pure Python: no render), and the scene file's `eta` / `k` keys of the conductor kinds."""
from __future__ import annotations

import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model.mitsuba_conductor_ior import CONDUCTOR_IOR
from drtlab.kernels.scene_model.scene_file import load_scene

from test_mitsuba_xml import load, refused, xml


def test_complex_index_and_named_metals_become_conductor_kinds(tmp_path):
    body = """
    <shape type="sphere" id="cu"><bsdf type="conductor"><string name="material" value="Cu"/>
      <rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/></bsdf></shape>
    <shape type="sphere" id="au"><bsdf type="roughconductor"><string name="material" value="Au"/>
      <float name="alpha" value="0.2"/></bsdf></shape>
    <shape type="sphere" id="rgb"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.3"/><rgb name="eta" value="1.5, 1.0, 0.5"/><rgb name="k" value="3, 2, 1"/></bsdf></shape>
    <shape type="sphere" id="float"><bsdf type="conductor"><float name="eta" value="0.5"/></bsdf></shape>
    <shape type="sphere" id="none"><bsdf type="conductor"><string name="material" value="none"/></bsdf></shape>
    <shape type="sphere" id="glass"><bsdf type="roughdielectric"><float name="alpha" value="0.25"/></bsdf></shape>"""
    s = load(tmp_path, xml(body))
    mat = {x.name: s.materials[x.material] for x in s.shapes}
    cu, au = CONDUCTOR_IOR["Cu"], CONDUCTOR_IOR["Au"]
    assert (mat["cu"].kind, mat["cu"].albedo.tolist()) == ("conductor", [0.9, 0.8, 0.7])
    assert (mat["cu"].eta.tolist(), mat["cu"].k.tolist()) == (list(cu[0]), list(cu[1]))
    assert (mat["au"].kind, mat["au"].roughness, mat["au"].eta.tolist()) == ("beckmann_conductor", 0.2, list(au[0]))
    assert (mat["rgb"].kind, mat["rgb"].eta.tolist(), mat["rgb"].k.tolist()) == ("ggx_conductor", [1.5, 1.0, 0.5],
                                                                                 [3, 2, 1])
    # eta alone: Mitsuba's k defaults to 1
    assert (mat["float"].kind, mat["float"].eta.tolist(), mat["float"].k.tolist()) == ("conductor", [0.5] * 3, [1] * 3)
    assert mat["none"].kind == "mirror"             # 0 + 1i reflects everything: the mirror
    assert (mat["glass"].kind, mat["glass"].roughness) == ("beckmann_dielectric", 0.25)  # Mitsuba's default


@pytest.mark.parametrize("bsdf,where,what", [
    ('<bsdf type="conductor"><string name="material" value="Unobtainium"/></bsdf>', "string[@name=material]",
     "'Unobtainium' is not supported (supported: none, Ag, Al, "),
    ('<bsdf type="conductor"><string name="material" value="Cu"/><float name="eta" value="1"/></bsdf>',
     "float[@name=eta]", "either material ('Cu') or eta and k"),
    ('<bsdf type="roughconductor"><rgb name="k" value="1, -1, 1"/></bsdf>', "rgb[@name=k]", ">= 0"),
])
def test_bad_conductors_are_one_line(tmp_path, bsdf, where, what):
    msg = refused(tmp_path, xml(f'<shape type="sphere">{bsdf}</shape>'))
    assert where in msg and what in msg, msg


SCENE = """[scene]
description = "a metal sphere"
resolution = [8, 6]
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]
[materials.metal]
kind = "ggx_conductor"
roughness = 0.2
eta = [0.2, 0.9, 1.1]
k = [3.9, 2.5, 2.1]
[[shapes]]
kind = "sphere"
material = "metal"
center = [0, 0, 0]
radius = 1
"""


def test_scene_file_keys(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SCENE)
    m = load_scene(path).materials[0]
    assert (m.kind, m.eta.tolist(), m.k.tolist()) == ("ggx_conductor", [0.2, 0.9, 1.1], [3.9, 2.5, 2.1])
    for text, field in ((SCENE.replace('"ggx_conductor"', '"ggx"'), "materials.metal"),
                        (SCENE.replace("k = [3.9", "k = [-3.9"), "materials.metal.k")):
        path.write_text(text)
        with pytest.raises(InputError) as e:
            load_scene(path)
        assert field in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_export_writes_eta_and_k_back(tmp_path):
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    text = SCENE.replace('[[shapes]]', '''[materials.cu]
kind = "conductor"
albedo = [0.9, 0.8, 0.7]
eta = [0.2, 0.9, 1.1]
k = [3.9, 2.5, 2.1]
[materials.au]
kind = "beckmann_conductor"
roughness = 0.3
eta = [0.14, 0.37, 1.44]
k = [3.98, 2.38, 1.6]
[materials.frost]
kind = "beckmann_dielectric"
roughness = 0.25
ior = 1.5
[[shapes]]''', 1).replace('[scene]', '[scene]\nintegrator = "path"')
    text += "".join(f'[[shapes]]\nkind = "sphere"\nmaterial = "{m}"\ncenter = [{x}, 0, 0]\nradius = 0.5\n'
                    for x, m in ((2, "cu"), (3, "au"), (4, "frost")))
    (tmp_path / "m.toml").write_text(text)
    a = load_scene(tmp_path / "m.toml")
    export_mitsuba(a, tmp_path / "m.xml")
    b = load_scene(tmp_path / "m.xml")
    key = [(m.kind, m.albedo.tolist(), m.eta.tolist(), m.k.tolist(), m.roughness if "conductor" != m.kind else 0)
           for m in a.materials]
    assert key == [(m.kind, m.albedo.tolist(), m.eta.tolist(), m.k.tolist(), m.roughness if "conductor" != m.kind else 0)
                   for m in b.materials]
