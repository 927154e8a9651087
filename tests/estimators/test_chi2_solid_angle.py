"""Chi-square tests of solid-angle sampling of rectangle and triangle lights (estimators/
spherical_maps.py through kernels/lights.py, `strategy.solid_angle`), with the harness of
experiments/stats/chi2/ (LightAdapter, MeshLightAdapter).

Each case draws N samples from a point x, histograms their directions on the light's own (s, t)
rectangle coordinates (RectangleDomain: a light seen edge-on is a sliver in any grid of directions),
integrates the pdf the code claims over every cell and runs Pearson's test at ALPHA = 0.01, Sidak
over the N_TESTS tests of this module. Besides the chi-square test, each case checks that

* the pdf a sample carries equals light_pdf evaluated on its own at the same point (what MIS uses);
* that pdf is the exact density in float64: 1 / Omega (Van Oosterom and Strackee's formula, written
  here again) where kernels/lights.py's rule says solid angle (A cos_l / d^2 at the centre >=
  SPHERICAL_PAYS, Omega in [SPHERICAL_MIN, SPHERICAL_MAX], elevation >= SPHERICAL_MIN_ELEVATION),
  the area density d^2 / (cos A) elsewhere (the fallback) - so both sides of each threshold are
  checked against their own density.

Cases: a 2 x 2 rectangle light seen from below its centre, obliquely, far below with A cos_l / d^2
twice and half SPHERICAL_PAYS (for a rectangle it is reached before SPHERICAL_MIN, which the mesh
cases straddle), nearly edge-on from 3 and 2 units away at twice and half SPHERICAL_MIN_ELEVATION
and at 1e-3 below its plane (a shading point nearly in the light's plane), very close under it
(Omega ~ 6.04 sr) and closer still (Omega > SPHERICAL_MAX: area); a
terrain of 72 triangles seen from below (every face spherical-triangle sampled) and a far icosphere
(every face below SPHERICAL_MIN: area). Negative controls (must be rejected at the same level):
features.SPHERICAL_LINEAR (the maps' second coordinate linear) on the rectangle from below and on
the terrain; features.SPHERICAL_MIS_AREA (light_pdf ignoring the spherical density) by the pdf
consistency check. From behind the light and from its plane: no valid sample, no NaN.
"""
from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
from scipy import optimize

from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.features import SPHERICAL_LINEAR, SPHERICAL_MIS_AREA
from drtlab.kernels.lights import (SPHERICAL_MAX, SPHERICAL_MIN, SPHERICAL_MIN_ELEVATION,
                                   SPHERICAL_PAYS)

from mesh_util import chi2_domain, facing_mass, light_scene, mesh

N = 1_000_000
RES = (40, 40)
N_TESTS = 9 + 2 + 2          # clean rectangle cases, clean mesh cases, negative controls
LEVEL = C.sidak(C.ALPHA, N_TESTS)

# A one-sided 2 x 2 rectangle light in the plane y = 1, emitting down (u x v = -y).
Q0, U, V = np.array([-1.0, 1.0, -1.0]), np.array([2.0, 0.0, 0.0]), np.array([0.0, 0.0, 2.0])
RECT = light_scene([{"kind": "quad", "material": "warm", "origin": Q0.tolist(), "edge_u": U.tolist(),
                     "edge_v": V.tolist()}],
                   {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]}})


def seed_of(name: str) -> int:
    return zlib.crc32(f"solid-angle:{name}".encode())


def tri_solid_angle(a, b, c) -> np.ndarray:
    """Van Oosterom and Strackee, float64, rows of corners relative to x."""
    la, lb, lc = (np.linalg.norm(v, axis=-1) for v in (a, b, c))
    triple = np.einsum("...i,...i", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("...i,...i", a, b) * lc + np.einsum("...i,...i", a, c) * lb
           + np.einsum("...i,...i", b, c) * la)
    return 2.0 * np.arctan2(np.abs(triple), den)


def rect_solid_angle(x) -> float:
    a, b, c, d = Q0 - x, Q0 + U - x, Q0 + U + V - x, Q0 + V - x
    return float(tri_solid_angle(a, b, c) + tri_solid_angle(a, c, d))


