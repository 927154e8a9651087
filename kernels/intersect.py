"""Scene intersection per kernel variant: shapes at a shutter offset, nearest hit, shadow-ray visibility.

`make_motion(motion)` returns sphere_center(sd, i, dt) and quad_origin(sd, i, dt);
`make_intersect(features)` returns intersect(sd, o, d, tmax, dt) -> Hit and
visible(sd, o, d, dist, dt, target_kind, target_index) -> 1 or 0. Absent shape kinds and motion are
compiled out.
"""
from types import SimpleNamespace

import warp as wp

from drtlab.estimators.warps import INV_PI
from drtlab.kernels.device_scene import QUAD, SPHERE, SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.geometry import Hit, hit_quad, hit_sphere, quad_params


def make_motion(motion: bool) -> SimpleNamespace:
    """Shape positions at shutter offset dt; without motion the velocity is never read."""

    @wp.func
    def sphere_center(sd: SceneData, i: int, dt: float) -> wp.vec3:
        c = sd.sph_center[i]
        if wp.static(motion):
            c = c + sd.sph_velocity[i] * dt
        return c

    @wp.func
    def quad_origin(sd: SceneData, i: int, dt: float) -> wp.vec3:
        q0 = sd.quad_origin[i]
        if wp.static(motion):
            q0 = q0 + sd.quad_velocity[i] * dt
        return q0

    return SimpleNamespace(sphere_center=sphere_center, quad_origin=quad_origin)


def make_intersect(f: Features) -> SimpleNamespace:
    HAS_SPH = f.spheres
    HAS_QUAD = f.quads
    motion_funcs = make_motion(f.motion)
    sphere_center = motion_funcs.sphere_center
    quad_origin = motion_funcs.quad_origin

    @wp.func
    def intersect(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> Hit:
        h = Hit()
        h.t = tmax
        h.kind = -1
        h.index = -1
        if wp.static(HAS_SPH):
            for i in range(sd.n_spheres):
                c = sphere_center(sd, i, dt)
                t = hit_sphere(o, d, c, sd.sph_radius[i], h.t)
                if t < h.t:
                    h.t = t
                    h.kind = SPHERE
                    h.index = i
        if wp.static(HAS_QUAD):
            for i in range(sd.n_quads):
                q0 = quad_origin(sd, i, dt)
                t = hit_quad(o, d, q0, sd.quad_u[i], sd.quad_v[i], h.t)
                if t < h.t:
                    h.t = t
                    h.kind = QUAD
                    h.index = i
        if h.index >= 0:
            p = o + d * h.t
            h.p = p
            if wp.static(HAS_SPH):
                if h.kind == SPHERE:
                    c = sphere_center(sd, h.index, dt)
                    n = wp.normalize(p - c)
                    h.n = n
                    h.uv = wp.vec2(0.5 + wp.atan2(n[2], n[0]) * (0.5 * INV_PI),
                                   wp.acos(wp.clamp(n[1], -1.0, 1.0)) * INV_PI)
                    h.material = sd.sph_material[h.index]
                    h.light = sd.sph_light[h.index]
            if wp.static(HAS_QUAD):
                if h.kind == QUAD:
                    q0 = quad_origin(sd, h.index, dt)
                    h.n = sd.quad_normal[h.index]
                    h.uv = quad_params(p - q0, sd.quad_u[h.index], sd.quad_v[h.index])
                    h.material = sd.quad_material[h.index]
                    h.light = sd.quad_light[h.index]
        return h

    @wp.func
    def visible(sd: SceneData, o: wp.vec3, d: wp.vec3, dist: float, dt: float,
                target_kind: int, target_index: int) -> int:
        # A light point is visible when nothing is hit before it, or the first hit is the light's
        # own shape (robust against the shadow ray stopping a hair short of or past the point).
        if target_index < 0:
            h = intersect(sd, o, d, dist * (1.0 - 1.0e-4), dt)
            if h.index < 0:
                return 1
            return 0
        h = intersect(sd, o, d, dist * (1.0 + 1.0e-3) + sd.eps, dt)
        if h.index < 0:
            return 1
        if h.kind == target_kind and h.index == target_index:
            return 1
        return 0

    return SimpleNamespace(intersect=intersect, visible=visible)
