"""A material's `opacity` (Mitsuba 3's `mask`) and `one_sided` (its BSDFs outside `twosided`),
wrapped around every kind by kernels/materials/mask.py, and their Mitsuba XML import.

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS clean tests (chi-square
cases, pass-through shares, the transmitted fraction); each negative control is judged at the same
level and must be rejected.
* eval and pdf: exactly opacity times the kind's (float32: one rounding), one-sided zero from behind.
* Sampling: the share of pass-through events (delta, wi = -wo, weight 1) against 1 - opacity
  (binomial z); the chi-square harness of the scattered directions against pdf_bsdf (opacity times
  the kind's density; the pass-throughs fall in the rest cell). Negative controls: the kind's
  density without the opacity, and with the opacity applied twice.
* Renders: a black masked plane in front of a white background transmits exactly 1 - opacity (a
  binomial test of every sample); negative control: the pass-through weighted 1 / (1 - opacity)
  (features.MASK_DIVIDES_BY_CHOICE). The pass-through is a bounce (Mitsuba's path.cpp): at
  max_depth 1 the plane is exactly black. A white masked sphere in a white background is a furnace:
  every pixel 1 to float rounding; the fault's is above.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from drtlab.errors import InputError
from drtlab.experiments.stats import chi2 as C
from drtlab.kernels.features import MASK_DIVIDES_BY_CHOICE, features_of
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict

import scene_util as su
from scene_pieces import camera_dict, quad, scene_dict
from stats_util import ALPHA, seed_for
from test_mitsuba_xml import load, one_bsdf, xml

N = 200_000
NORMAL = np.array([0.0, 0.0, 1.0])
TINT = (0.8, 0.3, 0.1)
# (kind, albedo, shape, ior, opacity, theta of wo); shape is the lobe's (MaterialAt.shape)
CHI2_CASES = [("diffuse", TINT, 0.0, 1.5, 0.3, 30.0), ("ggx", TINT, 0.3, 1.5, 0.7, 60.0),
              ("beckmann", TINT, 0.2, 1.5, 0.5, 45.0)]
M_TESTS = 2 * len(CHI2_CASES) + 1
LEVEL = C.sidak(ALPHA, M_TESTS)
Z = stats.norm.isf(LEVEL / 2)


def wo_at(theta: float, side: float = 1.0) -> np.ndarray:
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, side * math.cos(t)])


def _dirs(n: int, seed: int) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def case_of(kind, albedo, shape, ior, theta, side=1.0):
    return (kind, albedo, shape, ior, NORMAL, wo_at(theta, side))


# ---- eval and pdf --------------------------------------------------------------------------------

@pytest.mark.parametrize("kind,shape,opacity", [("diffuse", 0.0, 0.3), ("ggx", 0.3, 0.7),
                                                ("smooth_plastic", float(np.mean(TINT)), 0.45),
                                                ("beckmann_conductor", 0.2, 0.6)])
def test_eval_and_pdf_are_opacity_times_the_kinds(kind, shape, opacity):
    wi = _dirs(4000, 11)
    case = case_of(kind, TINT, shape, 1.5, 40.0)
    pdf, f = C.BSDFAdapter(True).evaluate(case, wi)
    pdf_m, f_m = C.BSDFAdapter(True, opacity=opacity).evaluate(case, wi)
    assert np.any(f > 0) and np.any(pdf > 0)
    # one float32 product: within half an ulp of the float64 one (subnormals: an absolute ulp)
    np.testing.assert_allclose(f_m, np.float32(opacity) * f.astype(np.float64), rtol=1.2e-7, atol=1.5e-45)
    np.testing.assert_allclose(pdf_m, np.float32(opacity) * pdf, rtol=1.2e-7, atol=1.5e-45)


def test_diffuse_mask_is_the_closed_form():
    wi = _dirs(2000, 12)
    wo = wo_at(25.0)
    pdf, f = C.BSDFAdapter(True, opacity=0.25).evaluate(("diffuse", TINT, 0.0, 1.5, NORMAL, wo), wi)
    cos = np.where(wi[:, 2] > 0, wi[:, 2], 0.0)
    np.testing.assert_allclose(f, 0.25 * np.outer(cos, TINT) / math.pi, rtol=3e-6, atol=1e-9)
    np.testing.assert_allclose(pdf, 0.25 * cos / math.pi, rtol=3e-6, atol=1e-9)


@pytest.mark.parametrize("kind,shape", [("diffuse", 0.0), ("ggx", 0.3), ("smooth_plastic", 0.4)])
def test_one_sided_is_black_from_behind(kind, shape):
    wi = _dirs(3000, 13)
    two = C.BSDFAdapter(True)
    one = C.BSDFAdapter(True, one_sided=True)
    front = case_of(kind, TINT, shape, 1.5, 35.0)
    back = case_of(kind, TINT, shape, 1.5, 35.0, side=-1.0)
    p2, f2 = two.evaluate(front, wi)
    p1, f1 = one.evaluate(front, wi)
    np.testing.assert_array_equal(f1, f2 * (wi[:, 2] > 0)[:, None])
    np.testing.assert_array_equal(p1, p2 * (wi[:, 2] > 0))
    pb2, fb2 = two.evaluate(back, wi)
    pb1, fb1 = one.evaluate(back, wi)
    assert np.any(fb2 > 0) and np.any(pb2 > 0)          # drtlab's kinds are two-sided ...
    assert not np.any(fb1) and not np.any(pb1)          # ... one_sided is black from behind
    s = one.sample(back, 2000, 1)
    assert not np.any(s.valid)
    s = one.sample(front, 2000, 1)
    assert np.any(s.valid) and np.all(s.wi[s.valid, 2] > 0)


# ---- sampling ------------------------------------------------------------------------------------

def _samples(case, opacity):
    kind, albedo, shape, ior, theta = case[0], case[1], case[2], case[3], case[5]
    ad = C.BSDFAdapter(True, opacity=opacity)
    c = case_of(kind, albedo, shape, ior, theta)
    return ad, c, ad.sample(c, N, seed_for("mask-sample", kind, opacity, theta))


@pytest.mark.parametrize("case", CHI2_CASES, ids=[c[0] for c in CHI2_CASES])
def test_pass_through_share_direction_and_weight(case):
    opacity = case[4]
    _, c, s = _samples(case, opacity)
    null = s.valid & s.delta
    share = null.mean()
    assert abs(share - (1 - opacity)) / math.sqrt(opacity * (1 - opacity) / N) < Z, share
    np.testing.assert_array_equal(s.wi[null], np.broadcast_to(-c[5], s.wi[null].shape).astype(np.float32))
    np.testing.assert_array_equal(s.weight[null], 1.0)
    v = s.valid & ~s.delta          # the kind's samples: pdf = opacity x its own, weight f / pdf
    assert v.sum() > 0.5 * opacity * N
    assert C.relative_error(s.pdf[v], s.pdf_eval[v]).max() < 1e-5
    assert C.relative_error(s.weight[v], s.f_eval[v] / s.pdf[v][:, None]).max() < 1e-4


def _chi2(case, pdf_func=None, name=""):
    ad, c, s = _samples(case, case[4])
    return C.run_chi2(C.SphericalDomain(NORMAL), lambda k, sd: (s.wi, s.valid & ~s.delta),
                      pdf_func or ad.pdf(c), name=name or f"masked {case[0]} opacity={case[4]}",
                      sample_count=N, res=(51, 102), seed=3, test_count=M_TESTS)


@pytest.mark.parametrize("case", CHI2_CASES, ids=[c[0] for c in CHI2_CASES])
def test_sampling_chi2(case):
    r = _chi2(case)
    assert r.passed, r.summary()
    if case[0] == "diffuse":        # the cosine lobe lies on the sphere whole: the mass is the opacity
        assert r.integral == pytest.approx(case[4], abs=1e-3), r.summary()


@pytest.mark.parametrize("scale,what", [(lambda a: 1.0 / a, "without the opacity"),
                                        (lambda a: a, "with the opacity twice")])
def test_negative_control_a_wrong_opacity_factor_is_rejected(scale, what):
    case = CHI2_CASES[0]
    a = case[4]
    right = C.BSDFAdapter(True, opacity=a).pdf(case_of(*case[:4], case[5]))
    r = _chi2(case, lambda pts: right(pts) * scale(a), f"masked diffuse {what}")
    assert r.rejected and r.p_value < LEVEL, r.summary()


# ---- renders -------------------------------------------------------------------------------------

def plane_scene(opacity: float, depth: int = 4, albedo: float = 0.0) -> dict:
    """A masked diffuse plane filling the view of a camera, a white background behind it."""
    cam = camera_dict((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 30.0)
    mats = {"leaf": {"kind": "diffuse", "albedo": [albedo] * 3, "opacity": opacity}}
    return scene_dict("a masked plane", cam, mats, [quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), "leaf")],
                      max_depth=depth, background=(1.0, 1.0, 1.0))


def transmitted(opacity: float, faults=(), depth=4, spp=64):
    img = render(scene_from_dict(plane_scene(opacity, depth)), spp=spp, sampler="independent+importance",
                 seed=seed_for("mask-plane", opacity, faults, depth), progress=False, faults=tuple(faults))
    return img, img.shape[0] * img.shape[1] * spp


def test_a_black_masked_plane_transmits_one_minus_its_opacity_and_the_fault_is_rejected():
    a = 0.35
    img, n = transmitted(a)
    assert np.all(img[..., 0] == img[..., 1]) and np.all(img[..., 0] == img[..., 2])
    z = (img[..., 0].mean() - (1 - a)) / math.sqrt(a * (1 - a) / n)
    assert abs(z) < Z, (img.mean(), 1 - a, z)
    bad, n = transmitted(a, faults=(MASK_DIVIDES_BY_CHOICE,))
    z = (bad[..., 0].mean() - (1 - a)) / math.sqrt(a * (1 - a) / n)
    assert abs(z) >= Z, (bad.mean(), z)


def test_the_pass_through_is_a_bounce():
    img, _ = transmitted(0.35, depth=1, spp=8)
    assert not np.any(img)          # max_depth 1: emitters seen directly only, none through the mask
    img, _ = transmitted(0.35, depth=2, spp=8)
    assert np.any(img)


def behind_a_mask(integrator: str) -> dict:
    """A black masked plane in front of a white diffuse plane that a quad light faces: the white
    plane, seen through the mask, is lit directly only (the black plane reflects nothing), so drt
    and path render the same image in expectation."""
    cam = camera_dict((0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 30.0)
    mats = {"leaf": {"kind": "diffuse", "albedo": [0.0] * 3, "opacity": 0.35},
            "wall": {"kind": "diffuse", "albedo": [0.8] * 3},
            "lamp": {"kind": "emitter", "emission": [4.0] * 3}}
    shapes = [quad((-4, -4, 0), (8, 0, 0), (0, 8, 0), "leaf"), quad((-4, -4, -1), (8, 0, 0), (0, 8, 0), "wall"),
              quad((-1, 1.5, -0.9), (2, 0, 0), (0, 0, 0.8), "lamp")]
    return scene_dict("a lit wall behind a mask", cam, mats, shapes, integrator=integrator, max_depth=6)


def test_drt_lights_what_it_sees_through_a_mask():
    """drt's path ends one segment after a diffuse scatter; a mask's pass-through on a diffuse
    surface is no such scatter: the wall behind it is lit as under path (a z-test of the image
    means, alpha ALPHA)."""
    means, ses = [], []
    for integrator in ("drt", "path"):
        from drtlab.kernels.render import render_with_stats
        st = render_with_stats(scene_from_dict(behind_a_mask(integrator)), spp=64, seed=seed_for("behind", integrator),
                               sampler="independent+importance", progress=False, variance=True)
        means.append(st.image.mean())
        ses.append(math.sqrt(st.variance.mean() / 64 / (st.image.shape[0] * st.image.shape[1])))
    assert means[0] > 0.0
    z = (means[0] - means[1]) / math.hypot(*ses)
    assert abs(z) < stats.norm.ppf(1 - ALPHA / 2), (means, z)


def test_white_masked_sphere_furnace():
    base = su.sphere_furnace("diffuse", depth=200).scene
    base["materials"]["m"]["opacity"] = 0.4
    img = render(scene_from_dict(base), spp=16, sampler="independent+importance", seed=5, progress=False)
    np.testing.assert_allclose(img, 1.0, rtol=1e-5)
    bad = render(scene_from_dict(base), spp=16, sampler="independent+importance", seed=5, progress=False,
                 faults=(MASK_DIVIDES_BY_CHOICE,))
    assert bad.mean() > 1.1


# ---- the scene model -----------------------------------------------------------------------------

def test_scenes_without_masks_compile_none():
    for name in ("cornell", "aa-edges"):
        try:
            f = features_of(load_scene(name), "path")
        except InputError:
            continue
        assert not f.masks and not f.one_sided
    f = features_of(scene_from_dict(plane_scene(0.5)), "path")
    assert f.masks and not f.one_sided and "masks" in f.key()


@pytest.mark.parametrize("material,field", [
    ({"kind": "diffuse", "opacity": 1.5}, "materials.m.opacity"),
    ({"kind": "diffuse", "opacity": "half"}, "materials.m.opacity"),
    ({"kind": "diffuse", "one_sided": 1}, "materials.m.one_sided"),
    ({"kind": "dielectric", "one_sided": True}, "materials.m.one_sided"),
    ({"kind": "emitter", "emission": [1, 1, 1], "opacity": 0.5}, "materials.m.opacity"),
])
def test_bad_values_are_refused_in_one_line(material, field):
    d = plane_scene(0.5)
    d["materials"] = {"m": material}
    d["shapes"][0]["material"] = "m"
    with pytest.raises(InputError) as e:
        scene_from_dict(d)
    assert "\n" not in str(e.value) and str(e.value).startswith(field), str(e.value)


def test_whitted_refuses_a_mask():
    with pytest.raises(InputError) as e:
        features_of(scene_from_dict(plane_scene(0.5)), "whitted")
    assert "opacity" in str(e.value) and "\n" not in str(e.value)


# ---- Mitsuba XML import --------------------------------------------------------------------------

DIFFUSE = '<bsdf type="diffuse"><rgb name="reflectance" value="0.1, 0.8, 0.1"/></bsdf>'


@pytest.mark.parametrize("bsdf,opacity,one_sided", [
    (f'<bsdf type="mask">{DIFFUSE}</bsdf>', 0.5, True),
    (f'<bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="twosided">{DIFFUSE}</bsdf></bsdf>',
     0.25, False),
    (f'<bsdf type="twosided">{DIFFUSE}</bsdf>', 1.0, False),
    (DIFFUSE, 1.0, True),
])
def test_mask_and_sides_load(tmp_path, bsdf, opacity, one_sided):
    m = one_bsdf(tmp_path, bsdf).materials[0]
    assert (m.kind, m.albedo.tolist(), m.opacity, m.one_sided) == ("diffuse", [0.1, 0.8, 0.1], opacity,
                                                                   one_sided)


def test_bare_one_sided_kinds_and_two_sided_dielectrics(tmp_path):
    for bsdf, one_sided in (('<bsdf type="conductor"/>', True), ('<bsdf type="roughplastic"/>', True),
                            ('<bsdf type="dielectric"/>', False),
                            ('<bsdf type="twosided"><bsdf type="plastic"/></bsdf>', False)):
        assert one_bsdf(tmp_path, bsdf).materials[0].one_sided is one_sided, bsdf


@pytest.mark.parametrize("bsdf,what", [
    (f'<bsdf type="mask"><float name="opacity" value="1.5"/>{DIFFUSE}</bsdf>', "opacity]: must be in [0, 1]"),
    ('<bsdf type="mask"/>', "a mask needs exactly one nested bsdf, got 0"),
    (f'<bsdf type="mask">{DIFFUSE}{DIFFUSE}</bsdf>', "a mask needs exactly one nested bsdf, got 2"),
    (f'<bsdf type="mask"><bsdf type="mask">{DIFFUSE}</bsdf></bsdf>', "a mask inside a mask"),
    (f'<bsdf type="twosided"><bsdf type="mask">{DIFFUSE}</bsdf></bsdf>', "twosided around 'mask'"),
])
def test_refused_masks_in_one_line(tmp_path, bsdf, what):
    with pytest.raises(InputError) as e:
        one_bsdf(tmp_path, bsdf)
    assert "\n" not in str(e.value) and what in str(e.value), str(e.value)


# ---- an opacity texture --------------------------------------------------------------------------

RGB = (0.1, 0.5, 0.9)


def test_an_opacity_texture_is_read_as_its_luminance(tmp_path):
    """A black plane whose opacity texture is one RGB colour: it transmits 1 - its luminance."""
    from drtlab.kernels.colour import luminance
    from drtlab.kernels.imageio import write_exr
    write_exr(tmp_path / "op.exr", np.broadcast_to(np.array(RGB, np.float32), (4, 4, 3)).copy())
    d = plane_scene(0.5)
    del d["materials"]["leaf"]["opacity"]
    d["materials"]["leaf"]["opacity_texture"] = {"file": str(tmp_path / "op.exr")}
    scene = scene_from_dict(d)
    assert features_of(scene, "path").masks and features_of(scene, "path").textures
    spp = 64
    img = render(scene, spp=spp, sampler="independent+importance", seed=seed_for("mask-texture"),
                 progress=False)
    a = float(luminance(RGB))
    n = img.shape[0] * img.shape[1] * spp
    z = (img[..., 0].mean() - (1 - a)) / math.sqrt(a * (1 - a) / n)
    assert abs(z) < Z, (img.mean(), 1 - a, z)
    # the mean of the channels (0.5) would be another opacity, far outside the interval
    assert abs(0.5 - a) / math.sqrt(a * (1 - a) / n) > 3 * Z
    d["materials"]["leaf"]["opacity"] = 0.5
    with pytest.raises(InputError) as e:
        scene_from_dict(d)
    assert str(e.value).startswith("materials.leaf.opacity") and "not both" in str(e.value)


def test_a_mask_with_a_bitmap_opacity_loads_as_a_texture(tmp_path):
    """Mitsuba's leaf mask is a grey + alpha PNG: its grey (sRGB-decoded) is the opacity, alpha dropped."""
    from drtlab.kernels.imageio import write_png
    grey = np.linspace(0.0, 1.0, 16, dtype=np.float32).reshape(4, 4)
    write_png(tmp_path / "mask.png", np.repeat(grey[..., None], 3, axis=2))
    scene = load(tmp_path, xml(f'<shape type="rectangle"><bsdf type="mask"><texture name="opacity" type="bitmap">'
                               f'<string name="filename" value="mask.png"/></texture>{DIFFUSE}</bsdf></shape>'))
    m = scene.materials[scene.shapes[-1].material]
    t = m.textures["opacity"]
    assert m.one_sided and t.kind == "bitmap" and t.pixels.shape == (4, 4, 3)
    assert np.all(t.pixels[..., 0] == t.pixels[..., 1]) and np.all(t.pixels[..., 0] == t.pixels[..., 2])
    np.testing.assert_allclose(t.pixels[..., 0], grey, atol=5e-3)      # 8 bits, sRGB round trip
