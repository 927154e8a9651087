"""The tables of a scene file, one validator each: [scene], [camera], [materials.*], [[shapes]],
[[lights]], [environment] (kernels/scene_model/environment_map.py) -> the in-memory `Scene` (kernels/scene_model/scene.py). Every check raises one `InputError` naming the
offending value's dotted path.

Beyond SCENE_FORMAT.md this loader requires `kind` on every shape and light and the position/intensity
(point) or direction/irradiance (directional) of every light: a light without them is meaningless.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from drtlab import fields
from drtlab.errors import InputError
from drtlab.fields import (REQUIRED, Table, boolean, integer, scene_colour, scene_number as number,
                           scene_numbers as numbers, show, string)
from drtlab.kernels.scene_model.environment_map import parse_environment
from drtlab.kernels.scene_model.float32_checks import check_emitter_sizes, check_float32_area
from drtlab.kernels.scene_model.scene import (INTEGRATORS, SPOT_BEAM_SHARE, SPOT_CUTOFF_DEFAULT,
                                             DirectionalLight, Material, PointLight, Scene, Shape)
from drtlab.kernels.scene_model.camera_table import parse_camera
from drtlab.kernels.scene_model.material_table import parse_materials
from drtlab.kernels.scene_model.light_projection import (PROJECTOR_KEYS, SPOT_PROJECTION_KEYS, parse_projector,
                                                        parse_spot_texture)
from drtlab.kernels.scene_model.transforms import parallel, parse_transform, transform_quad, transform_sphere
from drtlab.kernels.scene_model.mesh_attributes import check_attribute_textures
from drtlab.kernels.scene_model.mesh_file import MESH_KEYS, SPHERE_GRID_KEYS, parse_mesh_shape, parse_sphere_grid

TOP_LEVEL_KEYS = ("scene", "camera", "materials", "shapes", "lights", "environment")
SCENE_KEYS = ("description", "resolution", "spp", "integrator", "max_depth", "russian_roulette",
              "rr_depth", "background", "emitter_samples", "bsdf_samples")
# What a file may say; boxes become quads, sphere grids spheres (meshes: kernels/scene_model/mesh_file.py).
SHAPE_FILE_KINDS = ("sphere", "quad", "box", "mesh", "sphere_grid")
SHAPE_COMMON_KEYS = ("kind", "material", "name", "velocity", "transform")
SHAPE_KEYS = {
    "sphere": SHAPE_COMMON_KEYS + ("center", "radius"),
    "quad": SHAPE_COMMON_KEYS + ("origin", "edge_u", "edge_v"),
    "box": SHAPE_COMMON_KEYS + ("min", "max"),
    "mesh": SHAPE_COMMON_KEYS + MESH_KEYS,
    "sphere_grid": SHAPE_COMMON_KEYS + SPHERE_GRID_KEYS,
}
LIGHT_KEYS = {
    "point": ("kind", "position", "intensity"),
    "directional": ("kind", "direction", "irradiance"),
    "spot": ("kind", "position", "intensity", "direction", "look_at", "cutoff_angle", "beam_width")
    + SPOT_PROJECTION_KEYS,
    "projector": PROJECTOR_KEYS,
}

# ---------------------------------------------------------------------------------------------------
# Scene-specific values
# ---------------------------------------------------------------------------------------------------
def _vec3(v: Any, field: str) -> np.ndarray:
    return numbers(v, field, 3)


# ---------------------------------------------------------------------------------------------------
# The scene, table by table
# ---------------------------------------------------------------------------------------------------

def build_scene(data: dict, *, name: str, source: str, text: str) -> Scene:
    # Huge-but-finite inputs may overflow in differences and cross products; the checks below turn
    # the resulting infinities into InputErrors, so numpy's warnings would only be noise.
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        return _build_scene_checked(data, name=name, source=source, text=text)


def _build_scene_checked(data: dict, *, name: str, source: str, text: str) -> Scene:
    for key in data:
        if key not in TOP_LEVEL_KEYS:
            raise InputError(key, f"unknown top-level table '{key}'; allowed: {', '.join(TOP_LEVEL_KEYS)}")
    settings = parse_settings(data.get("scene", REQUIRED))
    camera = parse_camera(data.get("camera", REQUIRED))
    materials = parse_materials(data.get("materials", {}))
    groups = _parse_shapes(data.get("shapes", []), materials)
    check_emitter_sizes(groups, data["shapes"], materials, camera)
    shapes = [s for g in groups for s in g]
    check_attribute_textures(shapes, materials)
    point_lights, directional_lights = _parse_lights(data.get("lights", []))
    environment = parse_environment(data["environment"]) if "environment" in data else None
    if environment is not None and np.any(settings["background"] > 0.0):
        raise InputError("scene.background", "give either a background or an [environment] "
                                             "(kind = \"constant\" is a sampled background), not both")
    if environment is not None and settings["integrator"] == "direct" and settings["bsdf_samples"] == 0:
        # drtlab's direct reaches the environment through BSDF samples only: none would be missing.
        raise InputError("scene.bsdf_samples", "the direct integrator lights an [environment] by its "
                                               "BSDF samples: give bsdf_samples >= 1")
    return Scene(name=name, camera=camera, materials=materials, shapes=shapes,
                 point_lights=point_lights, directional_lights=directional_lights,
                 environment=environment, source=source, text=text, **settings)


def parse_settings(value: Any) -> dict:
    """The [scene] table validated: the Scene's settings (description, width, height, spp, ...)."""
    if value is REQUIRED:
        raise InputError("scene", "the [scene] table is required (description, resolution, spp, ...)")
    t = Table(value, "scene", "[scene]")
    t.check_keys(SCENE_KEYS)
    description = string(t.get("description", REQUIRED, "a one-line string"), t.field("description"))
    width, height = fields.resolution(t.get("resolution", [96, 72], ""), t.field("resolution"))
    spp = integer(t.get("spp", 16, ""), t.field("spp"), ">= 1", lambda n: n >= 1)
    integrator = string(t.get("integrator", "drt", ""), t.field("integrator"), INTEGRATORS)
    roulette = boolean(t.get("russian_roulette", False, ""), t.field("russian_roulette"))
    if roulette and integrator != "path":
        raise InputError(t.field("russian_roulette"), "true is allowed with integrator 'path' only, "
                                                      f"got integrator '{integrator}'")
    max_depth = _max_depth(t.get("max_depth", 5, ""), t.field("max_depth"), roulette)
    rr_depth = integer(t.get("rr_depth", 5, ""), t.field("rr_depth"), ">= 1", lambda n: n >= 1)
    background = scene_colour(t.get("background", [0, 0, 0], ""), t.field("background"))
    counts = _direct_samples(t, integrator)
    return dict(description=description, width=width, height=height, spp=spp, integrator=integrator,
                max_depth=max_depth, rr_depth=rr_depth, russian_roulette=roulette, background=background,
                **counts)