def reach(x, corners) -> float:
    return float(np.max(np.linalg.norm(np.asarray(corners) - x, axis=-1)))


def rect_elevation(x) -> float:
    """The sine of x's elevation over the light's plane, seen from its farthest corner."""
    return (1.0 - x[1]) / reach(x, [Q0, Q0 + U, Q0 + U + V, Q0 + V])


def rect_pays_measure(x) -> float:
    """A cos_l / d^2 at the light's centre (kernels/lights.py's rect_pays)."""
    c = Q0 + 0.5 * (U + V) - x
    n = np.cross(U, V)
    return float(abs(c @ n) / np.linalg.norm(c) ** 3)


def spherical_side(omega: float, elevation: float) -> bool:
    """kernels/lights.py's rule for a triangle, written again: solid angle where this holds, area
    elsewhere."""
    return SPHERICAL_MIN <= omega <= SPHERICAL_MAX and elevation >= SPHERICAL_MIN_ELEVATION


def rect_spherical_side(x) -> bool:
    """The rule for a rectangle: the triangle's, and the switch SPHERICAL_PAYS."""
    return (rect_pays_measure(x) >= SPHERICAL_PAYS
            and spherical_side(rect_solid_angle(x), rect_elevation(x)))


def steep_point(measure: float) -> np.ndarray:
    """x = (0.3, 1 - h, 0.2) far below the light, with A cos_l / d^2 at its centre = measure."""
    h = optimize.brentq(lambda h: rect_pays_measure(np.array([0.3, 1.0 - h, 0.2])) - measure,
                        1.0, 1e4, xtol=1e-12)
    return np.array([0.3, 1.0 - h, 0.2])


def edge_on_point(elevation: float, beside: float) -> np.ndarray:
    """x = (beside, 1 - h, 0.3): beside the light's centre, h below its plane, at this elevation."""
    h = optimize.brentq(lambda h: rect_elevation(np.array([beside, 1.0 - h, 0.3])) - elevation,
                        1e-12, 1.0, xtol=1e-15)
    return np.array([beside, 1.0 - h, 0.3])


RECT_CASES = {
    "below": np.array([0.0, 0.0, 0.0]),
    "oblique": np.array([0.5, -0.3, 2.0]),
    "far-above-pays": steep_point(2.0 * SPHERICAL_PAYS),
    "far-below-pays": steep_point(0.5 * SPHERICAL_PAYS),
    "edge-on-above-elevation": edge_on_point(2.0 * SPHERICAL_MIN_ELEVATION, 3.0),
    # 2 units beside, not 3: there A cos_l / d^2 still reaches SPHERICAL_PAYS at this elevation.
    "edge-on-below-elevation": edge_on_point(0.5 * SPHERICAL_MIN_ELEVATION, 2.0),
    "grazing": np.array([3.0, 1.0 - 1e-3, 0.3]),
    "close": np.array([0.3, 0.96, 0.2]),
    "closer-than-max": np.array([0.3, 0.999, 0.2]),
}
SPHERICAL_CASES = {"below", "oblique", "far-above-pays", "edge-on-above-elevation", "close"}

_uploads: dict = {}


def uploaded(name, d):
    if name not in _uploads:
        _uploads[name] = C.upload_scene(d)
    return _uploads[name]


def exact_rect_pdf(x, s) -> np.ndarray:
    """The density the samples should carry: 1 / Omega on the spherical side, d^2 / (cos A) else."""
    om = rect_solid_angle(x)
    if rect_spherical_side(x):
        return np.full(len(s.dist), 1.0 / om)
    n = np.cross(U, V) / np.linalg.norm(np.cross(U, V))
    cos_l = np.abs(s.wi.astype(np.float64) @ n)
    return s.dist.astype(np.float64) ** 2 / (cos_l * np.linalg.norm(np.cross(U, V)))


def rect_samples(x, name, faults=()):
    sd, _ = uploaded("rect", RECT)
    ad = C.LightAdapter(True, True, faults=faults)
    return ad, sd, ad.sample(sd, x, N, seed_of(name))


