"""Quantities derived from a scene's numbers checked against what float32 holds: each number may be
in range (fields.SCENE_LIMIT) and what the kernels compute from it not. A quad's area (its normal is
normalize(edge_u x edge_v) in float32) and an emitter's area against the scene's extent (MIS squares
its density d^2 / (A cos)); the Phong exponent's bound is `fields.PHONG_EXPONENT_MAX`, an environment's
radiance x scale `environment_map`'s. Each violation is one InputError naming the field."""
from __future__ import annotations

import numpy as np

from drtlab import fields
from drtlab.errors import InputError
from drtlab.kernels.scene_model.scene import Camera, Material, Shape


def check_float32_area(shape: Shape, area: float, field: str, what: str) -> None:
    """A quad's area at least float32's smallest normal number: below it the kernels' normal
    normalize(edge_u x edge_v) is 0 / 0."""
    if shape.kind == "quad" and not area >= fields.FLOAT32_TINY:
        raise InputError(field, f"{what} needs an area float32 holds (>= {fields.FLOAT32_TINY:.3g}, "
                                f"the kernels trace in float32), got area {area:.3g}")


def check_emitter_sizes(groups: list[list[Shape]], entries: list, materials: list[Material],
                         camera: Camera) -> None:
    """Every emitting shape's area at least EMITTER_AREA_SHARE of the scene's extent squared (the
    camera and every shape's box): its light density, squared by MIS in float32, stays finite."""
    points = [camera.position[None, :]]
    for shape in (s for g in groups for s in g):
        points.append(corners(shape))
    pts = np.concatenate(points)
    extent2 = float(np.sum((pts.max(axis=0) - pts.min(axis=0)) ** 2))
    least = fields.EMITTER_AREA_SHARE * extent2
    for i, group in enumerate(groups):
        for s in group:
            if not materials[s.material].emissive:
                continue
            area = s.area()
            if not area >= least:
                key = ("transform" if "transform" in entries[i] else
                       {"quad": "edge_v", "sphere": "radius", "box": "max"}.get(entries[i]["kind"], "kind"))
                raise InputError(f"shapes[{i}].{key}",
                                 f"an emitting shape needs an area of at least {least:.3g} (the scene's "
                                 f"extent squared, {extent2:.3g}, x {fields.EMITTER_AREA_SHARE:.2g}: "
                                 "its light density is squared in float32), got area "
                                 f"{area:.3g}; make it larger or use a point light")


def corners(shape: Shape) -> np.ndarray:
    """Points whose box holds the shape (its defining points)."""
    if shape.kind == "sphere":
        return np.stack([shape.center - shape.radius, shape.center + shape.radius])
    if shape.kind == "mesh":
        return shape.mesh.vertices
    o, u, v = shape.origin, shape.edge_u, shape.edge_v
    return np.stack([o, o + u, o + v, o + u + v])
