"""Triangle-mesh shapes of a scene file: `kind = "mesh"` with `file = "x.obj" | "x.ply"` (read by
trimesh; or Mitsuba's "x.serialized", mesh_serialized.py) or `generate = NAME` (kernels/scene_model/procedural.py), validated into a `TriangleMesh`
(kernels/scene_model/scene.py). See SCENE_FORMAT.md, "Triangle meshes".

Validation is as strict as for every other shape, because a broken mesh silently changes what a study
measures: a missing or unreadable file, a mesh without triangles, NaN/Inf vertices or normals, a
triangle index past the vertices and a degenerate (zero-area) triangle each raise one `InputError`
naming the field and what was found. Nothing is repaired silently (trimesh loads with
process=False: no merging, no dropping of faces). `sphere_grid` shapes are parsed here too: like a
generated mesh they expand one table into many primitives.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import MAX_SEED, Table, existing_file, integer, number, numbers, show, string
from drtlab.kernels.scene_model.mesh_attributes import ply_attributes
from drtlab.kernels.scene_model.mesh_serialized import SerializedError, has_vertex_normals, read_serialized
from drtlab.kernels.scene_model.procedural import GENERATORS, MAX_GRID, sphere_grid_centres
from drtlab.kernels.scene_model.scene import Shape, TriangleMesh
from drtlab.kernels.scene_model.transforms import apply_transform, mirrors, parse_transform

MESH_FORMATS = (".obj", ".ply", ".serialized")
MESH_SOURCE_KEYS = ("file", "generate")
MESH_KEYS = (MESH_SOURCE_KEYS + ("normals",)
             + tuple(sorted({k for _, params in GENERATORS.values() for k in params})))
# `normals` of a file mesh: "file" (the file's vertex normals, else flat shading) or "smooth" (the
# file's, else Mitsuba 3's: each vertex the angle-weighted mean of its faces' normals).
NORMALS = ("file", "smooth")
SPHERE_GRID_KEYS = ("count", "center", "size", "radius")
# wp.Mesh indexes vertices with int32 and its BVH with int32 node ids: far below both limits.
MAX_TRIANGLES = 1 << 26
# A triangle whose area (of its float32 vertices, which the kernels see) is at most this times the
# square of the mesh's bounding-box diagonal is degenerate: no ray can hit it reliably and its
# normal, which light sampling and shading need, does not exist.
DEGENERATE_AREA = 1e-12


# ---------------------------------------------------------------------------------------------------
# The shape table
# ---------------------------------------------------------------------------------------------------

def parse_mesh_shape(t: Table, name: str, material: int, velocity: np.ndarray) -> Shape:
    """shapes[i] with kind = "mesh" -> Shape(kind="mesh"); relative `file` paths were anchored at the
    scene file's folder by the loader (kernels/scene_model/scene_file.py)."""
    has = [k for k in MESH_SOURCE_KEYS if t.has(k)]
    if len(has) != 1:
        raise InputError(t.field(has[1] if len(has) == 2 else "file"),
                         "a mesh needs exactly one of file = 'PATH.obj' | 'PATH.ply' or generate = "
                         f"{' | '.join(repr(g) for g in GENERATORS)}"
                         + (", not both" if len(has) == 2 else ""))
    if has[0] == "file":
        _only_keys(t, (), "file = ...")
        mesh = load_mesh_file(t.data["file"], t.field("file"))
    else:
        mesh = _generated(t)
    normals = string(t.get("normals", "file", ""), t.field("normals"), NORMALS)
    if t.has("normals") and has[0] != "file":
        raise InputError(t.field("normals"), "applies to a file mesh only (generated meshes come "
                                             "with their normals)")
    if t.has("transform"):
        mesh = _transformed(mesh, t.data["transform"], t.field("transform"))
    if normals == "smooth" and mesh.normals is None:
        # After the transform, as Mitsuba computes them from the world-space positions.
        mesh = TriangleMesh(vertices=mesh.vertices, faces=mesh.faces,
                            normals=smooth_normals(mesh.vertices, mesh.faces), source=mesh.source,
                            uvs=mesh.uvs, attributes=mesh.attributes)
    mesh = checked_mesh(mesh.vertices, mesh.faces, mesh.normals, t.path, mesh.source, mesh.uvs,
                        mesh.attributes)
    return Shape(kind="mesh", name=name, material=material, velocity=velocity, mesh=mesh)


