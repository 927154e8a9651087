"""The plastic material (kernels/materials/plastic.py eval_plastic): a diffuse base under a glossy dielectric
coat. References are float64 formulas sharing no code with the renderer (tests/support/plastic_util.py).

Statistics. Level ALPHA = 0.01 with the Sidak correction over the M_TESTS clean statistical tests
of this module, LEVEL = 1 - 0.99^(1 / M_TESTS); every negative control is judged at the same LEVEL.
* Sampling: the generic chi-square harness (experiments/stats/chi2, 10^6 samples, as tests/estimators/test_chi2.py)
  of sample_bsdf against pdf_bsdf, lobe and uniform strategies; plus the checks a chi-square test
  cannot see (the pdf a sample carries = pdf_bsdf, weight = eval_bsdf / pdf), the integral of the
  claimed pdf (1, or the valid mass where the coat lobe crosses the horizon) and the fraction of
  valid samples. Negative controls: the coat chosen with probability 1/2 instead of F_o, and the
  coat lobe's exponent 10% high in the claimed pdf.
* Directional albedo: the mean sample weight (2^20 samples) against a float64 quadrature, two-sided
  z; negative controls: the quadrature with one modelling choice wrong (no 1/(1 - Fbar), coat
  weighted by F_o instead of min(F_o, F_i), ior +5%, albedo +1%), each checked to move the albedo by
  >= z_crit + z_0.01 standard errors first (power >= 0.99).
* Energy: deterministic quadrature <= 1 over angles x exponents x iors, and the kernel's mean weight
  for a white base one-sided against 1.
* Renders: a plastic sphere in a white furnace (closed form: the pixel-averaged directional albedo)
  with the lobe and the uniform strategy, each against the closed form and against each other, and
  tests/support/data/plastic.toml with both strategies against each other (Welch t per region -> chi-square,
  tests/support/stats_util.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drtlab.errors import InputError
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

import plastic_util as pu
import scene_util as su
from scene_pieces import camera_rays
from stats_util import ALPHA, compare, render_estimate, seed_for
from bsdf_checks import assert_albedo_with_controls, assert_consistent

N = 1_000_000
ALBEDO_SAMPLES = 1 << 20
NORMAL = pu.unit([0.3, -0.2, 0.93])        # not axis-aligned: exercises frame_to_world
FRAME = C.orthonormal_frame(NORMAL)
TINT = (0.8, 0.6, 0.4)
SCENE = "tests/support/data/plastic.toml"


def wo_at(theta_deg: float, below: bool = False) -> np.ndarray:
    th = math.radians(theta_deg)
    return FRAME @ np.array([math.sin(th), 0.0, -math.cos(th) if below else math.cos(th)])


def case_of(exponent, ior, theta, below=False, albedo=TINT):
    albedo = (albedo,) * 3 if np.isscalar(albedo) else albedo
    return ("plastic", albedo, float(exponent), float(ior), NORMAL, wo_at(theta, below))


# (lobe strategy, exponent, ior, theta_o, from below, zoomed grid about the mirror direction)
CHI2_CASES = [
    (True, 0.0, 1.5, 30.0, False, False),
    (True, 10.0, 1.5, 60.0, False, False),
    (True, 30.0, 1.5, 85.0, False, False),      # coat chosen 60% of the time, lobe cut by the horizon
    (True, 100.0, 2.5, 45.0, True, False),      # two-sided: wo below the surface
    (True, 1000.0, 1.5, 20.0, False, True),
    (True, 1e4, 1.5, 89.5, False, True),        # horizon through the zoomed lobe
    (False, 10.0, 1.5, 30.0, False, False),
    (False, 1.0, 1.5, 70.0, True, False),
]
# (id, lobe, exponent, ior, theta_o, below, albedo, negative controls: Plastic fields changed)
ALBEDO_CASES = [
    ("n0-30deg", True, 0.0, 1.5, 30.0, False, 0.8, {"no 1/(1 - Fbar)": dict(fbar_scale=0.0),
                                                     "ior x1.05": dict(ior=1.575)}),
    ("n20-60deg", True, 20.0, 1.5, 60.0, False, 0.8, {"coat by F_o": dict(coat_min=False),
                                                      "ior x1.05": dict(ior=1.575)}),
    ("n100-85deg", True, 100.0, 1.5, 85.0, False, 0.5, {"coat by F_o": dict(coat_min=False),
                                                        "albedo +1%": dict(albedo=0.505)}),
    ("n1000-20deg-dark", True, 1000.0, 1.5, 20.0, False, 0.05, {"ior x1.05": dict(ior=1.575),
                                                                "no 1/(1 - Fbar)": dict(fbar_scale=0.0)}),
    ("n10-45deg-below", True, 10.0, 2.0, 45.0, True, 0.8, {"coat by F_o": dict(coat_min=False),
                                                           "albedo +1%": dict(albedo=0.808)}),
    ("n5-40deg-uniform", False, 5.0, 1.5, 40.0, False, 0.8, {"no 1/(1 - Fbar)": dict(fbar_scale=0.0),
                                                             "albedo +1%": dict(albedo=0.808)}),
    ("n30-75deg-uniform", False, 30.0, 1.3, 75.0, False, 0.8, {"coat by F_o": dict(coat_min=False),
                                                               "ior x1.05": dict(ior=1.365)}),
]
# White base, lobe sampling: (exponent, ior, theta_o); the mean weight must not exceed 1.
ENERGY_CASES = [(0.0, 1.5, 0.0), (10.0, 1.5, 45.0), (100.0, 2.5, 80.0), (1.0, 1.5, 89.0)]
RENDER_COMPARISONS = 4      # furnace: lobe vs truth, uniform vs truth, lobe vs uniform; scene: 1
M_TESTS = len(CHI2_CASES) + len(ALBEDO_CASES) + len(ENERGY_CASES) + RENDER_COMPARISONS
LEVEL = C.sidak(ALPHA, M_TESTS)


# ---------------------------------------------------------------------------------------------------
# Deterministic: the formula, reciprocity, energy by quadrature, the loader
# ---------------------------------------------------------------------------------------------------

def test_formula_is_the_renderers():
    """eval_bsdf (f|cos|) equals the float64 formula at 4096 random directions per case (float32
    tolerance), both sides of the surface: the quadratures below integrate the renderer's BSDF."""
    rng = np.random.default_rng(11)
    wi = rng.normal(size=(4096, 3))
    wi /= np.linalg.norm(wi, axis=1, keepdims=True)
    ad = C.BSDFAdapter(True)
    for exponent, ior, theta, below, albedo in [(20.0, 1.5, 40.0, False, 0.7), (1000.0, 1.5, 30.0,
                                                False, 0.2), (0.0, 2.0, 80.0, True, 1.0),
                                                (5.0, 1.01, 60.0, False, 0.5)]:
        _, f = ad.evaluate(case_of(exponent, ior, theta, below, albedo), wi)
        ref = pu.Plastic(NORMAL, wo_at(theta, below), exponent, ior, albedo).f_cos(wi)
        err = np.abs(f[:, 0].astype(np.float64) - ref)
        assert np.all(err <= 3e-4 * ref + 1e-6 * ref.max()), (exponent, ior, float(err.max()))


