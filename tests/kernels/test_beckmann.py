"""The Beckmann rough conductor (kernels/materials/beckmann.py), a kind from the kind table
(`MaterialKind.model`). References are float64 formulas sharing no code with the renderer.

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests (the
chi-square cases and the albedo cases); negative controls judged at the same level.
* Sampling: the chi-square harness (4 x 10^5 samples) of sample_bsdf against pdf_bsdf, lobe
  (D cos) and uniform strategies, alpha 0.1 (zoomed grid) to 1, near-normal and grazing wo; the valid
  fraction against the claimed pdf's integral. Negative control: the pdf of alpha 10% higher.
* Directional albedo: the mean sample weight against a float64 quadrature of the formula, two-sided
  z; negative control: the quadrature at alpha +25%.
Deterministic: the formula equals the renderer's, reciprocity, Walter's G1 fit within 0.35% of the
exact Smith masking of the Beckmann distribution. What every kind of the kind table must do in the
integrators: tests/kernels/test_kind_table.py.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import special, stats

from drtlab.experiments.stats import chi2 as C

from bsdf_checks import microfacet_chi2
from stats_util import ALPHA, seed_for

N = 400_000
NORMAL = np.array([0.0, 0.0, 1.0])
TINT = (0.8, 0.6, 0.4)
CHI2_CASES = [(True, 0.1, 30.0, True), (True, 0.3, 10.0, False), (True, 0.3, 80.0, False),
              (True, 1.0, 60.0, False), (False, 0.3, 45.0, False)]
ALBEDO_CASES = [(0.3, 30.0), (0.7, 70.0)]
M_TESTS = len(CHI2_CASES) + len(ALBEDO_CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)


def wo_at(theta: float) -> np.ndarray:
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def case(alpha: float, theta: float):
    return ("beckmann", TINT, alpha, 1.5, NORMAL, wo_at(theta))


def g1_fit(alpha, c):
    c = np.abs(c)
    a = c / (alpha * np.sqrt(np.maximum(1 - c * c, 1e-300)))
    return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))


def g1_exact(alpha, c):
    """Smith's masking of the Beckmann distribution: 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi)))."""
    a = np.abs(c) / (alpha * np.sqrt(np.maximum(1 - c * c, 1e-300)))
    return 2.0 / (1.0 + special.erf(a) + np.exp(-a * a) / (a * math.sqrt(math.pi)))


def f_cos(alpha: float, wo, wi, albedo: float = 1.0) -> np.ndarray:
    """f |cos_i| (float64): D G1 G1 / (4 cos_o) with D = exp(-tan^2 / a^2) / (pi a^2 cos^4)."""
    co, ci = wo[..., 2], wi[..., 2]
    h = wo + wi
    m = h / np.linalg.norm(h, axis=-1, keepdims=True)
    cm = m[..., 2]
    d = np.exp(-(1 - cm * cm) / (cm * cm * alpha * alpha)) / (math.pi * alpha ** 2 * cm ** 4)
    r = albedo * d * g1_fit(alpha, co) * g1_fit(alpha, ci) / (4 * co)
    return np.where((co > 0) & (ci > 0) & (cm > 0), r, 0.0)


def albedo_quadrature(alpha: float, theta: float, n: int = 768) -> float:
    x, w = np.polynomial.legendre.leggauss(n)
    ti, wt = 0.25 * math.pi * (x + 1), 0.25 * math.pi * w
    ph, wp_ = math.pi * (x + 1), math.pi * w
    T, P = np.meshgrid(ti, ph, indexing="ij")
    wi = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
    wo = np.broadcast_to(wo_at(theta), wi.shape)
    return float(np.sum(f_cos(alpha, wo, wi) * np.sin(T) * wt[:, None] * wp_[None, :]))


def _random_dirs(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_formula_is_the_renderers_and_reciprocal():
    ad = C.BSDFAdapter(True)
    for alpha, theta in ((0.05, 20.0), (0.3, 50.0), (1.0, 85.0)):
        wi = _random_dirs(2000, 7)
        _, f = ad.evaluate(("beckmann", (1.0, 1.0, 1.0), alpha, 1.5, NORMAL, wo_at(theta)), wi)
        ref = f_cos(alpha, np.broadcast_to(wo_at(theta), wi.shape), wi)
        np.testing.assert_allclose(f[:, 0], ref, rtol=2e-4, atol=1e-6 * ref.max())
        # f(wo, wi) = f(wi, wo): f|cos_i| / cos_i is symmetric.
        back = np.array([ad.evaluate(("beckmann", (1.0,) * 3, alpha, 1.5, NORMAL, w), wo_at(theta)[None])[1][0, 0]
                         for w in wi[:12]])
        np.testing.assert_allclose(f[:12, 0] / wi[:12, 2], back / wo_at(theta)[2], rtol=1e-3, atol=1e-6)


def test_walters_masking_fit_is_within_its_stated_error():
    c = np.cos(np.linspace(0.0, math.radians(89.9), 2000))
    for alpha in (0.05, 0.3, 1.0):
        err = np.abs(g1_fit(alpha, c) / g1_exact(alpha, c) - 1.0)
        assert err.max() < 0.0035, (alpha, err.max())


@pytest.mark.parametrize("lobe,alpha,theta,cap", CHI2_CASES)
def test_sampling_chi2(lobe, alpha, theta, cap):
    name = f"beckmann lobe={lobe} a={alpha:g} wo={theta:g}"
    s, r = microfacet_chi2(C.BSDFAdapter(lobe), case(alpha, theta), name, N, M_TESTS,
                           seed_for("beckmann-chi2", name), alpha if cap else None)
    if not cap:         # the sampler succeeds as often as its claimed pdf integrates to
        sigma = math.sqrt(max(r.integral * (1 - r.integral), 1e-12) / N)
        assert abs(s.valid.mean() - r.integral) < 5 * sigma + 1e-3, (s.valid.mean(), r.integral)


def test_negative_control_a_pdf_of_another_roughness_is_rejected():
    ad = C.BSDFAdapter(True)
    s = ad.sample(case(0.3, 45.0), N, seed_for("beckmann-nc", "alpha"))
    r = C.run_chi2(C.SphericalDomain(NORMAL), lambda n, seed: (s.wi, s.valid), ad.pdf(case(0.33, 45.0)),
                   name="beckmann vs alpha +10%", sample_count=N, res=(101, 202), seed=1, test_count=M_TESTS)
    assert r.rejected and r.p_value < LEVEL, r.summary()


@pytest.mark.parametrize("alpha,theta", ALBEDO_CASES)
def test_directional_albedo_and_its_negative_control(alpha, theta):
    s = C.BSDFAdapter(True).sample(("beckmann", (1.0,) * 3, alpha, 1.5, NORMAL, wo_at(theta)), N,
                                   seed_for("beckmann-albedo", f"{alpha}-{theta}"))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    mean, se = w.mean(), w.std(ddof=1) / math.sqrt(N)
    ref, wrong = albedo_quadrature(alpha, theta), albedo_quadrature(1.25 * alpha, theta)
    z_crit = stats.norm.isf(LEVEL / 2)
    assert 0 < ref <= 1 and abs(mean - ref) / se < z_crit, (mean, se, ref)
    assert abs(wrong - ref) / se >= z_crit + stats.norm.isf(0.01)        # the control is detectable
    assert abs(mean - wrong) / se >= z_crit, (mean, wrong)
