"""The anisotropic Beckmann conductor (kernels/materials/beckmann_anisotropic.py, kind
`beckmann_conductor_anisotropic`): Mitsuba 3's roughconductor with alpha_u != alpha_v. References
are float64 formulas written out here from microfacet.h, sharing no code with the renderer.

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests.
* Sampling: the chi-square harness (4 x 10^5 samples) of sample_bsdf against pdf_bsdf at (alpha_u,
  alpha_v) pairs from mild to strongly anisotropic, with a tangent that is not a frame axis and not
  orthogonal to the normal. Negative control: samples drawn with alpha_u and alpha_v swapped, tested
  against the unswapped pdf, must be rejected at the same level.
* Furnace: eta 0 + k 1 (F = 1), white: the mean weight (directional albedo) is <= 1 within the z
  bound and above 0.97 at small alphas (single scattering loses little light there), 0.9 at 0.3.
Deterministic: D and G1 at given directions against the formulas; alpha_u = alpha_v reproduces the
isotropic beckmann_conductor's eval and pdf to float rounding, whatever the tangent.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drtlab.experiments.stats import chi2 as C

from bsdf_checks import albedo_estimate, assert_consistent, microfacet_chi2
from stats_util import ALPHA, seed_for

KIND = "beckmann_conductor_anisotropic"
N = 400_000
NORMAL = np.array([0.0, 0.0, 1.0])
AU = ((0.1430, 0.3753, 1.4420), (3.9830, 2.3856, 1.6034))
NONE = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))           # F = 1
# A tangent along (1, 1, 0) tilted out of the surface: the lobe's s axis is its projection.
TANGENT = (0.8, 0.8, 0.5)
CHI2_CASES = [(0.3, 0.3, 40.0), (0.2, 0.5, 30.0), (0.05, 0.3, 60.0), (0.6, 0.08, 75.0)]
# (alpha_u, alpha_v, theta_o, the least albedo): single scattering loses more at larger alpha
FURNACE_CASES = [(0.05, 0.1, 30.0, 0.97), (0.08, 0.05, 70.0, 0.97), (0.3, 0.05, 60.0, 0.9)]
M_TESTS = len(CHI2_CASES) + len(FURNACE_CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)


def wo_at(theta: float, phi: float = 20.0) -> np.ndarray:
    t, p = math.radians(theta), math.radians(phi)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def case(au, av, theta, metal=AU, tangent=TANGENT, albedo=(0.8, 0.6, 0.4)):
    return (KIND, albedo, au, 1.5, NORMAL, wo_at(theta)) + tuple(metal) + (av, tangent)


def frame(n, tangent):
    n = np.asarray(n, float)
    s = np.asarray(tangent, float) - n * (n @ tangent)
    s /= np.linalg.norm(s)
    return s, np.cross(n, s), n


def d_ref(au, av, m):
    """Beckmann's anisotropic D (microfacet.h) at local unit normals m (..., 3)."""
    x, y, z = m[..., 0], m[..., 1], m[..., 2]
    return np.exp(-((x / au) ** 2 + (y / av) ** 2) / z ** 2) / (math.pi * au * av * z ** 4)


def g1_ref(au, av, v):
    """Smith's G1 (Walter's rational fit) at local directions v (..., 3) above the surface."""
    a = v[..., 2] / np.sqrt((au * v[..., 0]) ** 2 + (av * v[..., 1]) ** 2)
    return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))