@pytest.mark.parametrize("exponent,ior", [(0.0, 1.5), (20.0, 1.5), (300.0, 2.5)])
def test_eval_is_reciprocal(exponent, ior):
    """f(wo, wi) = f(wi, wo) (float32 tolerance) over all pairs of 24 random directions on both sides
    of the surface; pairs on opposite sides are 0 both ways."""
    rng = np.random.default_rng(int(exponent) + 7)
    d = rng.normal(size=(24, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ad = C.BSDFAdapter(True)
    f = np.empty((len(d), len(d)))
    for a, wo in enumerate(d):
        _, fc = ad.evaluate(("plastic", TINT, exponent, ior, NORMAL, wo), d)
        f[a] = fc[:, 1] / np.maximum(np.abs(d @ NORMAL), 1e-30)
    assert np.count_nonzero(f) > 200
    np.testing.assert_allclose(f, f.T, rtol=2e-4, atol=1e-7 * f.max())


def test_energy_conservation_by_quadrature():
    """Directional albedo of a white base <= 1 at 25 angles (cos_o from 1 to 0.001) for exponents 0
    to 10^4 and iors 1.01 to 4; exactly 1 at normal incidence while F is monotone (ior <= 3.7)."""
    for exponent in (0.0, 1.0, 10.0, 100.0, 1e4):
        for ior in (1.01, 1.5, 2.5, 3.7, 4.0):
            albedos = [pu.Plastic(NORMAL, wo_at(math.degrees(math.acos(c))), exponent, ior).albedo_value()
                       for c in np.linspace(1.0, 0.001, 25)]
            assert max(albedos) <= 1.0 + 1e-12, (exponent, ior, max(albedos))
            if ior <= 3.7:
                assert albedos[0] == pytest.approx(1.0, abs=1e-12), (exponent, ior)


def test_quadratures_are_exact():
    """The references themselves: the closed-form Fresnel average against a 10^6-point midpoint
    rule, and the lobe-frame albedo quadrature against a plain (cos theta, phi) grid."""
    mu = (np.arange(1_000_000) + 0.5) / 1_000_000
    for ior in (1.01, 1.5, 2.5):
        assert pu.fresnel_average(ior) == pytest.approx(np.mean(2 * mu * pu.fresnel_v(mu, ior)),
                                                        abs=1e-10)
    for exponent, ior, theta in ((0.0, 1.5, 30.0), (3.0, 2.5, 70.0), (10.0, 1.5, 85.0)):
        p = pu.Plastic(NORMAL, wo_at(theta), exponent, ior, 0.7)
        assert p.albedo_value() == pytest.approx(p.albedo_bruteforce(), abs=2e-6)


def test_loader_defaults_and_bad_input():
    base = {"scene": {"description": "t"}, "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
            "materials": {"p": {"kind": "plastic"}},
            "shapes": [{"kind": "sphere", "material": "p", "center": [0, 0, 0], "radius": 1}]}
    m = scene_from_dict(base).materials[0]
    assert (m.kind, m.exponent, m.ior) == ("plastic", 100.0, 1.5)
    assert m.albedo.tolist() == [0.5, 0.5, 0.5]
    for key, value, fragment in [("ior", 1.0, "> 1"), ("exponent", -1, ">= 0"),
                                 ("albedo", [1.1, 0, 0], "[0, 1]"), ("radius", 1, "allowed keys")]:
        d = {**base, "materials": {"p": {"kind": "plastic", key: value}}}
        with pytest.raises(InputError) as err:
            scene_from_dict(d)
        assert err.value.field == f"materials.p.{key}" and fragment in err.value.message


# ---------------------------------------------------------------------------------------------------
# Sampling: chi-square through the generic harness
# ---------------------------------------------------------------------------------------------------

def chi2_setup(lobe, exponent, ior, theta, below, cap):
    case = case_of(exponent, ior, theta, below)
    model = pu.Plastic(NORMAL, case[5], exponent, ior, TINT[0])
    if cap:
        return case, model, C.CapDomain(model.frame[3], 20.0 / (exponent + 1.0)), (101, 202)
    return case, model, C.SphericalDomain(NORMAL), (101, 202)


@pytest.mark.parametrize("lobe,exponent,ior,theta,below,cap", CHI2_CASES,
                         ids=[f"{'lobe' if c[0] else 'uniform'}-n={c[1]:g}-ior={c[2]:g}-"
                              f"wo={'-' if c[4] else ''}{c[3]:g}deg" for c in CHI2_CASES])
def test_sampling_chi2(lobe, exponent, ior, theta, below, cap):
    case, model, domain, res = chi2_setup(lobe, exponent, ior, theta, below, cap)
    name = f"plastic lobe={lobe} n={exponent:g} ior={ior:g} wo={theta:g}{'-' if below else ''}"
    ad = C.BSDFAdapter(lobe)
    s = ad.sample(case, N, seed_for("plastic-chi2", name))
    assert_consistent(s, name)
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), ad.pdf(case), name=name, sample_count=N,
                   res=res, seed=seed_for("plastic-chi2-grid", name), test_count=M_TESTS)
    print(r.summary())
    assert r.passed, r.summary()
    # The claimed pdf integrates to the valid mass (1 unless the coat lobe crosses the horizon), and
    # the sampler succeeds that often (binomial, 5 sigma). A zoomed grid holds only part of it.
    mass = model.valid_mass(lobe)
    if not cap:
        assert abs(r.integral - mass) < 1e-3, f"integral {r.integral:.6f} vs mass {mass:.6f}"
    sigma = math.sqrt(max(mass * (1 - mass), 1e-12) / N)
    assert abs(s.valid.mean() - mass) < 5 * sigma + 1e-5, (s.valid.mean(), mass)


