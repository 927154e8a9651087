"""The analytic integrand testbed (experiments/integrands/functions.py, experiments/integrands/study.py).

Exact values. Every integrand's closed-form integral (and 3 members of each randomised family)
agrees with a 2^22-point Monte Carlo estimate (numpy's PCG64, fixed seed) within MC_SIGMAS = 5
standard errors (estimated from the same sample; a false alarm has probability 6e-7 per
comparison); the smooth ones also agree with scipy's adaptive 2D quadrature to 1e-9, the disk and
the half-plane with a 1D quadrature of their exact cross-sections to 1e-9. The half-plane's clipped
area is checked by hand at axis-aligned angles, diagonals, lines touching only a corner, lines
outside the square and an almost axis-aligned angle.

Unbiasedness. The estimate of each integrand from `independent` points, N = 16, UNBIASED_RUNS runs
(fixed seeds, through `integrands.study.signed_errors`, the study's own path), has a mean error whose
t test against 0 must not reject at level ALPHA = 0.01 with a Sidak correction over the integrands
(the tests share their points, so they are dependent; Sidak's inequality still holds for two-sided
tests of jointly normal means). Negative controls: the same test must reject, for every integrand,
the estimate scaled by 1.1 and the one that drops the last point but still divides by N (a bias of
-I/16; measured at these seeds: |z| >= 6.2 for every integrand, where rejection needs 3.2).

Slopes. A small study on the quick profile's ladder (N = 16 ... 4096, 32 runs, the study's seeds):
the RMSE slope of `independent` (`slopes.fit_rmse_slope`) has a 95% interval that contains -0.5
on a discontinuous and a smooth integrand, and `stratified`'s slope on the smooth Gaussian is
steeper than -0.85 (its whole interval; the theory says -1.0).
"""
import math

import numpy as np
import pytest
from drtlab.errors import InputError
from drtlab.experiments.integrands import study
from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.experiments.integrands.functions import (INTEGRANDS, KINDS, SMOOTH, Disk, Family, Gaussian,
                                           HalfPlane, Triangle, half_plane_area)
from scipy import integrate, stats

MC_POINTS = 2 ** 22
MC_CHUNK = 2 ** 20
MC_SIGMAS = 5.0
FAMILY_MEMBERS = 3
ALPHA = 0.01
UNBIASED_N = 16
UNBIASED_RUNS = 4096
QUICK = study.load_study("quick")


def _members(name: str):
    """A batch of the integrand: the fixed one itself, or FAMILY_MEMBERS members of a family."""
    count = FAMILY_MEMBERS if isinstance(INTEGRANDS[name], Family) else 1
    return INTEGRANDS[name].members(np.random.default_rng(7), count)


# ---------------------------------------------------------------------------------------------------
# Exact values
# ---------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def mc_points():
    return np.random.default_rng(20250611).random((MC_POINTS, 2))


@pytest.mark.parametrize("name", list(INTEGRANDS))
def test_integral_matches_monte_carlo(name, mc_points):
    batch = _members(name)
    total = total_sq = 0.0
    for start in range(0, MC_POINTS, MC_CHUNK):
        chunk = mc_points[start:start + MC_CHUNK]
        x, y = chunk[None, :, 0], chunk[None, :, 1]           # (1, chunk): broadcasts over members
        v = np.broadcast_to(batch.f(x, y), (len(batch.exact()), x.shape[1]))
        total = total + v.sum(axis=1)
        total_sq = total_sq + (v * v).sum(axis=1)
    mean = total / MC_POINTS
    se = np.sqrt(np.maximum(total_sq / MC_POINTS - mean ** 2, 0.0) / MC_POINTS)
    exact = batch.exact()
    assert np.all(np.abs(mean - exact) <= MC_SIGMAS * se + 1e-12), (name, mean, exact, se)


@pytest.mark.parametrize("name", [n for n, e in INTEGRANDS.items() if e.kind == SMOOTH])
def test_smooth_integral_matches_quadrature(name):
    batch = _members(name)
    count = len(batch.exact())

    def f(y, x, j):                     # member j of the batch at one point (dblquad's order)
        v = batch.f(np.full((count, 1), x), np.full((count, 1), y))
        return float(np.broadcast_to(v, (count, 1))[j, 0])
    for j, exact in enumerate(batch.exact()):
        value, _ = integrate.dblquad(f, 0, 1, 0, 1, args=(j,), epsabs=1e-12, epsrel=1e-11)
        assert value == pytest.approx(exact, abs=1e-9)


