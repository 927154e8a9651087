"""Triangle meshes and accelerated primitives (kernels/scene_model/mesh_file.py, mesh_accel.py, mesh_rays.py).

* Exactness: intersect() on scenes of two meshes (a non-convex displaced sphere with smooth normals
  and a terrain) against a float64 Moller-Trumbore reference computed from the float32 vertices the
  kernels see, on random rays from outside and inside: hit or miss, face, distance, geometric and
  interpolated shading normal, wherever the answer is not decided by rounding (a hit more than 1e-4
  inside its triangle in barycentric terms and no rival within 1e-5 of its distance; a miss that
  clears every triangle by as much).
* Watertightness: rays from points inside a closed mesh aimed exactly at each of its vertices and at
  points of each shared edge: zero misses.
* Unbiasedness: tests/scene_util.light_over_plane's quad light over a Lambertian plane (closed form,
  Lambert's polygon formula) with the plane made of 1152 triangles of a graded grid (many shared
  edges in view; an OBJ file with vertex normals) and the light of 18 unequal triangles (a PLY
  file): RUNS renders of SPP with `importance` (MIS) and `uniform` (next-event estimation only)
  against the closed form, by the suite's one test (stats_util: 12 regions, Welch t -> chi-square).
  Negative control: the same renders with features.MESH_PDF_HIGH_10PCT must be rejected.
* Chi-square of triangle-light sampling (experiments/stats/chi2, MeshLightAdapter): a bumpy terrain light
  seen from below, a convex icosphere light, and an icosphere with a sphere and a quad light picked by
  power; the pdf a sample carries against light_pdf evaluated on its own (MIS), the integral of the
  claimed pdf against the exact facing mass, and triangle pick frequencies against their areas.
  Negative control: the 10%-high mesh pdf.
* Errors: every bad mesh input is one InputError (one line, the field named; exit 2 from the CLI).
* Motion: a moving mesh with its shutter closed at T renders bit-identically to the same mesh
  translated by v T; intersect() at shutter offset dt equals the translated mesh's answer.
* Many spheres: the wp.Bvh path renders the loop's image bit for bit.

Every statistical test (the renders' comparisons, the chi-square tests and pick-frequency tests) runs
at the Sidak level of ALPHA = 0.01 over the N_TESTS of this module; the negative controls must be
rejected at that same level.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import drtlab.kernels.features as features_module
from drtlab.errors import InputError
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.device_scene import MESH
from drtlab.kernels.features import MESH_PDF_HIGH_10PCT, features_of
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from drtlab.warp_runtime import warp as _wp

import scene_util as su
from cli_util import assert_one_line_error
from mesh_util import (chi2_domain, facing_mass, graded_plane, jittered_light, light_scene, mesh,
                       moller_trumbore, random_rays, scene_triangles, trace_rays, two_mesh_scene,
                       unit, write_mesh, zlib_seed)
from scene_pieces import camera_dict, scene_dict
from stats_util import ALPHA, compare, render_estimate, tier

RUNS = tier(8, 16)
SPP = tier(64, 256)
BLOCK = 4
N_CHI2 = 1_000_000
# Sub-samples per cell and axis of the pdf's quadrature: a polyhedron's area-sampling density jumps
# at every edge of its outline, where 4 x 4 midpoints bias a cell's expected count enough for 10^6
# samples to see (p-values down to 5e-4 over three seeds; 12 x 12: all > 0.1).
IRES = 12
# The family: 2 clean renders (+1 negative control), 3 chi-square tests (+1 negative control), 2
# triangle pick-frequency tests.
N_TESTS = 2 + 1 + 3 + 1 + 2
LEVEL = C.sidak(ALPHA, N_TESTS)


# ---------------------------------------------------------------------------------------------------
# Scenes and files
# ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ground_file(tmp_path_factory):
    """A terrain as a PLY file without normals (flat shading), 128 triangles."""
    from drtlab.kernels.scene_model.procedural import terrain
    v, f, _ = terrain([0.0, -0.5, 0.0], 6.0, 8, 0.3, 5)
    return write_mesh(tmp_path_factory.mktemp("ground") / "ground.ply", v, f)


@pytest.fixture(scope="module", autouse=True)
def warp_ready():
    _wp()


# ---------------------------------------------------------------------------------------------------
# Exactness and watertightness
# ---------------------------------------------------------------------------------------------------

def test_mesh_intersection_matches_float64_moller_trumbore(ground_file):
    scene = scene_from_dict(two_mesh_scene(ground_file))
    tris, vnormals = scene_triangles(scene)
    rng = np.random.default_rng(12)
    o, d = random_rays(rng, tris, 4000)
    got = trace_rays(scene, o, d)
    t, b1, b2, margin = moller_trumbore(got["o"], got["d"], tris)
    t_hit = np.where(margin >= 0.0, t, np.inf)
    best = np.argmin(t_hit, axis=1)
    rows = np.arange(len(t))
    t_ref = t_hit[rows, best]
    # Robust: well inside its triangle, and no other triangle (hit, or missed by less than 1e-4)
    # within 1e-5 of its distance; a robust miss clears every triangle by 1e-4.
    rival = np.partition(np.where(margin > -1e-4, t, np.inf), 1, axis=1)[:, 1]
    robust_hit = (np.isfinite(t_ref) & (margin[rows, best] > 1e-4)
                  & (rival > t_ref * (1 + 1e-5) + 1e-6))
    robust_miss = np.all(margin < -1e-4, axis=1)
    assert robust_hit.sum() > 1500 and robust_miss.sum() > 300, (robust_hit.sum(), robust_miss.sum())

    h = robust_hit
    assert np.all(got["kind"][h] == MESH) and np.array_equal(got["index"][h], best[h])
    scale = t_ref[h] + np.abs(got["o"][h]).max(axis=1)
    assert np.max(np.abs(got["t"][h] - t_ref[h]) / scale) < 1e-5
    ng = unit(np.cross(tris[best, 1] - tris[best, 0], tris[best, 2] - tris[best, 0]))
    assert np.min(np.sum(got["n"][h] * ng[h], axis=1)) > 1.0 - 1e-5
    # Shading normal: the vertex normals interpolated with the barycentric weights, on n's side.
    w = np.stack([1.0 - b1[rows, best] - b2[rows, best], b1[rows, best], b2[rows, best]], axis=1)
    smooth = h & (np.linalg.norm(vnormals[best].sum(axis=1), axis=1) > 0)
    with np.errstate(invalid="ignore"):         # flat faces have zero vertex normals
        ns = unit(np.einsum("nk,nkj->nj", w, vnormals[best]))
    ns = np.where(np.sum(ns * ng, axis=1, keepdims=True) < 0, -ns, ns)
    assert smooth.sum() > 500
    assert np.max(np.linalg.norm(got["ns"][smooth] - ns[smooth], axis=1)) < 1e-4
    flat = h & ~smooth
    assert flat.sum() > 100 and np.array_equal(got["ns"][flat], got["n"][flat])
    assert np.all(got["index"][robust_miss] == -1), "a ray clear of every triangle reported a hit"


def test_closed_mesh_is_watertight_at_shared_edges_and_vertices(ground_file):
    d = two_mesh_scene(ground_file)
    d["shapes"] = d["shapes"][:1]
    d["shapes"][0]["subdivisions"] = 3
    scene = scene_from_dict(d)
    m = scene.shapes[0].mesh
    v32 = m.vertices.astype(np.float32).astype(np.float64)
    edges = np.unique(np.sort(np.concatenate([m.faces[:, [0, 1]], m.faces[:, [1, 2]],
                                              m.faces[:, [2, 0]]]), axis=1), axis=0)
    fractions = np.array([0.5, 1.0 / 3.0, 0.123456])
    on_edges = (v32[edges[:, 0], None] * (1 - fractions[:, None])
                + v32[edges[:, 1], None] * fractions[:, None]).reshape(-1, 3)
    targets = np.concatenate([v32, on_edges])
    origins = np.array([[0.0, 1.0, 0.0], [0.2, 1.1, -0.15], [-0.3, 0.8, 0.25]])
    o = np.repeat(origins, len(targets), axis=0)
    dirs = unit(np.tile(targets, (len(origins), 1)) - o)
    got = trace_rays(scene, o, dirs)
    misses = int(np.sum(got["index"] < 0))
    assert misses == 0, f"{misses} of {len(o)} rays from inside slipped through the closed mesh"
    assert np.all(got["kind"] == MESH)


# ---------------------------------------------------------------------------------------------------
# Unbiasedness against the closed form
# ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def plane_case(tmp_path_factory):
    """(the closed form, the scene dict with mesh plane and mesh light)."""
    folder = tmp_path_factory.mktemp("meshes")
    cf = su.light_over_plane("quad")
    d = cf.scene
    plane, light = d["shapes"][0], d["shapes"][1]
    pv, pf = graded_plane(plane)
    lv, lf = jittered_light(light)
    plane_file = write_mesh(folder / "plane.obj", pv, pf, np.tile([0.0, 1.0, 0.0], (len(pv), 1)))
    light_file = write_mesh(folder / "light.ply", lv, lf)
    d = dict(d, shapes=[mesh("plane", file=plane_file, name="plane"),
                        mesh("light", file=light_file, name="light")])
    return cf, d


def mesh_estimate(d: dict, sampler: str, key, faults=()):
    return render_estimate(scene_from_dict(d, name="mesh-plane"), sampler, "path", SPP, RUNS,
                           ("meshes", key, sampler), block=BLOCK, faults=faults)


@pytest.mark.parametrize("sampler", ["importance", "uniform"])
def test_mesh_plane_under_mesh_light_matches_closed_form(plane_case, sampler):
    cf, d = plane_case
    scene = scene_from_dict(d)
    assert [len(s.mesh.faces) for s in scene.shapes] == [1152, 18]
    assert scene.shapes[0].mesh.normals is not None and scene.shapes[1].mesh.normals is None
    areas = scene.shapes[1].mesh.triangle_areas()
    assert areas.max() / areas.min() > 1.5, "the light's triangles must differ in area"
    est = mesh_estimate(d, sampler, "clean")
    c = compare(est, cf.region_truth(BLOCK), LEVEL)
    print(f"\nmesh plane/{sampler}: {c.summary()}")
    assert est.nonfinite == 0 and est.negative == 0
    assert not c.rejected, c.summary()


def test_negative_control_mesh_pdf_10pct_high_is_rejected(plane_case):
    cf, d = plane_case
    est = mesh_estimate(d, "uniform", "fault", faults=(MESH_PDF_HIGH_10PCT,))
    c = compare(est, cf.region_truth(BLOCK), LEVEL)
    print(f"\nnegative control mesh pdf: {c.summary()}")
    assert c.rejected, f"a 10% high mesh pdf must be rejected: {c.summary()}"


# ---------------------------------------------------------------------------------------------------
# Chi-square tests of triangle-light sampling
# ---------------------------------------------------------------------------------------------------

X = np.array([0.1, 0.0, 0.05])
TERRAIN_Y = 2.0


CHI2_CASES = {
    # A bumpy height field facing down, seen steeply from below: one crossing per direction.
    "terrain": light_scene([mesh("warm", generate="terrain", size=1.0, resolution=6, height=0.08,
                                 seed=4, transform={"rotate": {"axis": [1, 0, 0], "degrees": 180},
                                                    "translate": [0.0, TERRAIN_Y, 0.0]})],
                           {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]}}),
    # A convex icosphere (80 triangles of unequal area), half facing away from x.
    "icosphere": light_scene([mesh("warm", generate="displaced_sphere", center=[1.0, 0.6, 2.5],
                                   radius=0.8, subdivisions=1, amplitude=0.0)],
                             {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]}}),
    # The icosphere with test_chi2's sphere and quad lights, picked by power.
    "mixed": light_scene([mesh("cool", generate="displaced_sphere", center=[1.0, 0.6, 2.5],
                               radius=0.8, subdivisions=1, amplitude=0.0),
                          {"kind": "sphere", "material": "warm", "center": [-2.0, 0.5, 3.0],
                           "radius": 0.6},
                          {"kind": "quad", "material": "warm", "origin": [-3.0, -1.0, -2.0],
                           "edge_u": [2.0, 0.0, 0.0], "edge_v": [0.0, 2.0, 0.0]}],
                         {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]},
                          "cool": {"kind": "emitter", "emission": [1.0, 1.0, 2.0]}}),
}
_uploads: dict = {}


def uploaded(name):
    if name not in _uploads:
        _uploads[name] = C.upload_scene(CHI2_CASES[name])
    return _uploads[name]


def check_samples(s, scene, sd, name):
    """Consistency a chi-square test cannot see: pdf against light_pdf on its own, radiance, pick
    probability, and the sampled point on the face it reports."""
    v = s.valid
    err = C.relative_error(s.pdf[v], s.pdf_eval[v])
    assert err.max() < 1e-4, f"{name}: pdf vs light_pdf: worst rel err {err.max():.3g}"
    is_mesh = sd.lights.shape_kind.numpy()[s.light] == MESH
    emission = np.array([scene.materials[scene.shapes[i].material].emission
                         for i in scene.emitter_shapes()])[s.light]
    np.testing.assert_array_equal(s.radiance[v], emission[v].astype(np.float32))
    mv = v & is_mesh
    tris = np.concatenate([sh.mesh.vertices[sh.mesh.faces] for sh in scene.shapes if sh.kind == "mesh"])
    tri = tris[s.face[mv]]
    y = X + s.wi[mv] * s.dist[mv, None]
    # y = a + b1 e1 + b2 e2 by least squares (normal equations), and y's distance to that point.
    e = np.stack([tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]], axis=2)
    b = np.linalg.solve(np.einsum("nji,njk->nik", e, e),
                        np.einsum("nji,nj->ni", e, y - tri[:, 0])[..., None])[..., 0]
    off = np.linalg.norm(tri[:, 0] + np.einsum("nij,nj->ni", e, b) - y, axis=1)
    margin = np.minimum(np.minimum(b[:, 0], b[:, 1]), 1.0 - b.sum(axis=1))
    assert margin.min() > -1e-4 and off.max() < 1e-4, f"{name}: a sampled point lies off its face"


@pytest.mark.parametrize("name", list(CHI2_CASES))
def test_mesh_light_sampling_chi2(name):
    sd, scene = uploaded(name)
    ad = C.MeshLightAdapter()
    s = ad.sample(sd, X, N_CHI2, seed=zlib_seed(name))
    check_samples(s, scene, sd, name)
    domain, res = chi2_domain(name, scene, X)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), ad.pdf(sd, X), name=f"mesh light {name}",
                   sample_count=N_CHI2, res=res, seed=zlib_seed(name), test_count=N_TESTS,
                   ires=IRES)
    print(r.summary())
    assert r.passed, r.summary()
    mass = facing_mass(scene, X)
    assert abs(r.integral - mass) < 1e-3, f"integral {r.integral:.5f} vs facing mass {mass:.5f}"
    sigma = math.sqrt(mass * (1 - mass) / N_CHI2) + 1e-12
    assert abs(s.valid.mean() - mass) < 5 * sigma + 1e-4, (s.valid.mean(), mass)


def test_negative_control_mesh_light_pdf_10pct_high():
    sd, scene = uploaded("terrain")
    s = C.MeshLightAdapter().sample(sd, X, N_CHI2, seed=zlib_seed("nc"))
    domain, res = chi2_domain("terrain", scene, X)
    bad = C.MeshLightAdapter(mesh_fault=True)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), bad.pdf(sd, X), name="mesh pdf 10% high",
                   sample_count=N_CHI2, res=res, seed=zlib_seed("nc"), test_count=N_TESTS,
                   ires=IRES)
    print("negative control:", r.summary())
    assert r.rejected and r.p_value < LEVEL, r.summary()


@pytest.mark.parametrize("name", ["terrain", "icosphere"])
def test_triangle_pick_frequencies_follow_areas(name):
    sd, scene = uploaded(name)
    s = C.MeshLightAdapter().sample(sd, X, N_CHI2, seed=zlib_seed("pick" + name))
    m = scene.shapes[0].mesh
    # Every sample picks a face, valid or not; the invalid ones report none, so count the valid and
    # compare with the faces that face x.
    areas = m.triangle_areas()
    tri = m.vertices[m.faces]
    facing = np.sum(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) * (X - tri[:, 0]), axis=1) > 0
    counts = np.bincount(s.face[s.valid], minlength=len(areas))[facing]
    expected = areas[facing] / areas[facing].sum() * counts.sum()
    assert np.all(np.bincount(s.face[s.valid], minlength=len(areas))[~facing] == 0)
    p = stats.chisquare(counts, expected).pvalue
    assert p >= LEVEL, (name, p)


# ---------------------------------------------------------------------------------------------------
# Errors
# ---------------------------------------------------------------------------------------------------

BAD_FILES = {
    "garbage.ply": b"this is not a ply file\n",
    "empty.obj": b"# no vertices, no faces\n",
    "nan.obj": b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
    "inf.obj": b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n",
    "degenerate.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    "good.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
}


def bad_scene(shape: dict) -> dict:
    return scene_dict("bad mesh", camera_dict((0, 0, 5), (0, 0, 0), 40.0),
                      {"m": {"kind": "diffuse"}}, [mesh("m", **shape)])


@pytest.fixture(scope="module")
def bad_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bad-meshes")
    for name, data in BAD_FILES.items():
        (folder / name).write_bytes(data)
    return folder


@pytest.mark.parametrize("shape,field,words", [
    ({"file": "missing.obj"}, "shapes[0].file", "does not exist"),
    ({"file": "garbage.ply"}, "shapes[0].file", "cannot read mesh file"),
    ({"file": "empty.obj"}, "shapes[0].file", "has no triangles"),
    ({"file": "nan.obj"}, "shapes[0]", "vertex 1 is not finite"),
    ({"file": "inf.obj"}, "shapes[0]", "vertex 1 is not finite"),
    ({"file": "degenerate.obj"}, "shapes[0]", "triangle 2 (vertices [1, 2, 4] (counting from 1))"),
    ({"file": "good.stl"}, "shapes[0].file", ".obj or .ply"),
    ({"file": "good.obj", "generate": "terrain"}, "shapes[0].generate", "exactly one of"),
    ({}, "shapes[0].file", "exactly one of"),
    ({"generate": "teapot"}, "shapes[0].generate", "displaced_sphere, terrain"),
    ({"file": "good.obj", "radius": 2.0}, "shapes[0].radius", "not a parameter"),
    ({"generate": "terrain", "radius": 2.0}, "shapes[0].radius", "not a parameter"),
    ({"generate": "displaced_sphere", "amplitude": 1.5}, "shapes[0].amplitude", "< radius"),
    ({"generate": "displaced_sphere", "subdivisions": 99}, "shapes[0].subdivisions", "in [0, 8]"),
    ({"generate": "terrain", "resolution": 0}, "shapes[0].resolution", "in [1, 1024]"),
], ids=lambda v: v if isinstance(v, str) else None)
def test_bad_mesh_input_is_one_line_error(shape, field, words, bad_folder):
    shape = dict(shape)
    if "file" in shape:
        shape["file"] = str(bad_folder / shape["file"])
    with pytest.raises(InputError) as exc:
        scene_from_dict(bad_scene(shape))
    msg = str(exc.value)
    assert exc.value.field == field, msg
    assert words in exc.value.message and "\n" not in msg, msg


def test_bad_mesh_file_exits_2_from_the_cli(bad_folder, tmp_path, capsys):
    from drtlab.cli import main
    scene = tmp_path / "scene.toml"
    # A relative path is relative to the scene file.
    scene.write_text('[scene]\ndescription = "bad"\n[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n'
                     '[materials.m]\n[[shapes]]\nkind = "mesh"\nmaterial = "m"\nfile = "nan.obj"\n')
    (tmp_path / "nan.obj").write_bytes(BAD_FILES["nan.obj"])
    out = tmp_path / "out"
    out.mkdir()
    assert main(["render", str(scene), "--out", str(out / "x.exr")]) == 2
    captured = capsys.readouterr()
    assert_one_line_error(captured.err, "shapes[0]")
    assert "nan.obj" in captured.err and list(out.iterdir()) == []


# ---------------------------------------------------------------------------------------------------
# Motion
# ---------------------------------------------------------------------------------------------------

def test_moving_mesh_with_closed_shutter_is_the_translated_mesh(plane_case):
    _, d = plane_case
    v, t = np.array([0.3, 0.0, -0.2]), 0.75
    moving = dict(d, camera=dict(d["camera"], shutter=[t, t]),
                  shapes=[dict(s, velocity=v.tolist()) for s in d["shapes"]])
    moved = dict(d, camera=dict(d["camera"], shutter=[t, t]),
                 shapes=[dict(s, transform={"translate": (v * t).tolist()}) for s in d["shapes"]])
    a = render(scene_from_dict(moving), spp=4, sampler="importance", integrator="path", seed=9)
    b = render(scene_from_dict(moved), spp=4, sampler="importance", integrator="path", seed=9)
    still = render(scene_from_dict(d), spp=4, sampler="importance", integrator="path", seed=9)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, still), "the translation must show"


def test_moving_mesh_rays_at_shutter_offset_hit_the_translated_mesh(ground_file):
    v, dt = np.array([0.4, -0.1, 0.2]), 0.6
    moving = scene_from_dict(two_mesh_scene(ground_file, velocity=v.tolist(), shutter=(0.0, 1.0)))
    moved = scene_from_dict(two_mesh_scene(ground_file, translate=(v * dt).tolist()))
    assert moving.has_motion
    rng = np.random.default_rng(5)
    o, d = random_rays(rng, scene_triangles(moved)[0], 2000)
    a = trace_rays(moving, o, d, dt=dt)
    b = trace_rays(moved, o, d)
    hit = b["index"] >= 0
    assert hit.sum() > 800
    agree = a["index"] == b["index"]
    assert agree.mean() > 0.995, agree.mean()         # rounding may flip rays at shared edges
    both = hit & agree
    assert np.max(np.abs(a["t"][both] - b["t"][both]) / (b["t"][both] + 7.0)) < 1e-5


def test_no_light_leaks_out_of_a_smooth_coarse_mesh():
    # A lamp inside a closed 80-triangle icosphere shaded with smooth normals, seen from outside: at
    # grazing angles the interpolated normal lets the BSDF propose and accept directions into the
    # geometric surface, whose rays would start inside and see the lamp. The image must be exactly 0.
    shell = mesh("shade", generate="displaced_sphere", center=[0.0, 0.0, 0.0], radius=1.0,
                 subdivisions=1, amplitude=0.0)
    lamp = {"kind": "sphere", "material": "lamp", "center": [0.0, 0.0, 0.0], "radius": 0.3}
    d = scene_dict("lamp in a closed mesh", camera_dict((0.0, 0.4, 3.0), (0.0, 0.0, 0.0), 45.0),
                   {"shade": {"kind": "diffuse", "albedo": [0.9, 0.9, 0.9]},
                    "lamp": {"kind": "emitter", "emission": [50.0, 50.0, 50.0]}},
                   [shell, lamp], res=(24, 18), max_depth=4)
    scene = scene_from_dict(d)
    assert scene.shapes[0].mesh.normals is not None
    for sampler in ("importance", "uniform"):
        img = render(scene, spp=64, sampler=sampler, integrator="path", seed=4)
        assert np.count_nonzero(img) == 0, f"{sampler}: {np.count_nonzero(img)} lit values leaked"


# ---------------------------------------------------------------------------------------------------
# Many spheres: BVH against the loop
# ---------------------------------------------------------------------------------------------------

def test_sphere_bvh_renders_the_loops_image(monkeypatch):
    from drtlab.kernels.scene_model.scene_file import load_scene
    scene = load_scene("sphere-grid", {"shapes[1].count": 6})
    images = {}
    for mode, threshold in (("loop", 10**9), ("bvh", 0)):
        monkeypatch.setattr(features_module, "SPHERE_BVH_MIN", threshold)
        assert features_of(scene, "path").sphere_bvh == (mode == "bvh")
        images[mode] = render(scene, spp=4, res=24, sampler="importance", integrator="path", seed=3)
    assert np.array_equal(images["loop"], images["bvh"])
