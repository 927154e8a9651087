"""What tests/kernels/test_meshes.py builds its cases from: mesh shape dicts and files, a kernel running the
renderer's intersect() on arrays of rays, a float64 Moller-Trumbore reference, random rays, graded
and jittered grid triangulations of quads, and the chi-square cases' exact facing mass."""
from __future__ import annotations

import math
import zlib

import numpy as np
import trimesh
import warp as wp

from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.scene_upload import upload
from drtlab.kernels.features import features_of
from drtlab.kernels.intersection.motion import make_motion
from drtlab.kernels.intersection.scene_rays import make_intersect

from scene_pieces import camera_dict, scene_dict


def mesh(material, **kw) -> dict:
    return {"kind": "mesh", "material": material, **kw}


def two_mesh_scene(ground_file, velocity=None, translate=None, shutter=None) -> dict:
    """A displaced sphere (generated: smooth normals; non-convex) above a terrain (a file without
    normals: flat): meshes only."""
    blob = mesh("m", generate="displaced_sphere", center=[0.0, 1.0, 0.0], radius=1.0, subdivisions=2,
                amplitude=0.25, seed=3)
    ground = mesh("m", file=ground_file)
    if velocity is not None:
        blob["velocity"] = list(velocity)
    if translate is not None:
        blob["transform"] = {"translate": list(translate)}
    cam = camera_dict((0.0, 1.0, 5.0), (0.0, 0.5, 0.0), 40.0, shutter=shutter)
    return scene_dict("two meshes", cam, {"m": {"kind": "diffuse"}}, [blob, ground], res=(8, 6))


_kernels: dict = {}


def intersect_kernel(scene):
    """A kernel running the renderer's intersect() on arrays of rays (one per shape-kind set)."""
    f = features_of(scene, "path")
    key = (f.spheres, f.quads, f.meshes, f.sphere_bvh)
    if key not in _kernels:
        rays = make_intersect(f, motion=make_motion())

        @wp.kernel(enable_backward=False, module="unique")
        def k(sd: SceneData, o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), dt: float,
              out_t: wp.array(dtype=float), out_kind: wp.array(dtype=int),
              out_index: wp.array(dtype=int), out_n: wp.array(dtype=wp.vec3),
              out_ns: wp.array(dtype=wp.vec3)):
            i = wp.tid()
            h = rays.intersect(sd, o[i], d[i], 1.0e30, dt)
            out_t[i] = h.t
            out_kind[i] = h.kind
            out_index[i] = h.index
            out_n[i] = h.n
            out_ns[i] = h.ns

        _kernels[key] = k
    return _kernels[key]


def trace_rays(scene, o, d, dt=0.0) -> dict:
    sd = upload(scene, "cpu")
    o32 = np.ascontiguousarray(o, dtype=np.float32)
    d32 = np.ascontiguousarray(d, dtype=np.float32)
    n = len(o32)
    outs = [wp.zeros(n, dtype=t, device="cpu") for t in (float, int, int, wp.vec3, wp.vec3)]
    wp.launch(intersect_kernel(scene), dim=n, device="cpu",
              inputs=[sd, wp.array(o32, dtype=wp.vec3, device="cpu"),
                      wp.array(d32, dtype=wp.vec3, device="cpu"), float(dt), *outs])
    t, kind, index, nrm, ns = (a.numpy() for a in outs)
    return dict(t=t, kind=kind, index=index, n=nrm, ns=ns, o=o32, d=d32)


def scene_triangles(scene) -> tuple[np.ndarray, np.ndarray]:
    """(F, 3, 3) float32-rounded triangles of all meshes in face order, and (F, 3, 3) vertex normals."""
    tris, normals = [], []
    for s in scene.shapes:
        m = s.mesh
        v32 = m.vertices.astype(np.float32).astype(np.float64)
        tris.append(v32[m.faces])
        normals.append((m.normals if m.normals is not None else np.zeros_like(m.vertices))[m.faces])
    return np.concatenate(tris), np.concatenate(normals)