def smooth_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Mitsuba 3's vertex normals of a mesh without them (Mesh::compute_normals, after Thuermer and
    Wuethrich 1998): each face's unit normal added to its corners' vertices weighted by the corner's
    interior angle; trimesh's vertex normals are that weighting."""
    import trimesh
    n = np.array(trimesh.Trimesh(vertices=vertices, faces=faces, process=False).vertex_normals,
                 dtype=np.float64)
    # A vertex no face uses has none: Mitsuba's stand-in (1, 0, 0); no ray ever reads it.
    with np.errstate(invalid="ignore"):
        lone = ~(np.linalg.norm(n, axis=1) > 0.0)
    n[lone] = [1.0, 0.0, 0.0]
    return n


def _only_keys(t: Table, allowed: tuple, what: str) -> None:
    """Generator parameters other than `allowed` are errors (a `radius` on a file mesh is a typo)."""
    for key in MESH_KEYS:
        if key not in MESH_SOURCE_KEYS + ("normals",) and key not in allowed and t.has(key):
            raise InputError(t.field(key), f"is not a parameter of {what}; allowed: "
                                           f"{', '.join(allowed) or '(none)'}")


def _generated(t: Table) -> TriangleMesh:
    gen = string(t.data["generate"], t.field("generate"), tuple(GENERATORS))
    func, params = GENERATORS[gen]
    _only_keys(t, tuple(params), f"generate = '{gen}'")
    values = {key: _param(t, key, default, kind) for key, (default, kind) in params.items()}
    if gen == "displaced_sphere" and not values["amplitude"] < values["radius"]:
        raise InputError(t.field("amplitude"), f"must be < radius = {values['radius']:g} (the surface "
                                               f"would fold through its centre), got {values['amplitude']:g}")
    vertices, faces, normals = func(**values)
    source = f"{gen}(" + ", ".join(f"{k}={show(v)}" for k, v in values.items()) + ")"
    return TriangleMesh(vertices=vertices, faces=faces, normals=normals, source=source)


def _param(t: Table, key: str, default: Any, kind) -> Any:
    v = t.get(key, default, "")
    field = t.field(key)
    if kind == "vec3":
        return numbers(v, field, 3)
    if kind == "positive":
        return number(v, field, "> 0", lambda x: x > 0.0)
    if kind == "nonneg":
        return number(v, field, ">= 0", lambda x: x >= 0.0)
    if kind == "seed":
        return integer(v, field, "in [0, 2^32)", lambda n: 0 <= n <= MAX_SEED)
    _, low, high = kind
    return integer(v, field, f"in [{low}, {high}]", lambda n: low <= n <= high)


def _transformed(mesh: TriangleMesh, value: Any, field: str) -> TriangleMesh:
    """The mesh under its shape's `transform` (kernels/scene_model/transforms.py): vertices and normals mapped,
    the winding reversed under a mirror so that each triangle keeps its front side."""
    m, _ = parse_transform(value, field)
    if mesh.normals is None:
        vertices, normals = apply_transform(m, mesh.vertices), None
    else:
        vertices, normals = apply_transform(m, mesh.vertices, mesh.normals)
    faces = mesh.faces[:, [0, 2, 1]] if mirrors(m) else mesh.faces
    return TriangleMesh(vertices=vertices, faces=faces, normals=normals, source=mesh.source,
                        uvs=mesh.uvs, attributes=mesh.attributes)


# ---------------------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------------------

def load_mesh_file(value: Any, field: str) -> TriangleMesh:
    """A .obj or .ply file read by trimesh (a .serialized one by mesh_serialized.py); its vertex
    normals only when the file has them."""
    text = string(value, field)
    path = Path(text).expanduser()
    if path.suffix.lower() not in MESH_FORMATS:
        raise InputError(field, f"must name a {' or '.join(MESH_FORMATS)} file, got {show(text)}")
    existing_file(path, field, f"a mesh file ({' or '.join(MESH_FORMATS)})")
    if path.suffix.lower() == ".obj":
        _check_obj_indices(path, field)
    if path.suffix.lower() == ".serialized":
        try:
            vertices, faces, normals = read_serialized(path)
        except (OSError, SerializedError) as exc:
            raise InputError(field, f"mesh file '{path}' {exc}") from None
        return TriangleMesh(vertices=vertices, faces=faces, normals=normals, source=str(path))
    import trimesh                                  # only scenes with mesh files pay its import
    try:
        # Not force="mesh": that concatenation drops the normals the file gave.
        loaded = trimesh.load(str(path), process=False)
        parts = list(loaded.dump()) if isinstance(loaded, trimesh.Scene) else [loaded]
    except Exception as exc:                        # trimesh raises many kinds; each means unreadable
        reason = (str(exc).strip().splitlines() or [""])[0]
        raise InputError(field, f"cannot read mesh file '{path}': not a readable "
                                f"{path.suffix[1:].upper()} file, truncated or corrupt "
                                f"({type(exc).__name__}{': ' + reason if reason else ''})") from None
    parts = [m for m in parts if isinstance(m, trimesh.Trimesh) and len(m.faces)]
    if not parts:
        raise InputError(field, f"mesh file '{path}' has no triangles")
    mesh = _concatenated(parts, str(path))
    raw = parts[0].metadata.get("_ply_raw") if len(parts) == 1 else None
    if path.suffix.lower() == ".ply" and isinstance(raw, dict):
        mesh.attributes = ply_attributes(raw)
    return mesh


