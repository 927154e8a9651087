"""Point sets: uniformity and independence of dimensions, for every registered point set.

(Stratification itself, one point per stratum per dimension, is tests/estimators/test_pointsets.py's.)

* Uniformity: the centred L2 discrepancy (`scipy.stats.qmc.discrepancy`, method "CD") of each pixel's
  spp 2D points, averaged over P pixels, against the same statistic for i.i.d. uniform points (200
  replicates, numpy, fixed seed): independent points must fall inside the replicates' 0.5%..99.5%
  band, stratified ones below its 0.5% quantile (clearly below the i.i.d. median); scipy's
  LatinHypercube of the same size is reported alongside. A set this file does not know must at least
  not be worse than i.i.d.
* No correlation between dimensions, over the tracer's dimension layout (estimators/dimensions.py:
  pixel, lens, time and two bounces of light choice, light position, lobe choice, direction,
  roulette; 19 coordinates, 171 pairs):
  - pooled: one sample per pixel (index = pixel mod spp) over 2^20 pixels, the Pearson correlation of
    every pair within 4.5 / sqrt(N) (Bonferroni over the pairs at alpha = 0.01 needs 4.0);
  - per pixel: spp = 64 samples of each of 2^14 pixels; the correlation r_p of a pair within one pixel
    has (spp - 1) E[r_p^2] = 1 when the two dimensions are independent (exactly, for independently
    permuted strata: Spearman's rho), so the mean of (spp - 1) r_p^2 must stay below
    1 + 4.5 standard errors. A point set whose dimensions share structure within a pixel fails it
    even when the pooled correlation is zero.
  - jointly uniform: a 2D chi-square test of every pair on 8 x 8 and 32 x 32 cells, one sample per
    pixel (each sample must be uniform on the unit square jointly in every pair of dimensions, the
    condition for the estimator to be unbiased), Sidak-corrected over the 2 x 171 tests.
* Negative controls built as PointSets with their own Warp functions: `fake-correlated` (dimension
  d + 1 copies dimension d, d even) must fail the three independence tests; `fake-half` (stratified
  points squeezed into [0, 0.5)) must fail the uniformity test and the joint chi-square.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import stats
from scipy.stats import qmc

from drtlab.estimators import dimensions as D
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.independent import independent_1d
from drtlab.estimators.pointsets.stratified import stratified_1d, stratified_2d
from drtlab.estimators.registry import POINTSETS
from drtlab.warp_runtime import warp as _wp

ALPHA = 0.01
SEED = 20240607


# ---------------------------------------------------------------------------------------------------
# Fakes (negative controls)
# ---------------------------------------------------------------------------------------------------

from pointset_util import EXPECT, FAKE_CORRELATED, FAKE_HALF, KNOWN_DEFECTS, copied_1d, copied_2d, half_1d, half_2d


def registered(test: str):
    """One param per registered point set (new sets are picked up), xfail where a defect is known,
    skipped where the set is biased by design (PointSet.biased)."""
    out = []
    for name in POINTSETS:
        reason = KNOWN_DEFECTS.get((test, name))
        marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
        if POINTSETS[name].biased:
            marks = [pytest.mark.skip(reason="biased by design (PointSet.biased): not uniform")]
        out.append(pytest.param(name, id=name, marks=marks))
    return out


def pointset(name: str) -> PointSet:
    return {FAKE_CORRELATED.name: FAKE_CORRELATED, FAKE_HALF.name: FAKE_HALF}.get(name) \
        or POINTSETS[name]


# ---------------------------------------------------------------------------------------------------
# Generating points: the tracer's dimension layout, one kernel per point set
# ---------------------------------------------------------------------------------------------------

def layout(bounces: int = 2) -> list[tuple[str, int, int, int]]:
    """(label, 1 or 2 (get1d / get2d), dimension, component) in the order the tracer reads them."""
    out = [("pixel.x", 2, D.PIXEL, 0), ("pixel.y", 2, D.PIXEL, 1), ("lens.x", 2, D.LENS, 0),
           ("lens.y", 2, D.LENS, 1), ("time", 1, D.TIME, 0)]
    for b in range(bounces):
        out += [(f"light_choice{b}", 1, D.bounce_dim(b, D.LIGHT_CHOICE), 0),
                (f"light_pos{b}.x", 2, D.bounce_dim(b, D.LIGHT_POSITION), 0),
                (f"light_pos{b}.y", 2, D.bounce_dim(b, D.LIGHT_POSITION), 1),
                (f"lobe_choice{b}", 1, D.bounce_dim(b, D.LOBE_CHOICE), 0),
                (f"direction{b}.x", 2, D.bounce_dim(b, D.DIRECTION), 0),
                (f"direction{b}.y", 2, D.bounce_dim(b, D.DIRECTION), 1),
                (f"roulette{b}", 1, D.bounce_dim(b, D.ROULETTE), 0)]
    return out


LAYOUT = layout()
LABELS = [c[0] for c in LAYOUT]
PAIRS = list(zip(*np.triu_indices(len(LAYOUT), 1)))

_kernels: dict = {}
_cache: dict = {}


def make_kernel(ps: PointSet):
    get1d, get2d = ps.get1d, ps.get2d

    @wp.kernel(enable_backward=False, module="unique")
    def points(seed: wp.uint32, spp: int, per_pixel: int, kinds: wp.array(dtype=int),
               dims: wp.array(dtype=int), comps: wp.array(dtype=int),
               out: wp.array2d(dtype=float)):
        # per_pixel = spp: all samples of each pixel; per_pixel = 1: one sample per pixel, index =
        # pixel mod spp (independent samples, every index represented).
        tid = wp.tid()
        pixel = tid / per_pixel
        index = tid % per_pixel
        if per_pixel == 1:
            index = pixel % spp
        pix = wp.uint32(pixel)
        idx = wp.uint32(index)
        uspp = wp.uint32(spp)
        for c in range(kinds.shape[0]):
            v = float(0.0)
            if kinds[c] == 1:
                v = get1d(seed, pix, idx, wp.uint32(dims[c]), uspp)
            else:
                p = get2d(seed, pix, idx, wp.uint32(dims[c]), uspp)
                v = p[comps[c]]
            out[tid, c] = v

    return points


def generate(name: str, spp: int, n_pixels: int, per_pixel: int, coords=None) -> np.ndarray:
    """(n_pixels * per_pixel, len(coords)) float64 values of point set `name`."""
    key = (name, spp, n_pixels, per_pixel, None if coords is None else tuple(coords))
    if key in _cache:
        return _cache[key]
    _wp()
    if name not in _kernels:
        _kernels[name] = make_kernel(pointset(name))
    coords = LAYOUT if coords is None else coords
    n = n_pixels * per_pixel
    arr = lambda xs: wp.array(np.asarray(xs, dtype=np.int32), dtype=int, device="cpu")  # noqa: E731
    out = wp.zeros((n, len(coords)), dtype=float, device="cpu")
    wp.launch(_kernels[name], dim=n, device="cpu",
              inputs=[wp.uint32(SEED), spp, per_pixel, arr([c[1] for c in coords]),
                      arr([c[2] for c in coords]), arr([c[3] for c in coords]), out])
    values = out.numpy().astype(np.float64)
    assert np.all((values >= 0.0) & (values < 1.0))
    _cache.clear()                      # keep one array at a time (they are 150 MB)
    _cache[key] = values
    return values


# ---------------------------------------------------------------------------------------------------
# Uniformity: centred L2 discrepancy against i.i.d. and LatinHypercube
# ---------------------------------------------------------------------------------------------------

PIXELS = 32
REPLICATES = 200
DISCREPANCY_SPP = (16, 64, 128, 256)       # square and rectangular (8 x 16) strata grids
UNIFORMITY_DIMS = [("pixel", D.PIXEL), ("direction0", D.bounce_dim(0, D.DIRECTION))]
_reference: dict = {}


def mean_cd(sets) -> float:
    return float(np.mean([qmc.discrepancy(s, method="CD") for s in sets]))


def iid_reference(spp: int) -> dict:
    """Mean CD of PIXELS i.i.d. sets of spp points: REPLICATES replicates, and LatinHypercube's."""
    if spp not in _reference:
        rng = np.random.default_rng(SEED + spp)
        reps = np.array([mean_cd(rng.random((PIXELS, spp, 2))) for _ in range(REPLICATES)])
        lhs = qmc.LatinHypercube(d=2, seed=np.random.default_rng(SEED - spp))
        # The mean over PIXELS sets is close to normal; a Sidak-corrected two-sided band over all
        # verdicts of one point set (alpha = 0.01 in total) keeps false alarms at 1% per set.
        m = len(DISCREPANCY_SPP) * len(UNIFORMITY_DIMS)
        z = stats.norm.ppf(1 - (1 - (1 - 0.01) ** (1 / m)) / 2)
        mu, sd = reps.mean(), reps.std(ddof=1)
        _reference[spp] = dict(lo=mu - z * sd, median=np.median(reps), hi=mu + z * sd,
                               lhs=mean_cd([lhs.random(spp) for _ in range(PIXELS)]))
    return _reference[spp]


