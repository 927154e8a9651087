"""The Mitsuba 3 exporter over every material kind of the kind table and every field of the scene
and camera models: each is exported and imported back as the same numbers, or refused in one line
naming its field, before anything is written; never written as something else. Pure Python: no
render (the round trips of renders are in test_mitsuba_xml.py)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model import mitsuba_export
from drtlab.kernels.scene_model.material_kinds import KINDS
from drtlab.kernels.scene_model.mitsuba_export import (BSDF_OF_KIND, CAMERA_FIELDS, NO_COUNTERPART,
                                                       SCENE_FIELDS, SCENE_METADATA, export_mitsuba)
from drtlab.kernels.scene_model.scene import Camera, Material, Scene
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict


def _material(kind) -> dict:
    """A material of `kind` with every parameter its row reads away from its default."""
    m = {"kind": kind.name}
    if kind.emitter:
        return {**m, "emission": [3.0, 2.5, 2.0]}
    m["albedo"] = [0.7, 0.6, 0.5]
    if kind.microfacet:
        m["roughness"] = 0.3
    if kind.phong:
        m["exponent"] = 20.0
    if kind.transmits or kind.coat:
        m["ior"] = 1.4
    if kind.conductor:
        m.update(eta=[0.2, 0.9, 1.1], k=[3.9, 2.4, 2.2])
    return m


def _scene(kind=None, **tables) -> Scene:
    data = {"scene": {"description": "one material", "resolution": [8, 6], "integrator": "path"},
            "camera": {"position": [0.0, 1.0, 4.0], "look_at": [0.0, 0.5, 0.0], "fov": 40.0},
            "materials": {"m": _material(kind) if kind else {"albedo": [0.5, 0.4, 0.3]},
                          "lamp": {"kind": "emitter", "emission": [3.0, 3.0, 3.0]}},
            "shapes": [{"kind": "sphere", "material": "m", "center": [0.0, 0.5, 0.0], "radius": 0.5},
                       {"kind": "quad", "material": "lamp", "origin": [-1, 3, -1], "edge_u": [2, 0, 0],
                        "edge_v": [0, 0, 2]}]}
    for table, values in tables.items():
        data[table] = {**data.get(table, {}), **values} if isinstance(values, dict) else values
    return scene_from_dict(data)


def _numbers(obj):
    """What the renderer reads of a model object, names and provenance aside, arrays as bytes."""
    if isinstance(obj, np.ndarray):
        return (str(obj.dtype), obj.shape, obj.tobytes())
    if dataclasses.is_dataclass(obj):
        out = {f.name: _numbers(getattr(obj, f.name)) for f in dataclasses.fields(obj)
               if f.name not in ("name", "source", *SCENE_METADATA)}
        if isinstance(obj, Camera) and not obj.has_lens:
            out.pop("focus_distance")           # a pinhole reads none (kernels/camera.py)
        if isinstance(obj, Scene) and not (obj.russian_roulette and obj.rr_depth < obj.max_depth):
            out.update(russian_roulette=False, rr_depth=None)   # a roulette no path reaches: none
        return out
    if isinstance(obj, (list, tuple)):
        return [_numbers(x) for x in obj]
    return obj


def _round_trip(scene: Scene, tmp_path) -> Scene | InputError:
    """The scene exported and imported back, or the exporter's refusal (then nothing written)."""
    out = tmp_path / "out.xml"
    try:
        export_mitsuba(scene, out)
    except InputError as e:
        assert list(tmp_path.iterdir()) == [], "a refusal leaves nothing behind"
        return e
    return load_scene(out)


def _one_line(e: InputError, field: str) -> None:
    assert e.field == field and "\n" not in str(e) and len(e.message) > 10, str(e)


