"""What a projection adds to a point light (kernels/scene_model/scene.py `PointLight`): a spot's
projected `texture` (Mitsuba 3's src/emitters/spot.cpp) and Mitsuba 3's `projector`
(src/emitters/projector.cpp), read from a [[lights]] table. The kernels' side: kernels/projection.py.

Both need the emitter's frame, Mitsuba's look_at: z the axis, x = normalize(up x z) (Mitsuba's
"left"), y = z x x. A projector is a perspective camera run backwards: `fov` along `fov_axis` is
turned into the horizontal field of view by parse_fov (src/render/sensor.cpp) with the aspect of its
irradiance texture (width / height; 1 for a constant); no `fov`: a 50 mm focal length (36 x 24 mm
film), i.e. `fov_axis` diagonal. Its `intensity` is `scale` x `irradiance` (a constant irradiance)
or `scale` (a texture's texels give the colour).
"""
from __future__ import annotations

import math

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import Table, scene_number as number, scene_numbers as numbers, show, string
from drtlab.kernels.scene_model.scene import PointLight
from drtlab.kernels.scene_model.texture import parse_texture
from drtlab.kernels.scene_model.transforms import parallel

FOV_AXES = ("x", "y", "diagonal", "smaller", "larger")
FOCAL_LENGTH_MM = 50.0          # parse_fov's default focal length (35 mm film equivalent)
FILM_DIAGONAL_MM = math.hypot(36.0, 24.0)
UP_DEFAULT = (0.0, 1.0, 0.0)
PROJECTOR_KEYS = ("kind", "position", "direction", "look_at", "up", "irradiance", "irradiance_texture",
                  "scale", "fov", "fov_axis")
SPOT_PROJECTION_KEYS = ("up", "texture")


def resolved_axis(axis: str, aspect: float) -> str:
    """parse_fov's fov_axis "smaller" or "larger" as the image axis it names (width / height =
    aspect); "x", "y" and "diagonal" as they are."""
    if axis == "smaller":
        return "y" if aspect > 1 else "x"
    if axis == "larger":
        return "x" if aspect > 1 else "y"
    return axis


def fov_x(fov: float, axis: str, aspect: float) -> float:
    """parse_fov (src/render/sensor.cpp): the horizontal field of view in degrees of `fov` degrees
    along `axis` of an image of width / height = aspect."""
    axis = resolved_axis(axis, aspect)
    if axis == "x":
        return fov
    if axis == "y":
        return math.degrees(2.0 * math.atan(math.tan(0.5 * math.radians(fov)) * aspect))
    diagonal = 2.0 * math.tan(0.5 * math.radians(fov))
    return math.degrees(2.0 * math.atan(diagonal / math.sqrt(1.0 + 1.0 / (aspect * aspect)) * 0.5))


def focal_length_fov(mm: float) -> float:
    """The diagonal field of view in degrees of a focal length in mm (36 x 24 mm film)."""
    return 2.0 * math.degrees(math.atan(FILM_DIAGONAL_MM / (2.0 * mm)))


def light_frame(axis: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The emitter's unit frame, columns x, y, z (Mitsuba's look_at): z = the axis, x = up x z."""
    z = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    x = np.cross(np.asarray(up, dtype=np.float64), z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def texture_aspect(light: PointLight) -> float:
    """Width / height of a light's texture (Mitsuba's resolution(): 1 x 1 for a constant)."""
    if light.texture is None or light.texture.kind != "bitmap":
        return 1.0
    h, w = light.texture.pixels.shape[:2]
    return w / h


def parse_up(t: Table, light: PointLight) -> None:
    up = numbers(t.get("up", list(UP_DEFAULT), ""), t.field("up"), 3)
    if parallel(up, light.direction):
        raise InputError(t.field("up"), "must be non-zero and not parallel to the light's axis "
                                        f"{show(np.asarray(light.direction).tolist())}, got {show(up.tolist())}")
    light.up = up


def parse_spot_texture(t: Table, light: PointLight) -> None:
    """A spot's optional projected `texture` and the `up` that orients it."""
    if t.has("texture"):
        light.texture = parse_texture(t.data["texture"], t.field("texture"))
    if t.has("up") or light.texture is not None:
        parse_up(t, light)


def parse_projector(t: Table, light: PointLight) -> None:
    """A projector's irradiance (constant or texture), scale, field of view and frame, onto `light`
    (its position and axis already read)."""
    scale = number(t.get("scale", 1.0, ""), t.field("scale"), ">= 0", lambda x: x >= 0.0)
    if t.has("irradiance") and t.has("irradiance_texture"):
        raise InputError(t.field("irradiance_texture"), "give irradiance (a constant) or "
                                                        "irradiance_texture, not both")
    irradiance = np.ones(3)
    if t.has("irradiance_texture"):
        light.texture = parse_texture(t.data["irradiance_texture"], t.field("irradiance_texture"))
    elif t.has("irradiance"):
        irradiance = numbers(t.data["irradiance"], t.field("irradiance"), 3, ">= 0", lambda x: x >= 0.0)
    light.intensity = scale * irradiance
    if t.has("fov"):
        fov = number(t.data["fov"], t.field("fov"), "in (0, 180) degrees", lambda x: 0.0 < x < 180.0)
        axis = string(t.get("fov_axis", "x", ""), t.field("fov_axis"), FOV_AXES)
    elif t.has("fov_axis"):
        raise InputError(t.field("fov_axis"), "applies to a given fov (without one the field of "
                                              "view is a 50 mm lens's, along the diagonal)")
    else:
        fov, axis = focal_length_fov(FOCAL_LENGTH_MM), "diagonal"
    light.fov_x = fov_x(fov, axis, texture_aspect(light))     # in (0, 180) for any fov in (0, 180)
    parse_up(t, light)
