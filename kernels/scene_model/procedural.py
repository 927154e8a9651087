"""Procedural shape sources, so that scenes with many primitives need no download: triangle meshes
made by `generate = NAME` in a mesh shape (GENERATORS), and the `sphere_grid` shape (many spheres).
`disk` is Mitsuba 3's disk (kernels/scene_model/mitsuba_shapes.py) as a triangle fan, `cylinder` its
open cylinder as a tube of quads with radial vertex normals.

Each generator is a pure function of its parameters (the seed included) returning world-space
(vertices, faces, normals): faces wound so that (b - a) x (c - a) points out of the displaced sphere
and up from the terrain, and vertex normals computed from the faces (trimesh's area- and
angle-weighted average), since a generated mesh has no file to take them from. Parameters are
validated by kernels/scene_model/mesh_file.py with the same one-line errors as every other scene value.
"""
from __future__ import annotations

import numpy as np

# Bounds that keep a typo from asking for billions of triangles: 8 subdivisions of an icosahedron are
# 1.3M triangles, a 1024-cell terrain 2.1M.
MAX_SUBDIVISIONS = 8
MAX_RESOLUTION = 1024
MAX_GRID = 320              # sphere_grid: count x count spheres (~10^5; each one a Shape)
MAX_SEGMENTS = 1 << 16
# A fan of 1024 triangles has the circle's area to 6.3e-6 (relative): below the 1e-5 a Mitsuba disk
# may differ by.
DISK_SEGMENTS = 1024


def _waves(seed: int, count: int, dims: int):
    """Random plane waves (directions, frequencies, phases, weights) of a smooth noise field."""
    rng = np.random.default_rng(seed)
    dirs = rng.normal(size=(count, dims))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    freq = rng.uniform(1.5, 6.0, count)
    phase = rng.uniform(0.0, 2.0 * np.pi, count)
    weight = 1.0 / freq                   # smoother: low frequencies carry more of the amplitude
    return dirs, freq, phase, weight / weight.sum()


def _noise(points: np.ndarray, seed: int, dims: int) -> np.ndarray:
    """A smooth field in [-1, 1] at `points` (N, dims): a weighted sum of 12 sines."""
    dirs, freq, phase, weight = _waves(seed, 12, dims)
    return np.sin((points @ dirs.T) * freq + phase) @ weight


def _normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    import trimesh                          # only scenes with generated meshes pay its import
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    return np.asarray(mesh.vertex_normals, dtype=np.float64)


def displaced_sphere(center, radius: float, subdivisions: int, amplitude: float, seed: int):
    """An icosphere of `subdivisions` (20 * 4^s triangles) whose radius varies smoothly by up to
    `amplitude` (< radius, so the surface never folds through the centre)."""
    import trimesh
    ico = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=1.0)
    dirs = np.asarray(ico.vertices, dtype=np.float64)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    r = radius + amplitude * _noise(dirs, seed, 3)
    vertices = np.asarray(center, dtype=np.float64) + dirs * r[:, None]
    faces = np.asarray(ico.faces, dtype=np.int64)
    return vertices, faces, _normals(vertices, faces)


def terrain(center, size: float, resolution: int, height: float, seed: int):
    """A height field over the square of side `size` around `center` (in x and z), `resolution`
    cells per side (2 * resolution^2 triangles), heights center.y + height * noise in [-1, 1]."""
    n = int(resolution) + 1
    s = np.linspace(-0.5, 0.5, n) * size
    x, z = np.meshgrid(s, s, indexing="xy")
    xz = np.column_stack([x.ravel(), z.ravel()])
    y = height * _noise(xz / size * 4.0, seed, 2)
    c = np.asarray(center, dtype=np.float64)
    vertices = np.column_stack([xz[:, 0] + c[0], y + c[1], xz[:, 1] + c[2]])
    i = np.arange(n - 1)
    a = (i[None, :] + n * i[:, None]).ravel()          # cell corners: a (x, z), b (x+1), c (z+1)
    b, cc, d = a + 1, a + n, a + n + 1
    # (cc - a) x (b - a) = (+z) x (+x) = +y: wound to face up.
    faces = np.concatenate([np.column_stack([a, cc, b]), np.column_stack([b, cc, d])])
    return vertices, faces, _normals(vertices, faces)


