"""Plausibility checks of a valid scene that still renders nothing useful; each finding is one line.

A quad emits only on the side of normalize(edge_u x edge_v): writing the edges in the other order is
the easy mistake, and it leaves the light shining at nothing."""
from __future__ import annotations

import numpy as np

from drtlab.kernels.scene_model.scene import Scene, Shape


def _corners(shape: Shape) -> np.ndarray:
    o, u, v = shape.origin, shape.edge_u, shape.edge_v
    return np.array([o, o + u, o + v, o + u + v])


def _reaches_front(shape: Shape, origin: np.ndarray, normal: np.ndarray) -> bool:
    """Whether some part of `shape` lies strictly in front of the plane (origin, normal)."""
    if shape.kind == "sphere":
        return float(np.dot(shape.center - origin, normal)) + shape.radius > 0.0
    points = shape.mesh.vertices if shape.kind == "mesh" else _corners(shape)
    heights = (points - origin) @ normal
    scale = max(float(np.abs(points - origin).max()), 1e-30)
    return bool(np.any(heights > 1e-9 * scale))


def emitters_facing_nothing(scene: Scene) -> list[str]:
    """Emitting quads whose lit side faces away from every other shape."""
    found = []
    for i in scene.emitter_shapes():
        shape = scene.shapes[i]
        if shape.kind != "quad" or len(scene.shapes) < 2:
            continue
        n = np.cross(shape.edge_u, shape.edge_v)
        n = n / np.linalg.norm(n)
        others = [s for j, s in enumerate(scene.shapes) if j != i]
        if not any(_reaches_front(s, shape.origin, n) for s in others):
            found.append(f"emitter '{shape.name}' emits towards {np.round(n, 3).tolist()} "
                         "(normalize(edge_u x edge_v)), where no other shape is; swap edge_u and "
                         "edge_v to light the scene")
    return found


def tessellated_disks(scene: Scene) -> list[str]:
    """A line for the first disk (`generate = "disk"`, Mitsuba's disk) and the first cylinder: a
    triangle fan or tube, whose area and outline are the circle's only to a bound."""
    from drtlab.kernels.scene_model.procedural import cylinder_area_deficit, disk_area_deficit
    lines = []
    for kind, segments_of, deficit in (("disk", len, disk_area_deficit),
                                       ("cylinder", lambda f: len(f) // 2, cylinder_area_deficit)):
        found = [s for s in scene.shapes if s.kind == "mesh" and s.mesh.source.startswith(f"{kind}(")]
        if not found:
            continue
        n = segments_of(found[0].mesh.faces)
        more = f" (and {len(found) - 1} more {kind}s)" if len(found) > 1 else ""
        lines.append(f"{kind} '{found[0].name}'{more} is tessellated into {len(found[0].mesh.faces)} "
                     f"triangles: its area is the {'circle' if kind == 'disk' else 'cylinder'}'s to "
                     f"{deficit(n):.1e} (relative, smaller)")
    return lines


def scene_warnings(scene: Scene) -> list[str]:
    """Findings about a scene before it renders: shapes that move while the shutter is closed (the
    default [0, 0]), which render the static image a user who set a velocity does not expect; a
    disk rendered as a triangle fan."""
    moving = [s.name for s in scene.shapes if np.any(s.velocity != 0.0)]
    open_, close = scene.camera.shutter
    if moving and not close > open_:
        return tessellated_disks(scene) + [f"shape '{moving[0]}'{f' and {len(moving) - 1} more' if len(moving) > 1 else ''} "
                f"has a velocity but camera.shutter = [{open_:g}, {close:g}] is closed, so nothing "
                "moves; set camera.shutter = [0.0, 1.0] for motion blur"]
    return tessellated_disks(scene)


def image_warnings(scene: Scene, image: np.ndarray) -> list[str]:
    """Findings about a rendered image, one line in all: an emitter facing nothing (which explains a
    black image), else an image that is zero everywhere."""
    found = emitters_facing_nothing(scene)[:1]
    if not found and not np.any(image):
        found.append("the image is zero everywhere: the camera sees no light (lights enclosed, "
                     "facing away, or the camera looking at nothing)")
    return found
