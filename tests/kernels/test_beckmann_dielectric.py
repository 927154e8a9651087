"""`beckmann_dielectric` (kernels/materials/beckmann_dielectric.py): rough glass with Beckmann
microfacets and Walter's separable G1, Mitsuba 3's default `roughdielectric`. Reference: ggx_util's
float64 rough glass with the Beckmann D and G1 in place of GGX's (no code shared with the renderer).

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests.
* Sampling: the chi-square harness (4 x 10^5 samples) of sample_bsdf against pdf_bsdf over the
  sphere, from outside and from inside.
* Directional albedo (R + T as flux, tint 1): the mean weight against the quadrature, two-sided z;
  negative control: the separable GGX glass of the same alpha, checked first to be detectable.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from drtlab.experiments.stats import chi2 as C

import ggx_util as gu
from bsdf_checks import assert_albedo_with_controls, microfacet_chi2
from stats_util import ALPHA, seed_for

N = 400_000
NORMAL = np.array([0.0, 0.0, 1.0])
KIND = "beckmann_dielectric"
CASES = [(0.5, 60.0, False), (0.8, 40.0, True)]           # (alpha, theta, from inside)
M_TESTS = len(CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)


def g1_walter(alpha: float, c) -> np.ndarray:
    c = np.abs(np.asarray(c, float))
    with np.errstate(divide="ignore", invalid="ignore"):        # a = inf at the normal: G1 = 1
        a = c / (alpha * np.sqrt(np.maximum(1 - c * c, 0.0)))
        return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))


@dataclass(frozen=True)
class BeckmannGlass(gu.GGX):
    """D = exp(-tan^2 / a^2) / (pi a^2 cos^4), G = G1(wo) G1(wi) in Walter's fit."""
    transmits: bool = True
    beckmann: bool = True           # False: the GGX glass (the negative control)

    def d(self, c):
        if not self.beckmann:
            return super().d(c)
        c = np.asarray(c, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.exp(-(1 - c * c) / (c * c * self.alpha ** 2)) / (math.pi * self.alpha ** 2 * c ** 4)
        return np.where(c > 0, r, 0.0)

    def normal_angles(self, t):
        if not self.beckmann:
            return super().normal_angles(t)
        t2 = -self.alpha ** 2 * np.log1p(-t)         # D cos dm = dt dphi / (2 pi)
        return 1 / np.sqrt(1 + t2), np.sqrt(t2 / (1 + t2))

    def g2(self, co, ci):
        if not self.beckmann:
            return super().g2(co, ci)
        return g1_walter(self.alpha, co) * g1_walter(self.alpha, ci)


def case(alpha, theta, inside):
    t = math.radians(theta)
    wo = np.array([math.sin(t), 0.0, -math.cos(t) if inside else math.cos(t)])
    return (KIND, (1.0, 1.0, 1.0), alpha, 1.5, NORMAL, wo)


def test_formula_is_mitsubas_beckmann_rough_dielectric():
    ad = C.BSDFAdapter(True)
    rng = np.random.default_rng(8)
    for alpha, theta, inside in CASES + [(0.1, 20.0, False)]:
        wi = rng.normal(size=(2000, 3))
        wi /= np.linalg.norm(wi, axis=1, keepdims=True)
        c = case(alpha, theta, inside)
        _, f = ad.evaluate(c, wi)
        ref = BeckmannGlass(NORMAL, c[5], alpha, separable=True).f_cos(wi)
        np.testing.assert_allclose(f[:, 0], ref, rtol=3e-4, atol=1e-6 * ref.max())
        ggx = BeckmannGlass(NORMAL, c[5], alpha, separable=True, beckmann=False).f_cos(wi)
        assert np.abs(ggx - ref).max() > 0.05 * ref.max()       # the model is not GGX's


@pytest.mark.parametrize("alpha,theta,inside", CASES)
def test_sampling_chi2_and_albedo(alpha, theta, inside):
    name = f"{KIND} a={alpha:g} wo={'-' if inside else ''}{theta:g}"
    c = case(alpha, theta, inside)
    s, _ = microfacet_chi2(C.BSDFAdapter(True), c, name, N, M_TESTS, seed_for("beckmann-glass", name))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    assert_albedo_with_controls(name, BeckmannGlass(NORMAL, c[5], alpha, separable=True), w.mean(),
                                w.std(ddof=1) / math.sqrt(N), {"ggx": {"beckmann": False}}, LEVEL)
