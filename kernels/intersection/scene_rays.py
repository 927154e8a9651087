"""Scene intersection per kernel variant: nearest hit and shadow-ray visibility at a shutter offset.

`make_intersect(features, motion=motion)` (motion from intersection/motion.py) returns SceneRays:
intersect(sd, o, d, tmax, dt) -> Hit, visible(sd, o, d, dist, dt, target_kind, target_index) -> 1
or 0, and visible_mesh. Absent shape kinds are compiled out; motion is a runtime switch
(SceneData.moving).

Spheres are a loop over all of them, or, in scenes with many (Features.sphere_bvh), the candidates
a walk of the BVH of their boxes finds, ties broken towards the lower index as the loop does.
Triangle meshes (Features.meshes) are one BVH walk per mesh with a watertight triangle test
(kernels/intersection/bvh_traversal.py), in the mesh's frame at the ray's time (the whole mesh translates, so the ray
moves by -v dt instead), after spheres and quads; a mesh hit's shading normal is interpolated from
its vertex normals.

On the CPU (Features.quad_simd) lone quads and open boxes' faces are lanes of one vector plane test
(kernels/intersection/quad_simd.py; quad_records.vector_lanes), after the closed boxes' slab tests:
the nearest, a box on a tie, then the lowest quad index; `visible` towards a lane asks whether the
nearest lane is the target. Otherwise (CUDA, or too few or too many lanes) all
quads are tested as the groups of kernels/intersection/quad_records.py in index order: a single quad by its plane test
(geometry.hit_quad_nw), a box (three to six faces of one parallelepiped) by one slab test
(geometry.slab_hit), skipped when the ray misses a ball around a closed box. `visible` answers what
intersect() would (is the first hit the light's own shape?) but stops at the first occluder.
"""
from typing import NamedTuple

import warp as wp

from drtlab.estimators.domain_maps import INV_PI
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.intersection.primitives import (Hit, hit_quad_nw, hit_sphere, may_hit_ball, quad_params_w,
                                    slab_hit)
from drtlab.kernels.materials import checkered
from drtlab.kernels.intersection.bvh_traversal import (MeshRays, SphereBvh, make_mesh_rays,
                                                      make_sphere_bvh, mesh_shading_normal,
                                                      ray_shear)
from drtlab.kernels.intersection.motion import Motion
from drtlab.kernels.intersection.quad_simd import quads_nearest


@wp.struct
class GroupHit:
    t: float
    quad: int           # the quad hit (a box's face), -1 none


@wp.func
def group_hit(sd: SceneData, g: int, o: wp.vec3, d: wp.vec3, tmax: float,
              dt: float) -> GroupHit:
    """Nearest hit in (0, tmax) of quad group g: a single quad's plane test, or a box's slab
    test."""
    r = GroupHit()
    r.quad = -1
    r.t = tmax
    q = sd.quad_groups.quad[g]
    if q >= 0:
        rec = sd.quads.geom[q]
        q0 = rec.origin
        if sd.moving == 1:
            q0 = q0 + sd.quads.velocity[q] * dt
        r.t = hit_quad_nw(o, d, q0, rec.edge_u, rec.edge_v, rec.cross, rec.basis, tmax)
        if r.t < tmax:
            r.quad = q
    else:
        c = sd.quad_groups.corner[g]
        ball = sd.quad_groups.ball[g]
        if sd.moving == 1:
            shift = sd.quad_groups.velocity[g] * dt
            c = c + shift
            ball = ball + wp.vec4(shift[0], shift[1], shift[2], 0.0)
        if ball[3] < 0.0 or may_hit_ball(o, d, ball, tmax) == 1:
            # The ray in the box's coordinates, where it is [0, 1]^3 (see geometry.hit_box):
            # an axis-aligned box's diagonal inverse in a third of the multiplications.
            inv = sd.quad_groups.inverse[g]
            lo = o - c
            ld = d
            if sd.quad_groups.aligned[g] == 1:
                scale = wp.vec3(inv[0, 0], inv[1, 1], inv[2, 2])
                lo = wp.cw_mul(lo, scale)
                ld = wp.cw_mul(ld, scale)
            else:
                lo = inv * lo
                ld = inv * ld
            b = slab_hit(lo, ld, sd.quad_groups.rank[g], tmax)
            if b.slot >= 0:
                r.t = b.t
                r.quad = sd.quad_groups.faces[6 * g + b.slot]
    return r


