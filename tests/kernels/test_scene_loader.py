"""Scene loader: built-ins have the features they claim, boxes expand correctly, overrides work, and
every kind of bad input raises one InputError naming the field and what is allowed. No Warp here."""
from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drtlab.errors import InputError
from drtlab.kernels.scene_model.scene_tables import box_quads
from drtlab.kernels.scene_model.scene_file import (
    BUILTIN_DIR,
    builtin_descriptions,
    builtin_names,
    load_scene,
    scene_from_dict,
)
from drtlab.kernels.scene_model.scene import Scene

BUILTINS = ["aa-edges", "cornell-box", "displaced-sphere", "dof", "drt-showcase", "environment",
            "glossy", "glossy-ggx", "motion-blur", "soft-shadows", "sphere-grid", "translucency",
            "veach-mis"]


def normal(shape) -> np.ndarray:
    n = np.cross(shape.edge_u, shape.edge_v)
    return n / np.linalg.norm(n)


def centre(shape) -> np.ndarray:
    return shape.origin + 0.5 * shape.edge_u + 0.5 * shape.edge_v


def raw_toml(name: str) -> dict:
    return tomllib.loads((BUILTIN_DIR / f"{name}.toml").read_text())


def materials_of(scene: Scene, kind: str):
    return [m for m in scene.materials if m.kind == kind]


# ---------------------------------------------------------------------------------------------------
# Built-in scenes
# ---------------------------------------------------------------------------------------------------

def test_builtin_names_are_the_thirteen_scenes():
    assert builtin_names() == BUILTINS
    descriptions = builtin_descriptions()
    assert sorted(descriptions) == BUILTINS
    assert all(isinstance(d, str) and d.strip() for d in descriptions.values())


@pytest.mark.parametrize("name", BUILTINS)
def test_builtin_loads_small_and_sane(name):
    scene = load_scene(name)
    assert scene.name == name and scene.source == name
    assert 64 <= scene.width <= 96 and 48 <= scene.height <= 72
    assert scene.spp == 16
    assert scene.shapes and (scene.emitter_shapes() or scene.environment is not None), \
        "every built-in is lit by an emissive shape or an environment"
    assert len(scene.content_hash()) == 16
    # Every area light must face the scene: the camera or what it looks at is on its emitting side.
    for i in scene.emitter_shapes():
        shape = scene.shapes[i]
        if shape.kind != "quad":
            continue
        n, c = normal(shape), centre(shape)
        facing = [np.dot(p - c, n) > 0 for p in (scene.camera.position, scene.camera.look_at)]
        assert any(facing), f"{name}: emitter {shape.name} faces away from the scene"


def test_aa_edges():
    scene = load_scene("aa-edges")
    assert scene.integrator == "drt" and scene.max_depth == 2
    quads = [s for s in scene.shapes if s.kind == "quad"]
    angles = {round(math.degrees(math.atan2(s.edge_u[1], s.edge_u[0])) % 180) for s in quads}
    assert len(angles) >= 6, f"edges at several angles, got {sorted(angles)}"
    assert any(s.kind == "sphere" for s in scene.shapes), "a curved silhouette"
    assert np.all(scene.background >= 0.9), "white background against dark shapes"


def test_soft_shadows():
    scene = load_scene("soft-shadows")
    assert scene.integrator == "drt"
    lights = [scene.shapes[i] for i in scene.emitter_shapes()]
    assert len(lights) == 1 and lights[0].kind == "quad"
    assert normal(lights[0])[1] == pytest.approx(-1.0), "the area light faces down"
    assert lights[0].area() > 1.0, "a large light for wide penumbrae"
    light_y = lights[0].origin[1]
    occluders = [s for s in scene.shapes if s.kind == "sphere" or (s.kind == "quad" and "box" in s.name)]
    assert occluders and all(0.0 <= (s.center if s.kind == "sphere" else centre(s))[1] < light_y
                             for s in occluders)


