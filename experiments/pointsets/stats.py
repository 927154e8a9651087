"""Statistics of point-set samples held as arrays: the checks of tests/estimators/test_pointsets*.py
and tests/estimators/test_pointset_uniformity.py, written against numpy arrays so that `validate` can
run them on any generator (a registered point set through `points()`, or a researcher's own arrays).

Shapes: `u` is (P, spp, C): the spp samples of P pixels in C coordinates (pixels are independent:
every point set keys its samples by pixel); `pooled` is (P, C), one sample per pixel (index
p mod spp, as the tests pool), so its rows are independent draws.

Every function returns (label, p-value) pairs, one per sub-test, plus descriptive numbers where
useful; `hypothesis_tests.sidak_adjusted` folds a family of sub-tests into one p-value.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats
from scipy.stats import qmc

from drtlab.estimators import dimensions as D

# A float32 value in [0, 1) sits on a grid no finer than 2^-24: per-pixel means of such values can
# be off by that much with no bias in the point set, so it floors every standard error below.
FLOAT32_FLOOR = 2.0 ** -24

dimension_label = D.label
tracer_dims = D.tracer_dims


def slot_pairs(dims: list[int]) -> list[tuple[int, int]]:
    """Column pairs (a, a + 1) of `dims` that are one get2d slot (pixel, lens, light position,
    direction): where a 2D point set promises its 2D strata."""
    col = {d: i for i, d in enumerate(dims)}
    return [(col[d], col[d + 1]) for d in dims
            if D.slot(d) == (2, d) and d + 1 in col]


def pairs(n: int) -> list[tuple[int, int]]:
    return [(a, b) for a in range(n) for b in range(a + 1, n)]


# ---------------------------------------------------------------------------------------------------
# Uniformity
# ---------------------------------------------------------------------------------------------------

def discrepancy_vs_iid(u: np.ndarray, projections, labels, rng, reference_sets: int = 2048):
    """Centred L2 discrepancy (scipy, method "CD") of each pixel's spp points in each 2D
    projection against that of i.i.d. uniform sets of spp points (`reference_sets` of them): a
    one-sided Welch t test that the point set's mean CD is not above i.i.d.'s (test_pointset_
    uniformity's criterion for a set it does not know). Returns sub-tests and the CD ratios."""
    spp = u.shape[1]
    ref = np.array([qmc.discrepancy(x, method="CD") for x in rng.random((reference_sets, spp, 2))])
    out, ratios = [], {}
    for a, b in projections:
        cd = np.array([qmc.discrepancy(x, method="CD") for x in u[:, :, [a, b]]])
        p = stats.ttest_ind(cd, ref, equal_var=False, alternative="greater").pvalue
        name = f"{labels[a]} x {labels[b]}"
        out.append((f"{name}: mean CD {cd.mean():.3g} vs i.i.d. {ref.mean():.3g}", float(p)))
        ratios[name] = float(cd.mean() / ref.mean())
    return out, ratios


def joint_uniformity(pooled: np.ndarray, labels, bins_1d: int = 16, bins_2d: int = 8):
    """Pearson chi-square of the pooled samples: each coordinate on `bins_1d` bins and every pair
    on `bins_2d` x `bins_2d` cells (every sample must be uniform, jointly in every pair: the
    condition for an unbiased estimator)."""
    q1 = np.minimum((pooled * bins_1d).astype(np.int64), bins_1d - 1)
    q2 = np.minimum((pooled * bins_2d).astype(np.int64), bins_2d - 1)
    out = []
    for c in range(pooled.shape[1]):
        p = stats.chisquare(np.bincount(q1[:, c], minlength=bins_1d)).pvalue
        out.append((f"{labels[c]} on {bins_1d} bins", float(p)))
    for a, b in pairs(pooled.shape[1]):
        counts = np.bincount(q2[:, a] * bins_2d + q2[:, b], minlength=bins_2d ** 2)
        out.append((f"{labels[a]} x {labels[b]} on {bins_2d}x{bins_2d}",
                    float(stats.chisquare(counts).pvalue)))
    return out


# ---------------------------------------------------------------------------------------------------
# Independence of dimensions
# ---------------------------------------------------------------------------------------------------

def pooled_correlation(pooled: np.ndarray, labels):
    """Pearson correlation of every pair over independent samples; two-sided t-test p-values."""
    n = pooled.shape[0]
    r = np.corrcoef(pooled.T)
    out = []
    for a, b in pairs(pooled.shape[1]):
        # A constant coordinate has no correlation coefficient; it is not independent either.
        rho = float(np.clip(r[a, b], -1.0, 1.0)) if np.isfinite(r[a, b]) else 1.0
        t = rho * math.sqrt((n - 2) / max(1.0 - rho * rho, 1e-300))
        out.append((f"{labels[a]} x {labels[b]}: r = {rho:+.4f}",
                     float(2.0 * stats.t.sf(abs(t), n - 2))))
    return out


def per_pixel_correlation(u: np.ndarray, labels):
    """Within a pixel, (spp - 1) r^2 of two independent dimensions has mean 1 (exactly: given the
    values, a random pairing), so its mean over pixels is tested one-sided against 1 (standard
    error floored at 1e-3, as tests/estimators/test_pointset_uniformity.py does). A set whose dimensions share
    structure within a pixel fails it even where pooled samples look independent."""
    p_count, spp = u.shape[0], u.shape[1]
    z = u - u.mean(axis=1, keepdims=True)
    norm = np.sqrt((z * z).sum(axis=1, keepdims=True))
    z = z / np.where(norm > 0.0, norm, 1.0)
    r = np.matmul(z.transpose(0, 2, 1), z)
    out = []
    for a, b in pairs(u.shape[2]):
        t = (spp - 1) * r[:, a, b] ** 2
        se = max(float(t.std(ddof=1)) / math.sqrt(p_count), 1e-3)
        out.append((f"{labels[a]} x {labels[b]}: (spp-1) E[r^2] = {t.mean():.3f} +- {se:.3f}",
                    float(stats.norm.sf((t.mean() - 1.0) / se))))
    return out


# ---------------------------------------------------------------------------------------------------
# Stratification
# ---------------------------------------------------------------------------------------------------

def _dispersion(cells: np.ndarray, k: int) -> np.ndarray:
    """Per row of `cells` (P, spp) cell indices in [0, k): Pearson's X^2 of the counts."""
    p_count, spp = cells.shape
    flat = (np.arange(p_count)[:, None] * k + cells).ravel()
    counts = np.bincount(flat, minlength=p_count * k).reshape(p_count, k)
    e = spp / k
    return ((counts - e) ** 2 / e).sum(axis=1)


def _clumping_p(x2: np.ndarray, k: int, spp: int) -> float:
    """One-sided: is the mean X^2 over pixels above i.i.d.'s? Under i.i.d. (equiprobable
    multinomial) X^2 has mean k - 1 and variance 2 (k - 1)(1 - 1/spp), exactly."""
    se = math.sqrt(2.0 * (k - 1) * (1.0 - 1.0 / spp) / len(x2))
    return float(stats.norm.sf((x2.mean() - (k - 1)) / se))


def stratification(u: np.ndarray, labels, slots2d):
    """Counts per stratum in each pixel: spp 1D strata per coordinate, a g x g grid (g = isqrt(spp))
    per 2D slot. The verdict asks only that a set be no clumpier than i.i.d. points (any unbiased
    set passes; duplicated or clustered points fail); how stratified a set is, is reported: the
    fraction of (pixel, coordinate) with one point per stratum, of (pixel, slot) with one point per
    grid cell, and at spp = 2^m of (pixel, slot) that are (0,m,2)-nets."""
    spp = u.shape[1]
    g = math.isqrt(spp)
    s1 = np.minimum((u * spp).astype(np.int64), spp - 1)
    out, exact_1d, exact_2d = [], [], []
    for c in range(u.shape[2]):
        x2 = _dispersion(s1[:, :, c], spp)
        exact_1d.append(np.mean(x2 == 0.0))
        out.append((f"{labels[c]} in {spp} strata", _clumping_p(x2, spp, spp)))
    sg = np.minimum((u * g).astype(np.int64), g - 1)
    for a, b in slots2d:
        x2 = _dispersion(sg[:, :, a] * g + sg[:, :, b], g * g)
        exact_2d.append(np.mean(x2 == 0.0) if g * g == spp else np.nan)
        out.append((f"{labels[a]} x {labels[b]} on {g}x{g}", _clumping_p(x2, g * g, spp)))
    info = {"latin_1d_fraction": float(np.mean(exact_1d)),
            "jitter_2d_fraction": float(np.nanmean(exact_2d)) if exact_2d and g * g == spp
            else None,
            "net_fraction": net_fraction(s1, slots2d)}
    return out, info


def net_fraction(strata: np.ndarray, slots2d) -> float | None:
    """Fraction of (pixel, 2D slot) whose spp = 2^m points are a (0,m,2)-net in base 2 (one point
    in every elementary interval 2^-a x 2^-(m-a)); None when spp is not a power of 2. `strata` is
    floor(u * spp) (P, spp, C): at spp = 2^m, floor(u * 2^a) is strata >> (m - a) exactly."""
    p_count, spp = strata.shape[:2]
    if spp & (spp - 1) or not slots2d:
        return None
    m = spp.bit_length() - 1
    rows = np.arange(p_count)[:, None] * spp
    good = []
    for a, b in slots2d:
        ok = np.ones(p_count, dtype=bool)
        for k in range(m + 1):
            cells = rows + ((strata[:, :, a] >> (m - k)) << (m - k)) + (strata[:, :, b] >> k)
            counts = np.bincount(cells.ravel(), minlength=p_count * spp)
            ok &= counts.reshape(p_count, spp).max(axis=1) == 1
        good.append(ok.mean())
    return float(np.mean(good))


# ---------------------------------------------------------------------------------------------------
# Unbiasedness
# ---------------------------------------------------------------------------------------------------

def _t_p(per_pixel: np.ndarray, exact) -> np.ndarray:
    """Two-sided one-sample t-tests of per-pixel estimates (P, m) (independent across pixels)
    against `exact` (m,)."""
    n = per_pixel.shape[0]
    se = np.hypot(per_pixel.std(axis=0, ddof=1) / math.sqrt(n), FLOAT32_FLOOR)
    return 2.0 * stats.t.sf(np.abs(per_pixel.mean(axis=0) - exact) / se, n - 1)


def _gram(x: np.ndarray) -> np.ndarray:
    """(P, C, C): the mean over each pixel's samples of x_a x_b."""
    return np.matmul(x.transpose(0, 2, 1), x) / x.shape[1]


def unbiasedness(u: np.ndarray, labels):
    """Each pixel's estimate (the mean over its spp samples) of integrals with known values, tested
    over pixels: per coordinate x and [x < 1/3]; per pair (x - 1/2)(y - 1/2) (0: independent),
    [x < 1/2][y < 1/2] (1/4) and [x + y < 1] (1/2, a diagonal edge no stratum aligns with). The
    per-pixel estimate of an unbiased set has mean exactly the integral whatever its stratification
    (tests/estimators/test_pointsets.py's test_dimensions_of_one_sample_are_independent, widened)."""
    c = u.shape[2]
    names = [f"E[{x}] = 1/2" for x in labels] + [f"P({x} < 1/3) = 1/3" for x in labels]
    estimates = [u.mean(axis=1), (u < 1 / 3).mean(axis=1)]
    exact = [0.5] * c + [1 / 3] * c
    a_idx, b_idx = np.triu_indices(c, 1)
    cov = _gram(u - 0.5)[:, a_idx, b_idx]
    quad = _gram((u < 0.5).astype(np.float64))[:, a_idx, b_idx]
    diag = np.concatenate([((u[:, :, a, None] + u[:, :, a + 1:]) < 1.0).mean(axis=1)
                           for a in range(c - 1)], axis=1)
    for what, values, value in (("E[(x-1/2)(y-1/2)] = 0", cov, 0.0),
                                ("P(x < 1/2, y < 1/2) = 1/4", quad, 0.25),
                                ("P(x + y < 1) = 1/2", diag, 0.5)):
        names += [f"{labels[a]} x {labels[b]}: {what}" for a, b in zip(a_idx, b_idx)]
        estimates.append(values)
        exact += [value] * len(a_idx)
    p = _t_p(np.concatenate(estimates, axis=1), np.array(exact))
    return list(zip(names, p.tolist()))