@pytest.mark.parametrize("kind", KINDS, ids=lambda k: k.name)
def test_every_material_kind_is_exported_as_the_same_numbers_or_refused(tmp_path, kind):
    a = _scene(kind)
    b = _round_trip(a, tmp_path)
    if kind.name in BSDF_OF_KIND:
        assert not isinstance(b, InputError), str(b)
        assert b.materials[0].kind == kind.name
        assert _numbers(b) == _numbers(a)
    else:
        assert isinstance(b, InputError)
        _one_line(b, "materials.m.kind")
        assert NO_COUNTERPART.get(kind.name, "is not mapped") in b.message


def test_the_tables_name_kinds_of_the_kind_table_only():
    names = {k.name for k in KINDS}
    assert set(BSDF_OF_KIND) <= names and set(NO_COUNTERPART) <= names
    assert not set(BSDF_OF_KIND) & set(NO_COUNTERPART)


def test_a_kind_the_exporter_does_not_map_is_refused_not_written_as_diffuse(tmp_path):
    # negative control: a kind added to the table without an export row (as the loader would give
    # it); before the table the exporter wrote it as diffuse without a word
    a = _scene()
    a.materials[0] = dataclasses.replace(a.materials[0], kind="sheen")
    b = _round_trip(a, tmp_path)
    assert isinstance(b, InputError) and "'sheen' is not mapped to a Mitsuba 3 BSDF" in b.message
    _one_line(b, "materials.m.kind")


# One change per camera field, away from its default (with what it needs beside it): a new field
# must be added here, and is refused by the exporter until CAMERA_FIELDS maps it.
CAMERA_CHANGES = {
    "position": {"position": np.array([0.3, 1.1, 4.2])},
    "look_at": {"look_at": np.array([0.1, 0.2, -0.1])},
    "up": {"up": np.array([0.1, 1.0, 0.0])},
    "vfov_deg": {"vfov_deg": 33.25},
    "aperture_radius": {"aperture_radius": 0.05, "focus_distance": 3.5},
    "focus_distance": {"focus_distance": 2.5},                       # a pinhole's: not read
    "shutter": {"shutter": (0.0, 0.5)},
    "filter": {"filter": "mitchell"},
    "filter_stddev": {"filter": "mitsuba_gaussian", "filter_stddev": 0.4},
    "filter_clip": {"filter": "mitchell", "filter_clip": True},
    "ortho_height": {"ortho_height": 2.0},
}


@pytest.mark.parametrize("field", [f.name for f in dataclasses.fields(Camera)])
def test_every_camera_field_is_exported_as_the_same_numbers_or_refused(tmp_path, field):
    assert field in CAMERA_CHANGES, f"add a change of the new camera field {field} to CAMERA_CHANGES"
    a = _scene()
    a = dataclasses.replace(a, camera=dataclasses.replace(a.camera, **CAMERA_CHANGES[field]))
    b = _round_trip(a, tmp_path)
    if field in CAMERA_FIELDS:
        assert not isinstance(b, InputError), str(b)
        assert _numbers(b) == _numbers(a)
    else:
        assert isinstance(b, InputError)
        _one_line(b, f"camera.{field}")


def test_a_camera_field_the_export_drops_is_caught(tmp_path, monkeypatch):
    # negative control: the shutter claimed as mapped, so the exporter writes the scene without it;
    # the import's camera then differs, and the comparison above sees it
    monkeypatch.setitem(mitsuba_export.CAMERA_FIELDS, "shutter", "nowhere")
    a = _scene()
    a = dataclasses.replace(a, camera=dataclasses.replace(a.camera, shutter=(0.0, 0.5)))
    b = _round_trip(a, tmp_path)
    assert not isinstance(b, InputError) and _numbers(b) != _numbers(a)


