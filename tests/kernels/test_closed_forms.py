"""Closed-form references that share no code with the renderer: motion blur, depth of field, the
pixel filter, several lights of unequal power, and the glossy dielectric's directional albedo.

Why: the unbiasedness tests compare every estimator with the renderer's own reference, so an error
every estimator shares (a shape moving at twice its velocity in intersection and light sampling
alike) passes them. Here every expected value is computed in float64 numpy from the geometry and the
formulas alone (tests/support/closed_forms_util.py): exact coverage integrals for the image-plane scenes,
Lambert's and the sphere-light formula for irradiance, a 1D quadrature of the BSDF formula.

Statistics. Image tests: RUNS independent renders (fixed seeds, stats_util.seed_for), regions of
BLOCK x BLOCK pixels, Welch t per region against the exact region value -> equal-p normal deviate
-> X = sum z^2 ~ chi-square(R) (stats_util.compare). In the coverage tests (every sample is 0 or
Le) regions exactly covered or exactly uncovered must equal Le or 0 exactly, and the chi-square runs
over the partly covered regions that expect >= 100 hits and misses (closed_forms_util.
testable_binary_regions). BSDF albedo: z = (mean weight - albedo) / standard error, 2^20 samples.
Level and correction (every test): ALPHA = 0.01 with the Sidak correction over the M_TESTS clean
comparisons of this module, alpha_test = 1 - 0.99^(1 / M_TESTS). Each test also runs its NEGATIVE
CONTROLS at the same alpha_test: a deliberately wrong closed form that the same data must reject
(velocity x 2, a quad 1% too wide, focus or aperture 3% off, one light's power changed, a light pick
proportional to area, a wrong Phong exponent / ior / tint in the quadrature).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.scene_model.scene_file import scene_from_dict

import closed_forms_util as cu
from stats_util import ALPHA, compare, render_estimate, seed_for

RES = (16, 16)
BLOCK = 2
RUNS = 16
LE = 2.0                        # emitted radiance of the image-plane emitters (exact in float32)
SAMPLER = "importance"          # independent points: pixel, lens and time uniform and independent
FOV = 30.0

# The clean comparisons of this module (the Sidak family): motion blur 1, the t ~ U(shutter) streak
# 2 (its image and its mean position), the shutter-offset convention 1 (expected to fail, still
# counted), thin lens 2, pixel filter 1, lights over a plane 2 (two strategies) + 2 (moving, two
# strategies), glossy dielectric albedo len(GD_CASES).
GD_CASE_COUNT = 8
M_TESTS = 1 + 2 + 1 + 2 + 1 + 4 + GD_CASE_COUNT
ALPHA_TEST = C.sidak(ALPHA, M_TESTS)


def _load(d: dict, name: str):
    return scene_from_dict(d, name=name)


# ---------------------------------------------------------------------------------------------------
# Coverage tests: every sample is 0 or Le
# ---------------------------------------------------------------------------------------------------

def coverage_test(name: str, scene_d: dict, coverage: np.ndarray, wrong: dict, spp: int,
                  runs: int = RUNS, block: int = BLOCK):
    """Render `scene_d` (an emitter seen directly, max_depth 1, black background) and compare every
    region with the exact coverage x Le, and with each wrong coverage of `wrong`.
    Returns (clean Comparison, {name: Comparison}, Estimate, testable mask)."""
    est = render_estimate(_load(scene_d, name), SAMPLER, "path", spp, runs, ("closed-forms", name),
                          block=block)
    assert est.nonfinite == 0 and est.negative == 0, (est.nonfinite, est.negative)
    ref = cu.exact_regions(3.0 * LE * coverage, block)
    f = ref.mean / (3.0 * LE)
    exact = (f == 0.0) | (f == 1.0)
    # Regions never or always covered: every sample is exactly 0 or exactly Le (float32 2.0).
    off = exact & (est.mean != ref.mean)
    assert not off.any(), (f"{name}: regions {np.flatnonzero(off)} should be exactly "
                           f"{ref.mean[off]}, got {est.mean[off]}")
    mask = cu.testable_binary_regions(f, spp * runs * block * block)
    assert mask.sum() >= 10, f"{name}: only {mask.sum()} testable regions"
    a = cu.subset(est, mask)
    clean = compare(a, cu.subset(ref, mask), ALPHA_TEST)
    wrongs = {k: compare(a, cu.subset(cu.exact_regions(3.0 * LE * c, block), mask), ALPHA_TEST)
              for k, c in wrong.items()}
    return clean, wrongs, est, mask


def assert_clean_and_controls(name, clean, wrongs):
    assert not clean.rejected, f"{name}: {clean.summary()}"
    for k, c in wrongs.items():
        assert c.rejected, f"{name}: negative control '{k}' not rejected: {c.summary()}"


# ---------------------------------------------------------------------------------------------------
# 1. Motion blur
# ---------------------------------------------------------------------------------------------------

# The emitter seen through a pinhole: camera at the origin looking down -z, emitter plane z = -4.
SCREEN = cu.Screen(RES[0], RES[1], FOV, 4.0)
EMITTER = {"e": {"kind": "emitter", "emission": [LE] * 3}}
# A rectangle [X0, X1] x [Y0, Y1] (pixel units at shutter open) moving by (VX, VY) pixels per unit
# of time, diagonally, over the shutter [0, 1].
MB_RECT = (2.3, 6.55, 3.4, 9.8)
MB_V = (6.72, 2.45)


def moving_scene(rect, v, shutter, name):
    x0, x1, y0, y1 = rect
    vel = [float(c) for c in SCREEN.world_vector(*v)]
    q = SCREEN.facing_quad((x0, y0), (x1 - x0, 0.0), (0.0, y1 - y0), "e", velocity=vel)
    return cu.scene_dict(name, SCREEN.camera(shutter=shutter), EMITTER, [q], RES, max_depth=1)


def test_motion_blur_fraction_of_shutter_covered():
    """A fronto-parallel emitter quad moving diagonally at constant velocity over a black
    background, seen directly through a pinhole (max_depth 1): every pixel is Le x the fraction of
    (pixel area x shutter time) the moving rectangle covers, integrated exactly (closed_forms_util.
    moving_rect_coverage: piecewise polynomial in time, exact Gauss-Legendre between the kinks).
    Level ALPHA = 0.01, Sidak over M_TESTS (alpha_test). Negative control: the closed form for the
    velocity x 2 must be rejected (chi2 ~ 5e3 on 30 regions)."""
    x0, x1, y0, y1 = MB_RECT
    vx, vy = MB_V
    cu.assert_off_grid(x0, x1 + vx, y0, y1 + vy)
    exact = cu.moving_rect_coverage(x0, x1, y0, y1, vx, vy, *RES)
    assert math.isclose(exact.sum(), (x1 - x0) * (y1 - y0), rel_tol=1e-12)   # all in view
    wrong = {"velocity x2": cu.moving_rect_coverage(x0, x1, y0, y1, 2 * vx, 2 * vy, *RES)}
    scene = moving_scene(MB_RECT, MB_V, (0.0, 1.0), "mb")
    clean, wrongs, _, _ = coverage_test("motion-blur", scene, exact, wrong, spp=512)
    assert_clean_and_controls("motion blur", clean, wrongs)


# A thin vertical strip (0.45 px wide) sweeping 13.1 px to the right during a shutter of length 0.5:
# its time-averaged image is the histogram of its positions c + v t, flat (0.45 / 13.1 per pixel)
# exactly when t is uniform over the shutter, starting at c and ending at c + v (close - open).
STRIP = (1.35, 1.80, 2.6, 13.4)
STRIP_SWEEP = 13.1
STRIP_SHUTTER = (0.0, 0.5)


def test_motion_positions_are_c_plus_vt_with_t_uniform_over_the_shutter():
    """Unit test of the time dimension: the strip's streak must match the closed form for positions
    c + v t with t ~ U[open, close] (shutter [0, 0.5], so a kernel that ignored the shutter length
    would sweep twice as far). Level ALPHA = 0.01, Sidak over M_TESTS (alpha_test). Negative
    controls (must be rejected): the shutter length ignored (t ~ U[0, 1]: velocity x 2), and a
    non-uniform time density 2 s over the shutter fraction s (a linear ramp)."""
    x0, x1, y0, y1 = STRIP
    length = STRIP_SHUTTER[1] - STRIP_SHUTTER[0]
    v = (STRIP_SWEEP / length, 0.0)         # pixels per unit time
    cu.assert_off_grid(x0, x1, x0 + STRIP_SWEEP, x1 + STRIP_SWEEP, y0, y1)
    exact = cu.moving_rect_coverage(x0, x1, y0, y1, STRIP_SWEEP, 0.0, *RES)
    wrong = {
        "shutter length ignored": cu.moving_rect_coverage(x0, x1, y0, y1, 2 * STRIP_SWEEP, 0.0,
                                                          *RES),
        "time density 2s": cu.moving_rect_coverage(x0, x1, y0, y1, STRIP_SWEEP, 0.0, *RES,
                                                   density=[2.0, 0.0]),
    }
    scene = moving_scene(STRIP, v, STRIP_SHUTTER, "ms")
    clean, wrongs, est, _ = coverage_test("motion-strip", scene, exact, wrong, spp=1024)
    assert_clean_and_controls("moving strip", clean, wrongs)
    # The mean position of the streak (region centres weighted by region values; delta-method
    # variance of the ratio from the regions' variances) against the same functional of the closed
    # form: for t uniform it is the strip's centre + v (close - open) / 2, up to the region grid.
    # Same level alpha_test; the ramp density 2s moves it by sweep / 6 ~ 2.2 px.
    xr = np.tile(np.arange(RES[0] // BLOCK) * BLOCK + BLOCK / 2.0, RES[1] // BLOCK)

    def mean_position(values):
        return float(np.sum(xr * values) / np.sum(values))

    mu = mean_position(est.mean)
    sd = math.sqrt(np.sum(((xr - mu) / np.sum(est.mean)) ** 2 * est.var))
    z_crit = stats.norm.isf(ALPHA_TEST / 2)
    mu_ref = mean_position(cu.exact_regions(3.0 * LE * exact, BLOCK).mean)
    assert abs(mu - mu_ref) / sd < z_crit, (mu, mu_ref, sd)
    mu_ramp = mean_position(cu.exact_regions(3.0 * LE * wrong["time density 2s"], BLOCK).mean)
    assert abs(mu - mu_ramp) / sd >= z_crit, (mu, mu_ramp, sd)


def test_motion_positions_with_a_shutter_not_opening_at_zero():
    """Positions c + v t, t ~ U[open, close], for the shutter [0.5, 1.5]: the rectangle of the
    motion-blur test sweeps from c + v / 2 to c + 3 v / 2. Level ALPHA = 0.01, Sidak over M_TESTS
    (alpha_test). Control: the closed form for c + v (t - open) must be rejected. (This test found
    that the kernels once moved shapes by v (t - open): chi2 = 5.7e3 on 30 against c + v t.)"""
    x0, x1, y0, y1 = MB_RECT
    vx, vy = MB_V
    absolute = cu.moving_rect_coverage(x0 + vx / 2, x1 + vx / 2, y0 + vy / 2, y1 + vy / 2, vx, vy,
                                       *RES)
    from_open = cu.moving_rect_coverage(x0, x1, y0, y1, vx, vy, *RES)
    clean, wrongs, _, _ = coverage_test("motion-offset-shutter",
                                        moving_scene(MB_RECT, MB_V, (0.5, 1.5), "mbo"),
                                        absolute, {"c + v (t - open)": from_open}, spp=512)
    assert_clean_and_controls("shutter [0.5, 1.5]", clean, wrongs)


# ---------------------------------------------------------------------------------------------------
# 2. Depth of field
# ---------------------------------------------------------------------------------------------------

# An emitter half-plane on z = -8 whose edge crosses the view at 20 degrees from vertical, blurred
# by a circle of confusion of 3 pixels; focused behind (D = 2F: 1 - D/F = -1) or in front of it
# (F = 2D: 1 - D/F = 1/2).
DOF_DEPTH = 8.0
DOF_SCREEN = cu.Screen(RES[0], RES[1], FOV, DOF_DEPTH)
DOF_NORMAL = np.array([math.cos(math.radians(20.0)), math.sin(math.radians(20.0))])
DOF_POINT = np.array([7.6, 8.3])
DOF_BLUR_PX = 3.0


def halfplane_scene(aperture, focus, name):
    t = np.array([-DOF_NORMAL[1], DOF_NORMAL[0]])
    L = 300.0      # the other three edges lie far outside the view (and its blur)
    corner = DOF_POINT - L * t
    q = DOF_SCREEN.facing_quad(tuple(corner), tuple(2 * L * t), tuple(L * DOF_NORMAL), "e")
    cam = DOF_SCREEN.camera(aperture=aperture, focus=focus)
    return cu.scene_dict(name, cam, EMITTER, [q], RES, max_depth=1)


def halfplane_coverage(focus, aperture):
    rho = cu.circle_of_confusion(DOF_DEPTH, focus, aperture, DOF_SCREEN.pixel)
    return cu.blurred_halfplane_coverage(DOF_NORMAL, float(DOF_NORMAL @ DOF_POINT), rho, *RES)


@pytest.mark.parametrize("focus", [DOF_DEPTH / 2.0, DOF_DEPTH * 2.0], ids=["behind-focus",
                                                                          "before-focus"])
def test_thin_lens_blurs_an_emitter_edge_by_the_circle_of_confusion(focus):
    """An emitter half-plane seen directly through a thin lens (max_depth 1): a pixel point sees it
    with the probability that a uniform lens point, scaled by 1 - D / F onto the emitter plane,
    lands beyond the edge: the circle-segment fraction g((c - n.x) / rho), rho = |1 - D/F| A / p,
    integrated exactly over the pixel in x and by split Gauss-Legendre in y. Level ALPHA = 0.01,
    Sidak over M_TESTS (alpha_test). Negative controls (must be rejected): the closed form for a
    focus distance 3% longer, and for an aperture 3% wider."""
    aperture = DOF_BLUR_PX * DOF_SCREEN.pixel / abs(1.0 - DOF_DEPTH / focus)
    exact = halfplane_coverage(focus, aperture)
    wrong = {"focus +3%": halfplane_coverage(focus * 1.03, aperture),
             "aperture +3%": halfplane_coverage(focus, aperture * 1.03)}
    clean, wrongs, _, _ = coverage_test(f"thin-lens-f{focus:g}",
                                        halfplane_scene(aperture, focus, "dof"), exact, wrong,
                                        spp=512)
    assert_clean_and_controls(f"thin lens F={focus:g}", clean, wrongs)


# ---------------------------------------------------------------------------------------------------
# 3. Pixel filter
# ---------------------------------------------------------------------------------------------------

PF_RECT = (3.37, 12.41, 2.62, 13.28)


def test_box_filter_coverage_of_a_static_quad():
    """A static fronto-parallel emitter rectangle seen directly through a pinhole (max_depth 1), its
    edges inside pixels: with the box filter (uniform sub-pixel offsets) a pixel's value is Le x the
    area of the pixel inside the projected rectangle, the product of two 1D overlaps. Level
    ALPHA = 0.01, Sidak over M_TESTS (alpha_test). Negative control (must be rejected): the
    rectangle 1% wider (0.045 px more on each side). Power: 16 runs x 512 spp give an edge pixel
    a standard error of ~0.0054 x 3 Le, so the control moves each of the 10 edge regions (of the
    20 partly covered ones tested) by ~8-12 standard errors: noncentrality ~1600, power > 0.9999
    (computed below from the measured variances and asserted > 0.999)."""
    x0, x1, y0, y1 = PF_RECT
    cu.assert_off_grid(x0, x1, y0, y1)
    exact = cu.rect_coverage(x0, x1, y0, y1, *RES)
    grow = 0.005 * (x1 - x0)
    wider = cu.rect_coverage(x0 - grow, x1 + grow, y0, y1, *RES)
    q = SCREEN.facing_quad((x0, y0), (x1 - x0, 0.0), (0.0, y1 - y0), "e")
    d = cu.scene_dict("pixel filter", SCREEN.camera(), EMITTER, [q], RES, max_depth=1)
    clean, wrongs, est, mask = coverage_test("pixel-filter", d, exact, {"1% wider": wider}, spp=512)
    diff = (cu.exact_regions(3 * LE * wider, BLOCK).mean - cu.exact_regions(3 * LE * exact,
                                                                            BLOCK).mean)[mask]
    power, lam = cu.chi2_power(diff, est.var[mask], ALPHA_TEST)
    assert power > 0.999, f"design: power {power:.4f} (lambda {lam:.0f}) against a 1% wider quad"
    assert_clean_and_controls("pixel filter", clean, wrongs)


# ---------------------------------------------------------------------------------------------------
# 4. Several lights of unequal power over a Lambertian plane
# ---------------------------------------------------------------------------------------------------

RHO = 0.6
LIGHT_CAM = {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
             "fov": FOV}
# (kind, centre, size, Le): two one-sided rectangles in the plane y = 1.8 facing down (coplanar, so
# neither can shadow the other) and a sphere low beside them; all outside the camera's view.
LIGHTS = [("quad", (-1.0, 1.8, 0.3), (0.8, 0.5), 6.0),
          ("quad", (0.9, 1.8, -0.6), (0.3, 0.3), 40.0),
          ("sphere", (1.6, 0.6, 0.5), 0.2, 20.0)]


def _rect_down(center, size):
    sx, sz = size
    c = np.array(center, float)
    eu, ev = np.array([sx, 0.0, 0.0]), np.array([0.0, 0.0, sz])      # eu x ev = -y: emits down
    return c - 0.5 * (eu + ev), eu, ev


def light_area(light) -> float:
    kind, _, size, _ = light
    return size[0] * size[1] if kind == "quad" else 4.0 * math.pi * size ** 2


# Velocities for the moving-lights variant (world units per unit time, shutter [0, 1]): the first
# rectangle slides away from the view within its plane, the sphere rises and drifts; the second
# rectangle stays. Every position during the shutter keeps the lights out of view and unshadowed.
LIGHT_VELOCITIES = [(-0.8, 0.0, 0.3), (0.0, 0.0, 0.0), (0.0, 0.3, -0.5)]


def lights_scene(moving: bool = False):
    mats = {"plane": {"kind": "diffuse", "albedo": [RHO] * 3}}
    shapes = [{"kind": "quad", "material": "plane", "origin": [-20.0, 0.0, 20.0],
               "edge_u": [40.0, 0.0, 0.0], "edge_v": [0.0, 0.0, -40.0]}]       # normal +y
    for i, (kind, c, size, le) in enumerate(LIGHTS):
        mats[f"light{i}"] = {"kind": "emitter", "emission": [le] * 3}
        if kind == "quad":
            o, eu, ev = _rect_down(c, size)
            shape = {"kind": "quad", "material": f"light{i}", "origin": [float(v) for v in o],
                     "edge_u": [float(v) for v in eu], "edge_v": [float(v) for v in ev]}
        else:
            shape = {"kind": "sphere", "material": f"light{i}", "center": [float(v) for v in c],
                     "radius": float(size)}
        if moving:
            shape["velocity"] = [float(v) for v in LIGHT_VELOCITIES[i]]
        shapes.append(shape)
    cam = dict(LIGHT_CAM, shutter=[0.0, 1.0]) if moving else LIGHT_CAM
    return cu.scene_dict("lights over a plane", cam, mats, shapes, RES, max_depth=2)


def per_light_irradiance(displacement=None) -> np.ndarray:
    """(n_lights, H, W) pixel-averaged irradiance of the plane point each camera ray sees, per
    light, each light displaced by displacement[i] (6 x 6 Gauss-Legendre over the pixel; the
    integrand is smooth). Checks that no camera ray sees a light and that the sphere shadows no
    rectangle from any visible point."""
    disp = np.zeros((len(LIGHTS), 3)) if displacement is None else np.asarray(displacement, float)
    o, d, w = cu.pinhole_rays(LIGHT_CAM, *RES)
    t = -o[1] / d[..., 1]
    assert np.all(t > 0)
    x = o + d * t[..., None]
    n = np.array([0.0, 1.0, 0.0])
    out = []
    si = next(i for i, l in enumerate(LIGHTS) if l[0] == "sphere")
    sph_c, sph_r = np.asarray(LIGHTS[si][1]) + disp[si], LIGHTS[si][2]
    for (kind, c, size, le), shift in zip(LIGHTS, disp):
        if kind == "quad":
            q0, eu, ev = _rect_down(c, size)
            q0 = q0 + shift
            assert not cu.ray_hits_parallelogram(o, d, q0, eu, ev).any()
            corners = [q0, q0 + eu, q0 + eu + ev, q0 + ev]
            ab = np.linspace(0.0, 1.0, 9)
            grid = [q0 + a * eu + b * ev for a in ab for b in ab]
            assert cu.segment_clears_sphere(x[::3, ::3, ::7].reshape(-1, 3), grid, sph_c, sph_r,
                                            margin=0.05)
            E = cu.polygon_irradiance(x, n, corners, le)
        else:
            assert not cu.ray_hits_sphere(o, d, sph_c, size).any()
            E = cu.sphere_irradiance(x, n, sph_c, size, le)
        out.append(np.sum(E * w, axis=-1))
    return np.array(out)


def moving_light_irradiance(velocity_scale: float = 1.0, n_time: int = 8) -> np.ndarray:
    """Shutter average (t uniform on [0, 1]) of per_light_irradiance with every light at c + v t:
    Gauss-Legendre in t (the irradiance is smooth in t)."""
    tg, wg = np.polynomial.legendre.leggauss(n_time)
    tg, wg = 0.5 * (tg + 1.0), 0.5 * wg
    v = np.asarray(LIGHT_VELOCITIES, float) * velocity_scale
    return sum(wj * per_light_irradiance(v * tj) for tj, wj in zip(tg, wg))


def plane_radiance(E: np.ndarray, weights=None) -> np.ndarray:
    """R + G + B of the Lambertian plane: 3 rho / pi sum_i w_i E_i."""
    w = np.ones(len(E)) if weights is None else np.asarray(weights, float)
    return 3.0 * RHO / math.pi * np.tensordot(w, E, axes=1)


@pytest.mark.parametrize("sampler", ["importance", "uniform"])
def test_lights_of_unequal_power_over_a_lambertian_plane(sampler):
    """Direct light (path, max_depth 2) on a diffuse plane (albedo rho) from two rectangle lights
    and a sphere light of unequal power (power-proportional pick probabilities 0.15, 0.22, 0.63):
    each pixel is rho / pi x sum_i E_i, E_i by Lambert's polygon formula or the exact sphere formula
    pi Le (r/d)^2 cos, averaged over the pixel. Rendered with `importance` (power pick, solid angle,
    MIS) and `uniform` (uniform pick, area sampling, NEE only). Level ALPHA = 0.01, Sidak over
    M_TESTS (alpha_test). Negative controls (must be rejected): the weakest-contributing light 10%
    brighter in the closed form; and the expectation of an estimator that picks lights with
    probability proportional to AREA while weighting by the pick probability it claims (power for
    `importance`, 1/3 for `uniform`): sum_i (q_area_i / p_claimed_i) E_i. For `uniform` (no MIS)
    that is exactly what such a bug would render; for `importance` it is the light-sampled part's
    bias only (MIS shares each light between the two techniques), used as a wrong reference."""
    E = per_light_irradiance()
    exact = plane_radiance(E)
    power = np.array([l[3] * light_area(l) for l in LIGHTS])
    area = np.array([light_area(l) for l in LIGHTS])
    claimed = power / power.sum() if sampler == "importance" else np.full(len(LIGHTS), 1 / 3)
    weakest = int(np.argmin(E.sum(axis=(1, 2))))
    brighter = np.ones(len(LIGHTS))
    brighter[weakest] = 1.1
    wrong = {f"light {weakest} +10%": plane_radiance(E, brighter),
             "area pick": plane_radiance(E, (area / area.sum()) / claimed)}
    est = render_estimate(_load(lights_scene(), "lights"), sampler, "path", 128, RUNS,
                          ("closed-forms", "lights", sampler), block=BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    clean = compare(est, cu.exact_regions(exact, BLOCK), ALPHA_TEST)
    wrongs = {k: compare(est, cu.exact_regions(v, BLOCK), ALPHA_TEST) for k, v in wrong.items()}
    assert_clean_and_controls(f"lights/{sampler}", clean, wrongs)


@pytest.mark.parametrize("sampler", ["importance", "uniform"])
def test_moving_lights_over_a_lambertian_plane(sampler):
    """The lights of the previous test moving during the shutter [0, 1] (path, max_depth 2; with
    `importance` scattered rays must find the lights where light sampling puts them, both at
    c + v t; `uniform` area-samples the moving sphere and rectangle): each pixel is rho / pi x the
    shutter average of the irradiance, Lambert's and the sphere formula at every time, 8-point
    Gauss-Legendre in t (converged to < 1e-9, checked below). Level ALPHA = 0.01, Sidak over
    M_TESTS (alpha_test). Negative control (must be rejected): the closed form for the velocities
    x 2 (the audit's consistent error, in intersection and light sampling alike)."""
    E = moving_light_irradiance()
    E16 = moving_light_irradiance(n_time=16)
    assert np.max(np.abs(E - E16)) < 1e-9 * np.max(E)
    exact = plane_radiance(E)
    wrong = {"velocity x2": plane_radiance(moving_light_irradiance(2.0))}
    est = render_estimate(_load(lights_scene(moving=True), "moving-lights"), sampler, "path", 128,
                          RUNS, ("closed-forms", "moving-lights", sampler), block=BLOCK)
    assert est.nonfinite == 0 and est.negative == 0
    clean = compare(est, cu.exact_regions(exact, BLOCK), ALPHA_TEST)
    wrongs = {k: compare(est, cu.exact_regions(v, BLOCK), ALPHA_TEST) for k, v in wrong.items()}
    assert_clean_and_controls(f"moving lights/{sampler}", clean, wrongs)


# ---------------------------------------------------------------------------------------------------
# 5. Glossy dielectric: directional albedo
# ---------------------------------------------------------------------------------------------------

GD_SAMPLES = 1 << 20
GD_TINT = 0.8           # albedo: tints transmission only
NORMAL = np.array([0.0, 0.0, 1.0])


def wo_at(theta_deg: float, side: float) -> np.ndarray:
    t = math.radians(theta_deg)
    return np.array([math.sin(t), 0.0, side * math.cos(t)])


# (id, exponent, ior, theta_o in degrees, side (+1 outside, -1 inside), lobe sampling,
#  negative controls: {name: (exponent, ior, tint) of the wrong quadrature}).
GD_CASES = [
    ("n10-30deg", 10.0, 1.5, 30.0, 1.0, True, {"ior x1.02": (10.0, 1.53, GD_TINT),
                                                "tint ignored": (10.0, 1.5, 1.0)}),
    ("n10-70deg", 10.0, 1.5, 70.0, 1.0, True, {"exponent 9": (9.0, 1.5, GD_TINT)}),
    ("n100-80deg", 100.0, 1.5, 80.0, 1.0, True, {"exponent 90": (90.0, 1.5, GD_TINT)}),
    ("n3-inside-tir", 3.0, 1.5, 60.0, -1.0, True, {"exponent 2.7": (2.7, 1.5, GD_TINT)}),
    ("n30-inside", 30.0, 1.5, 20.0, -1.0, True, {"ior x1.02": (30.0, 1.53, GD_TINT)}),
    ("n10-ior0.67", 10.0, 1 / 1.5, 20.0, 1.0, True, {"ior x1.02": (10.0, 1.02 / 1.5, GD_TINT)}),
    ("n1-45deg-uniform", 1.0, 1.5, 45.0, 1.0, False, {"exponent 0.8": (0.8, 1.5, GD_TINT),
                                                       "ior x1.02": (1.0, 1.53, GD_TINT)}),
    ("n10-30deg-uniform", 10.0, 1.5, 30.0, 1.0, False, {"ior x1.02": (10.0, 1.53, GD_TINT)}),
]
assert len(GD_CASES) == GD_CASE_COUNT


def gd_case(exponent, ior, theta, side):
    return ("glossy_dielectric", (GD_TINT,) * 3, exponent, ior, NORMAL, wo_at(theta, side))


@pytest.mark.parametrize("cid,exponent,ior,theta,side,lobe,controls", GD_CASES,
                         ids=[c[0] for c in GD_CASES])
def test_glossy_dielectric_directional_albedo(cid, exponent, ior, theta, side, lobe, controls):
    """Directional albedo (reflected + transmitted f|cos| over the sphere, for one wo) of the glossy
    dielectric BSDF: an independent float64 quadrature of the formula of kernels/materials/
    (closed_forms_util.GlossyDielectric: Fresnel-weighted Phong lobes about the mirror and refracted
    directions, each counted on its own side of the surface, transmission x tint (1 - F) / eta^2)
    against the mean sample weight of the renderer's sample_bsdf (chi2 BSDFAdapter; lobe or
    uniform-sphere sampling), 2^20 samples. Level ALPHA = 0.01 (two-sided z), Sidak over M_TESTS
    (alpha_test). Negative controls (must be rejected): the quadrature with a wrong exponent, ior
    or tint, chosen per case where that parameter matters (each shifts the albedo by >= 6 standard
    errors; checked below as a design condition: power >= 0.99)."""
    gd = cu.GlossyDielectric(NORMAL, wo_at(theta, side), exponent, ior, GD_TINT)
    albedo = gd.albedo_value()
    s = C.BSDFAdapter(lobe).sample(gd_case(exponent, ior, theta, side), GD_SAMPLES,
                                   seed=seed_for("closed-forms", "gd", cid))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    assert np.all(np.isfinite(w)) and np.all(w >= 0)
    mean, se = cu.mean_weight_estimate(w)
    z_crit = stats.norm.isf(ALPHA_TEST / 2)
    z = (mean - albedo) / se
    assert abs(z) < z_crit, (f"{cid}: albedo {albedo:.6f}, mean weight {mean:.6f} +- {se:.2e}: "
                             f"z = {z:.2f}, |z| >= {z_crit:.2f} (alpha_test {ALPHA_TEST:.2e})")
    for name, (e2, ior2, tint2) in controls.items():
        a2 = cu.GlossyDielectric(NORMAL, wo_at(theta, side), e2, ior2, tint2).albedo_value()
        shift = abs(a2 - albedo) / se
        assert shift >= z_crit + stats.norm.isf(0.01), \
            f"{cid}/{name}: design: the control moves the albedo by only {shift:.1f} se"
        z2 = (mean - a2) / se
        assert abs(z2) >= z_crit, f"{cid}: negative control '{name}' not rejected: z = {z2:.2f}"


def test_glossy_dielectric_formula_is_the_renderers():
    """The numpy formula the albedo quadrature integrates equals the renderer's eval_bsdf
    (f|cos|) at 4096 random directions per case (float32 tolerance): the quadrature integrates the
    BSDF the renderer samples, not a look-alike. Deterministic; no significance level."""
    rng = np.random.default_rng(7)
    wi = rng.normal(size=(4096, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    for cid, exponent, ior, theta, side, lobe, _ in GD_CASES:
        gd = cu.GlossyDielectric(NORMAL, wo_at(theta, side), exponent, ior, GD_TINT)
        _, f = C.BSDFAdapter(True).evaluate(gd_case(exponent, ior, theta, side), wi)
        ref = gd.f_cos(wi)
        err = np.abs(f[:, 0].astype(np.float64) - ref)
        assert np.all(err <= 1e-4 * ref + 1e-5 * ref.max()), (cid, float(err.max()))


# ---------------------------------------------------------------------------------------------------
# The closed forms' own consistency (deterministic)
# ---------------------------------------------------------------------------------------------------

def test_closed_form_quadratures_are_exact():
    """Deterministic checks of the references themselves: the moving-rectangle integral conserves
    area x time and a shutter density integrating to 1; the segment antiderivative's derivative is
    the segment fraction; the blurred half-plane quadrature has converged and conserves the edge
    position (the blur is symmetric); the Phong-lobe 1D reduction matches a plain 2D grid."""
    x0, x1, y0, y1 = MB_RECT
    area = (x1 - x0) * (y1 - y0)
    for dens in (None, [2.0, 0.0], [3.0, 0.0, 0.0]):
        cov = cu.moving_rect_coverage(x0, x1, y0, y1, *MB_V, *RES, density=dens)
        assert math.isclose(cov.sum(), area, rel_tol=1e-12)
    h = np.linspace(-1.5, 1.5, 30001)
    G = cu.segment_fraction_antiderivative(h)
    assert np.max(np.abs(np.gradient(G, h) - cu.segment_fraction(h))) < 1e-4
    rho = 3.0
    a = cu.blurred_halfplane_coverage(DOF_NORMAL, float(DOF_NORMAL @ DOF_POINT), rho, *RES)
    b = cu.blurred_halfplane_coverage(DOF_NORMAL, float(DOF_NORMAL @ DOF_POINT), rho, *RES,
                                      n_gauss=64)
    assert np.max(np.abs(a - b)) < 1e-10
    sharp = cu.blurred_halfplane_coverage(DOF_NORMAL, float(DOF_NORMAL @ DOF_POINT), 1e-9, *RES)
    # A symmetric blur moves no coverage across the edge along any row far from the image sides.
    rows = slice(5, 11)
    assert np.allclose(a[rows].sum(axis=1), sharp[rows].sum(axis=1), atol=1e-9)
    for exponent, ior, theta, side in ((10.0, 1.5, 70.0, 1.0), (3.0, 1.5, 60.0, -1.0),
                                       (2.0, 1 / 1.5, 50.0, 1.0)):
        gd = cu.GlossyDielectric(NORMAL, wo_at(theta, side), exponent, ior, GD_TINT)
        assert math.isclose(gd.albedo_value(), gd.albedo_bruteforce(800, 800), rel_tol=5e-5)
