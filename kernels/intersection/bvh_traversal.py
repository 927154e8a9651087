"""Ray queries of the accelerated primitives, for kernels/intersection/scene_rays.py: triangle meshes and many
spheres, each through a wp.Bvh of padded boxes (kernels/intersection/bvh_build.py builds them, and says why not
wp.Mesh), walked by bvh_query_capsule of radius 0 (Warp's robust slab test, closed at max_dist).

`hit_triangle(o, shear, a, b, c, tmax)` is Woop, Benthin & Wald's watertight ray-triangle test
(JCGT 2013): the ray's dominant axis becomes z, the triangle is sheared into the ray's frame and
three 2D edge functions decide. Each edge function is the difference of two products of float32
values, which float64 holds exactly, so an edge shared by two triangles gets exactly opposite values
in both whatever the compiler fuses (CUDA contracts to FMA): no ray passes between triangles, at
edges or vertices. `make_mesh_rays(motion=motion)` returns MeshRays:
    nearest_in_mesh(sd, k, o, shear, d, tmax, dt) -> MeshHit   closest face of mesh k in (0, tmax)
    nearest_mesh(sd, o, d, tmax, dt) -> MeshHit                  over all meshes
    meshes_occlude(sd, o, d, t_target, dt, skip) -> 1 when a mesh other than `skip` is hit before
    mesh_target(sd, o, d, dist, limit, dt, face) -> the t at which the shadow ray meets the emitting
        mesh of `face` (limit: missed), or -1 when another part of that mesh comes first
`make_sphere_bvh(motion=motion)` returns SphereBvh:
    bvh_nearest_sphere(sd, o, d, tmax, dt) -> SphereHit   the loop's answer, ties to the lower index
    bvh_spheres_occlude(sd, o, d, limit, dt, target_kind, target_index, tie, t_target) -> 1 or 0
`mesh_shading_normal(sd, mh)` is a hit's interpolated vertex normal.

A mesh translates rigidly (c + v t like every shape), so a ray at shutter offset dt is moved into the
mesh's frame at shutter open (o - v dt) rather than the mesh refitted per sample. A hit at t <= 0 (a
ray starting on the surface) is not one, as for the other shapes (ray origins are offset).
"""
from typing import NamedTuple

import warp as wp

from drtlab.kernels.device_scene import SPHERE, SceneData
from drtlab.kernels.intersection.motion import Motion
from drtlab.kernels.intersection.primitives import hit_sphere

# A shadow ray towards a point on an emitting mesh is blocked by the same mesh when it meets another
# of its faces this much nearer than the point (a neighbour at a shared edge meets it at the same t).
SELF_OCCLUSION = wp.constant(1.0e-3)


@wp.struct
class RayShear:
    """hit_triangle's per-ray constants: axis permutation (kz the dominant one) and shear."""
    kx: int
    ky: int
    kz: int
    sx: float
    sy: float
    sz: float


@wp.struct
class TriHit:
    t: float
    u: float            # barycentric weights of the first and second vertex
    v: float
    ok: int


@wp.struct
class MeshHit:
    t: float
    mesh: int           # -1 none
    face: int           # within the mesh
    u: float            # barycentric weights of the face's first and second vertex
    v: float
    n: wp.vec3          # unit (b - a) x (c - a)


@wp.struct
class SphereHit:
    t: float
    index: int          # -1 none


@wp.func
def ray_shear(d: wp.vec3) -> RayShear:
    s = RayShear()
    s.kz = 0
    if wp.abs(d[1]) > wp.abs(d[s.kz]):
        s.kz = 1
    if wp.abs(d[2]) > wp.abs(d[s.kz]):
        s.kz = 2
    s.kx = (s.kz + 1) % 3
    s.ky = (s.kx + 1) % 3
    if d[s.kz] < 0.0:               # keep the winding: a mirrored frame swaps x and y
        tmp = s.kx
        s.kx = s.ky
        s.ky = tmp
    s.sx = d[s.kx] / d[s.kz]
    s.sy = d[s.ky] / d[s.kz]
    s.sz = 1.0 / d[s.kz]
    return s