def test_glossy():
    scene = load_scene("glossy")
    assert scene.integrator == "drt"
    exponents = sorted(m.exponent for m in materials_of(scene, "glossy"))
    assert len(exponents) >= 3 and len(set(exponents)) == len(exponents)
    assert exponents[-1] / exponents[0] >= 100
    assert any(m.checker for m in scene.materials), "a checker pattern to reflect"


def test_translucency():
    scene = load_scene("translucency")
    assert scene.integrator == "drt" and scene.max_depth >= 5
    glossy_dielectrics = materials_of(scene, "glossy_dielectric")
    assert len(glossy_dielectrics) >= 2 and materials_of(scene, "dielectric")
    assert any(m.checker for m in scene.materials)


def test_dof_lens_focus_is_the_gaussian_lens_formula():
    scene = load_scene("dof")
    camera = raw_toml("dof")["camera"]
    assert scene.integrator == "drt" and scene.camera.has_lens
    assert 0.1 <= scene.camera.aperture_radius <= 0.2
    f, di = camera["focal_length"], camera["image_distance"]
    assert "focus_distance" not in camera
    assert scene.camera.focus_distance == pytest.approx(1.0 / (1.0 / f - 1.0 / di), rel=1e-12)
    # The focus plane passes through the middle object: the sphere named focus-sphere.
    view = scene.camera.look_at - scene.camera.position
    view /= np.linalg.norm(view)
    middle = next(s for s in scene.shapes if s.name == "focus-sphere")
    depth = np.dot(middle.center - scene.camera.position, view)
    assert abs(depth - scene.camera.focus_distance) < middle.radius
    depths = [np.dot((s.center if s.kind == "sphere" else centre(s)) - scene.camera.position, view)
              for s in scene.shapes if not scene.materials[s.material].emissive]
    assert min(depths) < 0.6 * depth and max(depths) > 1.5 * depth, "objects before and after focus"


def test_motion_blur():
    scene = load_scene("motion-blur")
    assert scene.integrator == "drt" and scene.has_motion
    open_, close = scene.camera.shutter
    assert close - open_ > 0
    moving = [s for s in scene.shapes if np.any(s.velocity != 0)]
    assert len(moving) >= 2 and len(moving) < len(scene.shapes), "moving and static shapes"
    assert any(m.checker for m in scene.materials)


def test_cornell_box_matches_mitsuba():
    scene = load_scene("cornell-box")
    assert scene.width == scene.height == 64
    assert scene.integrator == "path" and scene.max_depth == 8
    assert scene.camera.vfov_deg == pytest.approx(39.3077)
    np.testing.assert_allclose(scene.camera.position, [0, 0, 3.9])
    by_name = {s.name: s for s in scene.shapes}
    assert len(scene.shapes) == 6 + 12
    white = scene.materials[by_name["floor"].material].albedo
    np.testing.assert_allclose(white, [0.885809, 0.698859, 0.666422])
    light = by_name["light"]
    np.testing.assert_allclose(scene.materials[light.material].emission, [18.387, 13.9873, 6.75357])
    np.testing.assert_allclose(normal(light), [0, -1, 0], atol=1e-12)
    assert light.area() == pytest.approx(0.46 * 0.38)
    # Walls face into the box (towards the origin), cube faces point out of their cube.
    for wall in ("floor", "ceiling", "back", "green-wall", "red-wall"):
        assert np.dot(normal(by_name[wall]), -centre(by_name[wall])) > 0.99
    for box in ("small-box", "large-box"):
        faces = [s for s in scene.shapes if s.name.startswith(box + ".")]
        assert len(faces) == 6
        middle = np.mean([centre(f) for f in faces], axis=0)
        assert all(np.dot(normal(f), centre(f) - middle) > 0 for f in faces)
        assert sum(f.area() for f in faces) == pytest.approx(
            {"small-box": 6 * 0.6 * 0.6, "large-box": 2 * 0.6 * 0.6 + 4 * 0.6 * 1.22}[box], rel=1e-6)


