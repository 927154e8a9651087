"""Cook's pre-sampled tables (estimators/pointsets/presampled.py): on the bounce-direction
dimensions `presampled` returns one fixed 4 x 4 jittered table of K = 16 points, the same for every
pixel and seed (biased by design), `presampled_random` the same table re-drawn per pixel, seed and
block of K samples; every other dimension is `stratified`'s, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from drtlab.estimators import dimensions as D
from drtlab.estimators.pointsets.presampled import K, SIDE
from drtlab.estimators.registry import POINTSETS, biased_pointsets, parse_sampler

from pointset_util import evaluate

FIXED, RANDOM, STRAT = POINTSETS["presampled"], POINTSETS["presampled_random"], POINTSETS["stratified"]
DIRECTIONS = [D.bounce_dim(b, D.DIRECTION) for b in range(4)]          # 9, 17, 25, 33
PIXELS = (0, 1, 7, 4095, 123457)
SEEDS = (0, 1, 42, 0xFFFFFFFF)


def table(ps, seed, pixel, dim, spp=K, start=0):
    """The 2D points of samples start ... start + K - 1 at a direction dimension, (K, 2) float64."""
    _, v2 = evaluate(ps, seed, spp, pixel, np.arange(start, start + K), dim)
    return v2.astype(np.float64)


def cells(pts):
    return np.sort(np.floor(pts[:, 1] * SIDE).astype(int) * SIDE + np.floor(pts[:, 0] * SIDE).astype(int))


def test_registered_and_flagged():
    assert FIXED.biased and not RANDOM.biased and not STRAT.biased
    assert biased_pointsets() == ["presampled"]
    assert parse_sampler("presampled+importance").pointset is FIXED
    assert parse_sampler("presampled_random+importance").pointset is RANDOM
    assert K == SIDE * SIDE == 16


@pytest.mark.parametrize("ps", [FIXED, RANDOM], ids=lambda p: p.name)
def test_table_is_4x4_stratified(ps):
    # Any K consecutive samples of a block hold one point in each cell of the 4 x 4 grid.
    for seed in SEEDS:
        for pixel in PIXELS:
            for dim in DIRECTIONS:
                for start in (0, K, 5 * K):
                    pts = table(ps, seed, pixel, dim, start=start)
                    assert np.array_equal(cells(pts), np.arange(K)), (ps.name, seed, pixel, dim)


@pytest.mark.parametrize("spp", [1, 4, 16, 17, 64])
def test_fixed_table_ignores_seed_pixel_and_block(spp):
    ref = table(FIXED, 0, 0, DIRECTIONS[0], spp)
    for seed in SEEDS:
        for pixel in PIXELS:
            for start in (0, K, 3 * K):             # indices past K replay the table
                assert np.array_equal(table(FIXED, seed, pixel, DIRECTIONS[0], spp, start), ref)
    # Indexed by index mod K: at spp = K a pixel reads every entry exactly once.
    _, v2 = evaluate(FIXED, 5, spp, 3, np.arange(2 * K), DIRECTIONS[0])
    assert np.array_equal(v2[:K], v2[K:])
    assert len({tuple(p) for p in v2[:K].tolist()}) == K


def test_fixed_table_differs_between_bounces():
    # One table per bounce depth (its own jitter and entry order), so a path does not replay the
    # same cell at every bounce.
    t = [table(FIXED, 0, 0, d) for d in DIRECTIONS]
    for a in range(len(t)):
        for b in range(a + 1, len(t)):
            assert np.mean(np.any(t[a] != t[b], axis=1)) > 0.9


def test_random_table_depends_on_seed_pixel_and_block():
    ref = table(RANDOM, 0, 0, DIRECTIONS[0])
    for seed, pixel, start in ((1, 0, 0), (0, 1, 0), (0, 0, K), (0xFFFFFFFF, 123457, 0)):
        other = table(RANDOM, seed, pixel, DIRECTIONS[0], start=start)
        assert np.mean(np.any(other != ref, axis=1)) > 0.95, (seed, pixel, start)


def test_random_table_is_uniform_over_pixels():
    # Unbiased: pooled over pixels, one sample index of the randomised table is uniform on [0, 1)^2
    # (chi-square on 8 x 8 cells, 64000 pixels); the fixed table is a single point for every pixel.
    from scipy.stats import chi2
    npx = 64000
    for ps, uniform in ((RANDOM, True), (FIXED, False)):
        _, v2 = evaluate(ps, 9, K, np.arange(npx), 3, DIRECTIONS[1])
        c = (np.floor(v2[:, 1].astype(np.float64) * 8) * 8 + np.floor(v2[:, 0] * 8)).astype(int)
        counts = np.bincount(c, minlength=64)
        p = chi2.sf(np.sum((counts - npx / 64) ** 2 / (npx / 64)), 63)
        assert (p > 1e-4) == uniform, (ps.name, p)


def test_one_dimensional_reads_match_the_table():
    # get1d(dim) is the table's x, get1d(dim + 1) its y: a dimension means one thing.
    idx = np.arange(2 * K)
    for ps in (FIXED, RANDOM):
        for dim in DIRECTIONS[:2]:
            x, v2 = evaluate(ps, 11, 8, 77, idx, dim)
            y, _ = evaluate(ps, 11, 8, 77, idx, dim + 1)
            assert np.array_equal(x, v2[:, 0]) and np.array_equal(y, v2[:, 1])


@pytest.mark.parametrize("spp", [1, 4, 16, 17])
def test_other_dimensions_equal_stratified(spp):
    direction = set()
    for d in DIRECTIONS:
        direction |= {d, d + 1}
    dims = np.array([d for d in range(0, 5 + 8 * 4) if d not in direction] + [1000, 0xFFFFFFF0])
    p, i, d = np.meshgrid(np.array(PIXELS), np.arange(2 * spp), dims, indexing="ij")
    # get2d at dim reads dim and dim + 1: compare 2D only where neither is a direction dimension.
    two = ~np.isin(d.ravel() + 1, list(direction))
    for seed in (0, 42):
        s1, s2 = evaluate(STRAT, seed, spp, p.ravel(), i.ravel(), d.ravel())
        for ps in (FIXED, RANDOM):
            v1, v2 = evaluate(ps, seed, spp, p.ravel(), i.ravel(), d.ravel())
            assert np.array_equal(v1, s1), ps.name
            assert np.array_equal(v2[two], s2[two]), ps.name