def _check_obj_indices(path: Path, field: str) -> None:
    """Every index of every `f` line of an OBJ file, as written: 1 ... n counts from the first vertex,
    -1 ... -n back from the last one defined so far, and 0 is no index at all. trimesh turns a 0 or a
    too-large index into a degenerate triangle or a numpy message without a face number; here it is
    the file, the line, the face and the index the user wrote."""
    counts = {"v": 0, "vt": 0, "vn": 0}
    faces = []                                      # (line number, face number, tokens)
    try:
        with open(path, encoding="utf-8") as fh:
            for number, line in enumerate(fh, 1):
                word, _, rest = line.partition("#")[0].strip().partition(" ")
                if word in counts:
                    counts[word] += 1
                elif word == "f":
                    faces.append((number, len(faces) + 1, rest.split(), dict(counts)))
    except OSError as exc:
        raise InputError(field, f"cannot read mesh file '{path}': {exc.strerror}") from None
    except UnicodeDecodeError as exc:
        raise InputError(field, f"mesh file '{path}' is not an OBJ file: an OBJ file is text, and its "
                                f"byte {exc.start} is not UTF-8 (a binary file?)") from None
    kinds = (("v", "vertex", "vertices"), ("vt", "texture coordinate", "texture coordinates"),
             ("vn", "normal", "normals"))
    for number, face, tokens, defined in faces:
        for token in tokens:
            for (key, what, plural), text in zip(kinds, token.split("/")):
                if not text and key != "v":
                    continue
                where = f"mesh file '{path}' line {number}: face {face} ('f {' '.join(tokens)}')"
                try:
                    index = int(text)
                except ValueError:
                    raise InputError(field, f"{where}: {what} index {text!r} is not an integer") from None
                if index == 0:
                    raise InputError(field, f"{where}: {what} index 0 is not an OBJ index (they count "
                                            f"from 1, or from -1 back from the last {what})")
                total = counts[key] if index > 0 else defined[key]
                if abs(index) > total:
                    scope = "in the file" if index > 0 else "defined before this line"
                    allowed = f" (1 ... {total} or -1 ... -{total})" if total else ""
                    raise InputError(field, f"{where}: {what} index {index} is out of range: "
                                            f"{total} {plural} {scope}{allowed}")


def _concatenated(parts: list, source: str) -> TriangleMesh:
    """One TriangleMesh of a file's meshes (an OBJ's objects); vertex normals when all have them.
    trimesh computes vertex_normals lazily from the faces; its cache holds them before the first
    access only when the file provided them, and computed ones must not pass as the file's."""
    offsets = np.cumsum([0] + [len(m.vertices) for m in parts])
    with_normals = all("vertex_normals" in m._cache for m in parts)
    uvs = [getattr(m.visual, "uv", None) for m in parts]
    with_uvs = source.lower().endswith(".obj") and all(
        u is not None and len(u) == len(m.vertices) for u, m in zip(uvs, parts))
    return TriangleMesh(
        uvs=(np.concatenate([np.asarray(u, dtype=np.float64) for u in uvs]) * [1.0, -1.0] + [0.0, 1.0]
             if with_uvs else None),
        vertices=np.concatenate([np.asarray(m.vertices, dtype=np.float64) for m in parts]),
        faces=np.concatenate([np.asarray(m.faces) + o for m, o in zip(parts, offsets)]),
        normals=np.concatenate([np.asarray(m.vertex_normals) for m in parts]) if with_normals else None,
        source=source)


# ---------------------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------------------