def uniformity_verdicts(name: str, expect: str) -> list[tuple[bool, str]]:
    out = []
    for spp in DISCREPANCY_SPP:
        ref = iid_reference(spp)
        for label, dim in UNIFORMITY_DIMS:
            pts = generate(name, spp, PIXELS, spp, [("x", 2, dim, 0), ("y", 2, dim, 1)])
            cd = mean_cd(pts.reshape(PIXELS, spp, 2))
            if expect == "iid":
                ok = ref["lo"] <= cd <= ref["hi"]
            elif expect == "better":
                ok = cd < ref["lo"]
            else:
                ok = cd <= ref["hi"]
            out.append((ok, f"{name} {label} spp={spp}: mean CD {cd:.3g}; i.i.d. band "
                            f"[{ref['lo']:.3g}, {ref['hi']:.3g}] median {ref['median']:.3g}; "
                            f"LatinHypercube {ref['lhs']:.3g}; expected {expect}"))
    return out


@pytest.mark.parametrize("name", registered("discrepancy"))
def test_discrepancy_against_iid_and_lhs(name):
    verdicts = uniformity_verdicts(name, EXPECT.get(name, "not worse than iid"))
    print("\n".join(m for _, m in verdicts))
    assert all(ok for ok, _ in verdicts), "\n".join(m for ok, m in verdicts if not ok)