def _wrong_coat_probability(model: pu.Plastic):
    """The mixture pdf with the coat chosen with probability 1/2 instead of F_o (float64)."""
    nf, _, _, r = model.frame
    n = model.exponent

    def pdf(wi):
        wi = np.asarray(wi, float)
        ci, ca = wi @ nf, wi @ r
        lobe = np.where(ca > 0, (n + 1) / (2 * math.pi) * np.maximum(ca, 0) ** n, 0.0)
        return np.where(ci > 0, 0.5 * lobe + 0.5 * ci / math.pi, 0.0)
    return pdf


@pytest.mark.parametrize("control", ["coat probability 1/2", "exponent +10%"])
def test_negative_control_wrong_pdf_is_rejected(control):
    case, model, domain, res = chi2_setup(True, 30.0, 1.5, 70.0, False, False)
    ad = C.BSDFAdapter(True)
    s = ad.sample(case, N, seed_for("plastic-nc", control))
    pdf = (_wrong_coat_probability(model) if control == "coat probability 1/2"
           else ad.pdf(case_of(33.0, 1.5, 70.0)))
    r = C.run_chi2(domain, lambda n, seed: (s.wi, s.valid), pdf, name=f"plastic vs {control}",
                   sample_count=N, res=res, seed=1, test_count=M_TESTS)
    print("negative control:", r.summary())
    assert r.rejected and r.p_value < LEVEL, r.summary()


