"""Mitsuba 3's `roughplastic` as drtlab's `beckmann_plastic` / `ggx_plastic` (and `_nonlinear`)
(kernels/materials/rough_plastic.py, its table rough_plastic_table.py), and its Mitsuba XML import.

* The coat's table: T and R_int against a float64 reference sharing no code with the table, the
  same integrals over microfacet normals (a Gauss-Legendre grid in the D cos theta_m chart,
  normalised by the visible area), agreeing to Mitsuba's own 32 x 32 rule's error; and, where
  Mitsuba is installed, drtlab's eval against Mitsuba's (scalar_rgb) at directions, to float32.
* eval and pdf against a float64 transcription of roughplastic.cpp's formulas, on both sides.
* Statistics: level ALPHA = 0.01, Sidak-corrected over M_TESTS clean tests. Sampling: the
  chi-square harness (2 x 10^5 samples) against pdf_bsdf; negative control: the pdf without the
  coat lobe's share. Directional albedo: the mean sample weight against a float64 quadrature of the
  formula, at most 1; negative control: the base without its 1 / eta^2, above 1 and rejected.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from drtlab import load_scene
from drtlab.errors import InputError
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.materials.rough_plastic_table import table_row

from bsdf_checks import albedo_estimate
from stats_util import ALPHA, seed_for
from test_mitsuba_xml import one_bsdf

N = 200_000
NORMAL = np.array([0.0, 0.0, 1.0])
TINT = (0.8, 0.3, 0.1)
CHI2_CASES = [("ggx_plastic", 0.1, 30.0), ("beckmann_plastic", 0.3, 75.0)]
ALBEDO_CASES = [("ggx_plastic", (1.0, 1.0, 1.0), 0.3, 1.49, 20.0), ("beckmann_plastic_nonlinear", TINT, 0.1, 1.7, 70.0)]
M_TESTS = len(CHI2_CASES) + len(ALBEDO_CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)


def wo_at(theta: float, side: float = 1.0) -> np.ndarray:
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, side * math.cos(t)])


# ---- float64 reference (roughplastic.cpp, microfacet.h, fresnel.h) --------------------------------

def fresnel(c, eta):
    """Unpolarised dielectric reflectance at cosine c > 0 from the side of index 1 into eta."""
    ct2 = 1 - (1 - c * c) / eta ** 2
    ct = np.sqrt(np.maximum(ct2, 0.0))
    rs, rp = (c - eta * ct) / (c + eta * ct), (eta * c - ct) / (eta * c + ct)
    return np.where(ct2 <= 0, 1.0, 0.5 * (rs * rs + rp * rp))


def d_of(dist, alpha, c):
    t2 = (1 - c * c) / (c * c)
    if dist == "beckmann":
        return np.exp(-t2 / alpha ** 2) / (math.pi * alpha ** 2 * c ** 4)
    return 1 / (math.pi * alpha ** 2 * c ** 4 * (1 + t2 / alpha ** 2) ** 2)


def g1_of(dist, alpha, c):
    """Smith's masking at |cos| c (Beckmann: Walter's rational fit, as Mitsuba)."""
    t = np.sqrt(np.maximum(1 - c * c, 0.0)) / np.abs(c)
    with np.errstate(divide="ignore"):
        a = 1 / (alpha * t)
    if dist == "beckmann":
        return np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))
    return 2 / (1 + np.sqrt(1 + (alpha * t) ** 2))


def coat_reference(dist, alpha, eta, mu, n=240):
    """(T(mu), R(mu) from inside at 1/eta): int over m of D max(0, wi.m) X / the same without X."""
    x, w = np.polynomial.legendre.leggauss(n)
    u, phi = np.meshgrid(0.5 * (x + 1), math.pi * (x + 1))
    wt = np.outer(w, w).ravel()
    u, phi = u.ravel(), phi.ravel()
    t2 = -alpha ** 2 * np.log1p(-u) if dist == "beckmann" else alpha ** 2 * u / (1 - u)
    cm = 1 / np.sqrt(1 + t2)
    sm = np.sqrt(1 - cm * cm)
    m = np.stack([sm * np.cos(phi), sm * np.sin(phi), cm], axis=-1)   # drawn with density D cos theta_m
    out = []
    for mu_ in mu:
        wi = np.array([math.sqrt(1 - mu_ * mu_), 0.0, mu_])
        c = m @ wi
        vis = np.maximum(c, 0.0) / cm
        # refracted into eta: wt = -wi / eta + (c / eta - cos_t) m
        ct = np.sqrt(np.maximum(1 - (1 - c * c) / eta ** 2, 0.0))
        wtr = -wi / eta + (c / eta - ct)[:, None] * m
        wtr /= np.linalg.norm(wtr, axis=1, keepdims=True)
        tr = (1 - fresnel(np.abs(c), eta)) * g1_of(dist, alpha, wtr[:, 2]) * (wtr[:, 2] < 0) * (np.sum(wtr * m, axis=1) < 0)
        wr = 2 * c[:, None] * m - wi
        rr = fresnel(np.abs(c), 1 / eta) * g1_of(dist, alpha, wr[:, 2]) * (wr[:, 2] > 0) * (np.sum(wr * m, axis=1) > 0)
        norm = np.sum(wt * vis)
        out.append((np.sum(wt * vis * tr) / norm, np.sum(wt * vis * rr) / norm))
    return np.array(out).T


def lerp_table(row, c):
    x = c * 63
    i = np.minimum(x.astype(int), 62)
    return row[i] + (x - i) * (row[i + 1] - row[i])


def eval_reference(kind, albedo, alpha, eta, wo, wi):
    """f |cos_i| (roughplastic.cpp's eval; drtlab's wo is Mitsuba's si.wi), two-sided."""
    row = table_row(kind, albedo, alpha, eta).astype(np.float64)
    dist = kind.split("_")[0]
    side = np.sign(wo[2])
    co, ci = abs(wo[2]), wi[:, 2] * side
    h = wo + wi
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    ch = np.abs(h[:, 2])
    spec = fresnel(h @ wo, eta) * d_of(dist, alpha, ch) * g1_of(dist, alpha, co) * g1_of(dist, alpha, ci) / (4 * co)
    a = np.asarray(albedo, float)
    d = a / (1 - (a * row[64] if kind.endswith("nonlinear") else row[64]))
    base = d * (lerp_table(row, np.full(1, co)) * lerp_table(row, np.abs(ci)) * np.abs(ci) / (math.pi * eta * eta))[:, None]
    return np.where((ci > 0)[:, None], spec[:, None] + base, 0.0), row


def coat_probability(row, co):
    t, w = lerp_table(row, np.full(1, co))[0], row[65]
    return (1 - t) * w / ((1 - t) * w + t * (1 - w))


# ---- the table ------------------------------------------------------------------------------------

@pytest.mark.parametrize("dist,alpha,eta", [("beckmann", 0.1, 1.49), ("ggx", 0.3, 1.7)])
def test_the_table_is_the_coats_transmittance_and_internal_reflectance(dist, alpha, eta):
    row = table_row(f"{dist}_plastic", TINT, alpha, eta).astype(np.float64)
    mu = np.maximum(1e-6, np.linspace(0, 1, 64))
    t, r = coat_reference(dist, alpha, eta, mu)
    # Mitsuba's 32 x 32 (128 x 128) rule in the sample square has its own error, ~1e-4.
    np.testing.assert_allclose(row[:64][8:], t[8:], atol=1e-3)
    assert abs(row[64] - 2 * np.mean(r * mu)) < 1e-3, (row[64], 2 * np.mean(r * mu))
    assert row[65] == pytest.approx(1 / (1 + np.mean(TINT)), rel=1e-6) and row[66] == (dist == "ggx")
    assert np.all(np.diff(row[8:64]) >= 0) and 0 < row[64] < 1    # more passes at normal incidence


def test_eval_is_mitsubas_at_directions():
    mi = pytest.importorskip("mitsuba")
    try:
        mi.set_variant("scalar_rgb")
    except Exception:       # a build without the variant
        pytest.skip("mitsuba without scalar_rgb")
    ad = C.BSDFAdapter(True)
    wi = np.array([[-0.5, 0.3, 0.81], [0.1, -0.2, 0.97], [0.7, 0.7, 0.14], [-0.95, 0.0, 0.31], [0.3, 0.1, 0.05]])
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    for kind, dist, alpha, eta, nonlinear in (("ggx_plastic_nonlinear", "ggx", 0.3, 1.5, True),
                                              ("beckmann_plastic", "beckmann", 0.1, 1.6, False)):
        b = mi.load_dict({"type": "roughplastic", "distribution": dist, "alpha": alpha, "int_ior": eta,
                          "ext_ior": 1.0, "nonlinear": nonlinear,
                          "diffuse_reflectance": {"type": "rgb", "value": list(TINT)}})
        si = mi.SurfaceInteraction3f()
        si.n = mi.Normal3f(0, 0, 1)
        si.sh_frame = mi.Frame3f(si.n)
        for theta in (20.0, 65.0):
            wo = wo_at(theta)
            si.wi = mi.Vector3f(*wo)
            ref = np.array([list(b.eval(mi.BSDFContext(), si, mi.Vector3f(*w))) for w in wi])
            _, f = ad.evaluate((kind, TINT, alpha, eta, NORMAL, wo), wi)
            np.testing.assert_allclose(f, ref, rtol=3e-5, atol=1e-7)


# ---- eval, pdf, sampling ---------------------------------------------------------------------------

def _dirs(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("kind,alpha", [("beckmann_plastic", 0.1), ("ggx_plastic_nonlinear", 0.3)])
def test_eval_and_pdf_are_the_reference_formula_on_both_sides(kind, alpha):
    ad = C.BSDFAdapter(True)
    wi = _dirs(3000, 5)
    for eta, theta, side in ((1.49, 25.0, 1.0), (1.9, 70.0, -1.0)):
        wo = wo_at(theta, side)
        pdf, f = ad.evaluate((kind, TINT, alpha, eta, NORMAL, wo), wi)
        ref, row = eval_reference(kind, TINT, alpha, eta, wo, wi)
        np.testing.assert_allclose(f, ref, rtol=2e-4, atol=1e-6)
        # The lobe choice is Mitsuba's; the cosine share of the pdf is exactly (1 - P(coat)) cos / pi.
        pc = coat_probability(row, abs(wo[2]))
        same = wi[:, 2] * side > 0
        assert np.all(pdf[~same] == 0) and np.all(pdf[same] >= (1 - pc) * np.abs(wi[same, 2]) / math.pi * (1 - 1e-5))


def _chi2(kind, alpha, theta, pdf_func=None, name=""):
    ad = C.BSDFAdapter(True)
    case = (kind, TINT, alpha, 1.49, NORMAL, wo_at(theta))
    s = ad.sample(case, N, seed_for("rough-plastic-chi2", f"{kind}-{theta}"))
    return C.run_chi2(C.SphericalDomain(NORMAL), lambda k, sd: (s.wi, s.valid),
                      pdf_func or ad.pdf(case), name=name or f"{kind} wo={theta:g}",
                      sample_count=N, res=(51, 102), seed=3, test_count=M_TESTS)


@pytest.mark.parametrize("kind,alpha,theta", CHI2_CASES)
def test_sampling_chi2(kind, alpha, theta):
    r = _chi2(kind, alpha, theta)
    assert r.passed, r.summary()


def test_negative_control_the_cosine_lobe_alone_is_rejected():
    wrong = lambda pts: np.where(pts[:, 2] > 0, pts[:, 2] / math.pi, 0.0)  # noqa: E731
    r = _chi2("ggx_plastic", 0.1, 30.0, wrong, "ggx_plastic without its coat lobe")
    assert r.rejected and r.p_value < LEVEL, r.summary()


def _albedo_reference(kind, albedo, alpha, eta, theta, scale_base=1.0, n=200):
    """The directional albedo, a float64 Gauss-Legendre quadrature of the reference eval."""
    x, w = np.polynomial.legendre.leggauss(n)
    mu, phi = np.meshgrid(0.5 * (x + 1), math.pi * (x + 1))
    s = np.sqrt(1 - mu ** 2)
    wi = np.stack([s * np.cos(phi), s * np.sin(phi), mu], axis=-1).reshape(-1, 3)
    wo = wo_at(theta)
    f, _ = eval_reference(kind, albedo, alpha, eta, wo, wi)
    if scale_base != 1.0:
        spec, _ = eval_reference(kind, (0.0, 0.0, 0.0), alpha, eta, wo, wi)
        f = spec + scale_base * (f - spec)
    return 0.5 * math.pi * np.sum(np.outer(w, w).ravel()[:, None] * f, axis=0)


@pytest.mark.parametrize("kind,albedo,alpha,eta,theta", ALBEDO_CASES)
def test_directional_albedo_is_at_most_one_and_its_negative_control(kind, albedo, alpha, eta, theta):
    s = C.BSDFAdapter(True).sample((kind, albedo, alpha, eta, NORMAL, wo_at(theta)), N,
                                   seed_for("rough-plastic-albedo", f"{kind}-{eta}-{theta}"))
    mean, se = albedo_estimate(s)
    ref = _albedo_reference(kind, albedo, alpha, eta, theta)
    wrong = _albedo_reference(kind, albedo, alpha, eta, theta, scale_base=eta * eta)
    z_crit = stats.norm.isf(LEVEL / 2)
    assert np.all(ref <= 1.0), ref
    # The quadrature itself is good to ~1e-4 (the lobe's peak at alpha 0.1); the estimate to se.
    assert np.all(np.abs(mean - ref) / np.hypot(se, 2e-4) < z_crit), (mean, se, ref)
    assert np.max(wrong) > 1 or np.max(np.abs(mean - wrong) / se) >= z_crit, wrong
    assert np.max(np.abs(mean - wrong) / se) >= z_crit, (mean, wrong)


# ---- Mitsuba XML import --------------------------------------------------------------------------

@pytest.mark.parametrize("bsdf,kind,albedo,alpha,eta", [
    ('<bsdf type="roughplastic"/>', "beckmann_plastic", [0.5] * 3, 0.1, 1.49 / 1.000277),
    ('<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/>'
     '<rgb name="diffuse_reflectance" value="0.8, 0.1, 0.2"/><float name="int_ior" value="1.9"/>'
     '<float name="ext_ior" value="1.2"/></bsdf>', "ggx_plastic", [0.8, 0.1, 0.2], 0.3, 1.9 / 1.2),
    ('<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha_u" value="0.2"/>'
     '<float name="alpha_v" value="0.2"/><boolean name="nonlinear" value="true"/>'
     '<rgb name="specular_reflectance" value="1"/></bsdf>', "beckmann_plastic_nonlinear", [0.5] * 3, 0.2, 1.49 / 1.000277),
    ('<bsdf type="twosided"><bsdf type="roughplastic"><string name="distribution" value="ggx"/><boolean '
     'name="nonlinear" value="true"/><boolean name="sample_visible" value="false"/></bsdf></bsdf>',
     "ggx_plastic_nonlinear", [0.5] * 3, 0.1, 1.49 / 1.000277),
])
def test_roughplastic_loads_as_its_kind(tmp_path, bsdf, kind, albedo, alpha, eta):
    m = one_bsdf(tmp_path, bsdf).materials[0]
    assert (m.kind, m.albedo.tolist()) == (kind, albedo)
    assert m.roughness == pytest.approx(alpha, rel=1e-12) and m.ior == pytest.approx(eta, rel=1e-12)


@pytest.mark.parametrize("bsdf,what", [
    ('<bsdf type="roughplastic"><rgb name="specular_reflectance" value="0.5"/></bsdf>',
     "rgb[@name=specular_reflectance]: must be 1 (drtlab's plastic coat reflects white)"),
    ('<bsdf type="roughplastic"><texture type="checkerboard" name="diffuse_reflectance"/></bsdf>', "textures"),
    ('<bsdf type="roughplastic"><float name="int_ior" value="1.0"/></bsdf>', "int_ior / ext_ior must be > 1"),
    ('<bsdf type="roughplastic"><string name="distribution" value="phong"/></bsdf>', "'phong' is not supported"),
])
def test_refused_roughplastics_in_one_line(tmp_path, bsdf, what):
    with pytest.raises(InputError) as e:
        one_bsdf(tmp_path, bsdf)
    assert "\n" not in str(e.value) and what in str(e.value), str(e.value)


def test_export_writes_them_back(tmp_path):
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    a = one_bsdf(tmp_path, "")
    kinds = ("beckmann_plastic", "ggx_plastic_nonlinear", "smooth_plastic_nonlinear")
    a.materials = [dataclasses.replace(a.materials[0], name=k, kind=k, albedo=np.array([0.8, 0.3, 0.1]),
                                       roughness=0.25, ior=1.6) for k in kinds]
    a.shapes = [dataclasses.replace(a.shapes[0], material=i) for i in range(len(kinds))]
    export_mitsuba(a, tmp_path / "m.xml")
    b = load_scene(tmp_path / "m.xml")
    assert [(m.kind, m.albedo.tolist(), m.ior, m.roughness if m.kind != kinds[2] else 0.25) for m in b.materials] \
        == [(k, [0.8, 0.3, 0.1], 1.6, 0.25) for k in kinds]
