"""Scene intersection per kernel variant: shapes at a shutter offset, nearest hit, shadow-ray visibility.

`make_motion(motion)` returns sphere_center(sd, i, dt) and quad_origin(sd, i, dt);
`make_intersect(features)` returns intersect(sd, o, d, tmax, dt) -> Hit and
visible(sd, o, d, dist, dt, target_kind, target_index) -> 1 or 0. Absent shape kinds are compiled
out; motion is a runtime switch (SceneData.moving).

Quads are tested as the groups of kernels/accel.py in index order: a single quad by its plane test
(geometry.hit_quad_nw), a box (three to six faces of one parallelepiped) by one slab test
(geometry.slab_hit), skipped when the ray misses a ball around a closed box. `visible` answers what
intersect() would (is the first hit the light's own shape?) but stops at the first occluder.
"""
from types import SimpleNamespace

import warp as wp

from drtlab.estimators.warps import INV_PI
from drtlab.kernels.device_scene import QUAD, SPHERE, SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.geometry import (Hit, hit_quad_nw, hit_sphere, may_hit_ball, quad_params_w,
                                    slab_hit)
from drtlab.kernels.materials import checkered


def make_motion(motion: bool) -> SimpleNamespace:
    """Shape positions at shutter offset dt. Compiled in (motion=True), shapes move when the scene
    does (SceneData.moving, a branch per shape: static and moving scenes share a variant);
    compiled out, the velocity is never read."""

    @wp.func
    def sphere_center(sd: SceneData, i: int, dt: float) -> wp.vec3:
        c = sd.sph_center[i]
        if wp.static(motion):
            if sd.moving == 1:
                c = c + sd.sph_velocity[i] * dt
        return c

    @wp.func
    def quad_origin(sd: SceneData, i: int, dt: float) -> wp.vec3:
        q0 = sd.quad_origin[i]
        if wp.static(motion):
            if sd.moving == 1:
                q0 = q0 + sd.quad_velocity[i] * dt
        return q0

    return SimpleNamespace(sphere_center=sphere_center, quad_origin=quad_origin)


@wp.struct
class GroupHit:
    t: float
    quad: int           # the quad hit (a box's face), -1 none