# ---------------------------------------------------------------------------------------------------
# Directional albedo and energy: the kernel's sample weights against the quadrature
# ---------------------------------------------------------------------------------------------------

def mean_weight(lobe: bool, case, key) -> tuple[float, float]:
    s = C.BSDFAdapter(lobe).sample(case, ALBEDO_SAMPLES, seed=seed_for("plastic-albedo", key))
    w = np.where(s.valid, s.weight[:, 0].astype(np.float64), 0.0)
    assert np.all(np.isfinite(w)) and np.all(w >= 0)
    return float(w.mean()), float(w.std(ddof=1) / math.sqrt(len(w)))


@pytest.mark.parametrize("cid,lobe,exponent,ior,theta,below,albedo,controls", ALBEDO_CASES,
                         ids=[c[0] for c in ALBEDO_CASES])
def test_directional_albedo(cid, lobe, exponent, ior, theta, below, albedo, controls):
    model = pu.Plastic(NORMAL, wo_at(theta, below), exponent, ior, albedo)
    mean, se = mean_weight(lobe, case_of(exponent, ior, theta, below, albedo), cid)
    assert_albedo_with_controls(cid, model, mean, se, controls, LEVEL)


@pytest.mark.parametrize("exponent,ior,theta", ENERGY_CASES)
def test_energy_conservation_of_the_kernel(exponent, ior, theta):
    """White base: the mean weight of lobe samples (its directional albedo) is not above 1
    (one-sided z at LEVEL); at normal incidence it is 1 within the same bound."""
    mean, se = mean_weight(True, case_of(exponent, ior, theta, albedo=1.0), ("energy", theta))
    z = (mean - 1.0) / se
    print(f"energy n={exponent:g} ior={ior:g} wo={theta:g}: albedo {mean:.6f} +- {se:.1e}, z = {z:.2f}")
    assert z < stats.norm.isf(LEVEL), f"albedo {mean:.6f} +- {se:.1e} exceeds 1 (z = {z:.2f})"
    if theta == 0.0:
        assert abs(z) < stats.norm.isf(LEVEL / 2), (mean, se)