def test_veach_mis_lights_have_equal_power():
    scene = load_scene("veach-mis")
    assert scene.integrator == "path" and scene.max_depth in (2, 3)
    assert np.all(scene.background == 0)
    lights = [scene.shapes[i] for i in scene.emitter_shapes()]
    assert len(lights) == 4 and all(s.kind == "sphere" for s in lights)
    radii = [s.radius for s in lights]
    assert len(set(radii)) == 4 and max(radii) / min(radii) >= 20
    powers = np.array([scene.materials[s.material].emission * s.area() * np.pi for s in lights])
    np.testing.assert_allclose(powers, np.broadcast_to(powers[0], powers.shape), rtol=1e-9)
    plates = [s for s in scene.shapes if s.kind == "quad"]
    exponents = sorted(scene.materials[s.material].exponent for s in plates)
    assert len(plates) == 4 and len(set(exponents)) == 4 and exponents[-1] / exponents[0] >= 1000


def test_drt_showcase_has_every_effect():
    scene = load_scene("drt-showcase")
    assert scene.integrator == "drt"
    assert scene.camera.has_lens and scene.has_motion
    kinds = {m.kind for m in scene.materials}
    assert {"glossy", "glossy_dielectric", "diffuse"} <= kinds
    assert any(scene.shapes[i].kind == "quad" for i in scene.emitter_shapes()), "an area light"


# ---------------------------------------------------------------------------------------------------
# Boxes, defaults, units
# ---------------------------------------------------------------------------------------------------

def test_box_expands_to_six_outward_quads_enclosing_the_box():
    lo, hi = np.array([-1.0, 0.5, 2.0]), np.array([0.5, 2.5, 2.25])
    faces = box_quads(lo, hi, material=3, name="b", velocity=np.array([1.0, 0, 0]))
    assert [f.name for f in faces] == ["b.px", "b.nx", "b.py", "b.ny", "b.pz", "b.nz"]
    mid, size = 0.5 * (lo + hi), hi - lo
    corners = set()
    for f in faces:
        assert f.kind == "quad" and f.material == 3
        np.testing.assert_array_equal(f.velocity, [1.0, 0, 0])
        n = normal(f)
        axis = int(np.argmax(np.abs(n)))
        assert abs(n[axis]) == pytest.approx(1.0)
        # the face lies on the box's boundary plane on the side its normal points to
        assert np.dot(n, centre(f) - mid) == pytest.approx(size[axis] / 2)
        for s, t in ((0, 0), (1, 0), (0, 1), (1, 1)):
            p = f.origin + s * f.edge_u + t * f.edge_v
            assert np.all(p >= lo - 1e-12) and np.all(p <= hi + 1e-12)
            corners.add(tuple(np.round(p, 12)))
    assert len(corners) == 8
    assert sum(f.area() for f in faces) == pytest.approx(
        2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]))


def base_scene() -> dict:
    return {
        "scene": {"description": "test", "resolution": [8, 6], "spp": 1, "integrator": "drt",
                  "max_depth": 3},
        "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0]},
        "materials": {
            "red": {"kind": "diffuse", "albedo": [0.8, 0.1, 0.1]},
            "lamp": {"kind": "emitter", "emission": [5, 5, 5]},
        },
        "shapes": [
            {"kind": "sphere", "material": "red", "center": [0, 1, 0], "radius": 1},
            {"kind": "quad", "material": "lamp", "origin": [-1, 3, -1], "edge_u": [2, 0, 0],
             "edge_v": [0, 0, 2]},
            {"kind": "box", "material": "red", "name": "crate", "min": [2, 0, 0], "max": [3, 1, 1]},
        ],
        "lights": [{"kind": "point", "position": [0, 4, 0], "intensity": [1, 1, 1]},
                   {"kind": "directional", "direction": [0, -2, 0], "irradiance": [1, 1, 1]}],
    }