def test_disk_matches_chord_quadrature():
    d = Disk(0.37, 0.6, 0.25)
    chord = lambda x: 2 * math.sqrt(max(d.r ** 2 - (x - d.cx) ** 2, 0.0))
    value, _ = integrate.quad(chord, d.cx - d.r, d.cx + d.r, epsabs=1e-13, limit=200)
    assert d.integral() == pytest.approx(value, abs=1e-9)


def _half_plane_quad(angle: float, offset: float) -> float:
    """1D quadrature of the cross-section: the length of {y in [0, 1]: cos a x + sin a y <= c}."""
    c, s = math.cos(angle), math.sin(angle)

    def length(x):
        t = (offset - c * x) / s
        return min(max(t, 0.0), 1.0) if s > 0 else 1.0 - min(max(t, 0.0), 1.0)
    kinks = [k for k in ((offset / c), (offset - s) / c) if 0 < k < 1] if c else None
    return integrate.quad(length, 0, 1, points=kinks or None, epsabs=1e-13, limit=200)[0]


def test_half_plane_area_matches_cross_section_quadrature():
    rng = np.random.default_rng(3)
    for angle, px, py in zip(rng.uniform(0, 2 * np.pi, 40), rng.uniform(-0.2, 1.2, 40),
                             rng.uniform(-0.2, 1.2, 40)):
        offset = math.cos(angle) * px + math.sin(angle) * py
        assert half_plane_area(angle, offset) == pytest.approx(_half_plane_quad(angle, offset),
                                                               abs=1e-9)


R2 = math.sqrt(2.0)


@pytest.mark.parametrize("angle, offset, area", [
    (0.0, 0.3, 0.3),                      # x <= 0.3
    (math.pi / 2, 0.7, 0.7),              # y <= 0.7
    (math.pi, -0.3, 0.7),                 # x >= 0.3
    (-math.pi / 2, -0.25, 0.75),          # y >= 0.25
    (0.0, 0.0, 0.0),                      # x <= 0: the left side only
    (0.0, 1.0, 1.0),                      # x <= 1: the whole square
    (math.pi / 4, 1 / R2, 0.5),           # x + y <= 1: the diagonal
    (math.pi / 4, 0.5 / R2, 0.125),       # x + y <= 0.5: the corner triangle
    (math.pi / 4, 1.5 / R2, 0.875),       # x + y <= 1.5
    (-math.pi / 4, 0.0, 0.5),             # x <= y
    (math.pi / 4, 0.0, 0.0),              # touches the corner (0, 0) only
    (math.pi / 4, R2, 1.0),               # touches the corner (1, 1) only
    (5 * math.pi / 4, 0.0, 1.0),          # x + y >= 0
    (5 * math.pi / 4, -R2, 0.0),          # x + y >= 2: the corner (1, 1) only
    (0.0, -1.0, 0.0), (0.0, 2.0, 1.0),    # the edge outside the square
    (math.atan2(-1, 2), 0.0, 0.25),       # y >= 2x
    (1e-12, 0.4, 0.4),                    # almost axis-aligned: no cancellation
])
def test_half_plane_area_cases(angle, offset, area):
    assert half_plane_area(angle, offset) == pytest.approx(area, abs=1e-12)
    assert HalfPlane(angle, offset).integral() == pytest.approx(area, abs=1e-12)


def test_bad_shapes_are_rejected():
    with pytest.raises(InputError, match="inside"):
        Disk(0.1, 0.5, 0.2)
    with pytest.raises(InputError, match="vertices"):
        Triangle((0, 0), (0.5, 0.5), (1, 1))
    with pytest.raises(InputError, match="sigma"):
        Gaussian(0.5, 0.5, 0.0)


def test_every_integrand_has_a_kind():
    assert {e.kind for e in INTEGRANDS.values()} == set(KINDS)


# ---------------------------------------------------------------------------------------------------
# Unbiasedness, with negative controls
# ---------------------------------------------------------------------------------------------------

def _t_pvalues(estimator) -> dict:
    errors = study.signed_errors("independent", list(INTEGRANDS), [UNBIASED_N], UNBIASED_RUNS,
                                 QUICK.seed + 1, estimator=estimator)
    return {name: float(stats.ttest_1samp(e[0], 0.0).pvalue) for name, e in errors.items()}


def test_independent_estimates_are_unbiased():
    alpha = sidak(ALPHA, len(INTEGRANDS))
    p = _t_pvalues(study.sample_mean)
    assert all(v > alpha for v in p.values()), p