def checked_mesh(vertices, faces, normals, field: str, source: str, uvs=None,
                 attributes=None) -> TriangleMesh:
    """The validated mesh (float64 vertices, int32 faces, unit normals or None), or one InputError."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    what = f"mesh {source}"
    if v.ndim != 2 or v.shape[1] != 3 or len(v) == 0 or f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
        raise InputError(field, f"{what} has no triangles")
    if len(f) > MAX_TRIANGLES:
        raise InputError(field, f"{what} has {len(f):,} triangles; at most {MAX_TRIANGLES:,} are supported")
    bad = np.flatnonzero(~np.all(np.isfinite(v), axis=1))
    if bad.size:
        raise InputError(field, f"{what}: vertex {bad[0]} is not finite ({show(v[bad[0]].tolist())}); "
                                f"{bad.size} NaN/Inf vertices in all")
    if f.min() < 0 or f.max() >= len(v):
        k = int(np.flatnonzero((f < 0).any(axis=1) | (f >= len(v)).any(axis=1))[0])
        raise InputError(field, f"{what}: triangle {k + 1} refers to vertices {_as_written(f[k], source)}, "
                                f"but there are {len(v)} vertices")
    f = f.astype(np.int32)
    _check_areas(v, f, field, what)
    if uvs is not None and (np.shape(uvs) != (len(v), 2) or not np.all(np.isfinite(uvs))):
        uvs = None                  # no usable texture coordinates: a texture reads (0, 0)
    return TriangleMesh(vertices=v, faces=f, normals=_checked_normals(normals, len(v), field, what),
                        source=source, uvs=uvs, attributes=dict(attributes or {}))


def _check_areas(v: np.ndarray, f: np.ndarray, field: str, what: str) -> None:
    with np.errstate(over="ignore", invalid="ignore"):
        v32 = v.astype(np.float32).astype(np.float64)
        a, b, c = (v32[f[:, k]] for k in range(3))
        areas = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        diag = float(np.linalg.norm(v32.max(axis=0) - v32.min(axis=0)))
    if not np.all(np.isfinite(areas)) or not np.isfinite(diag):
        raise InputError(field, f"{what} is too large: its triangle areas overflow")
    small = np.flatnonzero(~(areas > DEGENERATE_AREA * diag * diag))
    if small.size:
        k = int(small[0])
        raise InputError(field, f"{what}: triangle {k + 1} (vertices {_as_written(f[k], what)}) is "
                                f"degenerate (zero area); {small.size} such triangles in all: remove them")


def _as_written(face: np.ndarray, source: str) -> str:
    """A triangle's vertex indices as its file numbers them: from 1 in an OBJ, from 0 elsewhere."""
    base = 1 if source.lower().endswith(".obj") else 0
    return f"{show((face + base).tolist())} (counting from {base})"


def _checked_normals(normals, count: int, field: str, what: str) -> np.ndarray | None:
    if normals is None:
        return None
    n = np.asarray(normals, dtype=np.float64)
    if n.shape != (count, 3):
        raise InputError(field, f"{what}: {n.shape[0]} vertex normals for {count} vertices")
    with np.errstate(invalid="ignore", over="ignore"):
        length = np.linalg.norm(n, axis=1)
    bad = np.flatnonzero(~(np.isfinite(length) & (length > 0.0)))
    if bad.size:
        raise InputError(field, f"{what}: vertex normal {bad[0]} is zero or not finite "
                                f"({show(n[bad[0]].tolist())})")
    return n / length[:, None]


# ---------------------------------------------------------------------------------------------------
# Sphere grids
# ---------------------------------------------------------------------------------------------------

def parse_sphere_grid(t: Table, name: str, material: int, velocity: np.ndarray) -> list[Shape]:
    """shapes[i] with kind = "sphere_grid": count x count spheres of one material filling the square
    of side `size` around `center` (x and z), resting on the plane y = center.y, radius
    0.35 size / count unless given, named NAME[k] in row order; `count` alone scales the number of
    primitives (`--set shapes[i].count=100`)."""
    count = integer(t.get("count", 4, ""), t.field("count"), f"in [1, {MAX_GRID}]",
                    lambda n: 1 <= n <= MAX_GRID)
    center = numbers(t.get("center", [0.0, 0.0, 0.0], ""), t.field("center"), 3)
    size = number(t.get("size", 4.0, ""), t.field("size"), "> 0", lambda x: x > 0.0)
    radius = number(t.get("radius", 0.35 * size / count, ""), t.field("radius"), "> 0",
                    lambda x: x > 0.0)
    return [Shape(kind="sphere", name=f"{name}[{k}]", material=material, center=c, radius=radius,
                  velocity=velocity.copy())
            for k, c in enumerate(sphere_grid_centres(count, center + [0.0, radius, 0.0], size))]


def file_has_vertex_normals(path: Path) -> bool:
    """Whether an .obj has `vn` lines, a .ply declares nx or a .serialized stores normals: what
    decides Mitsuba's smooth normals."""
    if path.suffix.lower() == ".serialized":
        return has_vertex_normals(path)
    with path.open("rb") as f:
        if path.suffix.lower() == ".ply":
            for line in f:
                if line.strip() == b"end_header":
                    return False
                if line.split()[-1:] == [b"nx"]:
                    return True
            return False
        return any(line.startswith(b"vn ") for line in f)