def test_scene_from_dict_defaults_and_conversions():
    scene = scene_from_dict(base_scene(), name="unit")
    assert scene.name == "unit"
    assert (scene.width, scene.height, scene.spp) == (8, 6, 1)
    assert len(scene.shapes) == 1 + 1 + 6
    assert [s.name for s in scene.shapes[2:]][0] == "crate.px"
    assert scene.shapes[0].radius == 1.0 and isinstance(scene.shapes[0].radius, float)
    assert scene.camera.vfov_deg == 40.0 and not scene.camera.has_lens
    np.testing.assert_array_equal(scene.camera.up, [0, 1, 0])
    assert scene.camera.shutter == (0.0, 0.0) and not scene.has_motion
    assert scene.materials[1].emissive and np.all(scene.materials[1].albedo == 0)
    np.testing.assert_allclose(scene.directional_lights[0].direction, [0, -1, 0])
    assert scene.shapes[1].area() == 4.0 and normal(scene.shapes[1])[1] == -1.0
    assert scene.emitter_shapes() == [1]


def test_f_number_gives_aperture_and_focus_distance_direct():
    d = base_scene()
    d["camera"].update(f_number=2.0, focal_length=0.4, focus_distance=4)
    camera = scene_from_dict(d).camera
    assert camera.aperture_radius == pytest.approx(0.1) and camera.focus_distance == 4.0
    d = base_scene()
    d["camera"].update(aperture_radius=0)                        # no focus needed without aperture
    assert scene_from_dict(d).camera.aperture_radius == 0.0 and not scene_from_dict(d).camera.has_lens


def test_load_scene_from_a_path(tmp_path):
    path = tmp_path / "my-scene.toml"
    path.write_text((BUILTIN_DIR / "soft-shadows.toml").read_text())
    scene = load_scene(path)
    assert scene.name == "my-scene" and scene.source == str(path)
    assert load_scene(str(path)).content_hash() == load_scene("soft-shadows").content_hash()


# ---------------------------------------------------------------------------------------------------
# Overrides
# ---------------------------------------------------------------------------------------------------

def test_overrides_apply_and_change_the_hash():
    plain = load_scene("dof")
    changed = load_scene("dof", {"scene.resolution": [32, 24], "camera.aperture_radius": 0.0,
                                 "materials.red.albedo": [0.1, 0.2, 0.3], "shapes[2].radius": 0.25})
    assert (changed.width, changed.height) == (32, 24)
    assert not changed.camera.has_lens
    np.testing.assert_array_equal(changed.materials[3].albedo, [0.1, 0.2, 0.3])
    assert changed.shapes[2].radius == 0.25
    assert changed.content_hash() != plain.content_hash()
    again = load_scene("dof", {"shapes[2].radius": 0.25, "camera.aperture_radius": 0.0,
                               "scene.resolution": [32, 24], "materials.red.albedo": [0.1, 0.2, 0.3]})
    assert again.content_hash() == changed.content_hash(), "order of overrides does not matter"
    assert load_scene("dof", {}).content_hash() == plain.content_hash()
    glossy = load_scene("glossy", {"materials.gloss1000.exponent": 10})
    assert next(m for m in glossy.materials if m.name == "gloss1000").exponent == 10.0
    assert load_scene("glossy", {"scene.spp": 4}).content_hash() != load_scene("glossy").content_hash()


def test_overrides_are_validated_like_the_file():
    with pytest.raises(InputError) as err:
        load_scene("glossy", {"materials.gloss10.exponent": -1})
    assert err.value.field == "materials.gloss10.exponent" and ">= 0" in err.value.message
    with pytest.raises(InputError) as err:
        load_scene("glossy", {"camera.fvo": 30})
    assert err.value.field == "camera.fvo" and "allowed keys" in err.value.message


