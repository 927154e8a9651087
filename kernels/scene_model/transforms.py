"""Shape transforms: a scene file's `transform` table -> a 4x4 affine matrix, and its application to
the points, edges and normals that define a shape (see SCENE_FORMAT.md, "Transforms").

    transform = { scale = s | [sx, sy, sz], rotate = {axis, degrees} | [{...}, ...], translate = [x, y, z] }
    transform = { matrix = [[...], [...], [...], [0, 0, 0, 1]] }            # rows; alone

Composition (one definition: `compose`): scale first, then the rotations in the order listed, then
the translation, M = T R_k ... R_1 S, applied to column vectors (p' = M p). Rotations are right-handed
(counter-clockwise looking down the axis towards the origin), as Mitsuba's `rotate`.

Used by kernels/scene_model/scene_tables.py for spheres and quads (boxes are expanded into quads first) and meant
for any loader of other shapes (a triangle mesh: `apply_transform(m, vertices, normals)`, and reverse
the winding when `mirrors(m)`). Everything is float64 numpy at load time; velocities are not
transformed (they are world-space). Each problem raises one `InputError` naming the field.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import REQUIRED, Table, scene_number as number, scene_numbers as numbers, show

TRANSFORM_KEYS = ("scale", "rotate", "translate", "matrix")
ROTATE_KEYS = ("axis", "degrees")
# |det| of the linear part at or below this times the product of its column lengths: singular.
_SINGULAR_TOL = 1e-12
# A sphere stays a sphere when A^T A = s^2 I to this relative tolerance (rounding of rotations).
_SIMILARITY_TOL = 1e-9


# ---------------------------------------------------------------------------------------------------
# Matrices
# ---------------------------------------------------------------------------------------------------

def translation(offset) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = np.asarray(offset, dtype=np.float64)
    return m


def scaling(factors) -> np.ndarray:
    return np.diag(np.append(np.broadcast_to(np.asarray(factors, dtype=np.float64), 3), 1.0))


def rotation(axis, degrees: float) -> np.ndarray:
    """Right-handed rotation by `degrees` about `axis` (Rodrigues' formula); axis need not be unit."""
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1.0 - c) * np.outer(a, a)
    return m


def compose(scale=None, rotations=(), translate=None) -> np.ndarray:
    """M = T R_k ... R_1 S: scale, then each (axis, degrees) rotation in order, then translate."""
    m = scaling(1.0 if scale is None else scale)
    for axis, degrees in rotations:
        m = rotation(axis, degrees) @ m
    return translation(np.zeros(3) if translate is None else translate) @ m


# ---------------------------------------------------------------------------------------------------
# Application
# ---------------------------------------------------------------------------------------------------

def apply_transform(m: np.ndarray, points, normals=None):
    """Points (..., 3) mapped by the affine matrix m; with `normals` (..., 3) also those, mapped by
    the inverse transpose of the linear part and renormalised: returns (points, normals)."""
    p = np.asarray(points, dtype=np.float64)
    out = p @ m[:3, :3].T + m[:3, 3]
    if normals is None:
        return out
    n = np.asarray(normals, dtype=np.float64) @ np.linalg.inv(m[:3, :3])   # (A^-T n^T)^T = n A^-1
    return out, n / np.linalg.norm(n, axis=-1, keepdims=True)


def transform_vectors(m: np.ndarray, vectors) -> np.ndarray:
    """Displacements (edges) (..., 3) mapped by the linear part only."""
    return np.asarray(vectors, dtype=np.float64) @ m[:3, :3].T


def mirrors(m: np.ndarray) -> bool:
    """True when m reverses orientation (det < 0): a quad's edge_u x edge_v, or a triangle's
    winding, then points against the transformed normal and must be swapped to keep its side."""
    return bool(np.linalg.det(m[:3, :3]) < 0.0)


def similarity_scale(m: np.ndarray) -> float | None:
    """s when the linear part is s times an orthogonal matrix (a similarity), else None."""
    a = m[:3, :3]
    s2 = abs(np.linalg.det(a)) ** (2.0 / 3.0)
    if np.max(np.abs(a.T @ a - s2 * np.eye(3))) <= _SIMILARITY_TOL * s2:
        return math.sqrt(s2)
    return None


def transform_quad(m: np.ndarray, origin, edge_u, edge_v) -> tuple:
    """(origin, edge_u, edge_v) of the transformed parallelogram, the edges swapped under a mirror so
    that normalize(edge_u x edge_v) is the transformed normal (an emitter keeps its lit side, a box
    face stays outward; the swap exchanges the checker's u and v)."""
    o = apply_transform(m, origin)
    u, v = transform_vectors(m, edge_u), transform_vectors(m, edge_v)
    return (o, v, u) if mirrors(m) else (o, u, v)