def moller_trumbore(o, d, tris):
    """float64 ray-triangle tests of every ray against every triangle: (t, b1, b2, margin) (N, F):
    t of the ray's crossing of the triangle's plane (inf when parallel or behind the origin), b1 and
    b2 the barycentric weights of its second and third vertex there, margin the smallest of the
    three weights (negative outside the triangle; -inf without a crossing ahead)."""
    o = o.astype(np.float64)[:, None, :]
    d = d.astype(np.float64)[:, None, :]
    a, e1, e2 = tris[None, :, 0], tris[None, :, 1] - tris[None, :, 0], tris[None, :, 2] - tris[None, :, 0]
    p = np.cross(d, e2)
    det = np.sum(e1 * p, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o - a
        b1 = np.sum(s * p, axis=-1) * inv
        q = np.cross(s, e1)
        b2 = np.sum(d * q, axis=-1) * inv
        t = np.sum(e2 * q, axis=-1) * inv
    margin = np.minimum(np.minimum(b1, b2), 1.0 - b1 - b2)
    t = np.where((det != 0) & (t > 0), t, np.inf)
    return t, b1, b2, np.where(np.isfinite(t), margin, -np.inf)


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def random_rays(rng, tris, n):
    """Half from outside aimed near random surface points, a quarter from inside the blob, a quarter
    random (mostly misses)."""
    k = rng.integers(0, len(tris), n)
    w = rng.dirichlet(np.ones(3), n)
    target = np.einsum("nk,nkj->nj", w, tris[k]) + rng.normal(scale=0.05, size=(n, 3))
    o_out = unit(rng.normal(size=(n, 3))) * 7.0 + np.array([0.0, 1.0, 0.0])
    o_in = np.array([0.0, 1.0, 0.0]) + rng.uniform(-0.3, 0.3, (n, 3))
    o_rand = rng.uniform(-6.0, 6.0, (n, 3))
    q = n // 4
    o = np.concatenate([o_out[:2 * q], o_in[:q], o_rand[:n - 3 * q]])
    d = np.concatenate([unit(target[:2 * q] - o_out[:2 * q]), unit(rng.normal(size=(q, 3))),
                        unit(rng.normal(size=(n - 3 * q, 3)))])
    return o, d


def graded_plane(quad: dict, n: int = 24, a: float = 5.0, seed: int = 1):
    """The plane quad as an n x n grid of cells graded towards its centre (sinh spacing: many shared
    edges in the camera's view), each cut along a random diagonal, wound like the quad."""
    g = 0.5 + 0.5 * np.sinh(a * np.linspace(-1.0, 1.0, n + 1)) / math.sinh(a)
    return _grid_mesh(quad, g, g, np.random.default_rng(seed).integers(0, 2, (n, n)))


def jittered_light(quad: dict, n: int = 3, seed: int = 2):
    """The light quad as an n x n grid whose interior lines are moved (unequal triangles)."""
    rng = np.random.default_rng(seed)
    g = np.linspace(0.0, 1.0, n + 1)
    gs = g.copy()
    gt = g.copy()
    gs[1:-1] += rng.uniform(-0.12, 0.12, n - 1)
    gt[1:-1] += rng.uniform(-0.12, 0.12, n - 1)
    return _grid_mesh(quad, gs, gt, rng.integers(0, 2, (n, n)))


def _grid_mesh(quad: dict, gs, gt, diagonals):
    o, eu, ev = (np.asarray(quad[k], dtype=np.float64) for k in ("origin", "edge_u", "edge_v"))
    ns, nt = len(gs), len(gt)
    s, t = np.meshgrid(gs, gt, indexing="ij")
    vertices = o + s.reshape(-1, 1) * eu + t.reshape(-1, 1) * ev
    faces = []
    for i in range(ns - 1):
        for j in range(nt - 1):
            p00, p10, p01, p11 = i * nt + j, (i + 1) * nt + j, i * nt + j + 1, (i + 1) * nt + j + 1
            # Both cuts keep (b - a) x (c - a) along edge_u x edge_v.
            faces += ([[p00, p10, p11], [p00, p11, p01]] if diagonals[i, j]
                      else [[p00, p10, p01], [p10, p11, p01]])
    return vertices, np.array(faces)


def write_mesh(path, vertices, faces, normals=None):
    m = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    if path.suffix == ".obj":
        if normals is not None:
            m.vertex_normals = normals
        path.write_text(trimesh.exchange.obj.export_obj(m, include_normals=normals is not None))
    else:
        path.write_bytes(trimesh.exchange.ply.export_ply(m, vertex_normal=False, encoding="binary"))
    return str(path)


def light_scene(shapes: list, materials: dict) -> dict:
    return scene_dict("chi2: mesh lights", camera_dict((0, 0, -5), (0, 0, 0), 40.0), materials,
                      shapes, res=(4, 4))


def facing_mass(scene, x) -> float:
    """Exact probability that a light sample is valid: per light its pick probability times the
    area fraction facing x (a flat triangle faces x entirely or not at all)."""
    from drtlab.kernels.colour import luminance
    emitters = [scene.shapes[i] for i in scene.emitter_shapes()]
    power = np.array([luminance(scene.materials[s.material].emission) * s.area() for s in emitters])
    total = 0.0
    for pmf, s in zip(power / power.sum(), emitters):
        if s.kind == "mesh":
            tri = s.mesh.vertices[s.mesh.faces]
            n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            faces_x = np.sum(n * (x - tri[:, 0]), axis=1) > 0
            total += pmf * s.mesh.triangle_areas()[faces_x].sum() / s.area()
        else:
            total += pmf          # solid-angle sampled sphere, quad facing x
    return total


def chi2_domain(name, scene, x):
    if name == "mixed":
        return C.SphericalDomain((0.0, 0.0, 1.0)), (101, 202)
    m = scene.shapes[0].mesh
    c = m.vertices.mean(axis=0)
    r = np.linalg.norm(m.vertices - c, axis=1).max()
    omc = 1.0 - math.cos(math.asin(min(r / np.linalg.norm(c - x), 0.999)))
    return C.CapDomain(c - x, 1.3 * omc), (50, 100)


def zlib_seed(name: str) -> int:
    return zlib.crc32(f"meshes:{name}".encode())