def directions(k: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = rng.normal(size=(k, 3))
    w[:, 2] = np.abs(w[:, 2]) + 0.05
    return w / np.linalg.norm(w, axis=1, keepdims=True)


@pytest.mark.parametrize("au,av", [(0.1, 0.4), (0.5, 0.05), (0.25, 0.25)])
def test_eval_and_pdf_are_the_formulas(au, av):
    ad = C.BSDFAdapter(True)
    wo = wo_at(50.0, 35.0)
    wi = directions(3000, 5)
    pdf, f = ad.evaluate(case(au, av, 50.0, NONE, albedo=(1.0, 1.0, 1.0))[:5] + (wo,) + NONE + (av, TANGENT),
                         wi)
    s, t, n = frame(NORMAL, TANGENT)
    loc = lambda w: np.stack([w @ s, w @ t, w @ n], axis=-1)       # noqa: E731
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    lo, li, lh = loc(np.broadcast_to(wo, wi.shape)), loc(wi), loc(h)
    d = d_ref(au, av, lh)
    want_f = d * g1_ref(au, av, lo) * g1_ref(au, av, li) / (4 * lo[:, 2])
    want_pdf = d * lh[:, 2] / (4 * np.einsum("ij,ij->i", np.broadcast_to(wo, wi.shape), h))
    big = want_f > 1e-6 * want_f.max()
    np.testing.assert_allclose(f[big, 0], want_f[big], rtol=2e-4)
    np.testing.assert_allclose(f[:, 1], f[:, 0], rtol=0, atol=0)        # F = 1, white
    bigp = want_pdf > 1e-6 * want_pdf.max()
    np.testing.assert_allclose(pdf[bigp], want_pdf[bigp], rtol=2e-4)
    # The lobe turns with the tangent: a quarter turn of it is the swapped pair (a control that the
    # comparison above can tell the axes apart).
    if au != av:
        _, f_turned = ad.evaluate(case(au, av, 50.0, NONE)[:5] + (wo,) + NONE + (av, np.cross(NORMAL, TANGENT)),
                                  wi)
        swapped = d_ref(av, au, lh) * g1_ref(av, au, lo) * g1_ref(av, au, li) / (4 * lo[:, 2])
        np.testing.assert_allclose(f_turned[big, 0], swapped[big] * 0.8, rtol=2e-4, atol=1e-6)
        assert np.abs(f[big, 0] - f_turned[big, 0] / 0.8).max() > 0.1 * want_f.max()


def test_g1_values_at_hand_picked_directions():
    """G1 at a = z / sqrt(au^2 x^2 + av^2 y^2): along s only alpha_u counts, along t only alpha_v."""
    ad = C.BSDFAdapter(True)
    au, av = 0.3, 0.1
    s, t, n = frame(NORMAL, TANGENT)
    for axis, alpha in ((s, au), (t, av)):
        wo = math.sin(1.2) * axis + math.cos(1.2) * n        # 68.75 degrees off the normal, in-plane
        wi = 2 * (wo @ n) * n - wo                           # the mirror: wm = n, D = 1 / (pi au av)
        _, f = ad.evaluate((KIND, (1.0,) * 3, au, 1.5, NORMAL, wo) + NONE + (av, TANGENT), wi[None])
        a = math.cos(1.2) / (alpha * math.sin(1.2))
        g1 = 1.0 if a >= 1.6 else (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a)
        want = g1 * g1 / (math.pi * au * av) / (4 * math.cos(1.2))
        assert f[0, 0] == pytest.approx(want, rel=1e-5)


@pytest.mark.parametrize("alpha", [0.08, 0.4])
def test_equal_alphas_are_the_isotropic_kind(alpha):
    ad = C.BSDFAdapter(True)
    wo = wo_at(65.0, 10.0)
    wi = directions(2000, 9)
    for tangent in (TANGENT, (0.0, 1.0, 0.0), (0.0, 0.0, 0.0)):
        p_a, f_a = ad.evaluate((KIND, (0.9, 0.7, 0.5), alpha, 1.5, NORMAL, wo) + AU + (alpha, tangent), wi)
        p_i, f_i = ad.evaluate(("beckmann_conductor", (0.9, 0.7, 0.5), alpha, 1.5, NORMAL, wo) + AU, wi)
        np.testing.assert_allclose(f_a, f_i, rtol=3e-5, atol=1e-7 * f_i.max())
        np.testing.assert_allclose(p_a, p_i, rtol=3e-5, atol=1e-7 * p_i.max())


@pytest.mark.parametrize("au,av,theta", CHI2_CASES)
def test_sampling_chi2(au, av, theta):
    name = f"{KIND} au={au:g} av={av:g} wo={theta:g}"
    microfacet_chi2(C.BSDFAdapter(True), case(au, av, theta), name, N, M_TESTS,
                    seed_for("aniso-chi2", name))


def test_negative_control_swapped_alphas_in_sample_only_is_rejected():
    au, av, theta = 0.05, 0.3, 60.0
    ad = C.BSDFAdapter(True)
    name = "swapped alphas (control)"
    seed = seed_for("aniso-chi2", name)
    wrong = ad.sample(case(av, au, theta), N, seed)
    r = C.run_chi2(C.SphericalDomain(NORMAL), lambda k, sd: (wrong.wi, wrong.valid), ad.pdf(case(au, av, theta)),
                   name=name, sample_count=N, res=(101, 202), seed=seed + 1, test_count=M_TESTS)
    assert not r.passed, r.summary()


@pytest.mark.parametrize("au,av,theta,least", FURNACE_CASES)
def test_white_furnace(au, av, theta, least):
    s = C.BSDFAdapter(True).sample(case(au, av, theta, NONE, albedo=(1.0, 1.0, 1.0)), N,
                                   seed_for("aniso-furnace", f"{au}-{av}-{theta}"))
    assert_consistent(s, KIND)
    mean, se = albedo_estimate(s)
    z_crit = stats.norm.isf(LEVEL)
    assert np.all(mean <= 1.0 + z_crit * se), (mean, se)
    assert np.all(mean > least), mean