def _direct_samples(t, integrator: str) -> dict:
    """The direct integrator's sample counts (Mitsuba 3's `emitter_samples`, `bsdf_samples`,
    default 1 each, at least one in all); for another integrator they are not allowed."""
    counts = {}
    for key in ("emitter_samples", "bsdf_samples"):
        value = t.get(key, 1, "")
        if key in t.data and integrator != "direct":
            raise InputError(t.field(key), f"is for integrator 'direct' (Mitsuba 3's), got integrator "
                                           f"'{integrator}'")
        counts[key] = integer(value, t.field(key), "an integer 0 ... 64", lambda n: 0 <= n <= 64)
    if counts["emitter_samples"] + counts["bsdf_samples"] == 0:
        raise InputError(t.field("emitter_samples"), "emitter_samples and bsdf_samples are both 0; "
                                                     "at least one sample is needed")
    return counts


def _max_depth(v: Any, field: str, roulette: bool) -> int:
    """Mitsuba 3 convention: 1 = emitters seen directly, 2 = direct light, -1 = unbounded."""
    depth = integer(v, field, ">= 1, or -1 (unbounded, path with russian_roulette)",
                     lambda n: n >= 1 or n == -1)
    if depth == -1 and not roulette:
        raise InputError(field, "-1 (unbounded) needs russian_roulette = true (integrator 'path'); "
                                "otherwise use a depth >= 1")
    return depth


def _parse_shapes(value: Any, materials: list[Material]) -> list[list[Shape]]:
    """The shapes of each [[shapes]] entry (a box is six quads, a sphere grid many spheres)."""
    if not isinstance(value, list) or not value:
        raise InputError("shapes", "a scene needs at least one [[shapes]] entry (kind = "
                                   f"{' | '.join(SHAPE_FILE_KINDS)}), got {show(value)}")
    index = {m.name: i for i, m in enumerate(materials)}
    groups = [_transformed(i, body, _parse_shape(i, body, materials, index), materials)
              for i, body in enumerate(value)]
    return groups