def transform_sphere(m: np.ndarray, center, radius: float, field: str, spelled: str) -> tuple:
    """(center, radius, to_local) of the transformed sphere, to_local the orthogonal matrix taking
    world directions into the sphere's own frame (the inverse of m's rotation, a mirror included);
    `spelled` is the transform key that made m (for the error when m is not a similarity: a sphere
    would become an ellipsoid)."""
    s = similarity_scale(m)
    if s is None:
        raise InputError(f"{field}.{spelled}", "a sphere accepts only translate, rotate and a uniform "
                                               "scale (a similarity); this transform would make it an "
                                               "ellipsoid, which drtlab does not model")
    return apply_transform(m, center), radius * s, (np.asarray(m, np.float64)[:3, :3] / s).T


# ---------------------------------------------------------------------------------------------------
# The TOML table
# ---------------------------------------------------------------------------------------------------

def parse_transform(value: Any, field: str) -> tuple[np.ndarray, str]:
    """(matrix, spelled): the 4x4 matrix of a `transform` table and the key that an error about what
    it does to a shape should name ('matrix', else 'scale')."""
    t = Table(value, field, "transform: scale, rotate, translate, or matrix alone")
    t.check_keys(TRANSFORM_KEYS)
    if t.has("matrix"):
        others = [k for k in ("scale", "rotate", "translate") if t.has(k)]
        if others:
            raise InputError(t.field("matrix"), f"give either matrix alone or scale/rotate/translate, "
                                                f"not both (also given: {', '.join(others)})")
        return _matrix(t.data["matrix"], t.field("matrix")), "matrix"
    scale = _scale(t.data["scale"], t.field("scale")) if t.has("scale") else np.ones(3)
    rotations = _rotations(t.data["rotate"], t.field("rotate")) if t.has("rotate") else []
    offset = numbers(t.data["translate"], t.field("translate"), 3) if t.has("translate") else None
    m = compose(scale, rotations, offset)
    if not np.all(np.isfinite(m)):
        raise InputError(field, "must give a finite matrix (the composed transform overflows)")
    return m, "scale"       # rotations and translations keep a sphere a sphere: only scale can't


def _scale(v: Any, field: str) -> np.ndarray:
    """s or [sx, sy, sz], every factor finite and non-zero (negative factors mirror)."""
    rule = "non-zero (negative mirrors)"
    if isinstance(v, (list, tuple)):
        return numbers(v, field, 3, rule, lambda x: x != 0.0)
    return np.full(3, number(v, field, f"{rule}, or a list of 3 such", lambda x: x != 0.0))


def _rotations(v: Any, field: str) -> list[tuple[np.ndarray, float]]:
    """{axis, degrees} or a list of them, applied in order."""
    if isinstance(v, dict):
        return [_rotation(v, field)]
    if not isinstance(v, list) or not v:
        raise InputError(field, f"must be a table {{axis = [x, y, z], degrees = d}} or a non-empty "
                                f"list of such, got {show(v)}")
    return [_rotation(r, f"{field}[{i}]") for i, r in enumerate(v)]


def _rotation(v: Any, field: str) -> tuple[np.ndarray, float]:
    t = Table(v, field, "rotation: axis = [x, y, z], degrees = d")
    t.check_keys(ROTATE_KEYS)
    axis = numbers(t.get("axis", REQUIRED, "a non-zero list of 3 finite numbers"), t.field("axis"), 3)
    norm = float(np.linalg.norm(axis))
    if not (math.isfinite(norm) and norm > 0.0):
        raise InputError(t.field("axis"), f"must be a non-zero list of 3 finite numbers, got "
                                          f"{show(v['axis'])}")
    degrees = number(t.get("degrees", REQUIRED, "a finite number"), t.field("degrees"))
    return axis / norm, degrees


def _matrix(v: Any, field: str) -> np.ndarray:
    """4 rows of 4 finite numbers, the last row [0, 0, 0, 1] (affine), the linear part invertible."""
    if not isinstance(v, (list, tuple)) or len(v) != 4:
        raise InputError(field, f"must be 4 rows of 4 finite numbers, got {show(v)}")
    m = np.array([numbers(row, f"{field}[{i}]", 4) for i, row in enumerate(v)])
    if not np.array_equal(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise InputError(f"{field}[3]", f"must be [0, 0, 0, 1] (an affine transform; projective "
                                        f"ones are not supported), got {show(v[3])}")
    lengths = np.linalg.norm(m[:3, :3], axis=0)
    det = float(np.linalg.det(m[:3, :3]))
    if not (math.isfinite(det) and abs(det) > _SINGULAR_TOL * float(np.prod(lengths))):
        raise InputError(field, f"is singular (determinant {det:g} of its 3x3 part): a transform "
                                "must be invertible")
    return m


PARALLEL_TOL = 1e-9        # |a x b| <= tol * |a| |b| counts as parallel


def parallel(a: np.ndarray, b: np.ndarray) -> bool:
    """True when a and b are parallel or either is zero (relative test, safe against overflow)."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na == 0.0 or nb == 0.0 or not (np.isfinite(na) and np.isfinite(nb)):
        return True
    return float(np.linalg.norm(np.cross(a / na, b / nb))) <= PARALLEL_TOL
