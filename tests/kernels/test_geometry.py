"""Ray-shape intersection exactness: `hit_sphere` and `hit_quad` (kernels/intersection/primitives.py) evaluated on
arrays of rays by a small Warp kernel, against float64 closed forms computed from the very float32
values the kernel receives. Covers rays from outside and inside, grazing rays on both sides of the
tangent, rays starting exactly on the surface, quad edges and corners, and watertightness of a box's
shared edges and corners."""
from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from drtlab.kernels.intersection.primitives import hit_quad, hit_sphere
from drtlab.warp_runtime import warp as _wp
from drtlab.kernels.scene_model.scene_tables import box_quads

TMAX = np.float32(1.0e30)
REL = 1e-5


@wp.kernel(enable_backward=False)
def sphere_rays(o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), c: wp.array(dtype=wp.vec3),
                r: wp.array(dtype=float), tmax: float, out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = hit_sphere(o[i], d[i], c[i], r[i], tmax)


@wp.kernel(enable_backward=False)
def quad_rays(o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3), q0: wp.array(dtype=wp.vec3),
              eu: wp.array(dtype=wp.vec3), ev: wp.array(dtype=wp.vec3), tmax: float,
              out: wp.array(dtype=float)):
    i = wp.tid()
    out[i] = hit_quad(o[i], d[i], q0[i], eu[i], ev[i], tmax)


@wp.kernel(enable_backward=False)
def scene_quads_rays(o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3),
                     q0: wp.array(dtype=wp.vec3), eu: wp.array(dtype=wp.vec3),
                     ev: wp.array(dtype=wp.vec3), n_quads: int, tmax: float,
                     out_t: wp.array(dtype=float), out_index: wp.array(dtype=int)):
    # Nearest hit over all quads, as the tracer's `intersect` does it.
    i = wp.tid()
    best = tmax
    index = int(-1)
    for k in range(n_quads):
        t = hit_quad(o[i], d[i], q0[k], eu[k], ev[k], best)
        if t < best:
            best = t
            index = k
    out_t[i] = best
    out_index[i] = index


@pytest.fixture(scope="module", autouse=True)
def warp_ready():
    _wp()


def f32(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.float64).reshape(-1, 3).astype(np.float32))


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def launch_spheres(o, d, c, r, tmax=TMAX) -> np.ndarray:
    o, d, c = f32(o), f32(d), f32(c)
    r = np.broadcast_to(np.asarray(r, dtype=np.float32), (len(o),)).copy()
    c = np.broadcast_to(c, o.shape).copy() if len(c) == 1 else c
    out = wp.zeros(len(o), dtype=float, device="cpu")
    wp.launch(sphere_rays, dim=len(o), device="cpu",
              inputs=[wp.array(o, dtype=wp.vec3, device="cpu"), wp.array(d, dtype=wp.vec3, device="cpu"),
                      wp.array(c, dtype=wp.vec3, device="cpu"), wp.array(r, dtype=float, device="cpu"),
                      float(tmax), out])
    return out.numpy()


def launch_quads(o, d, q0, eu, ev, tmax=TMAX) -> np.ndarray:
    o, d = f32(o), f32(d)
    n = len(o)
    q0, eu, ev = (np.broadcast_to(f32(a), (n, 3)).copy() for a in (q0, eu, ev))
    out = wp.zeros(n, dtype=float, device="cpu")
    wp.launch(quad_rays, dim=n, device="cpu",
              inputs=[wp.array(a, dtype=wp.vec3, device="cpu") for a in (o, d, q0, eu, ev)]
              + [float(tmax), out])
    return out.numpy()


def launch_scene_quads(o, d, quads) -> tuple[np.ndarray, np.ndarray]:
    o, d = f32(o), f32(d)
    q0 = f32([q.origin for q in quads])
    eu = f32([q.edge_u for q in quads])
    ev = f32([q.edge_v for q in quads])
    out_t = wp.zeros(len(o), dtype=float, device="cpu")
    out_i = wp.zeros(len(o), dtype=int, device="cpu")
    wp.launch(scene_quads_rays, dim=len(o), device="cpu",
              inputs=[wp.array(a, dtype=wp.vec3, device="cpu") for a in (o, d, q0, eu, ev)]
              + [len(quads), float(TMAX), out_t, out_i])
    return out_t.numpy(), out_i.numpy()