@pytest.mark.parametrize("key", ["materials.nope.exponent", "lens.radius", "shapes[99].radius",
                                 "scene.spp.value", "camera..fov"])
def test_override_of_a_missing_table_names_the_key(key):
    with pytest.raises(InputError) as err:
        load_scene("glossy", {key: 1})
    assert err.value.field == key


def test_scene_from_dict_does_not_mutate_its_input():
    d = base_scene()
    before = copy.deepcopy(d)
    scene_from_dict(d, overrides={"camera.fov": 30})
    assert d == before


# ---------------------------------------------------------------------------------------------------
# Bad input: one InputError, exact field, message naming what is allowed
# ---------------------------------------------------------------------------------------------------

def _set(d: dict, path: str, value) -> dict:
    """Set (or with value DELETE, remove) a dotted path like 'shapes[1].edge_v' in d."""
    keys: list = []
    for part in path.split("."):
        name, *idx = part.replace("]", "").split("[")
        keys.append(name)
        keys.extend(int(i) for i in idx)
    target = d
    for k in keys[:-1]:
        target = target[k]
    if value is DELETE:
        del target[keys[-1]]
    else:
        target[keys[-1]] = value
    return d


DELETE = object()
NAN, INF = float("nan"), float("inf")

# (case id, {dotted path: new value or DELETE}, expected field, fragments the message must contain)
BAD = [
    ("missing required position", {"camera.position": DELETE}, "camera.position", ["required", "3 finite"]),
    ("missing description", {"scene.description": DELETE}, "scene.description", ["required", "string"]),
    ("missing scene table", {"scene": DELETE}, "scene", ["required", "description"]),
    ("missing camera table", {"camera": DELETE}, "camera", ["required", "position"]),
    ("missing sphere radius", {"shapes[0].radius": DELETE}, "shapes[0].radius", ["required", "> 0"]),
    ("wrong type: string radius", {"shapes[0].radius": "big"}, "shapes[0].radius", ["> 0", "'big'"]),
    ("wrong type: string vector", {"camera.position": "0,1,5"}, "camera.position", ["3 finite numbers"]),
    ("wrong length vector", {"shapes[0].center": [0, 1]}, "shapes[0].center", ["3 finite numbers"]),
    ("bool as number", {"camera.fov": True}, "camera.fov", ["(0, 180)", "true"]),
    ("bool as integer", {"scene.spp": True}, "scene.spp", [">= 1", "true"]),
    ("float as integer", {"scene.spp": 16.0}, "scene.spp", ["integer", ">= 1"]),
    ("NaN in a vector", {"shapes[0].center": [NAN, 0, 0]}, "shapes[0].center", ["finite"]),
    ("NaN fov", {"camera.fov": NAN}, "camera.fov", ["finite", "(0, 180)"]),
    ("inf aperture", {"camera.aperture_radius": INF, "camera.focus_distance": 5},
     "camera.aperture_radius", ["finite", ">= 0"]),
    ("inf emission", {"materials.lamp.emission": [INF, 1, 1]}, "materials.lamp.emission", ["finite", ">= 0"]),
    ("huge integer radius", {"shapes[0].radius": 10 ** 400}, "shapes[0].radius", ["finite", "> 0"]),
    ("negative radius", {"shapes[0].radius": -1}, "shapes[0].radius", ["> 0", "-1"]),
    ("zero-area emitting quad", {"shapes[1].edge_v": [4, 0, 0]}, "shapes[1].edge_v",
     ["not parallel", "emitting quad needs area > 0"]),
    ("zero edge_u", {"shapes[1].edge_u": [0, 0, 0]}, "shapes[1].edge_u", ["non-zero"]),
    ("zero-area emitting sphere", {"shapes[0].material": "lamp", "shapes[0].radius": 0},
     "shapes[0].radius", ["> 0"]),
    ("emitting sphere too small", {"shapes[0].material": "lamp", "shapes[0].radius": 1e-200},
     "shapes[0].radius", ["emitting shape", "area > 0"]),
    ("unknown material", {"shapes[0].material": "blue"}, "shapes[0].material", ["'blue'", "red, lamp"]),
    ("unknown shape kind", {"shapes[0].kind": "cone"}, "shapes[0].kind", ["sphere, quad, box", "'cone'"]),
    ("missing shape kind", {"shapes[0].kind": DELETE}, "shapes[0].kind", ["required", "sphere | quad | box"]),
    ("unknown material kind", {"materials.red.kind": "metal"}, "materials.red.kind",
     ["diffuse, glossy, mirror, dielectric, glossy_dielectric, emitter"]),
    ("unknown light kind", {"lights[0].kind": "area"}, "lights[0].kind", ["point, directional, spot"]),
    ("unknown integrator", {"scene.integrator": "bdpt"}, "scene.integrator", ["whitted, drt, path"]),
    ("unknown camera key", {"camera.fvo": 30}, "camera.fvo", ["allowed keys", "fov"]),
    ("unknown top-level table", {"render": {"spp": 4}}, "render", ["allowed", "scene, camera"]),
    ("key of another shape kind", {"shapes[1].radius": 1}, "shapes[1].radius", ["allowed keys", "edge_u"]),
    ("key of another material kind", {"materials.red.exponent": 10}, "materials.red.exponent",
     ["allowed keys", "albedo2"]),
    ("albedo > 1", {"materials.red.albedo": [1.2, 0, 0]}, "materials.red.albedo", ["[0, 1]", "1.2"]),
    ("albedo < 0", {"materials.red.albedo": [0.5, -0.1, 0]}, "materials.red.albedo", ["[0, 1]"]),
    ("negative emission", {"materials.lamp.emission": [1, -1, 1]}, "materials.lamp.emission", [">= 0"]),
    ("emitter without emission", {"materials.lamp.emission": [0, 0, 0]}, "materials.lamp.emission",
     ["at least one channel > 0"]),
    ("negative exponent", {"materials.red": {"kind": "glossy", "exponent": -5}},
     "materials.red.exponent", [">= 0"]),
    ("zero ior", {"materials.red": {"kind": "dielectric", "ior": 0}}, "materials.red.ior", ["> 0"]),
    ("checker without albedo2", {"materials.red.checker": [4, 4]}, "materials.red.checker", ["albedo2"]),
    ("checker of zero", {"materials.red.albedo2": [0, 0, 0], "materials.red.checker": [0, 4]},
     "materials.red.checker", ["integers >= 1"]),
    ("fov 180", {"camera.fov": 180}, "camera.fov", ["(0, 180)", "180"]),
    ("fov 0", {"camera.fov": 0}, "camera.fov", ["(0, 180)"]),
    ("max_depth 0", {"scene.max_depth": 0}, "scene.max_depth", [">= 1", "-1"]),
    ("max_depth -2", {"scene.max_depth": -2}, "scene.max_depth", [">= 1", "-1"]),
    ("max_depth -1 without roulette", {"scene.max_depth": -1, "scene.integrator": "path"},
     "scene.max_depth", ["russian_roulette"]),
    ("roulette outside path", {"scene.russian_roulette": True}, "scene.russian_roulette", ["'path'"]),
    ("roulette not a bool", {"scene.russian_roulette": 1}, "scene.russian_roulette", ["true or false"]),
    ("rr_depth 0", {"scene.rr_depth": 0}, "scene.rr_depth", [">= 1"]),
    ("look_at == position", {"camera.look_at": [0, 1, 5]}, "camera.look_at", ["differ", "camera.position"]),
    ("up parallel to view", {"camera.up": [0, 0, -3]}, "camera.up", ["not parallel", "view direction"]),
    ("zero up", {"camera.up": [0, 0, 0]}, "camera.up", ["non-zero"]),
    ("f_number without focal_length", {"camera.f_number": 2.8, "camera.focus_distance": 5},
     "camera.f_number", ["needs camera.focal_length"]),
    ("aperture and f_number", {"camera.aperture_radius": 0.1, "camera.f_number": 2.8,
                               "camera.focal_length": 0.05, "camera.focus_distance": 5},
     "camera.f_number", ["either aperture_radius or f_number"]),
    ("image_distance <= focal_length", {"camera.focal_length": 0.05, "camera.image_distance": 0.05},
     "camera.image_distance", ["> focal_length"]),
    ("image_distance without focal_length", {"camera.image_distance": 0.06}, "camera.focal_length",
     ["required", "> 0"]),
    ("focal_length alone", {"camera.focal_length": 0.05}, "camera.focal_length",
     ["f_number", "image_distance"]),
    ("focus_distance and image_distance", {"camera.focus_distance": 5, "camera.focal_length": 0.05,
                                           "camera.image_distance": 0.06},
     "camera.image_distance", ["either focus_distance or focal_length + image_distance"]),
    ("aperture without focus", {"camera.aperture_radius": 0.1}, "camera.focus_distance",
     ["focus_distance > 0", "focal_length + image_distance"]),
    ("negative focus distance", {"camera.aperture_radius": 0.1, "camera.focus_distance": -2},
     "camera.focus_distance", ["> 0"]),
    ("shutter close < open", {"camera.shutter": [1.0, 0.5]}, "camera.shutter", ["open <= close"]),
    ("shutter wrong length", {"camera.shutter": [0.0]}, "camera.shutter", ["2 finite numbers"]),
    ("empty shapes", {"shapes": []}, "shapes", ["at least one", "sphere | quad | box"]),
    ("missing shapes", {"shapes": DELETE}, "shapes", ["at least one"]),
    ("shapes not an array", {"shapes": {"kind": "sphere"}}, "shapes", ["at least one"]),
    ("shape not a table", {"shapes[0]": 3}, "shapes[0]", ["table"]),
    ("resolution 0", {"scene.resolution": [0, 6]}, "scene.resolution", [">= 1", "[width, height]"]),
    ("resolution wrong length", {"scene.resolution": [8]}, "scene.resolution", ["2 integers >= 1"]),
    ("spp 0", {"scene.spp": 0}, "scene.spp", [">= 1", "0"]),
    ("box max <= min", {"shapes[2].max": [3, 0, 1]}, "shapes[2].max", ["> min", "every axis"]),
    ("negative background", {"scene.background": [0, -1, 0]}, "scene.background", [">= 0"]),
    ("zero light direction", {"lights[1].direction": [0, 0, 0]}, "lights[1].direction", ["non-zero"]),
    ("missing light intensity", {"lights[0].intensity": DELETE}, "lights[0].intensity", ["required", ">= 0"]),
    ("velocity with NaN", {"shapes[0].velocity": [0, NAN, 0]}, "shapes[0].velocity", ["finite"]),
    ("materials not a table", {"materials": [1, 2]}, "materials", ["table"]),
]


