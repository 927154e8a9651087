"""The [camera] table of a scene file -> `Camera` (kernels/scene_model/scene.py): the view, the
lens (aperture, focus), the shutter, the pixel filter and the orthographic film. Every check raises
one `InputError` naming the offending value's dotted path."""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import REQUIRED, Table, boolean, scene_number as number, scene_numbers as numbers, show, string
from drtlab.kernels.filters import BOX, FILTER_NAMES, STDDEV_FILTERS, STDDEV_MAX, STDDEV_MIN
from drtlab.kernels.scene_model.scene import Camera
from drtlab.kernels.scene_model.transforms import parallel

CAMERA_KEYS = ("position", "look_at", "up", "fov", "aperture_radius", "f_number", "focus_distance",
               "focal_length", "image_distance", "shutter", "filter", "filter_stddev", "filter_clip",
               "ortho_height")


def vec3(v: Any, field: str) -> np.ndarray:
    return numbers(v, field, 3)


def parse_camera(value: Any) -> Camera:
    if value is REQUIRED:
        raise InputError("camera", "the [camera] table is required (position, look_at, ...)")
    t = Table(value, "camera", "[camera]")
    t.check_keys(CAMERA_KEYS)
    position = vec3(t.get("position", REQUIRED, "a list of 3 finite numbers"), t.field("position"))
    look_at = vec3(t.get("look_at", REQUIRED, "a list of 3 finite numbers"), t.field("look_at"))
    up = vec3(t.get("up", [0, 1, 0], ""), t.field("up"))
    view = look_at - position
    if not np.all(np.isfinite(view)) or not np.any(view != 0.0):
        raise InputError(t.field("look_at"), f"must differ from camera.position (a finite view "
                                             f"direction is needed), got {show(look_at.tolist())}")
    if parallel(view, up):
        raise InputError(t.field("up"), f"must be non-zero and not parallel to the view direction "
                                        f"look_at - position = {show(view.tolist())}, got {show(up.tolist())}")
    fov = number(t.get("fov", 40.0, ""), t.field("fov"), "in (0, 180) degrees", lambda x: 0.0 < x < 180.0)
    aperture, focus = _parse_lens(t)
    shutter = _parse_shutter(t.get("shutter", [0.0, 0.0], ""), t.field("shutter"))
    pixel_filter = string(t.get("filter", BOX, ""), t.field("filter"), FILTER_NAMES)
    stddev = t.get("filter_stddev", None, "")
    if stddev is not None:
        if pixel_filter not in STDDEV_FILTERS:
            raise InputError(t.field("filter_stddev"), f"is for filter {' or '.join(STDDEV_FILTERS)} "
                                                       f"(the others' shapes are fixed), not {pixel_filter!r}")
        stddev = number(stddev, t.field("filter_stddev"), f"in [{STDDEV_MIN}, {STDDEV_MAX}] pixels",
                        lambda x: STDDEV_MIN <= x <= STDDEV_MAX)
    clip = boolean(t.get("filter_clip", False, ""), t.field("filter_clip"))
    ortho = 0.0
    if t.has("ortho_height"):
        ortho = number(t.data["ortho_height"], t.field("ortho_height"), "> 0 (the film's height in world "
                       "units, orthographic)", lambda x: x > 0.0)
        if aperture > 0.0:
            raise InputError(t.field("ortho_height"), "an orthographic camera has no lens: drop "
                                                      "aperture_radius / f_number")
    return Camera(position=position, look_at=look_at, up=up, vfov_deg=fov, aperture_radius=aperture,
                  focus_distance=focus, shutter=shutter, filter=pixel_filter,
                  filter_stddev=float(stddev or 0.0), filter_clip=clip and pixel_filter != BOX,
                  ortho_height=float(ortho))


def _parse_lens(t: Table) -> tuple[float, float]:
    """(aperture_radius, focus_distance) from the thin-lens keys; (0, 1) for a pinhole."""
    positive = ("> 0", lambda x: x > 0.0)
    focal = number(t.data["focal_length"], t.field("focal_length"), *positive) \
        if t.has("focal_length") else None

    # Aperture: aperture_radius XOR f_number (which needs the focal length).
    if t.has("aperture_radius") and t.has("f_number"):
        raise InputError(t.field("f_number"), "give either aperture_radius or f_number "
                                              "(aperture_radius = focal_length / (2 f_number)), not both")
    if t.has("f_number"):
        f_number = number(t.data["f_number"], t.field("f_number"), *positive)
        if focal is None:
            raise InputError(t.field("f_number"), "needs camera.focal_length > 0 "
                                                  "(aperture_radius = focal_length / (2 f_number))")
        aperture = focal / (2.0 * f_number)
    elif t.has("aperture_radius"):
        aperture = number(t.data["aperture_radius"], t.field("aperture_radius"), ">= 0 (0 = pinhole)",
                           lambda x: x >= 0.0)
    else:
        aperture = 0.0

    # Focus: focus_distance XOR the Gaussian lens formula 1/di + 1/do = 1/f.
    if t.has("focus_distance") and t.has("image_distance"):
        raise InputError(t.field("image_distance"), "give either focus_distance or focal_length + "
                                                    "image_distance (Gaussian lens formula), not both")
    if t.has("image_distance"):
        image = number(t.data["image_distance"], t.field("image_distance"), *positive)
        if focal is None:
            raise InputError(t.field("focal_length"), "is required with camera.image_distance: a finite "
                                                      "number > 0 (focus = 1 / (1/f - 1/di))")
        if not image > focal:
            raise InputError(t.field("image_distance"), f"must be > focal_length = {focal:g} (an image "
                                                        f"inside the focal length focuses nothing), got {image:g}")
        focus = 1.0 / (1.0 / focal - 1.0 / image)
        if not (math.isfinite(focus) and focus > 0.0):
            raise InputError(t.field("image_distance"), f"must be clearly > focal_length = {focal:g}: the "
                                                        f"focus distance 1 / (1/f - 1/di) is not finite")
    elif t.has("focus_distance"):
        focus = number(t.data["focus_distance"], t.field("focus_distance"), *positive)
    else:
        focus = None

    if focal is not None and not (t.has("f_number") or t.has("image_distance")):
        raise InputError(t.field("focal_length"), "is used only with camera.f_number (aperture) or "
                                                  "camera.image_distance (focus); give one or drop it")
    if aperture > 0.0 and focus is None:
        raise InputError(t.field("focus_distance"), f"a lens with aperture {aperture:g} > 0 needs focus: "
                                                    "focus_distance > 0, or focal_length + image_distance")
    return aperture, (1.0 if focus is None else focus)


def _parse_shutter(v: Any, field: str) -> tuple[float, float]:
    times = numbers(v, field, 2)
    if times[1] < times[0]:
        raise InputError(field, f"must be [open, close] with open <= close, got {show(v)}")
    return float(times[0]), float(times[1])
