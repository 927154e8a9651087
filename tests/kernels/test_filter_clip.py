"""Mitsuba's Gaussian filter and filters truncated to the film (kernels/filters.py, camera keys
`filter_stddev` and `filter_clip`).

The profile is checked value by value against the table Mitsuba 3's CPU variants weigh samples by
(ReconstructionFilter::eval_discretized: its formula, src/rfilters/gaussian.cpp, at 31 bin starts),
its bins at their edges on the host and the device, and its CPU build's Remez polynomial (a tolerance).
A sharp edge mid-film must render the table's pixels, and the exact Gaussian's be rejected; the edge
of Mitsuba's own reference image (its constant projector scene) must fit the table, not the formula.
The truncated sampler is checked directly (a kernel calling PixelFilter.sample at a corner pixel): a
chi-square of its offsets against the table restricted to the film (the untruncated sampler must be
rejected there), and its weights' mean, 1 when the density is normalised over the cut support.
Renders: a half-plane lit for x < EDGE pixels (a vertical edge a quarter pixel into the film) has,
per column, the closed form
    V(c) = F(lo, min(hi, EDGE - c)) / F(lo, hi),   F(a, b) = integral_a^b f1 (the table's bins),
with [lo, hi] = [-r, r] cut to the film, [-c, W - c], or not (Mitsuba's sample_border true); the
rows cancel (separable filter, an edge along y). Columns are pooled over rows; each column's variance
is the spread of its K run means. ALPHA (tests/support/stats_util.py) Sidak-corrected over the
M_TESTS comparisons that must accept.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import warp as wp
from scipy import stats

from drtlab.experiments.stats.chi2 import sidak
from drtlab.kernels.features import features_of
from drtlab.kernels.filter_sampling import make_pixel_filter
from drtlab.kernels.filters import (MITSUBA_GAUSSIAN, clip_table, filter_cdf, get_filter, mitsuba_bin,
                                    mitsuba_gaussian_table)
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from drtlab.kernels.scene_upload import upload
from drtlab.kernels.device_scene import SceneData

from scene_pieces import camera_dict, quad, scene_dict
from stats_util import ALPHA, Estimate, compare, seed_for

RES = (10, 6)
EDGE = 0.25                     # pixels from the left edge: lit for x < EDGE
DISTANCE, FOV = 5.0, 40.0
M_TESTS = 7                     # accepted: the chi-square, the weights' mean, FIS and splatting renders
                                # at the film's edge and at a sharp edge mid-film, Mitsuba's reference's edge
ALPHA_TEST = sidak(ALPHA, M_TESTS)


# ---------------------------------------------------------------------------------------------------
# The profile: Mitsuba 3's formula, exactly
# ---------------------------------------------------------------------------------------------------

# Mitsuba's CPU build (src/rfilters/gaussian.cpp): a Remez fit of exp(-x/2) on [0, 16] in powers of
# (x / stddev)^2, shifted to reach 0 at the radius.
REMEZ = (9.992604880e-1, -4.977025247e-1, 1.222248550e-1, -1.932406282e-2, 2.136713061e-3,
         -1.679873860e-4, 9.202145248e-6, -3.329417433e-7, 7.128382794e-9, -6.821193280e-11)


def mitsuba_cpu_profile(x, stddev):
    t = (np.asarray(x) / stddev) ** 2
    poly = np.polynomial.polynomial.polyval
    return np.maximum(poly(t, REMEZ) - poly((4.0) ** 2, REMEZ), 0.0)


def mitsuba_formula(x, stddev):
    return np.maximum(0.0, np.exp(-np.asarray(x, dtype=np.float64) ** 2 / (2 * stddev ** 2)) - math.exp(-8.0))


def device_profile(filt, x: np.ndarray) -> np.ndarray:
    """The device's profile (PixelFilter.profile) at float32 x."""
    scene = edge_scene(True, filt.radius / 4)
    profile = make_pixel_filter(features_of(scene, "drt")).profile

    @wp.kernel(enable_backward=False, module="unique")
    def at(x: wp.array(dtype=float), out: wp.array(dtype=float)):
        i = wp.tid()
        out[i] = profile(x[i])

    out = wp.zeros(len(x), dtype=float, device="cpu")
    wp.launch(at, dim=len(x), inputs=[wp.array(x.astype(np.float32), dtype=float, device="cpu"), out],
              device="cpu")
    return out.numpy()