def sphere_reference(o, d, c, r) -> np.ndarray:
    """Nearest positive root of |o + t d - c| = r in float64, from the float32 inputs; inf on a miss."""
    o, d, c = (f32(a).astype(np.float64) for a in (o, d, c))
    c = np.broadcast_to(c, o.shape)
    r = np.broadcast_to(np.asarray(r, dtype=np.float32).astype(np.float64), (len(o),))
    a = np.einsum("ij,ij->i", d, d)
    f = o - c
    b = np.einsum("ij,ij->i", f, d) / a                      # t of the closest approach is -b
    perp = f - d * b[:, None]
    disc = (r * r - np.einsum("ij,ij->i", perp, perp)) / a
    with np.errstate(invalid="ignore"):
        sq = np.sqrt(disc)
    near, far = -b - sq, -b + sq
    t = np.where(near > 0, near, np.where(far > 0, far, np.inf))
    return np.where(disc >= 0, t, np.inf)


def random_directions(rng, n) -> np.ndarray:
    return unit(rng.normal(size=(n, 3)))


def perpendicular_frame(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.where(np.abs(d[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = unit(np.cross(d, helper))
    return e1, np.cross(d, e1)


# ---------------------------------------------------------------------------------------------------
# Spheres
# ---------------------------------------------------------------------------------------------------

def aimed_rays(rng, n, centres, radii, aim_fraction, distance_in_radii):
    """Rays from outside whose line passes at aim_fraction * r from the centre."""
    d = random_directions(rng, n)
    e1, e2 = perpendicular_frame(d)
    phi = rng.uniform(0, 2 * np.pi, n)
    offset = (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2) * (aim_fraction * radii)[:, None]
    o = centres + offset - d * (distance_in_radii * radii)[:, None]
    return o, d


def test_sphere_hits_from_outside_match_closed_form():
    rng = np.random.default_rng(1)
    n = 4000
    centres = rng.uniform(-50, 50, size=(n, 3))
    radii = 10.0 ** rng.uniform(-2, 2, n)
    o, d = aimed_rays(rng, n, centres, radii, rng.uniform(0, 0.95, n), rng.uniform(1.5, 40, n))
    t = launch_spheres(o, d, centres, radii)
    ref = sphere_reference(o, d, centres, radii)
    assert np.all(np.isfinite(ref))
    rel = np.abs(t - ref) / ref
    assert rel.max() < REL, f"worst relative error {rel.max():.3g} at ray {rel.argmax()}"


def test_small_sphere_far_away_is_hit_accurately():
    # The Haines et al. form exists for this case: r = 1e-3 seen from 1e3 away.
    rng = np.random.default_rng(2)
    n = 2000
    centres = rng.uniform(-10, 10, size=(n, 3))
    radii = np.full(n, 1.0e-3)
    o, d = aimed_rays(rng, n, centres, radii, rng.uniform(0, 0.5, n), np.full(n, 1.0e6))
    t = launch_spheres(o, d, centres, radii)
    ref = sphere_reference(o, d, centres, radii)
    assert np.all(np.isfinite(ref)) and np.all(t < TMAX)
    assert (np.abs(t - ref) / ref).max() < REL


def test_sphere_misses_and_spheres_behind_return_tmax():
    rng = np.random.default_rng(3)
    n = 2000
    centres = rng.uniform(-5, 5, size=(n, 3))
    radii = 10.0 ** rng.uniform(-1, 1, n)
    o, d = aimed_rays(rng, n, centres, radii, rng.uniform(1.05, 3.0, n), rng.uniform(2, 20, n))
    assert np.all(launch_spheres(o, d, centres, radii) == TMAX)
    # Aimed through the centre but pointing away from it: the sphere is behind the origin.
    o, d = aimed_rays(rng, n, centres, radii, rng.uniform(0, 0.9, n), rng.uniform(1.5, 20, n))
    assert np.all(launch_spheres(o, -d, centres, radii) == TMAX)


def test_sphere_hit_beyond_tmax_is_a_miss():
    o, d, c, r = [[0, 0, 0]], [[0, 0, 1]], [[0, 0, 10]], 1.0
    # Roots at 9 and 11: only (0, tmax) counts, and tmax itself is not inside it.
    assert launch_spheres(o, d, c, r, tmax=8.5)[0] == np.float32(8.5)
    assert launch_spheres(o, d, c, r, tmax=9.0)[0] == np.float32(9.0)
    assert launch_spheres(o, d, c, r, tmax=9.5)[0] == np.float32(9.0)
    # From inside (roots -1 and 1): the far root only if it lies below tmax.
    o_in = [[0, 0, 10.0]]
    assert launch_spheres(o_in, d, c, r, tmax=0.5)[0] == np.float32(0.5)
    assert launch_spheres(o_in, d, c, r, tmax=1.5)[0] == np.float32(1.0)


def test_sphere_rays_from_inside_hit_the_far_side():
    rng = np.random.default_rng(4)
    n = 4000
    centres = rng.uniform(-20, 20, size=(n, 3))
    radii = 10.0 ** rng.uniform(-2, 2, n)
    o = centres + random_directions(rng, n) * (rng.uniform(0, 0.95, n) * radii)[:, None]
    d = random_directions(rng, n)
    t = launch_spheres(o, d, centres, radii)
    ref = sphere_reference(o, d, centres, radii)
    assert np.all(np.isfinite(ref))
    assert (np.abs(t - ref) / ref).max() < REL
    # The exit point is on the sphere.
    p = f32(o).astype(np.float64) + f32(d).astype(np.float64) * t[:, None].astype(np.float64)
    dist = np.linalg.norm(p - f32(centres).astype(np.float64), axis=1)
    assert (np.abs(dist - radii) / radii).max() < 1e-4


@pytest.mark.parametrize("margin", [1e-4, 2e-5])
def test_grazing_rays_hit_inside_and_miss_outside_the_tangent(margin):
    rng = np.random.default_rng(5)
    n = 3000
    centres = rng.uniform(-5, 5, size=(n, 3))
    radii = 10.0 ** rng.uniform(-1, 1, n)
    dist = rng.uniform(1.5, 5, n)
    o_in, d_in = aimed_rays(rng, n, centres, radii, np.full(n, 1.0 - margin), dist)
    o_out, d_out = aimed_rays(rng, n, centres, radii, np.full(n, 1.0 + margin), dist)
    # The closed form (float64 from the float32 rays) agrees with the intent of the construction.
    ref_in = sphere_reference(o_in, d_in, centres, radii)
    assert np.all(np.isfinite(ref_in))
    assert np.all(np.isinf(sphere_reference(o_out, d_out, centres, radii)))
    t_in = launch_spheres(o_in, d_in, centres, radii)
    t_out = launch_spheres(o_out, d_out, centres, radii)
    assert np.all(t_in < TMAX), f"{np.sum(t_in == TMAX)} of {n} rays just inside the tangent missed"
    assert np.all(t_out == TMAX), f"{np.sum(t_out < TMAX)} of {n} rays just outside the tangent hit"
    # Near the tangent the root is ill-conditioned (dt/dh = h / sqrt(r^2 - h^2)), so the float32
    # rounding of the ray alone moves it by more than 1e-5; 1e-4 still pins the distance down.
    assert (np.abs(t_in - ref_in) / ref_in).max() < 1e-4


# Points exactly on a sphere in float32: integer Pythagorean quadruples scaled by powers of two.
_ON_SURFACE = [((3, 4, 0), 5), ((0, 3, 4), 5), ((2, 3, 6), 7), ((1, 4, 8), 9), ((4, 4, 7), 9),
               ((-2, 6, -9), 11), ((6, -6, 7), 11), ((-5, 0, 0), 5)]


@pytest.mark.parametrize("scale", [2.0 ** -6, 1.0, 8.0])
def test_rays_starting_exactly_on_the_surface(scale):
    rng = np.random.default_rng(6)
    centre = np.array([1.5, -2.25, 4.0]) * scale
    o_list, d_list, r_list, cos_list = [], [], [], []
    for p, r in _ON_SURFACE:
        p = np.array(p, dtype=np.float64) * scale
        normal = p / np.linalg.norm(p)
        for d in random_directions(rng, 300):
            cos = float(np.dot(d, normal))
            if abs(cos) < 0.01:
                continue
            o_list.append(centre + p)
            d_list.append(d)
            r_list.append(r * scale)
            cos_list.append(cos)
    o, d, r, cos = np.array(o_list), np.array(d_list), np.array(r_list), np.array(cos_list)
    assert np.array_equal(f32(o).astype(np.float64), o), "surface points are exact in float32"
    inward = cos < 0
    t = launch_spheres(o, d, centre[None, :], r)
    # Leaving the sphere: no hit at all (in particular not t = 0 or a tiny t).
    assert np.all(t[~inward] == TMAX)
    # Entering: the far side, at the chord length -2 (p - c).d (c2 = |p - c|^2 - r^2 is exactly 0).
    d32 = f32(d[inward]).astype(np.float64)
    chord = -2.0 * np.einsum("ij,ij->i", o[inward] - centre, d32) / np.einsum("ij,ij->i", d32, d32)
    rel = np.abs(t[inward] - chord) / chord
    steep = -cos[inward] >= 0.1
    assert rel[steep].max() < REL
    # Within ~6 degrees of the tangent plane the float32 discriminant r^2 - |l|^2 cancels (error
    # ~ eps / cos^2): still a hit on the far side, to a looser tolerance.
    assert np.all(t[inward] < TMAX) and rel[~steep].max() < 1e-3


# ---------------------------------------------------------------------------------------------------
# Quads
# ---------------------------------------------------------------------------------------------------

# An axis-aligned quad with exact binary coordinates: x in [-0.5, 1.0], y in [0.25, 1.0], z = -2,
# normal +z (edge_u x edge_v = (0, 0, 1.125)).
Q0 = np.array([-0.5, 0.25, -2.0])
EU = np.array([1.5, 0.0, 0.0])
EV = np.array([0.0, 0.75, 0.0])


def quad_boundary_points(k=64) -> np.ndarray:
    s = np.arange(k + 1) / k                       # exact multiples of 1/64 -> exact coordinates
    pts = [Q0 + np.outer(s, EU), Q0 + EV + np.outer(s, EU), Q0 + np.outer(s, EV),
           Q0 + EU + np.outer(s, EV)]
    return np.concatenate(pts)


def test_quad_edges_and_corners_are_hit_at_the_exact_distance():
    pts = quad_boundary_points()
    corners = np.array([Q0, Q0 + EU, Q0 + EV, Q0 + EU + EV])
    for p_set in (pts, corners):
        assert np.array_equal(f32(p_set).astype(np.float64), p_set)
        for sign in (1.0, -1.0):                   # from the front and from the back
            o = p_set + np.array([0.0, 0.0, 3.0 * sign])
            d = np.tile([0.0, 0.0, -sign], (len(p_set), 1))
            t = launch_quads(o, d, Q0, EU, EV)
            assert np.all(t == np.float32(3.0)), t[t != np.float32(3.0)]


def oblique_rays_at(rng, pts, min_cos=0.05):
    w = random_directions(rng, len(pts))
    w[:, 2] = np.abs(w[:, 2]) + min_cos            # not grazing: at least ~3 degrees off the plane
    w = unit(w) * np.where(rng.random(len(pts)) < 0.5, 1.0, -1.0)[:, None]
    return pts + w * rng.uniform(0.5, 6.0, len(pts))[:, None]


def test_quad_oblique_rays_exactly_through_edge_points_hit():
    # Origins on a 2^-10 grid and d = p - o (not normalized; hit_quad does not need a unit
    # direction): every value is exact in float32, so the ray passes exactly through the edge point.
    rng = np.random.default_rng(7)
    pts = np.repeat(quad_boundary_points(), 20, axis=0)
    o = np.round(oblique_rays_at(rng, pts) * 1024) / 1024
    d = pts - o
    assert np.array_equal(f32(o).astype(np.float64), o) and np.array_equal(f32(d).astype(np.float64), d)
    t = launch_quads(o, d, Q0, EU, EV)
    missed = t == TMAX
    assert not missed.any(), f"{missed.sum()} of {len(t)} rays through an edge point missed: {pts[missed][:3]}"
    assert np.abs(t - 1.0).max() < REL


def test_quad_oblique_unit_rays_near_edges():
    # Unit directions are rounded to float32, so a ray aimed at an edge point passes a hair inside or
    # outside it. Judge each by where the float32 ray really meets the plane (float64): inside the
    # closed quad -> must hit; more than 1e-5 outside -> must miss.
    rng = np.random.default_rng(11)
    pts = np.repeat(quad_boundary_points(), 20, axis=0)
    o = oblique_rays_at(rng, pts)
    d = unit(pts - o)
    t = launch_quads(o, d, Q0, EU, EV)
    o32, d32 = f32(o).astype(np.float64), f32(d).astype(np.float64)
    t_ref = (Q0[2] - o32[:, 2]) / d32[:, 2]
    hit_point = o32 + d32 * t_ref[:, None]
    s_u = (hit_point[:, 0] - Q0[0]) / EU[0]
    s_v = (hit_point[:, 1] - Q0[1]) / EV[1]
    inside = (s_u >= 0) & (s_u <= 1) & (s_v >= 0) & (s_v <= 1)
    outside = (s_u < -1e-5) | (s_u > 1 + 1e-5) | (s_v < -1e-5) | (s_v > 1 + 1e-5)
    assert inside.sum() > len(t) // 4
    missed = inside & (t == TMAX)
    assert not missed.any(), f"{missed.sum()} rays through the closed quad missed"
    assert np.all(t[outside] == TMAX)
    assert (np.abs(t[inside] - t_ref[inside]) / t_ref[inside]).max() < REL


def test_quad_rays_just_outside_miss():
    pts, outward = [], []
    s = np.arange(1, 64) / 64
    for base, edge, out in ((Q0, EU, (0, -1, 0)), (Q0 + EV, EU, (0, 1, 0)),
                            (Q0, EV, (-1, 0, 0)), (Q0 + EU, EV, (1, 0, 0))):
        pts.append(base + np.outer(s, edge))
        outward.append(np.tile(out, (len(s), 1)))
    corners = np.array([Q0, Q0 + EU, Q0 + EV, Q0 + EU + EV])
    centre = Q0 + 0.5 * (EU + EV)
    corner_out = np.sign(corners - centre) * np.array([1.0, 1.0, 0.0])
    pts = np.concatenate(pts + [corners, corners, corners])
    outward = np.concatenate(outward + [corner_out * [1, 0, 0], corner_out * [0, 1, 0], corner_out])
    targets = pts + 1.0e-3 * outward
    for sign in (1.0, -1.0):
        o = targets + np.array([0.0, 0.0, 3.0 * sign])
        d = np.tile([0.0, 0.0, -sign], (len(targets), 1))
        t = launch_quads(o, d, Q0, EU, EV)
        assert np.all(t == TMAX), targets[t != TMAX]
    # ... while the same rays moved 1e-3 inwards hit.
    inside = pts - 1.0e-3 * outward
    t = launch_quads(inside + [0.0, 0.0, 3.0], np.tile([0.0, 0.0, -1.0], (len(inside), 1)), Q0, EU, EV)
    assert np.all(t == np.float32(3.0))


def test_quad_parallel_rays_miss():
    rng = np.random.default_rng(8)
    n = 500
    d = random_directions(rng, n)
    d[:, 2] = 0.0                                  # parallel to the plane z = -2
    d = unit(d)
    for z in (-2.0, -1.5, -2.5):                   # in the plane and beside it
        o = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), np.full(n, z)])
        assert np.all(launch_quads(o, d, Q0, EU, EV) == TMAX)


def test_quad_behind_or_beyond_tmax_is_a_miss():
    centre = Q0 + 0.5 * (EU + EV)
    o = [centre + [0, 0, 3.0]]
    assert launch_quads(o, [[0, 0, 1.0]], Q0, EU, EV)[0] == TMAX              # quad behind
    assert launch_quads(o, [[0, 0, -1.0]], Q0, EU, EV, tmax=2.5)[0] == np.float32(2.5)
    assert launch_quads(o, [[0, 0, -1.0]], Q0, EU, EV, tmax=3.5)[0] == np.float32(3.0)


def test_general_parallelogram_hit_distance_and_bounds():
    # A slanted parallelogram: the ray through origin + s*eu + t*ev hits iff s, t in [0, 1].
    rng = np.random.default_rng(9)
    q0 = np.array([0.3, -1.2, 0.7])
    eu = np.array([1.1, 0.4, -0.2])
    ev = np.array([0.3, 0.9, 0.8])
    n = np.cross(eu, ev)
    n /= np.linalg.norm(n)
    k = 4000
    st = rng.uniform(-0.5, 1.5, size=(k, 2))
    inside = np.all((st > 0.01) & (st < 0.99), axis=1)
    outside = np.any((st < -0.01) | (st > 1.01), axis=1)
    p = q0 + st[:, :1] * eu + st[:, 1:] * ev
    w = unit(rng.normal(size=(k, 3)))
    w = unit(w + n * (np.sign(w @ n) * 0.3)[:, None])  # at least ~17 degrees off the plane
    o = p + w * rng.uniform(0.5, 10, k)[:, None]
    t = launch_quads(o, -w, q0, eu, ev)
    assert np.all(t[outside] == TMAX)
    assert np.all(t[inside] < TMAX)
    o32, d32 = f32(o).astype(np.float64), f32(-w).astype(np.float64)
    q32, eu32, ev32 = (f32(a)[0].astype(np.float64) for a in (q0, eu, ev))
    nn = np.cross(eu32, ev32)
    ref = ((q32 - o32) @ nn) / (d32 @ nn)
    assert (np.abs(t[inside] - ref[inside]) / ref[inside]).max() < REL


# ---------------------------------------------------------------------------------------------------
# Watertightness: a box's shared edges and corners
# ---------------------------------------------------------------------------------------------------

# Coordinates that are not exact in float32, so the faces' shared edges agree only up to rounding.
BOX_LO = np.array([-0.3, 0.2, -1.1])
BOX_HI = np.array([0.7, 1.45, 0.4])


def box_faces():
    return box_quads(BOX_LO, BOX_HI, material=0, name="box")


def side_value(axis: int, sign: float) -> float:
    return BOX_HI[axis] if sign > 0 else BOX_LO[axis]


def box_edges():
    """(i, si, j, sj, k, point on the edge) for the 12 edges at a few positions along each."""
    for i in range(3):
        for j in range(i + 1, 3):
            k = 3 - i - j
            for si in (-1.0, 1.0):
                for sj in (-1.0, 1.0):
                    for frac in (0.1, 0.37, 0.5, 0.83):
                        base = np.zeros(3)
                        base[i] = side_value(i, si)
                        base[j] = side_value(j, sj)
                        base[k] = BOX_LO[k] + frac * (BOX_HI[k] - BOX_LO[k])
                        yield i, si, j, sj, k, base


def edge_sweep_rays(offsets):
    """Rays aimed at points swept across each of the 12 edges, from outside both faces: offset < 0
    is on face i (|offset| from the edge), offset > 0 on face j."""
    origins, dirs, targets = [], [], []
    angles = np.radians([5.0, 30.0, 45.0, 60.0, 85.0])
    for i, si, j, sj, k, base in box_edges():
        pts = np.tile(base, (len(offsets), 1))
        on_i = offsets < 0                     # on face i: move along j into the box
        pts[on_i, j] -= sj * np.abs(offsets[on_i])
        pts[~on_i, i] -= si * offsets[~on_i]
        for a in angles:
            for tilt in (-0.4, 0.0, 0.7):
                w = np.zeros(3)
                w[i] = si * np.cos(a)
                w[j] = sj * np.sin(a)
                w[k] = tilt
                w = unit(w)
                origins.append(pts + w * 3.0)
                dirs.append(np.tile(-w, (len(pts), 1)))
                targets.append(pts)
    return np.concatenate(origins), np.concatenate(dirs), np.concatenate(targets)


def edge_grazing_rays(gap):
    """Rays passing `gap` outside each edge, perpendicular to the bisector of its faces' normals:
    they come within ~gap of both faces but never reach the box."""
    origins, dirs = [], []
    for i, si, j, sj, k, base in box_edges():
        bisector = np.zeros(3)
        bisector[i], bisector[j] = si, sj
        bisector = unit(bisector)
        across = np.zeros(3)
        across[i], across[j] = si, -sj
        across = unit(across)
        p = base + gap * bisector
        for b in np.radians([0.0, 20.0, 50.0, 80.0]):
            for sign in (-1.0, 1.0):
                w = np.cos(b) * across * sign
                w[k] += np.sin(b)
                origins.append(p - 2.0 * w)
                dirs.append(w)
    return np.array(origins), np.array(dirs)


def corner_sweep_rays(offsets):
    """Rays aimed at points near each of the 8 corners, on each of the three faces meeting there."""
    rng = np.random.default_rng(10)
    origins, dirs, targets = [], [], []
    grid = np.array([(a, b) for a in offsets for b in offsets])
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                sign = np.array([sx, sy, sz])
                corner = np.array([side_value(0, sx), side_value(1, sy), side_value(2, sz)])
                for face_axis in range(3):
                    a, b = [x for x in range(3) if x != face_axis]
                    pts = np.tile(corner, (len(grid), 1))
                    pts[:, a] -= sign[a] * grid[:, 0]
                    pts[:, b] -= sign[b] * grid[:, 1]
                    for _ in range(6):
                        w = unit(sign * rng.uniform(0.15, 1.0, 3))
                        origins.append(pts + w * 2.5)
                        dirs.append(np.tile(-w, (len(pts), 1)))
                        targets.append(pts)
    return np.concatenate(origins), np.concatenate(dirs), np.concatenate(targets)


def test_box_faces_share_edges_up_to_float32_rounding():
    # The premise of the watertightness tests: the faces' corners are not bit-identical in float32.
    corners = {}
    for q in box_faces():
        for c in (q.origin, q.origin + q.edge_u, q.origin + q.edge_v, q.origin + q.edge_u + q.edge_v):
            corners.setdefault(tuple(np.round(c, 9)), set()).add(tuple(f32(c)[0]))
    assert len(corners) == 8


def assert_hits_near_side(o, d, p, what):
    # A ray slipping through a crack would hit a face on the far side of the (closed) box, or nothing.
    t, idx = launch_scene_quads(o, d, box_faces())
    ref = np.linalg.norm(f32(p).astype(np.float64) - f32(o).astype(np.float64), axis=1)
    leaked = (idx < 0) | (np.abs(t - ref) > REL * ref)
    assert not leaked.any(), (f"{leaked.sum()} of {len(t)} rays through box {what} slipped through "
                              f"({np.sum(idx < 0)} missed the box), e.g. aimed at {p[leaked][:3]}")


def test_box_edges_are_watertight():
    offsets = np.concatenate([-np.geomspace(1e-3, 1e-9, 40), [0.0], np.geomspace(1e-9, 1e-3, 40)])
    o, d, p = edge_sweep_rays(offsets)
    assert_hits_near_side(o, d, p, "edges")


def test_box_corners_are_watertight():
    offsets = np.concatenate([[0.0], np.geomspace(1e-9, 1e-3, 12)])
    o, d, p = corner_sweep_rays(offsets)
    assert_hits_near_side(o, d, p, "corners")


def test_rays_just_outside_box_edges_miss():
    # The edge tolerance must stay tiny: rays passing 1e-3 outside an edge see no face, while the
    # same rays moved 1e-3 inside the edge hit it.
    o, d = edge_grazing_rays(1e-3)
    _, idx = launch_scene_quads(o, d, box_faces())
    assert np.all(idx < 0)
    o, d = edge_grazing_rays(-1e-3)
    _, idx = launch_scene_quads(o, d, box_faces())
    assert np.all(idx >= 0)
