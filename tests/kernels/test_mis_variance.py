"""Variance bugs are bugs: the MIS heuristics' values, and every built-in estimator's pixel variance
against its closed form, with a deliberately wasteful estimator that stays unbiased as the negative
control.

Heuristics (kernels/mis.py): exact values at chosen densities, w(a, b) + w(b, a) = 1, invariance to
a common scale, monotonicity, the power heuristic sharper than the balance one; `heuristic_of` with
the fault features.MIS_SWAPPED returns w(b, a).

Variance. A diffuse plane (albedo RHO) under a sphere light (radius R_LIGHT, radiance LE) that the
camera does not see, path depth 2 (direct light only). At a shading point x the light subtends a
cone; a light sample is uniform in that cone (strategies sampling by solid angle) or uniform on the
sphere's area (by area), a BSDF sample is cosine-distributed (`lobe`). With g = RHO / pi LE cos(theta)
the integrand, a technique T of density p_T weighted by w_T contributes
    m_T(x) = int_cone w_T g dw,   E[Y_T^2 | x] = int_cone w_T^2 g^2 / p_T dw,
and the two techniques' samples are independent given x, so one sample's variance is
    V(x) = sum_T (E[Y_T^2 | x] - m_T(x)^2),
and a pixel's (its position uniform over the pixel, box filter):
    V_pix = E_u[V(x(u))] + E_u[mu(x(u))^2] - E_u[mu(x(u))]^2,   mu = m_light + m_bsdf.
Both are computed in float64 by quadrature: Gauss-Legendre over the pixel (6 x 6 camera rays, the
kernel's own ray generation: scene_pieces.camera_rays), over cos(angle to the cone axis) with the
substitution t = cos_max + (1 - cos_max) s^2 (it makes the area density's square-root edge smooth)
and the periodic trapezoid rule in the azimuth. The same plane under a square quad light in the
sphere's place: Gauss-Legendre over the quad's area, each node the solid angle cos_l A / d^2, light
samples uniform in the solid angle (the spherical rectangle) or by area (density d^2 / (A cos_l)).
Weights: the strategy's heuristic for MIS, (1, 0)
for light sampling alone (`light`, `uniform`: area light samples), (0, 1) for BSDF sampling alone
(`bsdf`).

Test. Each render (variance=True) gives every pixel's unbiased sample variance s^2 over SPP samples;
over RUNS seeds x all pixels the differences s^2 - V_pix are independent with mean 0 when the kernel
is the estimator the closed form describes, and bounded (every estimator here is), so
    z = mean(s^2 - V_pix) / (sd(s^2 - V_pix) / sqrt(n))
is standard normal; two-sided, level ALPHA = 0.01 Sidak-corrected over the module's renders (CASES,
CONTROLS, ENV_CASES, ENV_CONTROLS). Cases: every unbiased built-in integrator x every strategy of
STRATEGIES under the sphere, path x each under the quad. Negative control: MIS_SWAPPED (each
technique weighted by the other's weight: still unbiased, the mean passes the region test against
the closed form) must be rejected, and its variance must be the swapped closed form's: 166 times the
correct one's under the sphere with the power heuristic, 37 times with the balance heuristic (the
light subtends up to 80 degrees there, where BSDF sampling is not hopeless), 590 times under the
quad.

The same plane under a constant environment of radiance L_ENV (no sphere light): one sample's
variance is the same at every point (nothing occludes the sky), a 1D quadrature over theta, row by
row of the environment's lat-long table for its image sampler (environment_map.direction_pdf);
env-cosine's MIS of two cosine-distributed techniques is exact (zero variance: float32 rounding
only). Negative controls: the swap under the image and the uniform samplers (22 times the variance).

Veach's bound (Theorem 9.2, one sample per technique): the balance heuristic's variance is at most
any other combination's, light or BSDF sampling alone included, plus (1 - 1/2) mu^2; checked on the
closed forms, which the swapped balance heuristic violates.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import warp as wp
from scipy import stats

import drtlab
from drtlab.estimators.integrators import INTEGRATORS
from drtlab.estimators.strategies import STRATEGIES as STRATEGIES_REGISTERED
from drtlab.experiments.stats.chi2 import sidak
from drtlab.experiments.stats.region_tests import Estimate, compare, region_values
from drtlab.kernels import mis
from drtlab.kernels.features import MIS_SWAPPED
from drtlab.kernels.render import render_batch_with_stats
from drtlab.kernels.scene_model.scene_file import scene_from_dict

from scene_pieces import camera_rays, gauss01
from stats_util import ALPHA, seed_for

RHO, LE = 0.5, 10.0
CENTER, R_LIGHT = np.array([0.0, 0.9, 0.0]), 0.5
RES, SPP, RUNS = (16, 12), 32, 4
CAMERA = {"position": [1.5, 3.0, -3.0], "look_at": [0.8, 0.0, -0.8], "up": [0.0, 1.0, 0.0], "fov": 24.0}
UNBIASED = [name for name, i in INTEGRATORS.items() if not i.biased]
# strategy -> (light sampling: "cone" | "area" | None, heuristic name or None for no MIS, bsdf counted)
STRATEGIES = {"importance": ("solid_angle", "power", True), "importance-balance": ("solid_angle", "balance", True),
              "importance-area": ("area", "power", True), "light": ("solid_angle", None, False),
              "uniform": ("area", None, False), "bsdf": (None, None, True)}
# The same plane under a square quad light (one-sided, facing down) in the sphere's place: sampled
# by solid angle (the spherical rectangle: every visible point is well inside lights.py's thresholds
# for it) or by area; path only (the estimators are the sphere's).
QUAD_ORIGIN, QUAD_SIDE = np.array([-0.4, 0.9, -0.4]), 0.8
# drtlab's direct (Mitsuba's) always takes a BSDF sample beside its emitter sample and reaches an
# environment by its BSDF samples alone: its estimator is a strategy's only where that strategy's is
# (not the light-only strategies; under the environment, the cosine sampler's).
CASES = ([(i, s, "sphere") for i in UNBIASED for s in STRATEGIES if i != "direct" or STRATEGIES[s][2]]
         + [("path", s, "quad") for s in STRATEGIES])
CONTROLS = [("path", "importance", "sphere"), ("path", "importance-balance", "sphere"),
            ("path", "importance", "quad")]
# The plane under a constant environment instead (no sphere light): strategy -> environment sampler.
L_ENV = 2.0
ENV_STRATEGIES = {"importance": "image", "env-uniform": "uniform", "env-cosine": "cosine"}
ENV_CASES = [(i, s) for i in UNBIASED for s in ENV_STRATEGIES if i != "direct" or s == "env-cosine"]
ENV_CONTROLS = [("path", "importance"), ("path", "env-uniform")]   # env-cosine's densities are equal
ALPHA_TEST = sidak(ALPHA, len(CASES) + len(CONTROLS) + len(ENV_CASES) + len(ENV_CONTROLS))
HEURISTICS = {"power": lambda a, b: a * a / (a * a + b * b), "balance": lambda a, b: a / (a + b)}


# ---------------------------------------------------------------------------------------------------
# The heuristics' values
# ---------------------------------------------------------------------------------------------------

def _weights(fn, a, b) -> np.ndarray:
    @wp.kernel(enable_backward=False, module="unique")
    def k(a: wp.array(dtype=float), b: wp.array(dtype=float), out: wp.array(dtype=float)):
        i = wp.tid()
        out[i] = fn(a[i], b[i])
    out = wp.zeros(len(a), dtype=float, device="cpu")
    wp.launch(k, dim=len(a), inputs=[wp.array(np.asarray(a, np.float32), dtype=float, device="cpu"),
                                     wp.array(np.asarray(b, np.float32), dtype=float, device="cpu"), out],
              device="cpu")
    return out.numpy().astype(np.float64)


def test_each_heuristic_has_its_exact_values_and_properties():
    a = np.array([1.0, 2.0, 1.0, 3.0, 0.0, 1.0, 1e-6, 1e6])
    b = np.array([1.0, 1.0, 2.0, 1.0, 1.0, 0.0, 1.0, 1.0])
    exact = {"power": [0.5, 0.8, 0.2, 0.9, 0.0, 1.0, 1e-12, 1.0 - 1e-12],
             "balance": [0.5, 2 / 3, 1 / 3, 0.75, 0.0, 1.0, 1e-6 / (1 + 1e-6), 1e6 / (1e6 + 1)]}
    assert set(exact) == set(mis.HEURISTICS)
    rng = np.random.default_rng(3)
    x, y = 10.0 ** rng.uniform(-4, 4, 2000), 10.0 ** rng.uniform(-4, 4, 2000)
    for name, fn in mis.HEURISTICS.items():
        assert np.allclose(_weights(fn, a, b), exact[name], rtol=1e-6, atol=1e-12), name
        w, w_other = _weights(fn, x, y), _weights(fn, y, x)
        assert np.allclose(w + w_other, 1.0, atol=1e-6), name                    # unbiased combination
        assert np.all((w >= 0) & (w <= 1)), name
        assert np.allclose(_weights(fn, 7.0 * x, 7.0 * y), w, rtol=1e-5, atol=1e-7), name   # scale-free
        assert np.all(np.diff(_weights(fn, np.linspace(0.1, 10, 100), np.ones(100))) > 0), name
        assert np.allclose(w, HEURISTICS[name](x, y), rtol=1e-5, atol=1e-7), name
    p, bal = _weights(mis.power_heuristic, x, y), _weights(mis.balance_heuristic, x, y)
    assert np.all(p[x > y] >= bal[x > y] - 1e-7) and np.all(p[x < y] <= bal[x < y] + 1e-7)  # sharper


def test_the_swapped_heuristic_is_the_other_techniques_weight():
    rng = np.random.default_rng(4)
    x, y = 10.0 ** rng.uniform(-3, 3, 500), 10.0 ** rng.uniform(-3, 3, 500)
    for name in mis.HEURISTICS:
        strategy = STRATEGIES_REGISTERED["importance"]
        s = replace(strategy, light=replace(strategy.light, heuristic=name))
        assert mis.heuristic_of(s) is mis.HEURISTICS[name]
        swapped = mis.heuristic_of(s, frozenset({MIS_SWAPPED}))
        assert np.allclose(_weights(swapped, x, y), _weights(mis.HEURISTICS[name], y, x), rtol=1e-6, atol=1e-9)
        assert not np.allclose(_weights(swapped, x, y), _weights(mis.HEURISTICS[name], x, y), atol=1e-3)


# ---------------------------------------------------------------------------------------------------
# Closed forms
# ---------------------------------------------------------------------------------------------------

def _scene(light: str = "sphere") -> dict:
    """The plane under a "sphere" or "quad" light, or under a constant "environment"."""
    d = {"scene": {"description": f"a diffuse plane under a {light} light", "resolution": list(RES),
                   "spp": SPP, "integrator": "path", "max_depth": 2},
         "camera": dict(CAMERA),
         "materials": {"plane": {"kind": "diffuse", "albedo": [RHO] * 3},
                       "lamp": {"kind": "emitter", "emission": [LE] * 3}},
         "shapes": [{"kind": "quad", "material": "plane", "origin": [-20.0, 0.0, -20.0],
                     "edge_u": [0.0, 0.0, 40.0], "edge_v": [40.0, 0.0, 0.0]},
                    {"kind": "sphere", "material": "lamp", "center": CENTER.tolist(), "radius": R_LIGHT}]}
    if light == "quad":
        d["shapes"][1] = {"kind": "quad", "material": "lamp", "origin": QUAD_ORIGIN.tolist(),
                          "edge_u": [QUAD_SIDE, 0.0, 0.0], "edge_v": [0.0, 0.0, QUAD_SIDE]}   # u x v = -y
    if light == "environment":
        d["shapes"] = d["shapes"][:1]
        d["environment"] = {"kind": "constant", "radiance": [L_ENV] * 3}
    return d


def _plane_points() -> tuple[np.ndarray, np.ndarray]:
    """(points (H, W, Q, 3) where the camera's quadrature rays meet the plane y = 0, weights (Q,))."""
    o, d, q = camera_rays(CAMERA, RES[0], RES[1], n_pix=6)
    t = -o[..., 1] / d[..., 1]
    assert np.all(t > 0)
    x = o + d * t[..., None]
    # the camera must see neither light: no ray meets the sphere, nor the quad's plane within it
    oc = CENTER - o
    tc = np.sum(oc * d, axis=-1)
    assert np.all((np.sum(oc * oc, axis=-1) - tc ** 2 > R_LIGHT ** 2) | (tc < 0)), "the sphere is in view"
    y = o + d * ((QUAD_ORIGIN[1] - o[..., 1]) / d[..., 1])[..., None] - QUAD_ORIGIN
    assert not np.any((y[..., 0] >= 0) & (y[..., 0] <= QUAD_SIDE) & (y[..., 2] >= 0) & (y[..., 2] <= QUAD_SIDE))
    return x, q


def _cone_quadrature(x: np.ndarray, nt: int = 24, nphi: int = 48):
    """For points x (M, 3): (cos theta to the plane's normal, solid-angle weight, area-sampling density)
    at each (M, nt * nphi) node over the cone the light subtends."""
    n = np.array([0.0, 1.0, 0.0])
    dvec = CENTER - x
    dist = np.linalg.norm(dvec, axis=-1)
    axis = dvec / dist[:, None]
    cos_max = np.sqrt(1.0 - (R_LIGHT / dist) ** 2)
    s, ws = gauss01(nt)
    t = cos_max[:, None] + (1.0 - cos_max[:, None]) * s ** 2               # (M, nt)
    dt = 2.0 * (1.0 - cos_max[:, None]) * s * ws
    phi = (np.arange(nphi) + 0.5) * 2.0 * math.pi / nphi
    a_n = axis @ n                                                          # (M,)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - t ** 2))
    cos_theta = (t[:, :, None] * a_n[:, None, None]
                 + sin_t[:, :, None] * np.sqrt(np.maximum(0.0, 1.0 - a_n ** 2))[:, None, None] * np.cos(phi))
    w = np.repeat(dt[:, :, None] * (2.0 * math.pi / nphi), nphi, axis=2)
    # area sampling: the nearest point of the sphere along the direction, and its cosine
    perp2 = dist[:, None] ** 2 * (1.0 - t ** 2)
    root = np.sqrt(np.maximum(0.0, R_LIGHT ** 2 - perp2))
    hit = dist[:, None] * t - root
    cos_l = root / R_LIGHT
    with np.errstate(divide="ignore"):
        p_area = hit ** 2 / (cos_l * 4.0 * math.pi * R_LIGHT ** 2)
    p_area = np.repeat(p_area[:, :, None], nphi, axis=2)
    m = x.shape[0]
    return cos_theta.reshape(m, -1), w.reshape(m, -1), p_area.reshape(m, -1), cos_max


def _quad_quadrature(x: np.ndarray, n: int = 24):
    """As _cone_quadrature for the quad light: Gauss-Legendre over its area, each node's solid angle
    cos_l A / d^2; returns the solid angle it subtends in place of the cone's 1 - cos_max."""
    s, ws = gauss01(n)
    a, b = np.meshgrid(s, s, indexing="ij")
    y = QUAD_ORIGIN + QUAD_SIDE * np.stack([a.ravel(), np.zeros(a.size), b.ravel()], axis=-1)   # (K, 3)
    d = y[None] - x[:, None]                                                    # (M, K, 3)
    dist2 = np.sum(d * d, axis=-1)
    cos_theta = d[..., 1] / np.sqrt(dist2)                  # plane normal +y; the light's normal -y
    area = QUAD_SIDE ** 2
    w = np.outer(ws, ws).ravel()[None] * area * cos_theta / dist2
    p_area = dist2 / (area * cos_theta)
    return cos_theta, w, p_area, w.sum(axis=1)


def closed_form(strategy: str, swapped: bool = False, nt: int = 24, light_kind: str = "sphere") -> dict:
    """Per pixel (H, W): the expected value of one sample and its variance; and the image means of
    E_u[mu^2] (Veach's bound's term)."""
    light, heuristic, counts_bsdf = STRATEGIES[strategy]
    x, q = _plane_points()
    shape = x.shape[:3]
    if light_kind == "sphere":
        cos_t, w, p_area, cos_max = _cone_quadrature(x.reshape(-1, 3), nt=nt, nphi=2 * nt)
        omega = 2.0 * math.pi * (1.0 - cos_max)
    else:
        cos_t, w, p_area, omega = _quad_quadrature(x.reshape(-1, 3), n=nt)
    assert np.all(cos_t > 0), "the light must lie above every visible point's horizon"
    g = RHO / math.pi * LE * cos_t
    p_light = np.broadcast_to((1.0 / omega)[:, None], g.shape) if light == "solid_angle" else p_area
    p_bsdf = cos_t / math.pi
    if heuristic is None:
        w_light = np.full_like(g, 1.0 if light else 0.0)
        w_bsdf = np.full_like(g, 1.0 if (counts_bsdf and not light) else 0.0)
    else:
        h = HEURISTICS[heuristic]
        w_light, w_bsdf = h(p_light, p_bsdf), h(p_bsdf, p_light)
        if swapped:
            w_light, w_bsdf = w_bsdf, w_light
    terms = []
    for wt, p in ((w_light, p_light), (w_bsdf, p_bsdf)):
        with np.errstate(divide="ignore", invalid="ignore"):
            second = np.where(wt > 0, wt ** 2 * g ** 2 / p, 0.0)
        terms.append((np.sum(wt * g * w, axis=1), np.sum(second * w, axis=1)))
    mu = terms[0][0] + terms[1][0]
    var_x = sum(s2 - m ** 2 for m, s2 in terms)
    mu, var_x = mu.reshape(shape), var_x.reshape(shape)
    mean = mu @ q
    return {"mean": mean, "var": (var_x + mu ** 2) @ q - mean ** 2, "mu2": float(np.mean((mu ** 2) @ q))}


def closed_form_environment(strategy: str, swapped: bool = False, per_row: int = 8) -> tuple[float, float]:
    """(mean, variance) of one sample at any point of the plane under the constant environment (the
    same everywhere: nothing occludes the sky of an unbounded plane). The environment's density:
    uniform 1 / 4 pi, cosine cos / pi, or the image sampler's (environment_map.direction_pdf: its
    rows' probabilities over their solid angle, piecewise in theta), integrated row by row."""
    from drtlab.kernels.scene_model.environment_map import direction_pdf
    env = scene_from_dict(_scene("environment")).environment
    rows = env.height // 2                                       # the upper hemisphere's rows
    x, wx = gauss01(per_row)
    theta = ((np.arange(rows)[:, None] + x) * math.pi / env.height).ravel()
    dtheta = np.tile(wx * math.pi / env.height, rows)
    w = 2.0 * math.pi * np.sin(theta) * dtheta                   # solid angle of each node's ring
    cos_t = np.cos(theta)
    g = RHO / math.pi * L_ENV * cos_t
    p_bsdf = cos_t / math.pi
    sampler = ENV_STRATEGIES[strategy]
    if sampler == "uniform":
        p_light = np.full_like(g, 1.0 / (4.0 * math.pi))
    elif sampler == "cosine":
        p_light = p_bsdf
    else:
        dirs = np.stack([np.sin(theta), cos_t, np.zeros_like(theta)], axis=-1)
        p_light = direction_pdf(env.image, dirs, env=env)
    h = HEURISTICS["power"]
    w_light, w_bsdf = h(p_light, p_bsdf), h(p_bsdf, p_light)
    if swapped:
        w_light, w_bsdf = w_bsdf, w_light
    mean = var = 0.0
    for wt, p in ((w_light, p_light), (w_bsdf, p_bsdf)):
        m = float(np.sum(wt * g * w))
        mean += m
        var += float(np.sum(wt ** 2 * g ** 2 / p * w)) - m * m
    return mean, var


def test_the_closed_forms_agree_and_meet_veachs_bound():
    """The quadrature's own checks: every unbiased combination has the same mean; the techniques'
    variances order as they must; the balance heuristic meets Veach's bound, the swapped one breaks it."""
    forms = {s: closed_form(s) for s in STRATEGIES}
    for s, f in forms.items():
        assert np.allclose(f["mean"], forms["light"]["mean"], rtol=1e-6), s
    for s in ("importance", "importance-area"):      # the quadrature has converged (the area density's edge)
        assert np.allclose(closed_form(s, nt=40)["var"], forms[s]["var"], rtol=1e-6), s
        assert np.allclose(closed_form(s, nt=40, light_kind="quad")["var"],
                           closed_form(s, light_kind="quad")["var"], rtol=1e-6), s
    quad = {s: closed_form(s, light_kind="quad") for s in STRATEGIES}
    for s, f in quad.items():
        assert np.allclose(f["mean"], quad["light"]["mean"], rtol=1e-6), s
    vq = {s: float(np.mean(f["var"])) for s, f in quad.items()}
    assert vq["importance-balance"] <= min(vq["light"], vq["bsdf"]) + 0.5 * quad["light"]["mu2"]
    v = {s: float(np.mean(f["var"])) for s, f in forms.items()}
    swapped = {s: float(np.mean(closed_form(s, swapped=True)["var"])) for s in ("importance", "importance-balance")}
    bound = min(v["light"], v["bsdf"]) + 0.5 * forms["light"]["mu2"]
    assert v["importance-balance"] <= bound
    assert swapped["importance-balance"] > 5 * bound
    assert v["light"] < v["uniform"] and v["light"] < v["bsdf"]
    assert swapped["importance"] > 100 * v["importance"] and swapped["importance-balance"] > 20 * v["importance-balance"]
    for st in ENV_STRATEGIES:                        # every environment sampler: the same mean, rho L
        mean, var = closed_form_environment(st)
        assert math.isclose(mean, RHO * L_ENV, rel_tol=1e-9) and var >= 0, st
        assert math.isclose(closed_form_environment(st, per_row=16)[1], var, rel_tol=1e-4, abs_tol=1e-12), st
    # cosine light samples of a cosine integrand under a uniform sky: both techniques are perfect
    assert closed_form_environment("env-cosine")[1] < 1e-12
    for st in ("importance", "env-uniform"):
        assert closed_form_environment(st, swapped=True)[1] > 1.2 * closed_form_environment(st)[1], st


# ---------------------------------------------------------------------------------------------------
# The renderer against them
# ---------------------------------------------------------------------------------------------------

def _ensure_balance():
    if "importance-balance" not in STRATEGIES_REGISTERED:
        drtlab.register_strategy("importance-balance", "importance, balance heuristic", heuristic="balance")


def _measure(integrator: str, strategy: str, faults=(), light: str = "sphere"):
    key = ("mis-variance", integrator, strategy, faults, light)
    b = render_batch_with_stats(scene_from_dict(_scene(light)), [seed_for(*key, k) for k in range(RUNS)],
                                spp=SPP, sampler=f"independent+{strategy}", integrator=integrator,
                                variance=True, faults=faults, progress=False)
    return np.asarray(b.images), np.asarray(b.variances)


def _variance_z(s2: np.ndarray, exact: np.ndarray) -> tuple[float, float]:
    """(z, measured / exact variance): the mean of the pixels' s^2 - V_pix over runs and pixels."""
    d = (s2[..., 0] - exact[None]).ravel()
    z = float(d.mean() / (d.std(ddof=1) / math.sqrt(d.size)))
    return z, float(s2[..., 0].mean() / exact.mean())


@pytest.mark.parametrize("integrator, strategy, light", CASES)
def test_pixel_variance_is_the_closed_form(clean_registry, integrator, strategy, light):
    _ensure_balance()
    images, s2 = _measure(integrator, strategy, light=light)
    form = closed_form(strategy, light_kind=light)
    assert np.all(np.isfinite(s2)) and np.allclose(s2[..., 0], s2[..., 2], rtol=1e-4, atol=1e-9)  # grey
    z, ratio = _variance_z(s2, form["var"])
    p = 2 * stats.norm.sf(abs(z))
    print(f"\n{integrator} {strategy} ({light}): variance {ratio:.4f} x the closed form, z = {z:+.2f}, p = {p:.3g}")
    assert p >= ALPHA_TEST, f"{integrator} {strategy}: variance {ratio:.4f} x the closed form (z = {z:+.2f})"


@pytest.mark.parametrize("integrator, strategy, light", CONTROLS)
def test_swapped_mis_weights_are_unbiased_and_rejected(clean_registry, integrator, strategy, light):
    _ensure_balance()
    images, s2 = _measure(integrator, strategy, faults=(MIS_SWAPPED,), light=light)
    form = closed_form(strategy, light_kind=light)
    # unbiased: its mean passes the region test against the closed form ...
    exact = Estimate.exact(region_values(np.repeat(form["mean"][..., None], 3, axis=2), 4))
    c = compare(Estimate.from_images(images.sum(axis=3), 4), exact, ALPHA_TEST)
    assert not c.rejected, c.summary()
    # ... and wasteful: the variance test rejects it, and it is the swapped closed form's
    z, ratio = _variance_z(s2, form["var"])
    print(f"\n{integrator} {strategy} ({light}) with {MIS_SWAPPED}: variance {ratio:.0f} x the correct estimator's")
    assert 2 * stats.norm.sf(abs(z)) < ALPHA_TEST and ratio > 5
    z_swapped, _ = _variance_z(s2, closed_form(strategy, swapped=True, light_kind=light)["var"])
    assert 2 * stats.norm.sf(abs(z_swapped)) >= ALPHA_TEST, z_swapped


@pytest.mark.parametrize("integrator, strategy", ENV_CASES)
def test_pixel_variance_under_the_environment_is_the_closed_form(integrator, strategy):
    images, s2 = _measure(integrator, strategy, light="environment")
    mean, var = closed_form_environment(strategy)
    if var < 1e-12:                                  # a zero-variance estimator: float32 rounding only
        assert np.max(s2) < 1e-9 * mean ** 2 and np.allclose(images, mean, rtol=1e-5), np.max(s2)
        return
    z, ratio = _variance_z(s2, np.full(s2.shape[1:3], var))
    p = 2 * stats.norm.sf(abs(z))
    print(f"\n{integrator} {strategy} (environment): variance {ratio:.4f} x the closed form, z = {z:+.2f}")
    assert p >= ALPHA_TEST, f"{integrator} {strategy}: variance {ratio:.4f} x the closed form (z = {z:+.2f})"


@pytest.mark.parametrize("integrator, strategy", ENV_CONTROLS)
def test_swapped_environment_mis_weights_are_rejected(integrator, strategy):
    images, s2 = _measure(integrator, strategy, faults=(MIS_SWAPPED,), light="environment")
    z, ratio = _variance_z(s2, np.full(s2.shape[1:3], closed_form_environment(strategy)[1]))
    print(f"\n{integrator} {strategy} (environment) with {MIS_SWAPPED}: variance {ratio:.2f} x the correct one")
    assert 2 * stats.norm.sf(abs(z)) < ALPHA_TEST
    z_swapped, _ = _variance_z(s2, np.full(s2.shape[1:3], closed_form_environment(strategy, swapped=True)[1]))
    assert 2 * stats.norm.sf(abs(z_swapped)) >= ALPHA_TEST, z_swapped
