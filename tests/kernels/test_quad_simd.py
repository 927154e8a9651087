"""The CPU's vector quad test (kernels/intersection/quad_simd.py) against the scalar grouped tests
(the CUDA path), ray for ray, on the built-in scenes whose renders use it and on a scene of moving
quads: rays aimed at where the two could part - the quads' vertices, points on their edges (the
tolerance band), their interiors, grazing directions - plus rays from inside the scene in every
direction. Nearest hits must be the same quad with the same t up to rounding; where they name
different quads the two hits must be at one distance (a tie, which each path breaks by its own
scan order) or the ray must pass within rounding of an edge. Shadow rays toward a point on a lone
quad (a light sample's target) must get the same answer away from edges and ties."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import warp as wp

from drtlab.kernels.device_scene import QUAD, SceneData
from drtlab.kernels.scene_upload import upload, uses_vector_quads
from drtlab.kernels.features import features_of
from drtlab.kernels.intersection.motion import make_motion
from drtlab.kernels.intersection.quad_records import quad_groups, vector_lanes
from drtlab.kernels.intersection.quad_simd import LANES, quad_pack
from drtlab.kernels.intersection.scene_rays import make_intersect
from drtlab.kernels.scene_model.scene_file import load_scene

# Built-in scenes with 2-8 lanes, open boxes (cornell-box) and closed ones (dof, translucency).
SCENES = ("aa-edges", "cornell-box", "veach-mis", "dof", "translucency", "motion-blur")
_kernels: dict = {}


def _kernel(f):
    if f not in _kernels:
        rays = make_intersect(f, motion=make_motion())

        @wp.kernel(enable_backward=False, module="unique")
        def k(sd: SceneData, o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3),
              dist: wp.array(dtype=float), target: wp.array(dtype=int), dt: float,
              out_t: wp.array(dtype=float), out_index: wp.array(dtype=int),
              out_lit: wp.array(dtype=int)):
            i = wp.tid()
            h = rays.intersect(sd, o[i], d[i], 1.0e30, dt)
            out_t[i] = h.t
            out_index[i] = h.index * 4 + h.kind
            out_lit[i] = rays.visible(sd, o[i], d[i], dist[i], dt, QUAD, target[i])

        _kernels[f] = k
    return _kernels[f]


def _trace(scene, f, o, d, dist, target, dt=0.0):
    sd = upload(scene, "cpu")
    n = len(o)
    args = [wp.array(np.ascontiguousarray(x, dtype=np.float32), dtype=wp.vec3) for x in (o, d)]
    args += [wp.array(np.asarray(dist, np.float32), dtype=float),
             wp.array(np.asarray(target, np.int32), dtype=int)]
    outs = [wp.zeros(n, dtype=t) for t in (float, int, int)]
    wp.launch(_kernel(f), dim=n, inputs=[sd, *args, dt, *outs])
    return [x.numpy() for x in outs]


def _rays(scene, rng, n=4000):
    """Origins inside the scene's bounds and, per quad, rays at its vertices, edges and interior;
    each with a shadow-ray target: a point on a lone quad (a lane) and its distance; and which rays
    were aimed at an edge or vertex, or graze a quad."""
    quads = [s for s in scene.shapes if s.kind == "quad"]
    corners = np.array([c for q in quads for c in (q.origin, q.origin + q.edge_u,
                                                    q.origin + q.edge_v,
                                                    q.origin + q.edge_u + q.edge_v)])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    pad = 0.05 * (hi - lo).max()
    o = rng.uniform(lo - pad, hi + pad, size=(n, 3))
    lanes = vector_lanes(quad_groups(quads, float(scene.camera.shutter[0])))[0]
    target = rng.choice(lanes, size=n)
    # Aim: a quarter at vertices, a quarter at edges (s in [0, 1], t in {0, 1}), the rest inside;
    # the target quad's point doubles as the shadow ray's end.
    st = rng.random((n, 2))
    kind = rng.integers(0, 4, n)
    st[kind == 0] = np.round(st[kind == 0])
    st[kind == 1, 1] = np.round(st[kind == 1, 1])
    aim_quad = np.where(rng.random(n) < 0.5, target, rng.integers(0, len(quads), n))
    aim = np.array([quads[q].origin + s * quads[q].edge_u + t * quads[q].edge_v
                    for q, (s, t) in zip(aim_quad, st)])
    d = aim - o
    dist = np.linalg.norm(d, axis=1)
    d /= dist[:, None]
    # A tenth of the rays grazing: along a target quad's edge from just above its plane.
    g = rng.random(n) < 0.1
    for i in np.flatnonzero(g):
        q = quads[aim_quad[i]]
        nrm = np.cross(q.edge_u, q.edge_v)
        nrm /= np.linalg.norm(nrm)
        o[i] = aim[i] - q.edge_u * 0.5 + nrm * 1e-4
        d[i] = q.edge_u / np.linalg.norm(q.edge_u)
        dist[i] = np.linalg.norm(aim[i] - o[i])
    return o, d, dist, target, (kind <= 1) | g


def _edge_margin(scene, quad: int, o, d) -> float:
    """How far (in the quad's own s, t, float64) the ray's point in quad's plane lies from its
    boundary: rays within rounding of an edge may hit with one test and miss with the other."""
    q = [s for s in scene.shapes if s.kind == "quad"][quad]
    n = np.cross(q.edge_u, q.edge_v)
    rel = o + d * (np.dot(n, q.origin - o) / np.dot(n, d)) - q.origin
    w = n / np.dot(n, n)
    s, t = np.dot(w, np.cross(rel, q.edge_v)), np.dot(w, np.cross(q.edge_u, rel))
    return min(abs(s), abs(1 - s), abs(t), abs(1 - t))


def _assert_agree(scene, o, d, edge, vector, scalar) -> np.ndarray:
    """Hits the same, or a disagreement explained by a tie (two quads at one distance: coplanar
    faces, such as a box's bottom on the floor, where the CPU's test gives a closed box the tie and
    the grouped scan the lower group) or by an edge within rounding. Returns the explained rays."""
    (t_v, i_v), (t_s, i_s) = vector, scalar
    hit_v, hit_s = t_v < 1e29, t_s < 1e29
    assert hit_s.mean() > 0.5
    # Rounding of a hit's t scales with the distance and with the origin's magnitude.
    rel = np.abs(t_v - t_s) / np.maximum(t_s, np.abs(o).max(axis=1))
    differ = (hit_v != hit_s) | (hit_v & hit_s & (i_v != i_s))
    tie = differ & hit_v & hit_s & (rel < 2e-5)
    for k in np.flatnonzero(differ & ~tie):
        assert edge[k], f"ray {k} away from edges: {t_v[k]} {i_v[k]} against {t_s[k]} {i_s[k]}"
        quads = [i // 4 for i, h in ((i_v[k], hit_v[k]), (i_s[k], hit_s[k])) if h]
        margin = min(_edge_margin(scene, q, o[k].astype(np.float64), d[k].astype(np.float64))
                     for q in quads)
        assert margin < 1e-5, f"ray {k}: {margin} from the nearest edge"
    # The same quad: t to rounding (the vector test's plane rows are rounded from float64), which
    # grows as 1 / |cos| of the angle to the quad's normal.
    same = hit_v & hit_s & (i_v == i_s)
    assert same.sum() > 0.9 * hit_s.sum()
    quads = [s for s in scene.shapes if s.kind == "quad"]
    normals = np.array([np.cross(q.edge_u, q.edge_v) / np.linalg.norm(np.cross(q.edge_u, q.edge_v))
                        for q in quads])
    cos = np.abs(np.einsum("ij,ij->i", normals[i_s[same] // 4], d[same]))
    assert (rel[same] * cos).max() < 2e-5
    return differ


def _features(scene, simd: bool):
    return replace(features_of(scene, "path"), quad_simd=simd)


@pytest.mark.parametrize("name", SCENES)
def test_vector_test_matches_grouped_tests(name):
    scene = load_scene(name)
    assert uses_vector_quads(scene, "cpu") and not uses_vector_quads(scene, "cuda"), name
    rng = np.random.default_rng(11)
    o, d, dist, target, edge = _rays(scene, rng)
    t_v, i_v, lit_v = _trace(scene, _features(scene, True), o, d, dist, target)
    t_s, i_s, lit_s = _trace(scene, _features(scene, False), o, d, dist, target)
    differ = _assert_agree(scene, o, d, edge, (t_v, i_v), (t_s, i_s))
    # Shadow rays towards a lane: the same answer away from edges and ties.
    calm = ~edge & ~differ
    assert np.array_equal(lit_v[calm], lit_s[calm])
    assert calm.mean() > 0.4
    assert 0.05 < lit_s.mean() < 0.95


def test_moving_quads_match():
    scene = load_scene("motion-blur")
    f = features_of(scene, "path")
    assert f.motion
    rng = np.random.default_rng(5)
    o, d, dist, target, edge = _rays(scene, rng, n=2000)
    for dt in (0.0, 0.37):
        t_v, i_v, _ = _trace(scene, replace(f, quad_simd=True), o, d, dist, target, dt)
        t_s, i_s, _ = _trace(scene, replace(f, quad_simd=False), o, d, dist, target, dt)
        hit = t_s < 1e29
        # Away from edges (which move with the quads: the margin test above does not apply).
        assert np.array_equal((t_v < 1e29)[~edge], hit[~edge])
        same = (i_v == i_s) & hit & (t_v < 1e29)
        assert same[~edge].sum() == hit[~edge].sum()
        rel = np.abs(t_v[same] - t_s[same]) / np.maximum(t_s[same], 1e-30)
        assert rel.max() < 2e-5


def test_pack_layout():
    """Lanes are the lone quads and open boxes' faces in index order; closed boxes stay groups;
    the pack has one block per LANES lanes and padding lanes that no ray can hit (index -1)."""
    scene = load_scene("cornell-box")
    quads = [s for s in scene.shapes if s.kind == "quad"]
    groups = quad_groups(quads, 0.0)
    lanes, boxes = vector_lanes(groups)
    # The light (quad 0) and the room's five walls are lanes; the two closed boxes are not.
    assert lanes == [0, 1, 2, 3, 4, 5]
    assert len(boxes) == 2 and all(groups.quad[g] < 0 and groups.ball[g][3] > 0 for g in boxes)
    pack, blocks = quad_pack(lanes, *(np.array([getattr(q, a) for q in quads])
                                      for a in ("origin", "edge_u", "edge_v", "velocity")))
    assert blocks == -(-len(lanes) // LANES)
    rows = pack.reshape(blocks, -1, LANES)
    index = rows[:, -1, :].ravel()
    assert list(index[:len(lanes)]) == lanes and np.all(index[len(lanes):] == -1)
    normals = rows[:, 3:6, :].transpose(0, 2, 1).reshape(-1, 3)
    assert np.all(normals[len(lanes):] == 0)