# ---------------------------------------------------------------------------------------------------
# Renders
# ---------------------------------------------------------------------------------------------------

FURNACE = dict(exponent=20.0, ior=1.5, albedo=0.8)


def furnace(**change) -> su.ClosedForm:
    """A plastic sphere in a background of radiance 1 (tests/scene_util.sphere_furnace): every
    reflected ray escapes the convex sphere, so a pixel is its rays' directional albedo, averaged
    over the pixel (6 x 6 Gauss-Legendre rays, albedo interpolated from 257 quadratures)."""
    params = {**FURNACE, **change}
    cf = su.sphere_furnace("plastic", exponent=params["exponent"], ior=params["ior"],
                           albedo=FURNACE["albedo"], depth=2)
    cam = cf.scene["camera"]
    res = cf.scene["scene"]["resolution"]
    o, d, w = camera_rays(cam, res[0], res[1], n_pix=6)
    b = np.sum(o * d, axis=-1)
    t = -b - np.sqrt(b * b - (np.sum(o * o, axis=-1) - 1.0))
    cos_o = np.clip(np.sum((o + d * t[..., None]) * -d, axis=-1), 0.0, 1.0)
    table_c = np.linspace(0.0, 1.0, 257) ** 0.5
    normal = np.array([0.0, 0.0, 1.0])
    table_a = [pu.Plastic(normal, np.array([math.sqrt(1 - c * c), 0.0, c]), **params).albedo_value()
               for c in table_c]
    truth = 3.0 * np.sum(np.interp(cos_o, table_c, table_a) * w, axis=-1)
    return su.ClosedForm("plastic-furnace", cf.scene, truth)


def test_furnace_render_matches_the_closed_form_with_both_strategies():
    """Path tracing, lobe (importance) and uniform strategies, 8 runs x 64 spp, 12 regions of 4 x 4
    pixels: each against the closed form and against each other. Negative control: the closed
    form without the base's 1/(1 - Fbar) must be rejected by the lobe render."""
    cf = furnace()
    truth = cf.region_truth(4)
    est = {sampler: render_estimate(cf.load(), sampler, "path", 64, 8, ("plastic-furnace", sampler),
                                    block=4) for sampler in ("importance", "uniform")}
    for sampler, e in est.items():
        assert e.nonfinite == 0 and e.negative == 0
        c = compare(e, truth, LEVEL)
        print(sampler, c.summary())
        assert not c.rejected, f"{sampler}: {c.summary()}"
    c = compare(est["importance"], est["uniform"], LEVEL)
    assert not c.rejected, c.summary()
    wrong = furnace(fbar_scale=0.0).region_truth(4)
    assert compare(est["importance"], wrong, LEVEL).rejected


def test_scene_renders_agree_between_strategies():
    """tests/support/data/plastic.toml (plastic spheres and box, diffuse floor and wall, a quad light; path
    tracing, depth 5) at 32 x 24 with its coats broadened (exponents 30 and 60: uniform sampling
    of a 2000 lobe has heavy tails), importance vs uniform, 8 runs x 64 spp, 48 regions."""
    overrides = {"materials.red.exponent": 30.0, "materials.black.exponent": 60.0,
                 "scene.resolution": [32, 24]}
    scene = load_scene(SCENE, overrides)
    est = {s: render_estimate(scene, s, "path", 64, 8, ("plastic-scene", s), block=4)
           for s in ("importance", "uniform")}
    assert all(e.nonfinite == 0 and e.negative == 0 for e in est.values())
    c = compare(est["importance"], est["uniform"], LEVEL)
    print(c.summary())
    assert not c.rejected, c.summary()


@pytest.mark.parametrize("integrator", ["whitted", "drt"])
def test_other_integrators_render_plastic(integrator):
    """Whitted (direct light at plastic, as at glossy) and drt (continues through plastic like
    glossy) compile and render finite, non-negative images with a lit plastic sphere."""
    scene = load_scene(SCENE, {"scene.resolution": [24, 18]})
    img = render(scene, spp=4, sampler="importance", integrator=integrator, seed=3, progress=False)
    assert np.all(np.isfinite(img)) and np.all(img >= 0) and img.max() > 0