def test_bad_input_table_is_large_and_distinct():
    ids = [case[0] for case in BAD]
    assert len(ids) == len(set(ids)) and len(ids) >= 25


@pytest.mark.parametrize("changes, field, fragments", [case[1:] for case in BAD], ids=[c[0] for c in BAD])
def test_bad_input_raises_one_input_error(changes, field, fragments):
    d = base_scene()
    for path, value in changes.items():
        _set(d, path, value)
    with pytest.raises(InputError) as err:
        scene_from_dict(d)
    assert err.value.field == field, err.value
    for fragment in fragments:
        assert fragment in err.value.message, f"{fragment!r} not in {err.value.message!r}"
    assert str(err.value).startswith(f"{field}: ")


def test_unknown_scene_name_lists_the_builtins():
    with pytest.raises(InputError) as err:
        load_scene("no-such-scene")
    assert err.value.field == "scene"
    assert "unknown scene 'no-such-scene'" in err.value.message
    assert ", ".join(BUILTINS) in err.value.message and "path to a .toml file" in err.value.message


def test_malformed_toml_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('[scene]\ndescription = "unterminated\n')
    with pytest.raises(InputError) as err:
        load_scene(path)
    assert err.value.field == "scene"
    assert err.value.message.startswith(f"malformed TOML in {path}: ")