# One change per scene field: a TOML table change (exported or refused), or the tests above
# (camera, materials). A new field must be added here, and is refused until SCENE_FIELDS maps it.
SCENE_CHANGES = {
    "name": {}, "description": {"scene": {"description": "another"}}, "source": {}, "text": {},
    "width": {"scene": {"resolution": [10, 6]}}, "height": {"scene": {"resolution": [8, 10]}},
    "spp": {"scene": {"spp": 7}},
    "integrator": {"scene": {"integrator": "drt", "russian_roulette": False}},
    "max_depth": {"scene": {"max_depth": 3}},
    "emitter_samples": {"scene": {"integrator": "direct", "emitter_samples": 3}},
    "bsdf_samples": {"scene": {"integrator": "direct", "bsdf_samples": 2}},
    "rr_depth": {"scene": {"russian_roulette": True, "rr_depth": 2}},
    "russian_roulette": {"scene": {"russian_roulette": True, "rr_depth": 3}},
    "background": {"scene": {"background": [0.1, 0.2, 0.3]}},
    "camera": {"camera": {"fov": 31.5}},
    "materials": {"materials": {"m": {"kind": "dielectric", "ior": 1.33}}},
    "shapes": {"shapes": [{"kind": "box", "material": "m", "min": [0, 0, 0], "max": [1, 0.5, 0.25]},
                          {"kind": "quad", "material": "lamp", "origin": [-1, 3, -1], "edge_u": [2, 0, 0],
                           "edge_v": [0, 0, 2]}]},
    "point_lights": {"lights": [{"kind": "point", "position": [1, 2, 1], "intensity": [2, 2, 2]},
                                {"kind": "spot", "position": [0.5, 2, 0.25], "look_at": [0.1, 0, -0.3],
                                 "intensity": [3, 2, 1], "cutoff_angle": 35.5, "beam_width": 12.25}]},
    "directional_lights": {"lights": [{"kind": "directional", "direction": [0.0, -1.0, 0.0],
                                       "irradiance": [0.5, 0.5, 0.5]}]},
    "environment": {"environment": {"kind": "constant", "radiance": [0.1, 0.2, 0.3]}},
}
REFUSED = {"integrator": "scene.integrator", "background": "scene.background"}


@pytest.mark.parametrize("field", [f.name for f in dataclasses.fields(Scene)])
def test_every_scene_field_is_exported_as_the_same_numbers_or_refused(tmp_path, field):
    assert field in SCENE_CHANGES, f"add a change of the new scene field {field} to SCENE_CHANGES"
    assert field in SCENE_FIELDS + SCENE_METADATA or field in REFUSED
    a = _scene(**SCENE_CHANGES[field])
    b = _round_trip(a, tmp_path)
    if field in REFUSED:
        assert isinstance(b, InputError)
        _one_line(b, REFUSED[field])
    else:
        assert not isinstance(b, InputError), str(b)
        assert _numbers(b) == _numbers(a)


def test_a_scene_field_the_tables_lack_is_refused(tmp_path, monkeypatch):
    # negative control: a field the exporter does not know (as a new one would be) with a value
    # other than its default is refused by name, not dropped
    monkeypatch.setattr(mitsuba_export, "SCENE_FIELDS", tuple(f for f in SCENE_FIELDS if f != "spp"))
    b = _round_trip(_scene(scene={"spp": 7}), tmp_path)
    assert isinstance(b, InputError)
    _one_line(b, "scene.spp")


def test_a_refused_kind_through_the_cli_is_one_line_and_exit_2(tmp_path, capsys):
    from cli_util import assert_one_line_error
    from drtlab.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text('[scene]\ndescription = "x"\nresolution = [8, 6]\nintegrator = "path"\n'
                     '[camera]\nposition = [0, 1, 4]\nlook_at = [0, 0, 0]\nfov = 40\n'
                     '[materials.m]\nkind = "glossy"\nexponent = 20\n'
                     '[[shapes]]\nkind = "sphere"\nmaterial = "m"\ncenter = [0, 0, 0]\nradius = 1\n')
    assert main(["export", str(scene), str(tmp_path / "o.xml")]) == 2
    assert_one_line_error(capsys.readouterr().err, "materials.m.kind")
    assert not (tmp_path / "o.xml").exists()