@wp.func
def edge_function(ax: float, ay: float, bx: float, by: float) -> wp.float64:
    """ax by - ay bx, exact products in float64 (module doc): antisymmetric in (a, b)."""
    return wp.float64(ax) * wp.float64(by) - wp.float64(ay) * wp.float64(bx)


@wp.func
def hit_triangle(o: wp.vec3, s: RayShear, a: wp.vec3, b: wp.vec3, c: wp.vec3,
                 tmax: float) -> TriHit:
    r = TriHit()
    r.ok = 0
    A = a - o
    B = b - o
    C = c - o
    ax = A[s.kx] - s.sx * A[s.kz]
    ay = A[s.ky] - s.sy * A[s.kz]
    bx = B[s.kx] - s.sx * B[s.kz]
    by = B[s.ky] - s.sy * B[s.kz]
    cx = C[s.kx] - s.sx * C[s.kz]
    cy = C[s.ky] - s.sy * C[s.kz]
    zero = wp.float64(0.0)
    u = edge_function(cx, cy, bx, by)       # opposite a
    v = edge_function(ax, ay, cx, cy)       # opposite b
    w = edge_function(bx, by, ax, ay)       # opposite c
    if (u < zero or v < zero or w < zero) and (u > zero or v > zero or w > zero):
        return r
    det = u + v + w
    if det == zero:
        return r
    T = (u * wp.float64(s.sz * A[s.kz]) + v * wp.float64(s.sz * B[s.kz])
         + w * wp.float64(s.sz * C[s.kz]))
    t = float(T / det)
    if t > 0.0 and t < tmax:
        r.t = t
        r.u = float(u / det)
        r.v = float(v / det)
        r.ok = 1
    return r


@wp.func
def mesh_shading_normal(sd: SceneData, mh: MeshHit) -> wp.vec3:
    """The vertex normals interpolated at the hit and turned to the geometric normal's side (files
    may wind their triangles against their normals), or the geometric normal of a flat mesh."""
    ns = mh.n
    k = mh.mesh
    if sd.meshes.smooth[k] == 1:
        idx = sd.meshes.tri_index[sd.meshes.face0[k] + mh.face]
        s = (sd.meshes.vert_normal[idx[0]] * mh.u + sd.meshes.vert_normal[idx[1]] * mh.v
             + sd.meshes.vert_normal[idx[2]] * (1.0 - mh.u - mh.v))
        length = wp.length(s)
        if length > 0.0:
            ns = s / length
            if wp.dot(ns, mh.n) < 0.0:
                ns = -ns
    return ns


class MeshRays(NamedTuple):
    nearest_in_mesh: wp.Function
    nearest_mesh: wp.Function
    meshes_occlude: wp.Function
    mesh_target: wp.Function


class SphereBvh(NamedTuple):
    bvh_nearest_sphere: wp.Function
    bvh_spheres_occlude: wp.Function