def test_errors_in_files_name_the_field(tmp_path):
    text = (BUILTIN_DIR / "veach-mis.toml").read_text().replace("radius = 0.9", "radius = -0.9")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_scene(path)
    assert err.value.field == "shapes[7].radius" and "> 0" in err.value.message


# ---------------------------------------------------------------------------------------------------
# Fuzzing: any value anywhere gives a Scene or an InputError, never another exception
# ---------------------------------------------------------------------------------------------------

def _paths(d, prefix=""):
    """Every dotted path in the base scene (tables, arrays and leaves)."""
    items = d.items() if isinstance(d, dict) else enumerate(d)
    for k, v in items:
        path = f"{prefix}[{k}]" if isinstance(k, int) else (f"{prefix}.{k}" if prefix else k)
        yield path
        if isinstance(v, (dict, list)):
            yield from _paths(v, path)


_PATHS = list(_paths(base_scene()))
_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10 ** 20, 10 ** 20),
                     st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=6))
_values = st.recursive(_scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=5), inner, max_size=3)), max_leaves=8)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(changes=st.dictionaries(st.sampled_from(_PATHS), st.one_of(_values, st.just(DELETE)), max_size=3))
def test_fuzzed_scenes_raise_only_input_errors(changes):
    d = base_scene()
    for path, value in changes.items():
        try:
            _set(d, path, value)
        except (KeyError, IndexError, TypeError):
            continue            # an earlier change removed or replaced this path's parent
    try:
        scene = scene_from_dict(d)
    except InputError as err:
        assert err.field and err.message
        return
    assert isinstance(scene, Scene) and scene.shapes