@pytest.mark.parametrize("stddev", [0.5, 0.25, 0.3])
def test_mitsuba_gaussian_is_mitsubas_cpu_table(stddev):
    filt = get_filter(MITSUBA_GAUSSIAN, stddev)
    r = filt.radius
    assert r == 4 * stddev and filt.margin == math.ceil(4 * stddev - 0.5)
    # init_discretization: v[i] = eval(radius i / 31) (float32 arithmetic), v[31] = 0.
    table = mitsuba_gaussian_table(r)
    starts = (np.float32(r) * np.arange(31, dtype=np.float32)) / np.float32(31)
    assert table.dtype == np.float32 and table.shape == (32,) and table[31] == 0.0
    assert np.array_equal(table[:31], mitsuba_formula(starts, stddev).astype(np.float32))
    assert table[0] == np.float32(1.0 - math.exp(-8.0)) and np.all(np.diff(table) < 0) and table[30] > 0
    # The lookup: bin i on [r i / 31, r (i + 1) / 31), 31 (zero) from the radius on.
    i = np.arange(1, 31)
    edges = r * i / 31.0
    eps = 1e-5 * r
    for sign in (1.0, -1.0):
        assert np.array_equal(mitsuba_bin(sign * (edges + eps), r), i)
        assert np.array_equal(mitsuba_bin(sign * (edges - eps), r), i - 1)
        assert np.array_equal(filt.f1(sign * (edges + eps)), table[i].astype(np.float64))
        assert np.array_equal(filt.f1(sign * (edges - eps)), table[i - 1].astype(np.float64))
    assert mitsuba_bin(0.0, r) == 0 and filt.f1(0.0) == table[0]
    assert mitsuba_bin(r, r) == 31 and mitsuba_bin(1e9, r) == 31
    assert filt.f1(r) == 0.0 and filt.f1(r * (1 - 1e-5)) == table[30] and filt.f1(-r * 1.0001) == 0.0
    # Host and device read the same values at the same bins (float32 x: the device's input).
    x = np.concatenate([np.linspace(-1.2 * r, 1.2 * r, 4001), edges, -edges, edges + eps, edges - eps,
                        [0.0, r, -r]]).astype(np.float32)
    assert np.array_equal(device_profile(filt, x), filt.f1(x.astype(np.float64)).astype(np.float32))
    # The step function is a slightly wider filter than the formula: above it inside each bin.
    dense = np.linspace(0.0, r * (1 - 1e-9), 20001)
    assert np.all(filt.f1(dense) >= mitsuba_formula(dense, stddev).astype(np.float32) - 1e-7)
    # Mitsuba's CPU build evaluates a polynomial fit instead of exp: within 4.1e-4 of the formula
    # (peak 1) at the bin starts, a weight error well under the crosscheck's 1%.
    assert np.max(np.abs(mitsuba_cpu_profile(starts, stddev) - table[:31])) < 4.1e-4
    # The integral: the bins' sum, against a fine midpoint rule of the step function (2^20 cells)
    # and against scipy's quadrature split at the bin edges.
    cells = 1 << 20
    mid = (np.arange(cells) + 0.5) * (2 * r / cells) - r
    assert filt.integral1 == pytest.approx(float(np.sum(filt.f1(mid))) * 2 * r / cells, rel=1e-5)
    assert filt.integral1 == pytest.approx(filt.truncated_integral1(-9.0, 9.0), rel=1e-12)
    exact = stddev * math.sqrt(2 * math.pi) * math.erf(2 * math.sqrt(2)) - 2 * r * math.exp(-8.0)
    assert filt.integral1 > exact * 1.01                         # wider than the formula
    # The sampling table's bins straddling a step are integrated piece by piece: its CDF is the
    # step function's, to float32.
    grid = np.linspace(-r, r, len(filter_cdf(filt)))
    want = np.array([filt.truncated_integral1(-r, x) if x > -r else 0.0 for x in grid]) / filt.integral1
    assert np.max(np.abs(filter_cdf(filt) - want)) < 2e-7
    assert get_filter("gaussian", stddev).radius == 1.5        # drtlab's own keeps its shape


