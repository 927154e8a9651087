"""`ggx_separable` and `ggx_dielectric_separable` (kernels/materials/): GGX conductor and rough glass
with Mitsuba's separable Smith masking. References: tests/support/ggx_util.py's float64 GGX with
`separable=True` (no code shared with the renderer).

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests.
* Sampling: the chi-square harness (4 x 10^5 samples) of sample_bsdf against pdf_bsdf (visible
  normals), alpha 0.1 (zoomed) to 1, near-normal and grazing wo.
* Directional albedo: the mean sample weight against the float64 quadrature, two-sided z; negative
  control: the height-correlated quadrature (drtlab's `ggx`), checked first to be detectable.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.stats import chi2 as C

import ggx_util as gu
from bsdf_checks import microfacet_chi2
from stats_util import ALPHA, seed_for

N = 400_000
NORMAL = np.array([0.0, 0.0, 1.0])
CHI2_CASES = [(0.1, 30.0, True), (0.4, 15.0, False), (1.0, 75.0, False)]
ALBEDO_CASES = [(0.8, 75.0), (1.0, 60.0)]
GLASS = "ggx_dielectric_separable"
GLASS_CASES = [(0.8, 70.0, False), (1.0, 60.0, True)]           # (alpha, theta, from inside)
M_TESTS = len(CHI2_CASES) + len(ALBEDO_CASES) + 2 * len(GLASS_CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)


def wo_at(theta: float) -> np.ndarray:
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def case(alpha, theta, albedo=(0.8, 0.6, 0.4)):
    return ("ggx_separable", albedo, alpha, 1.5, NORMAL, wo_at(theta))


def test_formula_is_mitsubas_separable_ggx():
    ad = C.BSDFAdapter(True)
    rng = np.random.default_rng(5)
    for alpha, theta in ((0.05, 20.0), (0.4, 60.0), (1.0, 85.0)):
        wi = rng.normal(size=(2000, 3))
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        _, f = ad.evaluate(case(alpha, theta, (1.0, 1.0, 1.0)), wi)
        ref = gu.GGX(NORMAL, wo_at(theta), alpha, separable=True).f_cos(wi)
        np.testing.assert_allclose(f[:, 0], ref, rtol=3e-4, atol=1e-6 * ref.max())
        hc = gu.GGX(NORMAL, wo_at(theta), alpha).f_cos(wi)
        assert np.all(ref <= hc * (1 + 1e-9) + 1e-12)          # G1 G1 <= G2: never above ggx


@pytest.mark.parametrize("alpha,theta,cap", CHI2_CASES)
def test_sampling_chi2(alpha, theta, cap):
    name = f"ggx_separable a={alpha:g} wo={theta:g}"
    microfacet_chi2(C.BSDFAdapter(True), case(alpha, theta), name, N, M_TESTS, seed_for("ggxsep-chi2", name),
                    alpha if cap else None)


@pytest.mark.parametrize("alpha,theta", ALBEDO_CASES)
def test_directional_albedo_against_the_height_correlated_control(alpha, theta):
    s = C.BSDFAdapter(True).sample(case(alpha, theta, (1.0, 1.0, 1.0)), N,
                                   seed_for("ggxsep-albedo", f"{alpha}-{theta}"))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    mean, se = w.mean(), w.std(ddof=1) / math.sqrt(N)
    ref = gu.GGX(NORMAL, wo_at(theta), alpha, separable=True).albedo_value()
    wrong = gu.GGX(NORMAL, wo_at(theta), alpha).albedo_value()
    z_crit = stats.norm.isf(LEVEL / 2)
    assert abs(mean - ref) / se < z_crit, (mean, se, ref)
    assert abs(wrong - ref) / se >= z_crit + stats.norm.isf(0.01)        # the control is detectable
    assert abs(mean - wrong) / se >= z_crit, (mean, wrong)


def glass_case(alpha, theta, inside, albedo=(1.0, 1.0, 1.0)):
    wo = wo_at(theta) * (np.array([1.0, 1.0, -1.0]) if inside else 1.0)
    return (GLASS, albedo, alpha, 1.5, NORMAL, wo)


def test_glass_formula_is_mitsubas_separable_rough_dielectric():
    ad = C.BSDFAdapter(True)
    rng = np.random.default_rng(6)
    for alpha, theta, inside in GLASS_CASES:
        wi = rng.normal(size=(2000, 3))
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        case = glass_case(alpha, theta, inside)
        _, f = ad.evaluate(case, wi)
        ref = gu.GGX(NORMAL, case[5], alpha, 1.5, transmits=True, separable=True).f_cos(wi)
        np.testing.assert_allclose(f[:, 0], ref, rtol=3e-4, atol=1e-6 * ref.max())


@pytest.mark.parametrize("alpha,theta,inside", GLASS_CASES)
def test_glass_sampling_chi2_and_albedo(alpha, theta, inside):
    """Samples against the pdf over the whole sphere (reflection and refraction); the mean weight
    (R + T as flux, tint 1) against the quadrature, the height-correlated one rejected."""
    name = f"{GLASS} a={alpha:g} wo={'-' if inside else ''}{theta:g}"
    case = glass_case(alpha, theta, inside)
    s, _ = microfacet_chi2(C.BSDFAdapter(True), case, name, N, M_TESTS, seed_for("ggxsep-glass", name))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    mean, se = w.mean(), w.std(ddof=1) / math.sqrt(N)
    ref = gu.GGX(NORMAL, case[5], alpha, 1.5, transmits=True, separable=True).albedo_value()
    wrong = gu.GGX(NORMAL, case[5], alpha, 1.5, transmits=True).albedo_value()
    z_crit = stats.norm.isf(LEVEL / 2)
    assert abs(mean - ref) / se < z_crit, (mean, se, ref)
    assert abs(wrong - ref) / se >= z_crit + stats.norm.isf(0.01)
    assert abs(mean - wrong) / se >= z_crit, (mean, wrong)