@pytest.mark.parametrize("control", [
    lambda v: 1.1 * v.mean(axis=1),                        # scaled by 1.1
    lambda v: v[:, :-1].sum(axis=1) / v.shape[1],          # the last point dropped, still / N
], ids=["scaled-1.1", "last-point-dropped"])
def test_negative_control_is_rejected(control):
    alpha = sidak(ALPHA, len(INTEGRANDS))
    p = _t_pvalues(control)
    assert all(v < alpha for v in p.values()), p


# ---------------------------------------------------------------------------------------------------
# Slopes
# ---------------------------------------------------------------------------------------------------

def _fit(pointset: str, integrand: str) -> dict:
    e = study.signed_errors(pointset, [integrand], QUICK.n, QUICK.repetitions, QUICK.seed)[integrand]
    fit = study.fit_ladder_slope(QUICK.n, e, study.fit_seed(QUICK.seed, pointset, integrand))
    assert fit["ok"] and fit["converged"], fit.get("reason")
    return fit


@pytest.mark.parametrize("integrand", ["random-half-planes", "gaussian"])
def test_random_points_slope_is_minus_one_half(integrand):
    fit = _fit("independent", integrand)
    assert fit["slope_lo"] <= -0.5 <= fit["slope_hi"], (fit["slope"], fit["slope_lo"], fit["slope_hi"])


def test_stratified_is_steeper_on_smooth_integrand():
    fit = _fit("stratified", "gaussian")
    assert fit["slope_hi"] < -0.85, (fit["slope"], fit["slope_lo"], fit["slope_hi"])


# ---------------------------------------------------------------------------------------------------
# The study file, the command line and the outputs
# ---------------------------------------------------------------------------------------------------

def test_study_file_covers_every_point_set():
    """Every point set but Cook's tables, which on the pixel dimensions the testbed integrates are
    `stratified` itself (checked here)."""
    from drtlab.estimators.points import points
    from drtlab.estimators.registry import DIRECTION_ONLY_POINTSETS, POINTSETS
    others = tuple(p for p in POINTSETS if p not in DIRECTION_ONLY_POINTSETS)
    assert QUICK.pointsets == others and set(QUICK.expected) == set(others)
    assert DIRECTION_ONLY_POINTSETS == ("presampled", "presampled_random")
    for name in DIRECTION_ONLY_POINTSETS:
        same = POINTSETS[name].same_as_outside_directions
        for seed, pixel in ((0, 0), (7, 12345)):
            assert np.array_equal(points(name, 64, 2, seed=seed, pixel=pixel),
                                  points(same, 64, 2, seed=seed, pixel=pixel))
    assert study.load_study("full").n[-1] == 65536 and QUICK.n[-1] == 4096


@pytest.mark.parametrize("edit, field", [
    (("n = [16, 64, 256, 1024, 4096]", "n = [16, 64, 128]"), "profile.quick.n[2]"),
    (('pointsets = "all"', 'pointsets = ["sobol", "nope"]'), "study.pointsets[1]"),
    (("smooth = -1.5", "smooth = 0.5"), "expected.sobol.smooth"),
])
def test_bad_study_file_names_the_field(tmp_path, edit, field):
    path = tmp_path / "s.toml"
    path.write_text(study.STUDY_FILE.read_text().replace(*edit, 1))
    with pytest.raises(InputError) as e:
        study.load_study("quick", path)
    assert e.value.field == field


@pytest.mark.parametrize("argv, flag", [(["--profile", "huge"], "--profile"), (["--bogus"], "--bogus")])
def test_bad_flag_is_one_line(capsys, argv, flag):
    assert study.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"drtlab: {flag}:"), err
    if flag == "--profile":
        assert "quick" in err and "full" in err


def test_out_must_be_a_folder(capsys, tmp_path):
    (tmp_path / "file").write_text("")
    assert study.main(["--out", str(tmp_path / "file")]) == 2
    assert capsys.readouterr().err.startswith("drtlab: --out:")


def test_outputs(tmp_path, monkeypatch):
    from dataclasses import replace
    from drtlab.experiments.integrands.report import write_outputs
    monkeypatch.setattr(study, "STUDY_CHAIN", {"nsteps": 300, "burn": 100})     # short chains: files only
    small = replace(QUICK, pointsets=("independent", "sobol"), integrands=("disk", "bilinear"),
                    n=(16, 64, 256), repetitions=4)
    summary = study.run(small)
    write_outputs(summary, small, tmp_path, 1.0)
    for f in ("summary.json", "report.md", "manifest.json", "plots/rmse-discontinuous.png",
              "plots/rmse-smooth.png"):
        assert (tmp_path / f).stat().st_size > 0, f
    assert len(summary["results"]) == 4
    assert all(r["verdict"] for r in summary["results"])
    assert "| independent |" in (tmp_path / "report.md").read_text()