def _transformed(i: int, value: dict, shapes: list[Shape], materials: list[Material]) -> list[Shape]:
    """The shapes of shapes[i] under its optional `transform` (kernels/scene_model/transforms.py), applied to
    their defining points: sphere centres (a similarity also scales the radius), quad origins and
    edges (a box's six quads). Other kinds (meshes) apply it to their vertices in their own parser.
    Velocities stay world-space."""
    if "transform" not in value or not shapes:
        return shapes
    field = f"shapes[{i}].transform"
    m, spelled = parse_transform(value["transform"], field)
    emissive = materials[shapes[0].material].emissive
    for s in shapes:
        if s.kind == "sphere":
            s.center, s.radius, to_local = transform_sphere(m, s.center, s.radius, field, spelled)
            if materials[s.material].textures:     # only a texture reads the sphere's frame
                s.to_local = to_local
        elif s.kind == "quad":
            s.origin, s.edge_u, s.edge_v = transform_quad(m, s.origin, s.edge_u, s.edge_v)
        else:
            continue
        _check_area(s, field, emissive)
    return shapes


def _parse_shape(i: int, value: Any, materials: list[Material], index: dict[str, int]) -> list[Shape]:
    path = f"shapes[{i}]"
    t = Table(value, path, f"shape {i}")
    kind = string(t.get("kind", REQUIRED, " | ".join(SHAPE_FILE_KINDS)), t.field("kind"), SHAPE_FILE_KINDS)
    t.check_keys(SHAPE_KEYS[kind])
    material_name = string(t.get("material", REQUIRED, "the name of a [materials.NAME] table"),
                            t.field("material"))
    if material_name not in index:
        defined = ", ".join(index) or "(none)"
        raise InputError(t.field("material"), f"unknown material '{material_name}'; defined materials: {defined}")
    material = index[material_name]
    name = string(t.get("name", f"{kind}{i}", ""), t.field("name"))
    velocity = _vec3(t.get("velocity", [0, 0, 0], ""), t.field("velocity"))
    emissive = materials[material].emissive
    common = dict(material=material, velocity=velocity)

    if kind == "mesh":
        return [parse_mesh_shape(t, name, material, velocity)]
    if kind == "sphere_grid":
        return parse_sphere_grid(t, name, material, velocity)
    if kind == "sphere":
        center = _vec3(t.get("center", REQUIRED, "a list of 3 finite numbers"), t.field("center"))
        radius = number(t.get("radius", REQUIRED, "a finite number > 0"), t.field("radius"), "> 0",
                         lambda x: x > 0.0)
        shape = Shape(kind="sphere", name=name, center=center, radius=radius, **common)
        _check_area(shape, t.field("radius"), emissive)
        return [shape]
    if kind == "quad":
        origin = _vec3(t.get("origin", REQUIRED, "a list of 3 finite numbers"), t.field("origin"))
        edge_u = _vec3(t.get("edge_u", REQUIRED, "a list of 3 finite numbers"), t.field("edge_u"))
        edge_v = _vec3(t.get("edge_v", REQUIRED, "a list of 3 finite numbers"), t.field("edge_v"))
        if not np.any(edge_u != 0.0):
            raise InputError(t.field("edge_u"), "must be a non-zero list of 3 finite numbers, got [0, 0, 0]")
        if parallel(edge_u, edge_v):
            raise InputError(t.field("edge_v"), "must be non-zero and not parallel to edge_u (the normal "
                                                "normalize(edge_u x edge_v) must exist"
                                                f"{'; an emitting quad needs area > 0' if emissive else ''})"
                                                f", got {show(edge_v.tolist())}")
        shape = Shape(kind="quad", name=name, origin=origin, edge_u=edge_u, edge_v=edge_v, **common)
        _check_area(shape, t.field("edge_v"), emissive)
        return [shape]
    lo = _vec3(t.get("min", REQUIRED, "a list of 3 finite numbers"), t.field("min"))
    hi = _vec3(t.get("max", REQUIRED, "a list of 3 finite numbers"), t.field("max"))
    if not np.all(hi > lo):
        raise InputError(t.field("max"), f"must be > min = {show(lo.tolist())} on every axis, "
                                         f"got {show(hi.tolist())}")
    faces = box_quads(lo, hi, material=material, name=name, velocity=velocity)
    for face in faces:
        _check_area(face, t.field("max"), emissive)
    return faces


def _check_area(shape: Shape, field: str, emissive: bool) -> None:
    """Area must be finite and > 0 (an emitter's power is radiance * area * pi)."""
    try:
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            area = shape.area()
    except OverflowError:           # a Python-float radius ** 2 overflows instead of giving inf
        area = math.inf
    what = "an emitting shape" if emissive else "a shape"
    if not (math.isfinite(area) and area > 0.0):
        raise InputError(field, f"{what} needs a finite area > 0, got area {area:g}")
    check_float32_area(shape, area, field, what)


# The six faces of a box as (name suffix, corner, edge_u, edge_v) in units of the box's size d,
# ordered so that edge_u x edge_v points out of the box.
_BOX_FACES = (
    ("px", (1, 0, 0), (0, 1, 0), (0, 0, 1)),
    ("nx", (0, 0, 0), (0, 0, 1), (0, 1, 0)),
    ("py", (0, 1, 0), (0, 0, 1), (1, 0, 0)),
    ("ny", (0, 0, 0), (1, 0, 0), (0, 0, 1)),
    ("pz", (0, 0, 1), (1, 0, 0), (0, 1, 0)),
    ("nz", (0, 0, 0), (0, 1, 0), (1, 0, 0)),
)