def make_mesh_rays(*, motion: Motion) -> MeshRays:
    mesh_shift = motion.mesh_shift
    @wp.func
    def nearest_in_mesh(sd: SceneData, k: int, o: wp.vec3, shear: RayShear, d: wp.vec3,
                        tmax: float, dt: float) -> MeshHit:
        r = MeshHit()
        r.t = tmax
        r.mesh = -1
        ok = o - mesh_shift(sd, k, dt)
        f0 = sd.meshes.face0[k]
        query = wp.bvh_query_capsule(sd.meshes.bvh[k], ok, d, 0.0)
        f = int(0)
        while wp.bvh_query_next(query, f, r.t):
            idx = sd.meshes.tri_index[f0 + f]
            th = hit_triangle(ok, shear, sd.meshes.points[idx[0]], sd.meshes.points[idx[1]],
                              sd.meshes.points[idx[2]], r.t)
            if th.ok == 1:
                r.t = th.t
                r.mesh = k
                r.face = f
                r.u = th.u
                r.v = th.v
        if r.mesh >= 0:
            idx = sd.meshes.tri_index[f0 + r.face]
            a = sd.meshes.points[idx[0]]
            r.n = wp.normalize(wp.cross(sd.meshes.points[idx[1]] - a, sd.meshes.points[idx[2]] - a))
        return r

    @wp.func
    def nearest_mesh(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float, dt: float) -> MeshHit:
        shear = ray_shear(d)
        best = MeshHit()
        best.t = tmax
        best.mesh = -1
        k = int(0)
        while k < sd.meshes.count:
            mh = nearest_in_mesh(sd, k, o, shear, d, best.t, dt)
            if mh.mesh >= 0:
                best = mh
            k += 1
        return best

    @wp.func
    def meshes_occlude(sd: SceneData, o: wp.vec3, d: wp.vec3, t_target: float, dt: float,
                       skip: int) -> int:
        shear = ray_shear(d)
        k = int(0)
        while k < sd.meshes.count:
            if k != skip:
                ok = o - mesh_shift(sd, k, dt)
                f0 = sd.meshes.face0[k]
                query = wp.bvh_query_capsule(sd.meshes.bvh[k], ok, d, 0.0)
                f = int(0)
                while wp.bvh_query_next(query, f, t_target):
                    idx = sd.meshes.tri_index[f0 + f]
                    if hit_triangle(ok, shear, sd.meshes.points[idx[0]], sd.meshes.points[idx[1]],
                                    sd.meshes.points[idx[2]], t_target).ok == 1:
                        return 1
            k += 1
        return 0

    @wp.func
    def mesh_target(sd: SceneData, o: wp.vec3, d: wp.vec3, dist: float, limit: float, dt: float,
                    face: int) -> float:
        k = sd.meshes.tri_mesh[face]
        mh = nearest_in_mesh(sd, k, o, ray_shear(d), d, limit, dt)
        t = limit
        if mh.mesh >= 0:
            if sd.meshes.face0[k] + mh.face != face and mh.t < dist * (1.0 - SELF_OCCLUSION):
                return -1.0
            t = mh.t
        return t

    return MeshRays(nearest_in_mesh=nearest_in_mesh, nearest_mesh=nearest_mesh,
                    meshes_occlude=meshes_occlude, mesh_target=mesh_target)


def make_sphere_bvh(*, motion: Motion) -> SphereBvh:
    sphere_center = motion.sphere_center
    @wp.func
    def bvh_nearest_sphere(sd: SceneData, o: wp.vec3, d: wp.vec3, tmax: float,
                           dt: float) -> SphereHit:
        r = SphereHit()
        r.t = tmax
        r.index = -1
        query = wp.bvh_query_capsule(sd.spheres.bvh, o, d, 0.0)
        i = int(0)
        while wp.bvh_query_next(query, i, r.t):
            # Against tmax, not r.t, so that an exact tie is seen and goes to the lower index, as
            # in the loop over spheres (which the BVH visits in another order).
            t = hit_sphere(o, d, sphere_center(sd, i, dt), sd.spheres.radius[i], tmax)
            if t < r.t or (t == r.t and t < tmax and i < r.index):
                r.t = t
                r.index = i
        return r

    @wp.func
    def bvh_spheres_occlude(sd: SceneData, o: wp.vec3, d: wp.vec3, limit: float, dt: float,
                            target_kind: int, target_index: int, tie: bool,
                            t_target: float) -> int:
        query = wp.bvh_query_capsule(sd.spheres.bvh, o, d, 0.0)
        i = int(0)
        while wp.bvh_query_next(query, i, limit):
            if not (target_kind == SPHERE and i == target_index):
                # Spheres come first in intersect()'s scan: before any other kind, and before a
                # sphere target of higher index.
                before = target_kind != SPHERE or i < target_index
                t = hit_sphere(o, d, sphere_center(sd, i, dt), sd.spheres.radius[i], limit)
                if t < t_target or (tie and before and t == t_target):
                    return 1
        return 0

    return SphereBvh(bvh_nearest_sphere=bvh_nearest_sphere,
                     bvh_spheres_occlude=bvh_spheres_occlude)