def test_cases_straddle_the_thresholds():
    side = {k: rect_spherical_side(x) for k, x in RECT_CASES.items()}
    assert {k for k, v in side.items() if v} == SPHERICAL_CASES
    om = {k: rect_solid_angle(x) for k, x in RECT_CASES.items()}
    pays = {k: rect_pays_measure(x) for k, x in RECT_CASES.items()}
    assert pays["far-above-pays"] > SPHERICAL_PAYS > pays["far-below-pays"]
    assert om["far-below-pays"] > SPHERICAL_MIN                # area-sampled for the switch alone
    assert SPHERICAL_MIN < om["close"] < SPHERICAL_MAX < om["closer-than-max"]
    assert pays["closer-than-max"] > SPHERICAL_PAYS
    # Area-sampled for its elevation alone:
    assert om["edge-on-below-elevation"] > SPHERICAL_MIN and pays["edge-on-below-elevation"] > SPHERICAL_PAYS
    assert RECT_CASES["grazing"][1] > 0.998                   # nearly in the light's plane


@pytest.mark.parametrize("name", list(RECT_CASES))
def test_rectangle_light(name):
    x = RECT_CASES[name]
    ad, sd, s = rect_samples(x, name)
    assert s.valid.all(), f"{(~s.valid).sum()} invalid samples from in front of the light"
    v = s.valid
    assert np.isfinite(s.wi).all() and np.isfinite(s.pdf).all() and (s.pdf > 0).all()
    err = C.relative_error(s.pdf[v], s.pdf_eval[v])
    assert err.max() < 1e-4, f"pdf vs light_pdf: worst rel err {err.max():.3g}"
    exact = exact_rect_pdf(x, s)
    # float32 geometry: the solid angle to ~1e-6, the area density to its cos_l's rounding.
    err = C.relative_error(s.pdf[v], exact[v])
    assert np.median(err) < 1e-4 and err.max() < 2e-2, (np.median(err), err.max())
    domain = C.RectangleDomain(x, Q0, U, V)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), ad.pdf(sd, x), name=f"rect {name}",
                   sample_count=N, res=RES, seed=seed_of(name), test_count=N_TESTS)
    print(r.summary(), f"Omega = {rect_solid_angle(x):.4g}")
    assert r.passed, r.summary()
    assert abs(r.integral - 1.0) < 2e-3, r.integral


def test_negative_control_rectangle_linear_map_is_rejected():
    x = RECT_CASES["below"]
    ad, sd, s = rect_samples(x, "linear", faults=(SPHERICAL_LINEAR,))
    r = C.run_chi2(C.RectangleDomain(x, Q0, U, V), lambda n, seed: (s.wi, s.valid), ad.pdf(sd, x),
                   name="rect linear (fault)", sample_count=N, res=RES, seed=seed_of("linear"),
                   test_count=N_TESTS)
    print("negative control:", r.summary())
    assert r.rejected and r.p_value < LEVEL, r.summary()


def test_negative_control_mis_pdf_ignoring_the_spherical_density_is_caught():
    # A chi-square test of the directions cannot see it (sample_light is unchanged); the pdf
    # consistency check, the one MIS relies on, must.
    x = RECT_CASES["below"]
    _, _, s = rect_samples(x, "mis-area", faults=(SPHERICAL_MIS_AREA,))
    err = C.relative_error(s.pdf[s.valid], s.pdf_eval[s.valid])
    assert np.median(err) > 0.01, np.median(err)


# ---------------------------------------------------------------------------------------------------
# Triangles: mesh lights
# ---------------------------------------------------------------------------------------------------

MX = np.array([0.1, 0.0, 0.05])
MESH_CASES = {
    # 72 faces of ~7e-3 area 2 units above x: Omega ~ 1.7e-3 each, spherical triangles.
    "terrain": light_scene([mesh("warm", generate="terrain", size=1.0, resolution=6, height=0.08,
                                 seed=4, transform={"rotate": {"axis": [1, 0, 0], "degrees": 180},
                                                    "translate": [0.0, 2.0, 0.0]})],
                           {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]}}),
    # 80 faces of an icosphere of radius 0.8 at 60 units: every face below SPHERICAL_MIN (area).
    "far-icosphere": light_scene([mesh("warm", generate="displaced_sphere",
                                       center=[20.0, 10.0, 55.0], radius=0.8, subdivisions=1,
                                       amplitude=0.0)],
                                 {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]}}),
}