def _make_group_scan(quad_simd: bool):
    """(count(sd), group(sd, k)): the groups a quad scan walks in order: all of them, or with the
    vector test (Features.quad_simd) only the closed boxes, the lanes coming after."""
    @wp.func
    def scanned_groups(sd: SceneData) -> int:
        if wp.static(quad_simd):
            return sd.quad_groups.n_box
        return sd.quad_groups.count

    @wp.func
    def scanned_group(sd: SceneData, k: int) -> int:
        if wp.static(quad_simd):
            return sd.quad_groups.box[k]
        return k

    return scanned_groups, scanned_group


class SceneRays(NamedTuple):
    intersect: wp.Function      # (sd, o, d, tmax, dt) -> Hit, the nearest in (0, tmax)
    visible: wp.Function        # (sd, o, d, dist, dt, target_kind, target_index) -> 1 or 0
    visible_mesh: wp.Function   # (sd, o, d, dist, dt, k) -> 1 or 0, towards a point in mesh k


def make_intersect(f: Features, *, motion: Motion) -> SceneRays:
    mesh_rays = make_mesh_rays(motion=motion)
    sphere_bvh = make_sphere_bvh(motion=motion)
    intersect = _make_nearest(f, motion, mesh_rays, sphere_bvh)
    occluded = _make_occluded(f, motion, mesh_rays, sphere_bvh)
    visible, visible_mesh = _make_visible(f, motion, mesh_rays, occluded)
    return SceneRays(intersect=intersect, visible=visible, visible_mesh=visible_mesh)