def disk(radius: float, segments: int):
    """The disk of `radius` about the origin in the plane z = 0, facing +z, as a fan of `segments`
    triangles (a regular polygon inscribed in the circle; flat: no vertex normals)."""
    a = np.arange(int(segments)) * (2.0 * np.pi / int(segments))
    ring = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)]) * radius
    vertices = np.vstack([np.zeros((1, 3)), ring])
    i = np.arange(1, int(segments) + 1)
    # (ring_i - 0) x (ring_i+1 - 0) points +z: counter-clockwise seen from +z.
    faces = np.column_stack([np.zeros_like(i), i, i % int(segments) + 1])
    return vertices, faces, None


def cylinder(radius: float, segments: int):
    """Mitsuba 3's cylinder: the open tube of `radius` about the z axis from z = 0 to z = 1, facing
    outwards, as `segments` quads (2 triangles each) between two rings of a regular polygon inscribed
    in the circle, with the circle's radial normals at the vertices (smooth shading)."""
    n = int(segments)
    a = np.arange(n) * (2.0 * np.pi / n)
    radial = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    vertices = np.vstack([radial * radius, radial * radius + [0.0, 0.0, 1.0]])
    i = np.arange(n)
    j = (i + 1) % n
    # (ring0_j - ring0_i) x (ring1_j - ring0_i) points away from the axis.
    faces = np.concatenate([np.column_stack([i, j, j + n]), np.column_stack([i, j + n, i + n])])
    return vertices, faces, np.vstack([radial, radial])


def cylinder_area_deficit(segments: int) -> float:
    """1 - (the tessellated tube's area) / (the cylinder's): the inscribed polygon's perimeter
    against the circle's, 1 - N sin(pi / N) / pi, about (pi / N)^2 / 6."""
    return disk_area_deficit(2 * segments)


def disk_area_deficit(segments: int) -> float:
    """1 - (the fan's area) / (the circle's): 1 - N sin(2 pi / N) / (2 pi), about (2 pi / N)^2 / 6."""
    x = 2.0 * np.pi / segments
    return float(1.0 - np.sinc(x / np.pi) if x > 1e-3 else x * x / 6.0 - x ** 4 / 120.0)


# name -> (function, {parameter: (default, kind)}); kind: "vec3", "positive", "nonneg", "count", "seed".
GENERATORS = {
    "displaced_sphere": (displaced_sphere, {
        "center": ([0.0, 0.0, 0.0], "vec3"), "radius": (1.0, "positive"),
        "subdivisions": (3, ("count", 0, MAX_SUBDIVISIONS)), "amplitude": (0.1, "nonneg"),
        "seed": (0, "seed")}),
    "terrain": (terrain, {
        "center": ([0.0, 0.0, 0.0], "vec3"), "size": (10.0, "positive"),
        "resolution": (32, ("count", 1, MAX_RESOLUTION)), "height": (1.0, "nonneg"),
        "seed": (0, "seed")}),
    "disk": (disk, {
        "radius": (1.0, "positive"), "segments": (DISK_SEGMENTS, ("count", 3, MAX_SEGMENTS))}),
    "cylinder": (cylinder, {
        "radius": (1.0, "positive"), "segments": (DISK_SEGMENTS, ("count", 3, MAX_SEGMENTS))}),
}


def sphere_grid_centres(count: int, center, size: float) -> np.ndarray:
    """count x count centres filling the square of side `size` around `center` in x and z (cells
    of side size / count, a centre in each), row by row: more spheres, same square."""
    cell = size / count
    k = (np.arange(count) + 0.5) * cell - 0.5 * size
    i, j = np.meshgrid(k, k, indexing="ij")
    offsets = np.column_stack([i.ravel(), np.zeros(i.size), j.ravel()])
    return np.asarray(center, dtype=np.float64) + offsets


def inward_box_faces(lo, hi):
    """(axis, side, origin, edge_u, edge_v) of each of the 6 faces of the box [lo, hi]^3, with
    edge_u x edge_v pointing into the box (a quad with that normal emits inwards): closed boxes of
    emitters, the white furnaces of the tests and of the interval audit."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    ext = hi - lo
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        for side in (0, 1):
            origin = lo.copy()
            origin[a] = hi[a] if side else lo[a]
            eu, ev, inward = np.zeros(3), np.zeros(3), np.zeros(3)
            eu[b], ev[c] = ext[b], ext[c]
            inward[a] = -1.0 if side else 1.0
            if np.dot(np.cross(eu, ev), inward) < 0:
                eu, ev = ev, eu
            yield a, side, origin, eu, ev