# ---------------------------------------------------------------------------------------------------
# The truncated sampler at a corner pixel
# ---------------------------------------------------------------------------------------------------

def edge_scene(clip: bool, stddev: float = 0.5, edge: float = EDGE, res=RES):
    half_h = math.tan(math.radians(FOV) / 2.0)
    half_w = half_h * res[0] / res[1]

    def world(x, y):
        return np.array([DISTANCE * (2.0 * x / res[0] - 1.0) * half_w,
                         DISTANCE * (1.0 - 2.0 * y / res[1]) * half_h, 0.0])
    o = world(-1000.0, 1000.0)
    eu, ev = world(edge, 1000.0) - o, world(-1000.0, -1000.0) - o
    assert np.cross(eu, ev)[2] > 0          # emits towards the camera (+z)
    cam = camera_dict((0, 0, DISTANCE), (0, 0, 0), FOV)
    cam.update(filter=MITSUBA_GAUSSIAN, filter_stddev=stddev, filter_clip=clip)
    d = scene_dict("edge", cam, {"light": {"kind": "emitter", "emission": [1, 1, 1]}},
                   [quad(o, eu, ev, "light")], res=res, integrator="drt", max_depth=1)
    return scene_from_dict(d, name=f"edge-{clip}")


def sampled_offsets(clip: bool, n: int, px: int, py: int) -> np.ndarray:
    """(n, 3) offsets and weights the sampler of the clipped scene's filter (or, clip False, the
    untruncated one) draws for pixel (px, py) from uniform u."""
    scene = edge_scene(True)
    f = replace(features_of(scene, "drt"), filter_clip=clip)
    sample = make_pixel_filter(f).sample

    @wp.kernel(enable_backward=False, module="unique")
    def draw(sd: SceneData, u: wp.array(dtype=wp.vec2), px: int, py: int, out: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        out[i] = sample(sd, u[i], px, py)

    u = np.random.default_rng(seed_for("clip-chi2")).random((n, 2), dtype=np.float32)
    out = wp.zeros(n, dtype=wp.vec3, device="cpu")
    wp.launch(draw, dim=n, inputs=[upload(scene, "cpu"), wp.array(u, dtype=wp.vec2, device="cpu"), px, py,
                                   out], device="cpu")
    return out.numpy()


def chi2_p(offsets: np.ndarray, filt, lo: float, hi: float, bins: int = 24) -> float:
    """p-value of the offsets against the table's density restricted to [lo, hi] (piecewise linear
    CDF of the float32 table); offsets outside [lo, hi] land in a bin of expected count 0."""
    cdf = filter_cdf(filt).astype(np.float64)
    grid = np.linspace(-filt.radius, filt.radius, len(cdf))
    edges = np.linspace(lo, hi, bins + 1)
    c = np.interp(edges, grid, cdf)
    expected = np.diff(c) / (c[-1] - c[0]) * len(offsets)
    counts = np.histogram(offsets, bins=edges)[0]
    outside = len(offsets) - counts.sum()
    if outside:
        return 0.0
    return float(stats.chisquare(counts, expected).pvalue)


def test_truncated_sampling_stays_in_the_film_with_the_restricted_density():
    filt = get_filter(MITSUBA_GAUSSIAN, 0.5)
    r, n = filt.radius, 20000
    s = sampled_offsets(True, n, 0, RES[1] - 1)           # bottom-left corner: cut left and below
    lo, hi = -0.5, r
    assert s[:, 0].min() >= lo - 1e-6 and s[:, 1].max() <= 0.5 + 1e-6
    p = min(chi2_p(s[:, 0], filt, lo, hi), chi2_p(-s[:, 1], filt, lo, hi))
    assert p > 1 - (1 - ALPHA_TEST) ** 0.5, p
    # E w = integral_cut f / integral_cut f = 1: the density and the normalisation agree.
    w = s[:, 2].astype(np.float64)
    z = (w.mean() - 1.0) / (w.std(ddof=1) / math.sqrt(n))
    assert abs(z) < stats.norm.isf(ALPHA_TEST / 2), z
    # The table rows are what the sampler cuts with: the CDF at -(k + 0.5), +(k + 0.5), the tail.
    t = clip_table(filt)
    assert t.shape == (2, 3) and np.allclose(t[:, 0] + t[:, 1], 1.0, atol=1e-6)


def test_untruncated_sampling_is_rejected_at_the_border_pixel():
    filt = get_filter(MITSUBA_GAUSSIAN, 0.5)
    s = sampled_offsets(False, 20000, 0, 0)
    assert chi2_p(s[:, 0], filt, -0.5, filt.radius) < ALPHA


# ---------------------------------------------------------------------------------------------------
# Renders of the edge against the closed forms, cut and uncut
# ---------------------------------------------------------------------------------------------------

def F(a, b, stddev=0.5):
    """Integral of Mitsuba's (tabulated) Gaussian profile over [a, b] (0 when b <= a): a sum of
    constant bins, scipy's quadrature split at their edges."""
    if b <= a:
        return 0.0
    return get_filter(MITSUBA_GAUSSIAN, stddev).truncated_integral1(a, b)


def edge_truth(clip: bool, r: float = 2.0) -> np.ndarray:
    out = []
    for px in range(RES[0]):
        c = px + 0.5
        lo, hi = (max(-r, -c), min(r, RES[0] - c)) if clip else (-r, r)
        out.append(F(lo, min(hi, EDGE - c)) / F(lo, hi))
    return np.array(out)


def column_comparison(imgs: np.ndarray, truth: np.ndarray, columns=slice(0, 3)):
    means = imgs.mean(axis=1)[:, columns]                     # (K, columns): rows pooled
    return compare(Estimate.from_images(means[:, None, :], 1), Estimate.exact(truth[columns]), ALPHA_TEST)


def test_closed_forms_differ_at_the_border_only():
    cut, full = edge_truth(True), edge_truth(False)
    assert cut[0] == pytest.approx(F(-0.5, -0.25) / F(-0.5, 2.0), rel=1e-15)
    assert full[0] == pytest.approx(F(-2.0, -0.25) / F(-2.0, 2.0), rel=1e-15)
    assert cut[0] < full[0] - 0.1 and cut[1] < full[1]      # 0.179 vs 0.315, 0.0055 vs 0.0069
    assert np.array_equal(cut[2:], full[2:])                  # beyond the margin: the whole support


@pytest.mark.parametrize("sampler,spp", [("stratified", 16), ("stratified+splat", 64)])
def test_cut_renders_match_the_cut_closed_form_and_not_the_uncut_one(sampler, spp):
    scene = edge_scene(True)
    imgs = np.array([render(scene, spp=spp, sampler=sampler, seed=seed_for("clip", sampler, k),
                            threads=2, progress=False)[..., 0] for k in range(8)])
    assert np.isfinite(imgs).all()
    c = column_comparison(imgs, edge_truth(True))
    assert not c.rejected, c.summary()
    # Negative control: the same renders against Mitsuba's sample_border = true pixels.
    assert column_comparison(imgs, edge_truth(False)).rejected


# A sharp edge mid-film, on a pixel boundary: the columns beside it are where the table (a wider
# filter) and the exact Gaussian differ most, 0.1662 vs 0.1584 just outside, 0.8338 vs 0.8416 just
# inside (Mitsuba's projector test scene: 0.143 in its reference against 0.134 with the exact one).
MID_RES, MID_EDGE, MID_COLUMNS = (12, 64), 6.0, slice(4, 8)


def exact_gaussian_integral(a: float, b: float, stddev: float = 0.5) -> float:
    """Integral of the untabulated formula max(0, exp(-x^2 / 2 s^2) - exp(-8)) over [a, b]."""
    k = stddev * math.sqrt(2.0)
    return (stddev * math.sqrt(math.pi / 2.0) * (math.erf(b / k) - math.erf(a / k))
            - math.exp(-8.0) * (b - a))


def mid_edge_truth(integral) -> np.ndarray:
    r = 2.0
    return np.array([integral(-r, min(r, max(-r, MID_EDGE - (px + 0.5)))) / integral(-r, r)
                     for px in range(MID_RES[0])])


@pytest.mark.parametrize("sampler,spp", [("stratified", 64), ("stratified+splat", 64)])
def test_sharp_edge_renders_are_the_tables_pixels_not_the_exact_gaussians(sampler, spp):
    scene = edge_scene(False, edge=MID_EDGE, res=MID_RES)
    imgs = np.array([render(scene, spp=spp, sampler=sampler, seed=seed_for("mid-edge", sampler, k),
                            threads=2, progress=False)[..., 0] for k in range(8)])
    table = mid_edge_truth(F)
    exact = mid_edge_truth(exact_gaussian_integral)
    assert table[6] == pytest.approx(0.1662, abs=1e-4) and exact[6] == pytest.approx(0.1584, abs=1e-4)
    c = column_comparison(imgs, table, MID_COLUMNS)
    assert not c.rejected, c.summary()
    # Negative control: the exact Gaussian's pixels, rejected at the same level.
    bad = column_comparison(imgs, exact, MID_COLUMNS)
    assert bad.rejected, bad.summary()


def reference_edge_residuals(integral) -> np.ndarray:
    """(rows, 2): Mitsuba 3.9.1's reference of its constant projector test scene (48 x 48, a uniformly
    lit square whose right edge runs down column ~40): per row along the edge, the plateau p (columns
    30-36), the edge's position fitted to pixel 40's value / p under the filter of `integral`, then
    pixels 39 and 38 / p minus what that filter predicts there."""
    from scipy.optimize import brentq
    from drtlab.experiments.bench.mitsuba.suite import scenes, suite_dir
    from drtlab.kernels.imageio import read_linear
    jobs = [j for j in scenes(suite_dir()) if j["name"] == "test_projector_constant_direct"]
    if not jobs or not jobs[0]["ref"].is_file():
        pytest.skip(f"Mitsuba's test scenes are not at {suite_dir()} (set DRTLAB_MITSUBA_TESTS)")
    img = read_linear(jobs[0]["ref"])[0][..., 0].astype(np.float64)
    assert img.shape == (48, 48)
    r = 2.0

    def v(d):
        return integral(-r, min(r, max(-r, d))) / integral(-r, r)
    out = []
    for row in range(10, 38):
        p = img[row, 30:37].mean()
        e = brentq(lambda e: v(e - 40.5) - img[row, 40] / p, 39.0, 41.0)
        out.append([img[row, 39] / p - v(e - 39.5), img[row, 38] / p - v(e - 38.5)])
    return np.array(out)


def test_mitsubas_reference_edge_is_the_tables_not_the_exact_gaussians():
    """One t-test per column over the rows (independent pixels), Sidak over the 2 columns: the
    table's residuals are noise (t -1.6 and -0.15 when written), the exact Gaussian's are not
    (t -105 and -31: pixel 39 reads 0.807 where it predicts 0.823)."""
    alpha = sidak(ALPHA_TEST, 2)

    def p_values(res):
        t = res.mean(axis=0) / (res.std(axis=0, ddof=1) / math.sqrt(len(res)))
        return 2.0 * stats.t.sf(np.abs(t), len(res) - 1)
    assert np.all(p_values(reference_edge_residuals(F)) > alpha)
    assert np.any(p_values(reference_edge_residuals(exact_gaussian_integral)) < alpha)   # negative control


# ---------------------------------------------------------------------------------------------------
# Mitsuba 3 XML films
# ---------------------------------------------------------------------------------------------------

FILM = """<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
  {film}
</sensor>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
</scene>"""


def film_camera(tmp_path, film: str):
    from drtlab.kernels.scene_model.scene_file import load_scene
    (tmp_path / "s.xml").write_text(FILM.format(film=film))
    c = load_scene(tmp_path / "s.xml").camera
    return c.filter, c.filter_stddev, c.filter_clip


HDR = '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>{}</film>'
BORDER = '<boolean name="sample_border" value="{}"/>'


@pytest.mark.parametrize("film,want", [
    ("", (MITSUBA_GAUSSIAN, 0.0, True)),                                  # no film: Mitsuba's default
    (HDR.format(""), (MITSUBA_GAUSSIAN, 0.0, True)),                      # no rfilter: its Gaussian
    (HDR.format(BORDER.format("true")), (MITSUBA_GAUSSIAN, 0.0, False)),
    (HDR.format('<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>'),
     (MITSUBA_GAUSSIAN, 0.25, True)),
    (HDR.format(BORDER.format("false") + '<rfilter type="gaussian"/>'), (MITSUBA_GAUSSIAN, 0.0, True)),
    (HDR.format(BORDER.format("false") + '<rfilter type="mitchell"/>'), ("mitchell", 0.0, True)),
    (HDR.format(BORDER.format("true") + '<rfilter type="mitchell"/>'), ("mitchell", 0.0, False)),
    (HDR.format(BORDER.format("false") + '<rfilter type="box"/>'), ("box", 0.0, False)),
    (HDR.format(BORDER.format("true") + '<rfilter type="box"/>'), ("box", 0.0, False)),
])
def test_mitsuba_films_select_the_filter_and_its_cut(tmp_path, film, want):
    assert film_camera(tmp_path, film) == want


def test_refused_filters_and_stddev_name_their_path(tmp_path):
    from drtlab.errors import InputError
    for film, what in ((HDR.format('<rfilter type="lanczos"/>'), "supported: box, gaussian, mitchell"),
                       (HDR.format('<rfilter type="gaussian"><float name="stddev" value="8"/></rfilter>'),
                        "rfilter(gaussian)/float[@name=stddev]: must be in [0.25, 4.0] pixels")):
        with pytest.raises(InputError) as e:
            film_camera(tmp_path, film)
        assert what in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_scene_file_keys_and_their_errors():
    from drtlab.errors import InputError
    cam = camera_dict((0, 0, 5), (0, 0, 0), 40)
    base = scene_dict("k", cam, {"m": {"kind": "diffuse"}}, [quad((0, 0, 0), (1, 0, 0), (0, 1, 0), "m")])
    for extra, field in (({"filter": "gaussian", "filter_stddev": 0.5}, "camera.filter_stddev"),
                         ({"filter": MITSUBA_GAUSSIAN, "filter_stddev": 0.1}, "camera.filter_stddev"),
                         ({"filter": MITSUBA_GAUSSIAN, "filter_clip": 1}, "camera.filter_clip")):
        d = {**base, "camera": {**cam, **extra}}
        with pytest.raises(InputError) as e:
            scene_from_dict(d)
        assert e.value.field == field, (extra, e.value)


@pytest.mark.parametrize("extra", [{"filter_stddev": 0.75, "filter_clip": True}, {"filter_clip": False}])
def test_export_then_import_keeps_the_filter(tmp_path, extra):
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    from drtlab.kernels.scene_model.scene_file import load_scene
    cam = {**camera_dict((0, 0, 5), (0, 0, 0), 40), "filter": MITSUBA_GAUSSIAN, **extra}
    d = scene_dict("x", cam, {"m": {"kind": "diffuse"}}, [quad((0, 0, 0), (1, 0, 0), (0, 1, 0), "m")])
    a = scene_from_dict(d)
    export_mitsuba(a, tmp_path / "x.xml")
    b = load_scene(tmp_path / "x.xml").camera
    assert (b.filter, b.filter_stddev, b.filter_clip) == (a.camera.filter, a.camera.filter_stddev,
                                                          a.camera.filter_clip)