def make_intersect(f: Features) -> SimpleNamespace:
    HAS_SPH = f.spheres
    HAS_QUAD = f.quads
    motion_funcs = make_motion(True)
    sphere_center = motion_funcs.sphere_center
    quad_origin = motion_funcs.quad_origin

    @wp.func
    def group_hit(sd: SceneData, g: int, o: wp.vec3, d: wp.vec3, tmax: float,
                  dt: float) -> GroupHit:
        """Nearest hit in (0, tmax) of quad group g: a single quad's plane test, or a box's slab
        test."""
        r = GroupHit()
        r.quad = -1
        r.t = tmax
        q = sd.qgroup_quad[g]
        if q >= 0:
            rec = sd.quad_geom[q]
            q0 = rec.origin
            if sd.moving == 1:
                q0 = q0 + sd.quad_velocity[q] * dt
            r.t = hit_quad_nw(o, d, q0, rec.edge_u, rec.edge_v, rec.cross, rec.basis, tmax)
            if r.t < tmax:
                r.quad = q
        else:
            c = sd.qgroup_corner[g]
            ball = sd.qgroup_ball[g]
            if sd.moving == 1:
                shift = sd.qgroup_velocity[g] * dt
                c = c + shift
                ball = ball + wp.vec4(shift[0], shift[1], shift[2], 0.0)
            if ball[3] < 0.0 or may_hit_ball(o, d, ball, tmax) == 1:
                # The ray in the box's coordinates, where it is [0, 1]^3 (see geometry.hit_box):
                # an axis-aligned box's diagonal inverse in a third of the multiplications.
                inv = sd.qgroup_inverse[g]
                lo = o - c
                ld = d
                if sd.qgroup_aligned[g] == 1:
                    scale = wp.vec3(inv[0, 0], inv[1, 1], inv[2, 2])
                    lo = wp.cw_mul(lo, scale)
                    ld = wp.cw_mul(ld, scale)
                else:
                    lo = inv * lo
                    ld = inv * ld
                b = slab_hit(lo, ld, sd.qgroup_rank[g], tmax)
                if b.slot >= 0:
                    r.t = b.t
                    r.quad = sd.qgroup_faces[6 * g + b.slot]
        return r

    @wp.func
    def intersect(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> Hit:
        h = Hit()
        h.t = tmax
        h.kind = -1
        h.index = -1
        # Loops over shapes are while loops: a range() with a dynamic bound compiles to an iterator
        # that also handles negative steps, at a measurable cost per shape.
        if wp.static(HAS_SPH):
            i = int(0)
            while i < sd.n_spheres:
                c = sphere_center(sd, i, dt)
                t = hit_sphere(o, d, c, sd.sph_radius[i], h.t)
                if t < h.t:
                    h.t = t
                    h.kind = SPHERE
                    h.index = i
                i += 1
        if wp.static(HAS_QUAD):
            g = int(0)
            while g < sd.n_qgroups:
                gh = group_hit(sd, g, o, d, h.t, dt)
                if gh.quad >= 0:
                    h.t = gh.t
                    h.kind = QUAD
                    h.index = gh.quad
                g += 1
        if h.index >= 0:
            p = o + d * h.t
            h.p = p
            if wp.static(HAS_SPH):
                if h.kind == SPHERE:
                    c = sphere_center(sd, h.index, dt)
                    n = wp.normalize(p - c)
                    h.n = n
                    h.material = sd.sph_material[h.index]
                    h.light = sd.sph_light[h.index]
                    # texture coordinates only where a material reads them
                    if checkered(sd, h.material) == 1:
                        h.uv = wp.vec2(0.5 + wp.atan2(n[2], n[0]) * (0.5 * INV_PI),
                                       wp.acos(wp.clamp(n[1], -1.0, 1.0)) * INV_PI)
            if wp.static(HAS_QUAD):
                if h.kind == QUAD:
                    h.n = sd.quad_normal[h.index]
                    h.material = sd.quad_material[h.index]
                    h.light = sd.quad_light[h.index]
                    if checkered(sd, h.material) == 1:
                        q = sd.quad_geom[h.index]
                        h.uv = quad_params_w(p - quad_origin(sd, h.index, dt), q.edge_u, q.edge_v,
                                             q.basis)
        return h

    @wp.func
    def occluded(sd: SceneData, o: wp.vec3, d: wp.vec3, limit: float, dt: float,
                 target_kind: int, target_index: int, target_group: int, t_target: float) -> int:
        """1 when a shape other than the target would be intersect()'s answer before the target:
        one hit before t_target (the target's own distance; `limit` when the target is missed or
        there is none), or at exactly t_target by a shape the closest-hit scan meets first
        (spheres before quad groups, lower index first). Stops at the first such shape."""
        tie = t_target < limit
        if wp.static(HAS_SPH):
            i = int(0)
            while i < sd.n_spheres:
                if not (target_kind == SPHERE and i == target_index):
                    before = target_kind == QUAD or i < target_index
                    t = hit_sphere(o, d, sphere_center(sd, i, dt), sd.sph_radius[i], limit)
                    if t < t_target or (tie and before and t == t_target):
                        return 1
                i += 1
        if wp.static(HAS_QUAD):
            g = int(0)
            while g < sd.n_qgroups:
                if g != target_group:
                    gh = group_hit(sd, g, o, d, limit, dt)
                    if gh.quad >= 0:
                        before = target_kind == QUAD and g < target_group
                        if gh.t < t_target or (tie and before and gh.t == t_target):
                            return 1
                g += 1
        return 0

    @wp.func
    def visible(sd: SceneData, o: wp.vec3, d: wp.vec3, dist: float, dt: float,
                target_kind: int, target_index: int) -> int:
        # A light point is visible when nothing is hit before it, or the first hit is the light's
        # own shape (robust against the shadow ray stopping a hair short of or past the point):
        # exactly what intersect() would decide, without finding the closest hit.
        if target_index < 0:
            limit = dist * (1.0 - 1.0e-4)
            return 1 - occluded(sd, o, d, limit, dt, -1, -1, -1, limit)
        limit = dist * (1.0 + 1.0e-3) + sd.eps
        t_target = limit
        target_group = int(-1)
        if wp.static(HAS_SPH):
            if target_kind == SPHERE:
                t_target = hit_sphere(o, d, sphere_center(sd, target_index, dt),
                                      sd.sph_radius[target_index], limit)
        if wp.static(HAS_QUAD):
            if target_kind == QUAD:
                target_group = sd.quad_group[target_index]
                gh = group_hit(sd, target_group, o, d, limit, dt)
                if gh.quad >= 0:
                    if gh.quad != target_index:
                        return 0        # another face of the target's box comes first
                    t_target = gh.t
        return 1 - occluded(sd, o, d, limit, dt, target_kind, target_index, target_group,
                            t_target)

    return SimpleNamespace(intersect=intersect, visible=visible)