def face_solid_angles(scene, x) -> np.ndarray:
    m = scene.shapes[0].mesh
    tri = m.vertices[m.faces] - x
    return tri_solid_angle(tri[:, 0], tri[:, 1], tri[:, 2])


def test_mesh_cases_lie_on_either_side():
    om_t = face_solid_angles(C.upload_scene(MESH_CASES["terrain"])[1], MX)
    om_i = face_solid_angles(C.upload_scene(MESH_CASES["far-icosphere"])[1], MX)
    assert om_t.min() > 2 * SPHERICAL_MIN and om_i.max() < SPHERICAL_MIN


def exact_mesh_pdf(scene, x, s) -> np.ndarray:
    m = scene.shapes[0].mesh
    areas = m.triangle_areas()
    f = s.face
    om = face_solid_angles(scene, x)[f]
    tri = m.vertices[m.faces][f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    cos_l = np.abs(np.einsum("ij,ij->i", s.wi.astype(np.float64), n))
    with np.errstate(invalid="ignore", divide="ignore"):
        area_pdf = s.dist.astype(np.float64) ** 2 / (cos_l * areas.sum())
    elevation = np.abs(np.einsum("ij,ij->i", tri[:, 0] - x, n)) / np.linalg.norm(tri - x,
                                                                                axis=2).max(axis=1)
    sph = np.array([spherical_side(o, e) for o, e in zip(om, elevation)])
    return np.where(sph, areas[f] / areas.sum() / om, area_pdf)


@pytest.mark.parametrize("name", list(MESH_CASES))
def test_mesh_light(name):
    sd, scene = uploaded(name, MESH_CASES[name])
    ad = C.MeshLightAdapter()
    s = ad.sample(sd, MX, N, seed_of(name))
    v = s.valid
    err = C.relative_error(s.pdf[v], s.pdf_eval[v])
    assert err.max() < 1e-4, f"pdf vs light_pdf: worst rel err {err.max():.3g}"
    err = C.relative_error(s.pdf[v], exact_mesh_pdf(scene, MX, s)[v])
    assert np.median(err) < 1e-4 and err.max() < 2e-2, (np.median(err), err.max())
    domain, res = chi2_domain(name if name == "terrain" else "icosphere", scene, MX)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), ad.pdf(sd, MX), name=f"mesh {name}",
                   sample_count=N, res=res, seed=seed_of(name), test_count=N_TESTS, ires=12)
    print(r.summary())
    assert r.passed, r.summary()
    mass = facing_mass(scene, MX)
    assert abs(r.integral - mass) < 1e-3, (r.integral, mass)


def test_negative_control_triangle_linear_map_is_rejected():
    sd, scene = uploaded("terrain", MESH_CASES["terrain"])
    ad = C.MeshLightAdapter(faults=(SPHERICAL_LINEAR,))
    s = ad.sample(sd, MX, N, seed_of("tri-linear"))
    domain, res = chi2_domain("terrain", scene, MX)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), ad.pdf(sd, MX), name="tri linear (fault)",
                   sample_count=N, res=res, seed=seed_of("tri-linear"), test_count=N_TESTS, ires=12)
    print("negative control:", r.summary())
    assert r.rejected and r.p_value < LEVEL, r.summary()


@pytest.mark.parametrize("name,x", [("behind", np.array([0.2, 1.5, 0.1])),
                                    ("in-plane", np.array([0.2, 1.0, 0.1])),
                                    ("in-plane-outside", np.array([3.0, 1.0, 0.1]))])
def test_hidden_rectangle_light_gives_no_sample(name, x):
    # From behind a one-sided light, or exactly in its plane, nothing is sampled (no NaN, no
    # negative or infinite pdf), as area sampling would find every point facing away.
    _, _, s = rect_samples(x, name)
    assert not s.valid.any(), f"{s.valid.sum()} valid samples from {name}"
    assert np.isfinite(s.pdf).all() and (s.pdf >= 0).all()