def box_quads(lo: np.ndarray, hi: np.ndarray, *, material: int, name: str = "",
              velocity: np.ndarray | None = None) -> list[Shape]:
    """The axis-aligned box [lo, hi] as six quads with outward normals, named NAME.px, NAME.nx, ..."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    size = hi - lo
    vel = np.zeros(3) if velocity is None else np.asarray(velocity, dtype=np.float64)
    return [Shape(kind="quad", material=material, name=f"{name}.{suffix}",
                  origin=lo + np.array(corner) * size, edge_u=np.array(eu) * size,
                  edge_v=np.array(ev) * size, velocity=vel.copy())
            for suffix, corner, eu, ev in _BOX_FACES]


def _parse_lights(value: Any) -> tuple[list[PointLight], list[DirectionalLight]]:
    if not isinstance(value, list):
        raise InputError("lights", f"must be an array of tables ([[lights]] with kind = "
                                   f"{' | '.join(LIGHT_KEYS)}), got {show(value)}")
    points: list[PointLight] = []
    directionals: list[DirectionalLight] = []
    for i, body in enumerate(value):
        t = Table(body, f"lights[{i}]", f"light {i}")
        kind = string(t.get("kind", REQUIRED, " | ".join(LIGHT_KEYS)), t.field("kind"), tuple(LIGHT_KEYS))
        t.check_keys(LIGHT_KEYS[kind])
        if kind == "projector":
            position = _vec3(t.get("position", REQUIRED, "a list of 3 finite numbers"), t.field("position"))
            points.append(PointLight(position=position, intensity=np.ones(3)))
            points[-1].direction = _axis(t, position)
            parse_projector(t, points[-1])
        elif kind in ("point", "spot"):
            position = _vec3(t.get("position", REQUIRED, "a list of 3 finite numbers"), t.field("position"))
            intensity = scene_colour(t.get("intensity", REQUIRED, "a list of 3 finite numbers >= 0 (W/sr)"),
                               t.field("intensity"))
            points.append(PointLight(position=position, intensity=intensity))
            if kind == "spot":
                _spot_cone(t, points[-1])
                parse_spot_texture(t, points[-1])
        else:
            direction = _vec3(t.get("direction", REQUIRED, "a non-zero list of 3 finite numbers"),
                              t.field("direction"))
            norm = float(np.linalg.norm(direction))
            if not (math.isfinite(norm) and norm > 0.0):
                raise InputError(t.field("direction"), "must be a non-zero list of 3 finite numbers "
                                                       f"(the direction light travels), got {show(value[i]['direction'])}")
            irradiance = scene_colour(t.get("irradiance", REQUIRED, "a list of 3 finite numbers >= 0"),
                                t.field("irradiance"))
            directionals.append(DirectionalLight(direction=direction / norm, irradiance=irradiance))
    return points, directionals


def _axis(t: Table, position: np.ndarray) -> np.ndarray:
    """A spot's or projector's axis: direction, or look_at from its position."""
    if t.has("direction") == t.has("look_at"):
        raise InputError(t.field("direction"), f"a {t.data['kind']} needs either direction or look_at "
                                               "(a point its axis passes through), not both or neither")
    key = "direction" if t.has("direction") else "look_at"
    axis = _vec3(t.data[key], t.field(key))
    if key == "look_at":
        axis = axis - position
    norm = float(np.linalg.norm(axis))
    if not (math.isfinite(norm) and norm > 0.0):
        raise InputError(t.field(key), "must give a non-zero axis (a direction, or a look_at away "
                                       f"from the position), got {show(t.data[key])}")
    return axis


def _spot_cone(t: Table, light: PointLight) -> None:
    """A spot's axis (direction, or look_at from its position) and cone, Mitsuba 3's angles in degrees."""
    axis = _axis(t, light.position)
    cutoff = number(t.get("cutoff_angle", SPOT_CUTOFF_DEFAULT, ""), t.field("cutoff_angle"),
                    "in (0, 180] (degrees, where the light ends)", lambda x: 0.0 < x <= 180.0)
    beam = number(t.get("beam_width", SPOT_BEAM_SHARE * cutoff, ""), t.field("beam_width"),
                  f"in [0, cutoff_angle = {cutoff:g}] (degrees, the full-intensity cone)",
                  lambda x: 0.0 <= x <= cutoff)
    light.direction, light.cutoff_angle, light.beam_width = axis, float(cutoff), float(beam)