def test_scene_settings_are_the_loaded_scenes_settings():
    # `drtlab scenes` lists from scene_settings, which builds no shapes: its values must be the scene's.
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene, scene_settings
    for name in builtin_names():
        settings, scene = scene_settings(name), load_scene(name)
        assert settings.keys() >= {"description", "width", "height", "spp", "integrator"}
        for key, value in settings.items():
            assert np.array_equal(getattr(scene, key), value), (name, key)


@pytest.mark.parametrize("edit, field", [
    (lambda d: d["materials"]["lamp"].update(emission=[1e39, 5, 5]), "materials.lamp.emission"),
    (lambda d: d["shapes"][0].update(radius=1e39), "shapes[0].radius"),
    (lambda d: d["shapes"][0].update(center=[1e300, 0, 0]), "shapes[0].center"),
    (lambda d: d["lights"][0].update(intensity=[2e15, 1, 1]), "lights[0].intensity"),
])
def test_numbers_beyond_float32_tracing_are_refused(edit, field):
    """Finite in float64 but not traceable in float32: a radius of 1e39 made the sphere vanish and
    an emission of 1e39 rendered Inf pixels; every scene number is bounded by fields.SCENE_LIMIT."""
    d = base_scene()
    edit(d)
    with pytest.raises(InputError) as e:
        scene_from_dict(d)
    assert e.value.field == field and "magnitude at most 1e+15" in e.value.message
    ok = base_scene()
    ok["shapes"][0]["center"] = [1e14, 0, 0]                  # large but within range: accepted
    # (with no area light beside it: a 2 x 2 light 1e14 away has a density whose square float32
    # cannot hold, which test_accepted_wrongly.py's emitter-size test refuses)
    ok["shapes"][1]["material"] = "red"
    scene_from_dict(ok)
