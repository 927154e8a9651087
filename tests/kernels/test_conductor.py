"""The conductor kinds (`conductor`, `beckmann_conductor`, `ggx_conductor`; kernels/materials/
conductor.py): a complex index of refraction eta + i k per channel. References are float64 and
share no code with the renderer: the Fresnel equations in complex arithmetic (numpy), the microfacet
lobes of ggx_util and test_beckmann's formula.

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests.
* Sampling: the chi-square harness (4 x 10^5 samples) of each rough kind's sample_bsdf against its
  pdf_bsdf (the lobe does not depend on eta, k; the weight does).
* Directional albedo of the ggx conductor (copper): the mean weight against a float64 quadrature of
  the formula, two-sided z; negative control: the Fresnel taken at the macro normal instead of at
  the half vector, checked first to be detectable.
Deterministic: the smooth kind's weight is albedo F(cos) of the complex Fresnel; negative controls:
eta and k swapped, and the dielectric Fresnel of index eta, both far from it. The rough kinds' f is
their lobe's times F(wo.wm). The integrators: the smooth kind is a delta lobe (path and whitted
render 0 + 1i exactly as a mirror).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import drtlab
from drtlab.experiments.stats import chi2 as C

import ggx_util as gu
from bsdf_checks import albedo_estimate, assert_consistent, microfacet_chi2
from scene_pieces import glossy_ggx_as
from stats_util import ALPHA, seed_for
from test_beckmann import f_cos as beckmann_f_cos

N = 400_000
NORMAL = np.array([0.0, 0.0, 1.0])
CU = ((0.2010, 0.9237, 1.1022), (3.9133, 2.4530, 2.1421))
AU = ((0.1430, 0.3753, 1.4420), (3.9830, 2.3856, 1.6034))
CHI2_CASES = [("beckmann_conductor", 0.3, 40.0), ("ggx_conductor", 0.5, 70.0)]
M_TESTS = len(CHI2_CASES) + 1
LEVEL = C.sidak(ALPHA, M_TESTS)


def wo_at(theta: float) -> np.ndarray:
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def fresnel_complex(c, eta, k) -> np.ndarray:
    """Unpolarised reflectance from vacuum into index n = eta + i k at cos c: Snell's law and the
    Fresnel amplitudes in complex arithmetic, (|r_s|^2 + |r_p|^2) / 2, per channel (..., 3)."""
    c = np.asarray(c, float)[..., None]
    n = np.asarray(eta, float) + 1j * np.asarray(k, float)
    ct = np.sqrt(n * n - (1 - c * c) + 0j) / n          # cos of the (complex) refracted angle
    rs = (c - n * ct) / (c + n * ct)
    rp = (n * c - ct) / (n * c + ct)
    return 0.5 * (np.abs(rs) ** 2 + np.abs(rp) ** 2)


def test_smooth_conductor_weight_is_the_complex_fresnel():
    ad = C.BSDFAdapter(True)
    tint = np.array([0.9, 0.8, 0.7])
    thetas = np.array([0.0, 20.0, 45.0, 70.0, 85.0, 89.5])
    for eta, k in (CU, AU, ((1.5, 0.3, 0.05), (0.0, 0.2, 7.0))):
        got = np.array([ad.sample(("conductor", tint, 0.1, 1.5, NORMAL, wo_at(t), eta, k), 1, 0).weight[0]
                        for t in thetas])
        c = np.cos(np.radians(thetas))
        np.testing.assert_allclose(got, tint * fresnel_complex(c, eta, k), rtol=2e-5, atol=1e-6)
        # Negative controls: k and eta swapped, the dielectric Fresnel of index eta.
        swapped = tint * fresnel_complex(c, k, eta)
        dielectric = tint * np.stack([gu.fresnel(c, max(e, 1e-3)) for e in eta], axis=-1)
        for wrong in (swapped, dielectric):
            assert np.abs(got - wrong).max() > 0.05


@pytest.mark.parametrize("kind,ref", [("beckmann_conductor", "beckmann"), ("ggx_conductor", "ggx")])
def test_rough_conductor_is_its_lobe_times_fresnel_at_the_half_vector(kind, ref):
    ad = C.BSDFAdapter(True)
    rng = np.random.default_rng(11)
    wi = rng.normal(size=(2000, 3))
    wi[:, 2] = np.abs(wi[:, 2])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    alpha, wo = 0.4, wo_at(55.0)
    _, f = ad.evaluate((kind, (1.0, 1.0, 1.0), alpha, 1.5, NORMAL, wo) + CU, wi)
    lobe = (beckmann_f_cos(alpha, np.broadcast_to(wo, wi.shape), wi) if ref == "beckmann"
            else gu.GGX(NORMAL, wo, alpha, separable=True).f_cos(wi))
    h = gu.unit(wo + wi)
    want = lobe[:, None] * fresnel_complex(h @ wo, *CU)
    np.testing.assert_allclose(f, want, rtol=3e-4, atol=1e-6 * want.max())


@pytest.mark.parametrize("kind,alpha,theta", CHI2_CASES)
def test_sampling_chi2(kind, alpha, theta):
    name = f"{kind} a={alpha:g} wo={theta:g}"
    microfacet_chi2(C.BSDFAdapter(True), (kind, (0.8, 0.6, 0.4), alpha, 1.5, NORMAL, wo_at(theta)) + AU,
                    name, N, M_TESTS, seed_for("conductor-chi2", name))


def _albedo_quadrature(alpha: float, theta: float, at_half: bool, n: int = 512) -> np.ndarray:
    """int f |cos_i| dwi of the ggx conductor (copper), Gauss-Legendre over the hemisphere; Fresnel at
    wo.wm, or (the control) at the macro normal's cos_o."""
    x, w = np.polynomial.legendre.leggauss(n)
    ti, wt = 0.25 * math.pi * (x + 1), 0.25 * math.pi * w
    ph, wph = math.pi * (x + 1), math.pi * w
    T, P = np.meshgrid(ti, ph, indexing="ij")
    wi = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1).reshape(-1, 3)
    wo = wo_at(theta)
    lobe = gu.GGX(NORMAL, wo, alpha, separable=True).f_cos(wi)
    c = gu.unit(wo + wi) @ wo if at_half else np.full(len(wi), wo[2])
    weights = (np.sin(T) * wt[:, None] * wph[None, :]).reshape(-1)
    return np.einsum("i,ic->c", lobe * weights, fresnel_complex(c, *CU))


