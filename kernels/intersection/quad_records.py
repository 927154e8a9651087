"""Per-shape data computed once at upload so that ray tests do not recompute it: quad records and
groups of quads that are faces of one parallelepiped (boxes).

* `quad_geometry(origin, edge_u, edge_v, device)` -> QuadGeom records: per quad its corner and edges
  with the unnormalised normal edge_u x edge_v and the parameter basis w = cross / |cross|^2,
  computed by a Warp kernel with the very expressions `geometry.hit_quad` evaluates, so a test
  reading them gets bit-identical values, in one record (one address computation per test).
* `quad_groups(quads, t_open)` -> QuadGroups: the quads as groups in index order. A run of three to
  six consecutive quads that are distinct faces of one parallelepiped and move with one velocity (a
  box expanded by the loader or written face by face, the five walls of an open room) is one group,
  tested by `geometry.hit_box` (a slab test: the first face a ray meets is where it enters the
  parallelepiped, or else where it leaves it) instead of one plane test per face; every other quad
  is a group of its own. A face then reports the same hit as its quad up to float rounding.
"""
from dataclasses import dataclass, field

import numpy as np
import warp as wp

from drtlab.kernels.intersection.primitives import BOX_NO_FACE, QuadGeom, quad_basis

BOX_FACES = 6
# Fewer faces than this stay single quads: a slab test costs about as much as two plane tests.
MIN_BOX_FACES = 3
# Corners within this of a parallelepiped's (relative to its shortest edge) are its corners: far
# below float32 resolution, so the slab test sees the quads' own geometry up to rounding.
_BOX_TOLERANCE = 1e-7


@wp.kernel(enable_backward=False)
def _geom_kernel(q0: wp.array(dtype=wp.vec3), eu: wp.array(dtype=wp.vec3),
                 ev: wp.array(dtype=wp.vec3), out: wp.array(dtype=QuadGeom)):
    i = wp.tid()
    g = QuadGeom()
    g.origin = q0[i]
    g.edge_u = eu[i]
    g.edge_v = ev[i]
    g.cross = wp.cross(eu[i], ev[i])
    g.basis = quad_basis(g.cross)
    out[i] = g


def quad_geometry(origin: wp.array, edge_u: wp.array, edge_v: wp.array, device: str) -> wp.array:
    """The QuadGeom records of the uploaded quads (computed on `device`, as the ray tests would)."""
    out = wp.empty(origin.shape[0], dtype=QuadGeom, device=device)
    wp.launch(_geom_kernel, dim=origin.shape[0], inputs=[origin, edge_u, edge_v, out],
              device=device)
    return out


@dataclass
class QuadGroups:
    quad: list = field(default_factory=list)      # a single quad's index, -1 for a box
    corner: list = field(default_factory=list)    # box: the parallelepiped's corner at shutter open
    inverse: list = field(default_factory=list)   # box: local = inverse @ (x - corner) in [0, 1]^3
    ball: list = field(default_factory=list)      # box: (centre, radius) of a ball holding it
    rank: list = field(default_factory=list)      # box: geometry.hit_box's face ranks
    faces: list = field(default_factory=list)     # box: 6 quad indices by 2 * axis + side (or -1)
    velocity: list = field(default_factory=list)  # shared by the group's quads
    group_of: list = field(default_factory=list)  # per quad: its group


def _corners(q) -> np.ndarray:
    return np.array([q.origin, q.origin + q.edge_u, q.origin + q.edge_v,
                     q.origin + q.edge_u + q.edge_v], dtype=np.float64)


def _unit_cube_faces() -> list:
    """The unit cube's faces, by slot 2 * axis + side, as arrays of their four corners."""
    faces = []
    for axis in range(3):
        for side in (0.0, 1.0):
            pts = []
            for s in (0.0, 1.0):
                for t in (0.0, 1.0):
                    p = [s, t]
                    p.insert(axis, side)
                    pts.append(p)
            faces.append(np.array(pts))
    return faces


_CUBE = _unit_cube_faces()


def _slots(faces: list, o: np.ndarray, m: np.ndarray, tol: float) -> list | None:
    """Each quad's face slot on the parallelepiped o + m [0, 1]^3, or None if one is not a face."""
    slots = []
    for f in faces:
        corners = _corners(f)
        slot = None
        for k, cube in enumerate(_CUBE):
            box = o + cube @ m.T
            d = np.linalg.norm(corners[:, None, :] - box[None, :, :], axis=2)
            if np.all(d.min(axis=1) <= tol) and np.all(d.min(axis=0) <= tol):
                slot = k
                break
        if slot is None or slot in slots:
            return None
        slots.append(slot)
    return slots