def _make_nearest(f: Features, motion: Motion, mesh_rays: MeshRays, sphere_bvh: SphereBvh):
    HAS_SPH, HAS_QUAD, HAS_MESH, SPH_BVH = f.spheres, f.quads, f.meshes, f.sphere_bvh
    QUAD_SIMD = f.quad_simd
    TEXTURES = f.textures
    scanned_groups, scanned_group = _make_group_scan(QUAD_SIMD)
    sphere_center, quad_origin = motion.sphere_center, motion.quad_origin
    nearest_mesh, bvh_nearest_sphere = mesh_rays.nearest_mesh, sphere_bvh.bvh_nearest_sphere

    @wp.func
    def intersect(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> Hit:
        h = Hit()
        h.t = tmax
        h.kind = -1
        h.index = -1
        # Loops over shapes are while loops: a range() with a dynamic bound compiles to an iterator
        # that also handles negative steps, at a measurable cost per shape.
        if wp.static(HAS_SPH):
            if wp.static(SPH_BVH):
                sh = bvh_nearest_sphere(sd, o, d, h.t, dt)
                if sh.index >= 0:
                    h.t = sh.t
                    h.kind = SPHERE
                    h.index = sh.index
            else:
                i = int(0)
                while i < sd.spheres.count:
                    c = sphere_center(sd, i, dt)
                    t = hit_sphere(o, d, c, sd.spheres.radius[i], h.t)
                    if t < h.t:
                        h.t = t
                        h.kind = SPHERE
                        h.index = i
                    i += 1
        if wp.static(HAS_QUAD):
            # Every group in order; with the vector test only the closed boxes, then the lanes
            # (a tie goes to a box).
            k = int(0)
            while k < scanned_groups(sd):
                g = scanned_group(sd, k)
                gh = group_hit(sd, g, o, d, h.t, dt)
                if gh.quad >= 0:
                    h.t = gh.t
                    h.kind = QUAD
                    h.index = gh.quad
                k += 1
            if wp.static(QUAD_SIMD):
                qh = quads_nearest(sd.quads.pack, sd.quads.blocks, o, d, h.t, sd.moving, dt)
                if qh[1] >= 0.0:
                    h.t = qh[0]
                    h.kind = QUAD
                    h.index = int(qh[1])
        if wp.static(HAS_MESH):
            mh = nearest_mesh(sd, o, d, h.t, dt)
            if mh.mesh >= 0:
                h.t = mh.t
                h.kind = MESH
                h.index = sd.meshes.face0[mh.mesh] + mh.face
                h.n = mh.n
                h.ns = mesh_shading_normal(sd, mh)
                h.material = sd.meshes.material[mh.mesh]
                h.light = sd.meshes.light[mh.mesh]
                h.uv = wp.vec2(mh.u, mh.v)      # a checker on a mesh: by barycentric coordinates
                if wp.static(TEXTURES):
                    if sd.materials.textured[h.material] == 1:   # a texture: the file's coordinates
                        idx = sd.meshes.tri_index[h.index]
                        h.uv = (sd.meshes.vert_uv[idx[0]] * mh.u + sd.meshes.vert_uv[idx[1]] * mh.v
                                + sd.meshes.vert_uv[idx[2]] * (1.0 - mh.u - mh.v))
        if h.index >= 0:
            p = o + d * h.t
            h.p = p
            if wp.static(HAS_SPH):
                if h.kind == SPHERE:
                    c = sphere_center(sd, h.index, dt)
                    n = wp.normalize(p - c)
                    h.n = n
                    h.material = sd.spheres.material[h.index]
                    h.light = sd.spheres.light[h.index]
                    # texture coordinates only where a material reads them
                    reads_uv = checkered(sd, h.material)
                    if wp.static(TEXTURES):
                        if sd.materials.textured[h.material] == 1:
                            reads_uv = 1
                    if reads_uv == 1:
                        h.uv = wp.vec2(0.5 + wp.atan2(n[2], n[0]) * (0.5 * INV_PI),
                                       wp.acos(wp.clamp(n[1], -1.0, 1.0)) * INV_PI)
            if wp.static(HAS_QUAD):
                if h.kind == QUAD:
                    h.n = sd.quads.normal[h.index]
                    h.material = sd.quads.material[h.index]
                    h.light = sd.quads.light[h.index]
                    reads_uv = checkered(sd, h.material)
                    if wp.static(TEXTURES):
                        if sd.materials.textured[h.material] == 1:
                            reads_uv = 1
                    if reads_uv == 1:
                        q = sd.quads.geom[h.index]
                        h.uv = quad_params_w(p - quad_origin(sd, h.index, dt), q.edge_u, q.edge_v,
                                             q.basis)
            if wp.static(HAS_MESH):
                if h.kind != MESH:
                    h.ns = h.n
        return h

    return intersect


def _make_occluded(f: Features, motion: Motion, mesh_rays: MeshRays, sphere_bvh: SphereBvh):
    HAS_SPH = f.spheres
    HAS_QUAD = f.quads
    HAS_MESH = f.meshes
    SPH_BVH = f.sphere_bvh
    QUAD_SIMD = f.quad_simd
    scanned_groups, scanned_group = _make_group_scan(QUAD_SIMD)
    sphere_center = motion.sphere_center
    meshes_occlude = mesh_rays.meshes_occlude
    bvh_spheres_occlude = sphere_bvh.bvh_spheres_occlude

    @wp.func
    def occluded(sd: SceneData, o: wp.vec3, d: wp.vec3, limit: float, dt: float,
                 target_kind: int, target_index: int, target_group: int, t_target: float) -> int:
        """1 when a shape other than the target would be intersect()'s answer before the target:
        one hit before t_target (the target's own distance; `limit` when the target is missed or
        there is none), or at exactly t_target by a shape the closest-hit scan meets first
        (spheres before quad groups before meshes, lower index first). Stops at the first such
        shape. A mesh target's own mesh was tested by visible()."""
        tie = t_target < limit
        if wp.static(HAS_SPH):
            if wp.static(SPH_BVH):
                if bvh_spheres_occlude(sd, o, d, limit, dt, target_kind, target_index, tie,
                                       t_target) == 1:
                    return 1
            else:
                i = int(0)
                while i < sd.spheres.count:
                    if not (target_kind == SPHERE and i == target_index):
                        before = target_kind == QUAD or i < target_index
                        if wp.static(HAS_MESH):
                            before = before or target_kind == MESH
                        t = hit_sphere(o, d, sphere_center(sd, i, dt), sd.spheres.radius[i], limit)
                        if t < t_target or (tie and before and t == t_target):
                            return 1
                    i += 1
        if wp.static(HAS_QUAD):
            # Every group but the target's in order; with the vector test only the closed boxes,
            # then the lanes. A target among the lanes (a quad without a group here) was settled
            # against them by visible(): the nearest lane is the target.
            lane_target = target_kind == QUAD and target_group < 0
            k = int(0)
            while k < scanned_groups(sd):
                g = scanned_group(sd, k)
                if g != target_group:
                    gh = group_hit(sd, g, o, d, limit, dt)
                    if gh.quad >= 0:
                        before = lane_target or (target_kind == QUAD and g < target_group)
                        if wp.static(HAS_MESH):
                            before = before or target_kind == MESH
                        if gh.t < t_target or (tie and before and gh.t == t_target):
                            return 1
                k += 1
            if wp.static(QUAD_SIMD):
                if not lane_target:
                    qh = quads_nearest(sd.quads.pack, sd.quads.blocks, o, d, limit, sd.moving, dt)
                    if qh[1] >= 0.0:
                        before = False
                        if wp.static(HAS_MESH):
                            before = target_kind == MESH
                        if qh[0] < t_target or (tie and before and qh[0] == t_target):
                            return 1
        if wp.static(HAS_MESH):
            skip = int(-1)
            if target_kind == MESH:
                skip = sd.meshes.tri_mesh[target_index]
            if meshes_occlude(sd, o, d, t_target, dt, skip) == 1:
                return 1
        return 0

    return occluded


def _make_visible(f: Features, motion: Motion, mesh_rays: MeshRays, occluded) -> tuple:
    HAS_SPH = f.spheres
    HAS_QUAD = f.quads
    HAS_MESH = f.meshes
    QUAD_SIMD = f.quad_simd
    sphere_center = motion.sphere_center
    mesh_target = mesh_rays.mesh_target
    nearest_in_mesh = mesh_rays.nearest_in_mesh

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
                                      sd.spheres.radius[target_index], limit)
        if wp.static(HAS_QUAD):
            if target_kind == QUAD:
                in_lanes = False
                if wp.static(QUAD_SIMD):
                    in_lanes = sd.quads.lane[target_index] == 1
                if in_lanes:
                    qh = quads_nearest(sd.quads.pack, sd.quads.blocks, o, d, limit, sd.moving, dt)
                    if qh[1] >= 0.0:
                        if int(qh[1]) != target_index:
                            return 0    # another lane comes first (or as near, and earlier)
                        t_target = qh[0]
                else:
                    target_group = sd.quads.group[target_index]
                    gh = group_hit(sd, target_group, o, d, limit, dt)
                    if gh.quad >= 0:
                        if gh.quad != target_index:
                            return 0    # another face of the target's box comes first
                        t_target = gh.t
        if wp.static(HAS_MESH):
            if target_kind == MESH:     # target_index: the face the light sample lies on
                t_target = mesh_target(sd, o, d, dist, limit, dt, target_index)
                if t_target < 0.0:
                    return 0            # another part of the emitting mesh comes first
        return 1 - occluded(sd, o, d, limit, dt, target_kind, target_index, target_group,
                            t_target)

    @wp.func
    def visible_mesh(sd: SceneData, o: wp.vec3, d: wp.vec3, dist: float, dt: float,
                     k: int) -> int:
        """visible() towards a point at `dist` inside or on mesh k, any face of which may be the
        first hit (Whitted's shadow ray to a mesh light's centroid)."""
        limit = dist * (1.0 + 1.0e-3) + sd.eps
        t_target = limit
        if wp.static(HAS_MESH):
            mh = nearest_in_mesh(sd, k, o, ray_shear(d), d, limit, dt)
            if mh.mesh >= 0:
                t_target = mh.t
        return 1 - occluded(sd, o, d, limit, dt, MESH, sd.meshes.face0[k], -1, t_target)

    return visible, visible_mesh