def test_directional_albedo_and_its_negative_control():
    alpha, theta = 0.5, 75.0
    s = C.BSDFAdapter(True).sample(("ggx_conductor", (1.0,) * 3, alpha, 1.5, NORMAL, wo_at(theta)) + CU, N,
                                   seed_for("conductor-albedo", "ggx"))
    assert_consistent(s, "ggx_conductor")
    mean, se = albedo_estimate(s)
    ref, wrong = _albedo_quadrature(alpha, theta, True), _albedo_quadrature(alpha, theta, False)
    z_crit = stats.norm.isf(LEVEL / 2 / 3)          # three channels, Sidak within the test too
    z = (mean - ref) / se
    assert np.all(np.abs(z) < z_crit), (mean, se, ref)
    assert np.all(np.abs(wrong - ref) / se >= z_crit + stats.norm.isf(0.01))       # detectable
    assert np.any(np.abs(mean - wrong) / se >= z_crit), (mean, wrong)


@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_smooth_conductor_is_a_delta_lobe_in_the_integrators(integrator):
    """0 + 1i (Mitsuba's material "none") renders exactly as a mirror; copper, less bright."""
    mirror = drtlab.render(glossy_ggx_as("mirror", integrator), spp=2, seed=1)
    none = drtlab.render(glossy_ggx_as("conductor", integrator), spp=2, seed=1)
    cu = drtlab.render(glossy_ggx_as("conductor", integrator, eta=CU[0], k=CU[1]), spp=2, seed=1)
    assert np.array_equal(mirror, none)
    assert np.all(cu <= none + 1e-6) and cu.mean() < none.mean() and np.isfinite(cu).all()