def _axis_order(o: np.ndarray, m: np.ndarray) -> tuple:
    """An axis-aligned box described along +x, +y, +z (edges = columns of m), so that its inverse
    is diagonal (geometry.hit_aligned_box); any other parallelepiped unchanged."""
    axes = np.argmax(np.abs(m), axis=0)
    if sorted(axes) != [0, 1, 2] or np.count_nonzero(m) != 3:
        return o, m
    m = m[:, np.argsort(axes)]
    signs = np.sign(np.diag(m))
    return o + m @ ((1 - signs) / 2), m * signs


def parallelepiped(faces: list) -> tuple | None:
    """(corner, edge matrix, face slots) when the quads are distinct faces of one parallelepiped
    moving with one velocity, else None. The first quad fixes two edges; the third comes from a
    corner of another quad off its plane (each of its possible positions tried)."""
    if any(np.any(f.velocity != faces[0].velocity) for f in faces):
        return None
    o, a, b = faces[0].origin, faces[0].edge_u, faces[0].edge_v
    n = np.cross(a, b)
    n /= np.linalg.norm(n)
    pts = np.concatenate([_corners(f) for f in faces[1:]])
    off = pts[np.abs((pts - o) @ n) > 1e-6 * max(np.linalg.norm(a), np.linalg.norm(b))]
    if len(off) == 0:
        return None
    p = off[np.argmax(np.abs((off - o) @ n))]
    for u in (0.0, 1.0):
        for v in (0.0, 1.0):
            m = np.column_stack([a, b, p - o - u * a - v * b])
            lengths = np.linalg.norm(m, axis=0)
            if abs(np.linalg.det(m)) <= 1e-6 * np.prod(lengths):
                continue
            corner, m = _axis_order(o, m)
            slots = _slots(faces, corner, m, _BOX_TOLERANCE * lengths.min())
            if slots is not None:
                return corner, m, slots
    return None


def _ball(corner: np.ndarray, m: np.ndarray) -> np.ndarray:
    """(centre, radius) of a ball around the parallelepiped corner + m [0, 1]^3, the radius grown
    by 1e-4 and by float32's rounding of the corners' coordinates (the kernels see those)."""
    centre = corner + m @ np.full(3, 0.5)
    vertices = corner + np.array(np.meshgrid([0, 1], [0, 1], [0, 1])).reshape(3, -1).T @ m.T
    radius = np.linalg.norm(vertices - centre, axis=1).max()
    radius = radius * (1 + 1e-4) + 1e-6 * np.abs(vertices).max()
    return np.append(centre, radius)


def _ranks(faces: list) -> int:
    """hit_box's `rank`: 3 bits per slot, the face's place in quad order (BOX_NO_FACE if none)."""
    order = sorted(q for q in faces if q >= 0)
    return sum((order.index(q) if q >= 0 else int(BOX_NO_FACE)) << (3 * slot)
               for slot, q in enumerate(faces))


def quad_groups(quads: list, t_open: float) -> QuadGroups:
    """Longest runs (3 to 6 quads) of consecutive faces of one parallelepiped as boxes; the others
    alone."""
    g = QuadGroups()
    i = 0
    while i < len(quads):
        # Any three faces fix the parallelepiped, so a run grows one quad at a time while it fits.
        count = MIN_BOX_FACES
        box = parallelepiped(quads[i:i + count]) if i + count <= len(quads) else None
        while box is not None and count < BOX_FACES and i + count < len(quads):
            longer = parallelepiped(quads[i:i + count + 1])
            if longer is None:
                break
            box, count = longer, count + 1
        faces = [-1] * BOX_FACES
        if box is None:
            count = 1
            g.quad.append(i)
            g.corner.append(np.zeros(3))
            g.inverse.append(np.zeros((3, 3)))
            g.ball.append(np.zeros(4))
        else:
            corner, m, slots = box
            for k, slot in enumerate(slots):
                faces[slot] = i + k
            g.quad.append(-1)
            corner = corner + quads[i].velocity * t_open if t_open != 0.0 else corner
            g.corner.append(corner)
            g.inverse.append(np.linalg.inv(m))
            # An open box (a room) usually holds the rays it is tested with: no ball test.
            g.ball.append(_ball(corner, m) if len(box[2]) == BOX_FACES else -np.ones(4))
        g.velocity.append(quads[i].velocity)
        g.rank.append(_ranks(faces))
        g.faces += faces
        g.group_of += [len(g.quad) - 1] * count
        i += count
    return g


def vector_lanes(g: QuadGroups) -> tuple[list, list]:
    """How the CPU's vector test (kernels/intersection/quad_simd.py) splits the groups: (the quads
    it tests, one lane each: lone quads and the faces of open boxes, in index order; the groups
    still tested by a slab test: closed boxes, which a bounding-ball test usually skips for less
    than a lane costs)."""
    lanes, boxes = [], []
    for k, quad in enumerate(g.quad):
        if quad >= 0:
            lanes.append(quad)
        elif g.ball[k][3] < 0.0:
            lanes += [f for f in g.faces[6 * k:6 * k + 6] if f >= 0]
        else:
            boxes.append(k)
    return sorted(lanes), boxes