def test_negative_control_half_interval_is_not_uniform():
    # Points squeezed into [0, 0.5): rejected whether judged as stratified (must beat i.i.d.) or as
    # independent (must look i.i.d.), in every configuration.
    for expect in ("better", "iid"):
        verdicts = uniformity_verdicts(FAKE_HALF.name, expect)
        assert not any(ok for ok, _ in verdicts), [m for ok, m in verdicts if ok]


# ---------------------------------------------------------------------------------------------------
# Independence of dimensions
# ---------------------------------------------------------------------------------------------------

POOLED_PIXELS = 1 << 20
POOLED_SPP = 64
PER_PIXEL_SPP = 64
PER_PIXEL_PIXELS = 1 << 14
Z = 4.5


def pooled_correlation_failures(name: str) -> list[str]:
    u = generate(name, POOLED_SPP, POOLED_PIXELS, 1)
    r = np.corrcoef(u.T)
    bound = Z / math.sqrt(u.shape[0])
    return [f"{LABELS[a]} x {LABELS[b]}: r = {r[a, b]:+.5f} (bound {bound:.5f})"
            for a, b in PAIRS if abs(r[a, b]) > bound]


def per_pixel_correlation_failures(name: str) -> list[str]:
    u = generate(name, PER_PIXEL_SPP, PER_PIXEL_PIXELS, PER_PIXEL_SPP)
    u = u.reshape(PER_PIXEL_PIXELS, PER_PIXEL_SPP, -1)
    z = u - u.mean(axis=1, keepdims=True)
    norm = np.sqrt((z * z).sum(axis=1, keepdims=True))
    z = np.ascontiguousarray((z / np.where(norm > 0.0, norm, 1.0)).transpose(2, 0, 1))
    out = []
    for a, b in PAIRS:
        t = (PER_PIXEL_SPP - 1) * np.einsum("ps,ps->p", z[a], z[b]) ** 2
        se = t.std() / math.sqrt(PER_PIXEL_PIXELS)
        if t.mean() > 1.0 + Z * max(se, 1e-3):
            out.append(f"{LABELS[a]} x {LABELS[b]}: (spp-1) E[r^2] = {t.mean():.3f} "
                       f"(independent: 1 +- {se:.3f})")
    return out


def joint_uniformity_failures(name: str) -> list[str]:
    u = generate(name, POOLED_SPP, POOLED_PIXELS, 1)
    level = 1.0 - (1.0 - ALPHA) ** (1.0 / (2 * len(PAIRS)))
    out = []
    # 32 x 32 counts once per pair; the 8 x 8 ones are their 4 x 4 block sums (floor(8u) is
    # floor(32u) // 4 exactly), which halves the cost of this test.
    q = np.ascontiguousarray(np.minimum((u * 32).astype(np.int32), 31).T)
    fine = {(a, b): np.bincount(q[a] * 32 + q[b], minlength=32 * 32) for a, b in PAIRS}
    for g in (8, 32):
        for a, b in PAIRS:
            counts = fine[a, b] if g == 32 else fine[a, b].reshape(8, 4, 8, 4).sum(axis=(1, 3))
            p = stats.chisquare(counts.ravel()).pvalue
            if p < level:
                out.append(f"{LABELS[a]} x {LABELS[b]} on {g}x{g}: p = {p:.2g} (level {level:.2g})")
    return out


def _summary(fails: list[str]) -> str:
    return f"{len(fails)} of {len(PAIRS)} pairs:\n" + "\n".join(fails[:12])


@pytest.mark.parametrize("name", registered("pooled_correlation"))
def test_pooled_correlation_between_dimensions(name):
    fails = pooled_correlation_failures(name)
    assert not fails, _summary(fails)


@pytest.mark.parametrize("name", registered("per_pixel_correlation"))
def test_per_pixel_correlation_between_dimensions(name):
    fails = per_pixel_correlation_failures(name)
    assert not fails, _summary(fails)


@pytest.mark.parametrize("name", registered("joint_uniformity"))
def test_pairs_of_dimensions_jointly_uniform(name):
    fails = joint_uniformity_failures(name)
    assert not fails, _summary(fails)


def test_negative_control_copied_dimension_is_rejected():
    assert pooled_correlation_failures(FAKE_CORRELATED.name)
    assert per_pixel_correlation_failures(FAKE_CORRELATED.name)
    assert joint_uniformity_failures(FAKE_CORRELATED.name)


def test_negative_control_half_interval_fails_joint_uniformity():
    assert joint_uniformity_failures(FAKE_HALF.name)
