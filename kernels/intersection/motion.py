"""Shape positions at a shutter offset dt, for every query that finds or samples a shape.

`make_motion(moving)` is built once per kernel and handed to the factories that compose it (the ray
queries of scene_rays.py and bvh_traversal.py, the light sampling of kernels/lights.py), so that a
kernel holds one copy of these functions.
"""
from typing import NamedTuple

import warp as wp

from drtlab.kernels.device_scene import SceneData


class Motion(NamedTuple):
    sphere_center: wp.Function      # (sd, i, dt) -> sphere i's centre
    quad_origin: wp.Function        # (sd, i, dt) -> quad i's corner
    mesh_shift: wp.Function         # (sd, k, dt) -> how far mesh k has moved since shutter open


def make_motion(moving: bool = True) -> Motion:
    """Compiled in (moving=True, what every render kernel does), shapes move when the scene does
    (SceneData.moving, a branch per shape: static and moving scenes share a variant); compiled out
    (the chi-square adapters, which sample at shutter open), the velocity is never read."""

    @wp.func
    def sphere_center(sd: SceneData, i: int, dt: float) -> wp.vec3:
        c = sd.spheres.center[i]
        if wp.static(moving):
            if sd.moving == 1:
                c = c + sd.spheres.velocity[i] * dt
        return c

    @wp.func
    def quad_origin(sd: SceneData, i: int, dt: float) -> wp.vec3:
        q0 = sd.quads.origin[i]
        if wp.static(moving):
            if sd.moving == 1:
                q0 = q0 + sd.quads.velocity[i] * dt
        return q0

    @wp.func
    def mesh_shift(sd: SceneData, k: int, dt: float) -> wp.vec3:
        """How far mesh k has moved since shutter open (its rays move back by as much)."""
        s = wp.vec3(0.0)
        if wp.static(moving):
            if sd.moving == 1:
                s = sd.meshes.velocity[k] * dt
        return s

    return Motion(sphere_center=sphere_center, quad_origin=quad_origin, mesh_shift=mesh_shift)
