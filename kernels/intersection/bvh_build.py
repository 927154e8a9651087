"""What the kernels need of triangle meshes and of many spheres, built once per scene at upload:

* `mesh_tables(meshes, t_open, extent)` -> MeshTables: the meshes' vertices (float32, at shutter
  open) and triangles (global vertex indices), per-mesh / per-face / per-vertex arrays of SceneData
  (face offsets, the area cdf that light sampling picks a triangle with, vertex normals for smooth
  shading, each mesh's area, centroid and area-weighted normal for Whitted), and per mesh the padded
  bounding boxes of its triangles for its wp.Bvh.
* `sphere_boxes(spheres, t_open, t_close, extent)` -> the spheres' padded boxes (swept over the
  shutter) for a wp.Bvh that replaces the loop over every sphere.
* `build_bvh(lowers, uppers, device)` -> wp.Bvh (SAH on the CPU, LBVH on CUDA).

Why a wp.Bvh of padded triangle boxes and not wp.Mesh with wp.mesh_query_ray: Warp's ray-box test
rounds (a float32 slab test without slack), so a ray aimed exactly at a vertex that lies on a node's
box can be culled from every box holding its triangles: 6 of 19206 rays from inside a closed
1280-triangle mesh aimed at its vertices slipped through with Warp 1.19 (tests/kernels/test_meshes.py
checks none do here). Boxes padded by far more than that rounding (BOX_PAD of the scene's extent,
which holds every ray origin, the camera included), a robust slab test (bvh_query_capsule of radius
0) and the watertight triangle test of kernels/intersection/bvh_traversal.py close the gap.

A mesh moves rigidly (all its vertices with the shape's velocity), so its BVH is never refitted:
the kernels move the ray into the mesh's frame at its time instead (o - v dt).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

# Boxes grow by BOX_PAD x (the scene's extent + the box's largest coordinate): the float32 slab test
# errs by ~2^-22 of the distance from the ray's origin to the box (at most the extent, the camera
# included), so 1e-5 is a margin of 40 and costs nothing measurable in traversal.
BOX_PAD = 1e-5


@dataclass
class MeshTables:
    points: np.ndarray       # (V, 3) float32 vertices of all meshes at shutter open
    tri_index: np.ndarray    # (F, 3) int32 per face: its vertices' rows in `points`
    face0: np.ndarray        # (M + 1,) offsets of each mesh's faces in the per-face arrays
    area: np.ndarray         # (M,) total area (of the float32 triangles the kernels sample)
    smooth: np.ndarray       # (M,) 1 where the mesh has vertex normals
    centroid: np.ndarray     # (M, 3) area-weighted centroid at shutter open
    normal_area: np.ndarray  # (M, 3) sum over faces of area * unit normal
    cdf: np.ndarray          # (F,) per face: cumulative area fraction within its mesh
    tri_mesh: np.ndarray     # (F,) per face: its mesh
    vert_normal: np.ndarray  # (V, 3) unit vertex normals (zeros for flat meshes)
    vert_uv: np.ndarray      # (V, 2) texture coordinates (zeros for meshes without)
    boxes: list              # per mesh: (lowers, uppers) float32 (F_k, 3) padded triangle boxes


def _area_cdf(areas: np.ndarray) -> np.ndarray:
    """Cumulative area fractions in float64, ending at exactly 1 so that u < 1 always finds a face."""
    cdf = np.cumsum(areas) / np.sum(areas)
    cdf[-1] = 1.0
    return cdf


def padded(lowers: np.ndarray, uppers: np.ndarray, extent: float) -> tuple[np.ndarray, np.ndarray]:
    """Boxes grown by BOX_PAD (module doc), as float32 rounded outwards."""
    big = np.maximum(np.abs(lowers).max(axis=1), np.abs(uppers).max(axis=1))[:, None]
    pad = BOX_PAD * (extent + big)
    return ((lowers - pad).astype(np.float32), (uppers + pad).astype(np.float32))


def mesh_tables(meshes: list, t_open: float, extent: float) -> MeshTables:
    """The SceneData tables of `meshes` (Shapes of kind "mesh", in scene order)."""
    points, tri_index, areas, smooth, centroid, normal_area, cdf, tri_mesh, normals, boxes = \
        [], [], [], [], [], [], [], [], [], []
    uvs = []
    face0, base = [0], 0
    for k, shape in enumerate(meshes):
        m = shape.mesh
        v = m.vertices if t_open == 0.0 else m.vertices + shape.velocity * t_open
        p32 = np.ascontiguousarray(v, dtype=np.float32)
        tri = p32[m.faces].astype(np.float64)                       # (F, 3, 3)
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        tri_area = 0.5 * np.linalg.norm(cross, axis=1)
        points.append(p32)
        tri_index.append(m.faces.astype(np.int32) + base)
        areas.append(tri_area.sum())
        centroid.append((tri.mean(axis=1) * tri_area[:, None]).sum(axis=0) / tri_area.sum())
        normal_area.append(0.5 * cross.sum(axis=0))
        cdf.append(_area_cdf(tri_area))
        tri_mesh.append(np.full(len(m.faces), k, dtype=np.int32))
        smooth.append(int(m.normals is not None))
        normals.append(m.normals if m.normals is not None else np.zeros((len(v), 3)))
        uvs.append(m.uvs if m.uvs is not None else np.zeros((len(v), 2)))
        boxes.append(padded(tri.min(axis=1), tri.max(axis=1), extent))
        face0.append(face0[-1] + len(m.faces))
        base += len(v)
    cat = (lambda xs, shape: np.concatenate(xs) if xs else np.zeros(shape))
    return MeshTables(points=cat(points, (0, 3)).astype(np.float32),
                      tri_index=cat(tri_index, (0, 3)).astype(np.int32), face0=np.array(face0),
                      area=np.array(areas), smooth=np.array(smooth, dtype=np.int32),
                      centroid=np.array(centroid).reshape(-1, 3),
                      normal_area=np.array(normal_area).reshape(-1, 3), cdf=cat(cdf, (0,)),
                      tri_mesh=cat(tri_mesh, (0,)), vert_normal=cat(normals, (0, 3)), boxes=boxes,
                      vert_uv=cat(uvs, (0, 2)))


def sphere_boxes(spheres: list, t_open: float, t_close: float,
                 extent: float) -> tuple[np.ndarray, np.ndarray]:
    """(lowers, uppers) float32 of each sphere's padded box over the shutter: a sphere moving as
    c + v t stays inside the hull of its balls at both ends, whose box is the union of theirs."""
    c0 = np.array([s.center + s.velocity * t_open for s in spheres], dtype=np.float64).reshape(-1, 3)
    c1 = np.array([s.center + s.velocity * t_close for s in spheres], dtype=np.float64).reshape(-1, 3)
    r = np.array([s.radius for s in spheres], dtype=np.float64)[:, None]
    return padded(np.minimum(c0, c1) - r, np.maximum(c0, c1) + r, extent)


def build_bvh(lowers: np.ndarray, uppers: np.ndarray, device: str) -> wp.Bvh:
    return wp.Bvh(wp.array(lowers, dtype=wp.vec3, device=device),
                  wp.array(uppers, dtype=wp.vec3, device=device))
