"""Mitsuba 3's `principled` and `principledthin` as drtlab's `principled` and `principled_thin`
(kernels/materials/principled.py, principled_thin.py, principled_common.py) and their XML import.

* eval at normal incidence against the Disney terms computed by hand; eval and pdf at random
  directions against a float64 transcription of principled.cpp / principledthin.cpp (shares no
  code with the kernels), on both sides.
* Statistics: level ALPHA = 0.01, Sidak-corrected over M_TESTS clean tests. Sampling: the
  chi-square harness (2 x 10^5 samples) against pdf_bsdf for three parameter sets; negative control:
  a pdf whose diffuse lobe is chosen twice as often as sample() chooses it (a wrong lobe
  probability), rejected. Furnaces: white, lossless closed forms -- metallic 1 at roughness -> 0
  is a mirror (albedo 1), spec_trans 1 a smooth dielectric (F + (1 - F) / eta_path^2, radiance's
  compression, from either side), a thin smooth sheet F + (1 - F) = 1; a thin sheet with
  diff_trans 2 a Lambertian transmitter (every weight exactly base_color).
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

import warp as wp

from drtlab.errors import InputError
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.materials.material_at import material_at, material_at_for
from drtlab.kernels.materials.principled_common import METALLIC, SHEEN
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from drtlab.kernels.scene_upload import upload
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME
from drtlab.kernels.scene_model.principled_params import PARAM_BY_NAME, PARAMS, eta_of_specular

from bsdf_checks import albedo_estimate, assert_consistent
from stats_util import ALPHA, seed_for
from test_mitsuba_xml import load, one_bsdf
from test_textures import TO_UV, mapped, mitsuba_checkerboard, off_edges, quad_scene, uv_points

N = 200_000
Z = np.array([0.0, 0.0, 1.0])
BASE = (0.8, 0.5, 0.3)
FULL = {"roughness": 0.4, "metallic": 0.3, "spec_trans": 0.4, "clearcoat": 0.6, "clearcoat_gloss": 0.3,
        "sheen": 0.5, "sheen_tint": 0.4, "spec_tint": 0.3, "anisotropic": 0.5, "flatness": 0.3}
THIN = {"roughness": 0.35, "spec_trans": 0.5, "diff_trans": 0.8, "sheen": 0.6, "sheen_tint": 0.5,
        "spec_tint": 0.4, "anisotropic": 0.6, "flatness": 0.4}
# (kind, params, ior, wo)
CHI2_CASES = [("principled", FULL, 1.5, (0.6, 0.0, 0.8)),
              ("principled", {"roughness": 0.5, "spec_trans": 0.8, "anisotropic": 0.3}, 1.4, (0.3, 0.5, -0.812404)),
              ("principled_thin", THIN, 1.33, (-0.5, 0.2, 0.842615))]
FURNACES = 4
M_TESTS = len(CHI2_CASES) + FURNACES
LEVEL = C.sidak(ALPHA, M_TESTS)


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def full_params(p):
    return {q.name: p.get(q.name, q.default) for q in PARAMS}


# ---- float64 reference (principled.cpp, principledthin.cpp, principledhelpers.h, microfacet.h) -----

def fresnel(c, eta):
    """Mitsuba's fresnel(cos_i, eta), cos_i < 0 from inside."""
    c = np.asarray(c, dtype=np.float64)
    e = np.where(c >= 0, eta, 1 / eta)
    ca = np.abs(c)
    ct2 = 1 - (1 - ca * ca) / e ** 2
    ct = np.sqrt(np.maximum(ct2, 0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = (ca - e * ct) / (ca + e * ct)
        rp = (e * ca - ct) / (e * ca + ct)
    return np.where(ct2 <= 0, 1.0, 0.5 * (rs * rs + rp * rp))


def sw(c):
    return np.clip(1 - c, 0, 1) ** 5


def calc_schlick(r0, c, eta):
    out = c >= 0
    eta_it = np.where(out, eta, 1 / eta)
    eta_ti = np.where(out, 1 / eta, eta)
    ct = np.sqrt(np.maximum(1 - (1 - c * c) * eta_ti ** 2, 0))
    w = np.where(eta_it > 1, sw(np.abs(c)), sw(ct))[:, None]
    return r0 * (1 - w) + w


def alphas(p, rough=None):
    r2 = (p["roughness"] if rough is None else rough) ** 2
    asp = math.sqrt(1 - 0.9 * p["anisotropic"])
    return max(1e-3, r2 / asp), max(1e-3, r2 * asp)


def D(a, m):
    d = 1 / (math.pi * a[0] * a[1] * ((m[:, 0] / a[0]) ** 2 + (m[:, 1] / a[1]) ** 2 + m[:, 2] ** 2) ** 2)
    return np.where(d * m[:, 2] > 1e-20, d, 0)


def G1(a, v, m):
    xy = (a[0] * v[:, 0]) ** 2 + (a[1] * v[:, 1]) ** 2
    g = np.where(xy == 0, 1.0, 2 / (1 + np.sqrt(1 + xy / v[:, 2] ** 2)))
    return np.where(np.sum(v * m, 1) * v[:, 2] <= 0, 0.0, g)


def lum(c):
    return c @ np.array([0.212671, 0.715160, 0.072169])


def tint(c):
    return c / lum(c) if lum(c) > 0 else np.ones(3)


def diffuse(p, base, co, ci, cd):
    fo, fi = sw(co), sw(ci)
    rr = 2 * p["roughness"] * cd ** 2
    f = (1 - 0.5 * fi) * (1 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1))
    fss = (1 + fo * (rr / 2 - 1)) * (1 + fi * (rr / 2 - 1))
    fss = 1.25 * (fss * (1 / (co + ci) - 0.5) + 0.5)
    f = f * (1 - p["flatness"]) + fss * p["flatness"]
    return base * (f / math.pi)[:, None]


def sheen(p, base, cd):
    c = (1 - p["sheen_tint"]) + tint(base) * p["sheen_tint"]
    return c * sw(np.abs(cd))[:, None]


def principled_ref(p, base, eta, wi, wo):
    """(eval, pdf) of Mitsuba's principled at si.wi = wi (one direction) and wo (many)."""
    p = full_params(p)
    base = np.asarray(base, float)
    n = len(wo)
    wi = np.tile(wi, (n, 1))
    ci, co = wi[:, 2], wo[:, 2]
    met, st = p["metallic"], p["spec_trans"]
    brdf, bsdf = (1 - met) * (1 - st), (1 - met) * st
    refl, refr = ci * co > 0, ci * co < 0
    front = ci > 0
    ep = np.where(front, eta, 1 / eta)
    wh = unit(wi + wo * np.where(refl, 1, ep)[:, None])
    wh *= np.where(wh[:, 2] < 0, -1, 1)[:, None]
    a = alphas(p)
    ih, oh = np.sum(wi * wh, 1), np.sum(wo * wh, 1)
    F = fresnel(ih, eta)
    s = np.sign(ci)[:, None]
    cr = (np.sum(wi * wh * s, 1) > 0) & (np.sum(wo * wh * s, 1) > 0)
    ct = (np.sum(wi * wh * s, 1) > 0) & (np.sum(wo * wh * s, 1) < 0)
    DG = D(a, wh) * G1(a, wi, wh) * G1(a, wo, wh)
    f = np.zeros((n, 3))
    # specular reflection
    r0t = tint(base) * ((eta - 1) / (eta + 1)) ** 2
    ff = ((1 - met) * (1 - p["spec_tint"]) * F[:, None] + met * calc_schlick(base, ih, eta)
          + (1 - met) * p["spec_tint"] * calc_schlick(r0t, ih, eta))
    fp = np.where(front[:, None], ff, bsdf * F[:, None])
    on = refl & cr & (F > 0)
    f[on] += (fp * (DG / (4 * np.abs(ci)))[:, None])[on]
    # transmission
    on = refr & ct & (F < 1) & (bsdf > 0)
    t = np.abs((1 - F) * DG * ep ** 2 * ih * oh / (ep ** 2 * ci * (ih + ep * oh) ** 2))
    f[on] += (np.sqrt(base) * bsdf * t[:, None])[on]
    # clearcoat
    g = 0.1 * (1 - p["clearcoat_gloss"]) + 0.001 * p["clearcoat_gloss"]
    dcc = (g * g - 1) / (math.pi * math.log(g * g) * (1 + (g * g - 1) * wh[:, 2] ** 2))

    def sg(v):
        c2 = v[:, 2] ** 2
        r = 2 / (1 + np.sqrt(1 + 0.0625 * (1 - c2) / c2))
        r = np.where(v[:, 2] == 1, 1.0, r)
        return np.where(np.sum(v * wh, 1) * v[:, 2] <= 0, 0.0, r)
    on = refl & cr & front & (p["clearcoat"] > 0)
    fcc = 0.04 + 0.96 * calc_schlick(np.zeros((n, 1)), ih, eta)[:, 0]
    f[on] += (0.25 * p["clearcoat"] * fcc * dcc * sg(wi) * sg(wo) * np.abs(co))[on][:, None]
    # diffuse and sheen
    on = refl & front
    f[on & (brdf > 0)] += (brdf * np.abs(co)[:, None] * diffuse(p, base, np.abs(co), np.abs(ci), oh))[on & (brdf > 0)]
    if p["sheen"] > 0 and met < 1:
        f[on] += (p["sheen"] * (1 - met) * np.abs(co)[:, None] * sheen(p, base, oh))[on]
    # pdf
    rate = p["main_specular_sampling_rate"]
    pr = np.stack([np.where(front, brdf * p["diffuse_reflectance_sampling_rate"], 0),
                   np.where(front, 0.25 * p["clearcoat"] * p["clearcoat_sampling_rate"], 0),
                   np.where(front, rate * bsdf * (1 - F), 1 - F),
                   np.where(front, rate * (1 - bsdf * (1 - F)), F)], 1)
    pr /= pr.sum(1, keepdims=True)
    dwh = np.abs(np.where(refl, 1 / (4 * oh), ep ** 2 * oh / (ih + ep * oh) ** 2))
    wif = wi * s
    vis = D(a, wh) * G1(a, wif, wh) * np.abs(np.sum(wif * wh, 1)) / wif[:, 2]
    pdf = np.where(refl & cr, pr[:, 3] * vis * dwh + pr[:, 1] * dcc * wh[:, 2] * dwh, 0)
    pdf += np.where(refl, pr[:, 0] * np.maximum(co, 0) / math.pi, 0)
    pdf += np.where(refr & ct, pr[:, 2] * vis * dwh, 0)
    return f, pdf


def thin_ref(p, base, eta, wi, wo):
    """(eval, pdf) of Mitsuba's principledthin."""
    p = full_params(p)
    base = np.asarray(base, float)
    n = len(wo)
    sgn = np.sign(wi[2])
    wi = np.tile(wi * sgn, (n, 1))
    wo = wo * sgn
    ci, co = wi[:, 2], wo[:, 2]
    st, dt = p["spec_trans"], p["diff_trans"] / 2
    refl, refr = co > 0, co < 0
    wr = wo.copy()
    wr[:, 2] = np.abs(wr[:, 2])
    wh = unit(wi + wr)
    ih, oh = np.sum(wi * wh, 1), np.sum(wo * wh, 1)
    cr, ct = (ih > 0) & (oh > 0), (ih > 0) & (oh < 0)
    F = fresnel(ih, eta)
    a, at = alphas(p), alphas(p, (0.65 * eta - 0.35) * p["roughness"])
    f = np.zeros((n, 3))
    fs = F[:, None] * (1 - p["spec_tint"]) + p["spec_tint"] * calc_schlick(tint(base) * ((eta - 1) / (eta + 1)) ** 2, ih, eta)
    on = refl & cr & (st > 0)
    f[on] += (st * fs * (D(a, wh) * G1(a, wi, wh) * G1(a, wo, wh) / (4 * ci))[:, None])[on]
    on = refr & ct & (st > 0)
    f[on] += (st * base * ((1 - F) * D(at, wh) * G1(at, wi, wh) * G1(at, wo, wh) / (4 * ci))[:, None])[on]
    on = refl & (st < 1) & (dt < 1)
    d = diffuse(p, base, co, ci, oh) + p["sheen"] * sheen(p, base, oh)
    f[on] += ((1 - st) * (1 - dt) * co[:, None] * d)[on]
    on = refr & (st < 1) & (dt > 0)
    f[on] += ((1 - st) * dt * base * np.abs(co)[:, None] / math.pi)[on]
    pr = np.array([st * p["specular_reflectance_sampling_rate"] / 2, st * p["specular_transmittance_sampling_rate"] / 2,
                   p["diffuse_reflectance_sampling_rate"] * (1 - st) * (1 - dt),
                   p["diffuse_transmittance_sampling_rate"] * (1 - st) * dt])
    pr /= pr.sum()
    dwh = np.abs(1 / (4 * np.sum(wr * wh, 1)))
    vis = lambda a: D(a, wh) * G1(a, wi, wh) * np.abs(ih) / ci  # noqa: E731
    pdf = np.where(refl & cr, pr[0] * vis(a) * dwh, 0) + np.where(refr & ct, pr[1] * vis(at) * dwh, 0)
    pdf += np.where(refl, pr[2] * co / math.pi, 0) + np.where(refr, pr[3] * -co / math.pi, 0)
    return f, pdf


REFS = {"principled": principled_ref, "principled_thin": thin_ref}


def case(kind, params, ior, wo, base=BASE):
    return (kind, base, 0.0, ior, Z, unit(wo), dict(params))


# ---- eval and pdf -----------------------------------------------------------------------------------

def test_eval_at_normal_incidence_is_the_disney_terms_by_hand():
    """wo = wi = n, roughness 0.5 (alpha 1/4), clearcoat 1 (gloss 0: GTR1 alpha 0.1), eta 1.5: the
    diffuse base / pi (no Schlick weight, no retro), the specular F0 D / 4 = 0.04 / (4 pi alpha^2),
    the clearcoat 1/4 0.04 (a^2 - 1) / (pi ln(a^2) a^2), sheen 0 (its weight at cos_d = 1)."""
    ad = C.BSDFAdapter(True)
    _, f = ad.evaluate(case("principled", {"clearcoat": 1.0, "sheen": 0.7}, 1.5, Z), Z[None])
    a2 = 0.01
    want = np.array(BASE) / math.pi + 0.04 / (4 * math.pi * 0.0625) + 0.25 * 0.04 * (a2 - 1) / (math.pi * math.log(a2) * a2)
    np.testing.assert_allclose(f[0], want, rtol=2e-6)
    # A thin sheet's diffuse transmission (diff_trans 1.2: 0.6 of the diffuse part) at wi = -n.
    _, f = ad.evaluate(case("principled_thin", {"diff_trans": 1.2}, 1.5, Z), -Z[None])
    np.testing.assert_allclose(f[0], 0.6 * np.array(BASE) / math.pi, rtol=2e-6)


@pytest.mark.parametrize("kind,params,ior,wo", [
    ("principled", FULL, 1.5, (0.6, 0.0, 0.8)),
    ("principled", FULL, 1.5, (0.3, -0.2, -0.9)),                      # from inside
    ("principled", {**FULL, "anisotropic": 0.0, "metallic": 0.0, "flatness": 0.0}, 1.3, (0.9, 0.3, 0.2)),
    ("principled", {"roughness": 0.2, "spec_trans": 1.0, "main_specular_sampling_rate": 2.0}, 1.2, (0.1, 0.4, -0.7)),
    ("principled_thin", THIN, 1.33, (-0.5, 0.2, 0.84)),
    ("principled_thin", THIN, 1.6, (0.2, 0.7, -0.3)),                  # the other side
])
def test_eval_and_pdf_are_mitsubas_formulas(kind, params, ior, wo):
    ad = C.BSDFAdapter(True)
    wi = unit(np.random.default_rng(7).normal(size=(4000, 3)))
    pdf, f = ad.evaluate(case(kind, params, ior, wo), wi)
    ref_f, ref_pdf = REFS[kind](params, BASE, ior, unit(wo), wi)
    np.testing.assert_allclose(f, ref_f, rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(pdf, ref_pdf, rtol=2e-4, atol=1e-6)
    assert np.all(ref_f[np.abs(wi[:, 2]) > 0.05].sum(1) > 0) or kind == "principled"


@pytest.mark.parametrize("kind,params,ior,wo", CHI2_CASES)
def test_weights_are_eval_over_pdf(kind, params, ior, wo):
    s = C.BSDFAdapter(True).sample(case(kind, params, ior, wo), 20_000, 3)
    assert_consistent(s, kind)


# ---- sampling ---------------------------------------------------------------------------------------

def _chi2(kind, params, ior, wo, pdf_params=None, name=""):
    ad = C.BSDFAdapter(True)
    c = case(kind, params, ior, wo)
    s = ad.sample(c, N, seed_for("principled-chi2", kind, repr(sorted(params.items())), wo))
    pc = c if pdf_params is None else case(kind, pdf_params, ior, wo)
    return C.run_chi2(C.SphericalDomain(Z), lambda k, sd: (s.wi, s.valid), ad.pdf(pc),
                      name=name or f"{kind} wo={wo}", sample_count=N, res=(51, 102), seed=3,
                      test_count=M_TESTS)


@pytest.mark.parametrize("kind,params,ior,wo", CHI2_CASES)
def test_sampling_chi2(kind, params, ior, wo):
    r = _chi2(kind, params, ior, wo)
    assert r.passed, r.summary()


def test_negative_control_a_wrong_lobe_probability_is_rejected():
    """sample() choosing the diffuse lobe half as often as its pdf says (the pdf's diffuse sampling
    rate 2, sample's 1): the density differs from the claimed one, and chi-square sees it."""
    kind, params, ior, wo = CHI2_CASES[0]
    r = _chi2(kind, params, ior, wo, {**params, "diffuse_reflectance_sampling_rate": 2.0}, "wrong lobe choice")
    assert r.rejected and r.p_value < LEVEL, r.summary()


# ---- furnaces ---------------------------------------------------------------------------------------

def _smooth_glass(c, eta=1.5):
    """A smooth dielectric's directional albedo for radiance from cosine c (< 0: inside): F plus
    the transmitted 1 - F scaled by the solid-angle compression 1 / eta_path^2 (Mitsuba's, drtlab's)."""
    F = float(fresnel(c, eta))
    return F + (1 - F) / (eta if c > 0 else 1 / eta) ** 2


@pytest.mark.parametrize("kind,params,wo,want", [
    ("principled", {"metallic": 1.0, "roughness": 0.03}, (0.5, 0.0, 0.866025), 1.0),       # a mirror
    ("principled", {"spec_trans": 1.0, "roughness": 0.03}, (0.6, 0.0, 0.8), _smooth_glass(0.8)),
    ("principled", {"spec_trans": 1.0, "roughness": 0.03}, (0.5, 0.3, -0.812404), _smooth_glass(-0.812404)),
    ("principled_thin", {"spec_trans": 1.0, "roughness": 0.03}, (0.3, 0.1, 0.948683), 1.0),  # F + (1 - F)
])
def test_white_furnaces_keep_what_the_closed_form_says(kind, params, wo, want):
    s = C.BSDFAdapter(True).sample(case(kind, params, 1.5, wo, base=(1.0, 1.0, 1.0)), N,
                                   seed_for("principled-furnace", kind, repr(sorted(params.items())), wo))
    mean, se = albedo_estimate(s)
    z = stats.norm.isf(LEVEL / 2)
    # alpha 1e-3 facets mask ~1e-6 of the light; a lossless surface keeps the rest.
    if want <= 1:
        assert np.all(mean <= 1 + z * se + 1e-6), (mean, se)
    assert np.all(np.abs(mean - want) <= z * se + 2e-4), (mean, se, want)


def test_a_thin_lambertian_transmitter_weighs_every_sample_by_its_colour():
    s = C.BSDFAdapter(True).sample(case("principled_thin", {"diff_trans": 2.0}, 1.5, (0.3, 0.1, 0.948683)), 5000, 1)
    assert s.valid.all() and np.all(s.wi[:, 2] < 0)
    np.testing.assert_allclose(s.weight, np.tile(BASE, (5000, 1)), rtol=1e-5)


# ---- textured parameters ---------------------------------------------------------------------------

def test_textured_parameters_are_looked_up_as_mitsubas_eval_1():
    """A principled material's metallic (checkerboard) and sheen (constant row value) at the hit:
    MaterialAt.param from the variant's material_at, the checkerboard's colours swapped against its
    RGB lookup (Mitsuba's eval_1), a grey colour's luminance the grey itself; a scene without a
    principled kind gets the plain material_at."""
    assert material_at_for(False, kinds=frozenset({"diffuse"}))[0] is material_at
    at = material_at_for(True, kinds=frozenset({"principled"}))[0]
    c0, c1 = 0.7, 0.1
    d = quad_scene({"kind": "checkerboard", "color0": c0, "color1": c1, "to_uv": TO_UV.tolist()})
    d["materials"]["tex"] = {"kind": "principled", "sheen": 0.25, "metallic_texture": d["materials"]["tex"]["albedo_texture"]}
    scene = scene_from_dict(d)
    sd = upload(scene, "cpu")
    m = [x.name for x in scene.materials].index("tex")

    @wp.kernel(enable_backward=False, module="unique")
    def lookups(sd: SceneData, m: int, uv: wp.array(dtype=wp.vec2), out: wp.array(dtype=wp.vec2)):
        i = wp.tid()
        r = at(sd, m, uv[i])
        out[i] = wp.vec2(r.param[METALLIC], r.param[SHEEN])

    uv = uv_points()
    out = wp.zeros(len(uv), dtype=wp.vec2, device="cpu")
    wp.launch(lookups, dim=len(uv), inputs=[sd, m, wp.array(uv, dtype=wp.vec2, device="cpu"), out], device="cpu")
    got = out.numpy().astype(np.float64)
    uvp = mapped(uv)
    keep = off_edges(uvp, (2, 2))
    want = mitsuba_checkerboard(np.full(3, c1, np.float32), np.full(3, c0, np.float32), uvp.astype(np.float64))[:, 0]
    np.testing.assert_allclose(got[keep, 0], want[keep], rtol=1e-6)
    assert np.all(got[:, 1] == np.float32(0.25))


# ---- Mitsuba XML import ------------------------------------------------------------------------------

def test_defaults_are_mitsubas(tmp_path):
    m = one_bsdf(tmp_path, '<bsdf type="principled"/>').materials[0]
    assert (m.kind, m.albedo.tolist(), m.ior) == ("principled", [0.5] * 3, pytest.approx(1.5, rel=1e-12))
    want = {p.name: p.default for p in PARAMS}
    assert all(m.params[k] == want[k] for k in m.params) and m.params["roughness"] == 0.5
    t = one_bsdf(tmp_path, '<bsdf type="principledthin"/>').materials[0]
    assert (t.kind, t.ior, t.params["diff_trans"], t.params["spec_trans"]) == ("principled_thin", 1.5, 0.0, 0.0)


def on_rectangle(tmp_path, bsdf: str):
    """The material of a rectangle with `bsdf` (drtlab reads Mitsuba's uv on rectangles and OBJs)."""
    return load(tmp_path, '<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><rfilter '
                          f'type="box"/></film></sensor><shape type="rectangle">{bsdf}</shape></scene>').materials[0]


def test_parameters_textures_and_eta_as_mitsuba_reads_them(tmp_path):
    m = on_rectangle(tmp_path, '<bsdf type="principled"><rgb name="base_color" value="0.2, 0.8, 0.1"/>'
                           '<float name="roughness" value="0.15"/><float name="specular" value="0.7"/>'
                           '<texture name="metallic" type="checkerboard"><float name="color0" value="0.7"/>'
                           '<float name="color1" value="0.1"/></texture></bsdf>')
    assert m.albedo.tolist() == [0.2, 0.8, 0.1] and m.params["roughness"] == 0.15
    assert m.ior == pytest.approx(eta_of_specular(0.7), rel=1e-12) and set(m.textures) == {"metallic"}
    np.testing.assert_array_equal(m.textures["metallic"].pixels, np.float32([[[0.7] * 3, [0.1] * 3]]))
    # eta 1 where light crosses: Mitsuba's 1.001
    m = one_bsdf(tmp_path, '<bsdf type="principled"><float name="eta" value="1"/>'
                           '<float name="spec_trans" value="0.5"/></bsdf>').materials[0]
    assert m.ior == pytest.approx(1.001)
    m = on_rectangle(tmp_path, '<bsdf type="principledthin"><float name="eta" value="1.33"/>'
                               '<texture name="diff_trans" type="checkerboard"><float name="color1" value="1.4"/>'
                               '</texture></bsdf>')
    assert m.ior == pytest.approx(1.33) and set(m.textures) == {"diff_trans"}


@pytest.mark.parametrize("bsdf,what", [
    ('<bsdf type="principled"><float name="eta" value="1.3"/><float name="specular" value="0.5"/></bsdf>',
     "give either eta or specular, not both"),
    ('<bsdf type="principled"><float name="metallic" value="1.5"/></bsdf>', "metallic]: must be in [0, 1], got 1.5"),
    ('<bsdf type="principledthin"><float name="clearcoat" value="0.5"/></bsdf>', "property 'clearcoat' of bsdf 'principledthin' is not supported"),
    ('<bsdf type="principledthin"><float name="diff_trans" value="2.5"/></bsdf>', "must be in [0, 2]"),
])
def test_refused_in_one_line(tmp_path, bsdf, what):
    with pytest.raises(InputError) as e:
        one_bsdf(tmp_path, bsdf)
    assert "\n" not in str(e.value) and what in str(e.value), str(e.value)


def _scene_with(tmp_path, block: str):
    """glossy-ggx's TOML with its ggx05 material replaced by `block` (TOML lines)."""
    from drtlab import load_scene
    from drtlab.kernels.scene_model.scene_file import BUILTIN_DIR
    text = (BUILTIN_DIR / "glossy-ggx.toml").read_text()
    old = '[materials.ggx05]\nkind = "ggx"\nalbedo = [0.9, 0.75, 0.5]\nroughness = 0.5\n'
    assert old in text
    path = tmp_path / "s.toml"
    path.write_text(text.replace(old, "[materials.ggx05]\n" + block + "\n"))
    return load_scene(path)


def test_scene_file_keys_and_their_errors(tmp_path):
    scene = _scene_with(tmp_path, 'kind = "principled"\nmetallic = 0.5\nsheen_texture = { kind = "checkerboard" }')
    m = next(x for x in scene.materials if x.name == "ggx05")
    assert m.params["metallic"] == 0.5 and m.params["clearcoat"] == 0.0 and "sheen" in m.textures
    for bad, field in (('kind = "principled"\nior = 1.0', "materials.ggx05.ior"),
                       ('kind = "principled"\ndiff_trans = 0.5', "materials.ggx05"),
                       ('kind = "principled_thin"\nroughness = -0.1', "materials.ggx05.roughness")):
        with pytest.raises(InputError) as e:
            _scene_with(tmp_path, bad)
        assert field in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_export_writes_them_back(tmp_path):
    import dataclasses

    from drtlab import load_scene
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    a = one_bsdf(tmp_path, "")
    specs = (("principled", 1.7, {"roughness": 0.3, "metallic": 0.2, "spec_trans": 0.6, "clearcoat": 0.4,
                                   "clearcoat_sampling_rate": 2.0}),
             ("principled_thin", 1.33, {"diff_trans": 1.4, "sheen": 0.8, "anisotropic": 0.5}))
    a.materials = [dataclasses.replace(a.materials[0], name=k, kind=k, albedo=np.array([0.8, 0.3, 0.1]), ior=ior,
                                       one_sided=False,
                                       params={**{p: q.default for p, q in PARAM_BY_NAME.items()
                                                  if p in KIND_BY_NAME[k].params}, **v})
                   for k, ior, v in specs]
    a.shapes = [dataclasses.replace(a.shapes[0], material=i) for i in range(len(specs))]
    export_mitsuba(a, tmp_path / "m.xml")
    b = load_scene(tmp_path / "m.xml")
    assert [(m.kind, m.albedo.tolist(), m.ior, m.params) for m in b.materials] == \
        [(m.kind, m.albedo.tolist(), m.ior, m.params) for m in a.materials]
