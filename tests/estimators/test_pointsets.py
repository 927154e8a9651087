"""Point sets: the contract of every registered point set (values in [0, 1), a pure function of
(seed, pixel, index, dim), seeds decorrelate), exact stratification of `stratified` for square and
non-square counts, a negative control that the stratification check rejects a broken variant, and
`permute` being a bijection of [0, n)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from drtlab.estimators.hashing import hash_key, mix32, permute, unit_float
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.pointsets.stratified import grid_columns, place, place_bits
from drtlab.estimators.registry import POINTSETS
from drtlab.warp_runtime import warp as _wp

from pointset_util import (M32, GOLDEN, M1, M2, M3, eval_kernel, evaluate, py_hash_key,
                            py_mix32, py_permute)


@pytest.fixture(scope="module", autouse=True)
def warp_ready():
    _wp()


# ---------------------------------------------------------------------------------------------------
# Every registered point set
# ---------------------------------------------------------------------------------------------------

ALL = sorted(POINTSETS)
# Tests of unbiasedness / uniformity skip point sets biased by design (PointSet.biased).
BIASED = pytest.mark.skip(reason="biased by design (PointSet.biased): no uniformity to test")


def unbiased_param(name: str, *rest):
    return pytest.param(name, *rest, marks=[BIASED] if POINTSETS[name].biased else [])


def sample_grid(spp: int, pixels=(0, 1, 7, 4095, 123457), dims=(0, 1, 2, 4, 5, 12, 29, 101)):
    """(pixel, index, dim) covering two blocks of spp samples for a few pixels and dimensions."""
    p, i, d = np.meshgrid(np.array(pixels), np.arange(2 * spp), np.array(dims), indexing="ij")
    return p.ravel(), i.ravel(), d.ravel()


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("spp", [1, 3, 16, 17])
def test_values_in_unit_interval(name, spp):
    ps = POINTSETS[name]
    for seed in (0, 1, 0xFFFFFFFF):
        v1, v2 = evaluate(ps, seed, spp, *sample_grid(spp))
        for v in (v1, v2.ravel()):
            assert v.dtype == np.float32
            assert np.all(np.isfinite(v))
            assert v.min() >= 0.0 and v.max() < 1.0, (v.min(), v.max())


@pytest.mark.parametrize("name", ALL)
def test_extreme_keys_stay_in_unit_interval(name):
    ps = POINTSETS[name]
    big = 0xFFFFFFFF
    pixel = np.array([0, big, big, 0, 1 << 31])
    index = np.array([big, 0, big, big - 1, 1 << 31])
    dim = np.array([big - 1, big - 1, 0, big - 1, 1 << 31])   # get2d reads dim and dim + 1
    for spp in (1, 2, 5, 64, 1 << 20):
        v1, v2 = evaluate(ps, big, spp, pixel, index, dim)
        assert np.all((v1 >= 0) & (v1 < 1)) and np.all((v2 >= 0) & (v2 < 1))


@pytest.mark.parametrize("name", ALL)
def test_deterministic(name):
    ps = POINTSETS[name]
    grid = sample_grid(16)
    a1, a2 = evaluate(ps, 42, 16, *grid)
    b1, b2 = evaluate(ps, 42, 16, *grid)
    assert np.array_equal(a1, b1) and np.array_equal(a2, b2)
    # A value depends on its own key only, not on what else the launch evaluates or in which order.
    perm = np.random.default_rng(0).permutation(len(grid[0]))
    c1, c2 = evaluate(ps, 42, 16, *(g[perm] for g in grid))
    assert np.array_equal(a1[perm], c1) and np.array_equal(a2[perm], c2)
    k = 37
    d1, d2 = evaluate(ps, 42, 16, *(g[k:k + 1] for g in grid))
    assert d1[0] == a1[k] and np.array_equal(d2[0], a2[k])


@pytest.mark.parametrize("name", ALL)
def test_different_seeds_differ(name):
    ps = POINTSETS[name]
    grid = sample_grid(16)
    a1, a2 = evaluate(ps, 0, 16, *grid)
    for seed in (1, 2, 0x80000000):
        b1, b2 = evaluate(ps, seed, 16, *grid)
        # Not a shifted copy either: almost every value changes.
        assert np.mean(a1 != b1) > 0.95 and np.mean(np.any(a2 != b2, axis=1)) > 0.95


@pytest.mark.parametrize("name", ALL)
def test_pixels_and_dimensions_do_not_repeat(name):
    # Different pixels / dimensions do not replay the same sequence of values.
    ps = POINTSETS[name]
    spp = 16
    idx = np.arange(spp)
    base, base2 = evaluate(ps, 3, spp, 0, idx, 0)
    for pixel, dim in ((1, 0), (0, 1), (0, 5), (2, 7)):
        other, other2 = evaluate(ps, 3, spp, pixel, idx, dim)
        assert np.mean(base != other) > 0.9 and np.mean(np.any(base2 != other2, axis=1)) > 0.9


@pytest.mark.parametrize("name,spp", [unbiased_param(name, spp) for name in ALL
                                      for spp in (4, 16, 3, 5)])
def test_dimensions_of_one_sample_are_independent(name, spp):
    # Unbiasedness across dimensions: averaged over pixels (independent keys), a pixel's estimate of
    # E[x * y] and P(x < 1/2, y < 1/2) over two separate dimensions is exactly 1/4.
    ps = POINTSETS[name]
    npx = 20000
    p, i = np.meshgrid(np.arange(npx), np.arange(spp), indexing="ij")
    x, _ = evaluate(ps, 1, spp, p.ravel(), i.ravel(), 0)
    y, _ = evaluate(ps, 1, spp, p.ravel(), i.ravel(), 5)
    x = x.reshape(npx, spp).astype(np.float64)
    y = y.reshape(npx, spp).astype(np.float64)
    for per_pixel in ((x * y).mean(axis=1), ((x < 0.5) & (y < 0.5)).mean(axis=1)):
        se = per_pixel.std() / np.sqrt(npx)
        assert abs(per_pixel.mean() - 0.25) < 5 * se, (per_pixel.mean(), se)


@pytest.mark.parametrize("name", [unbiased_param(name) for name in ALL])
def test_roughly_uniform(name):
    # Over many pixels every point set is uniform on [0, 1) (a chi-square test on 16 bins, 1D and 2D).
    ps = POINTSETS[name]
    spp = 8
    p, i = np.meshgrid(np.arange(2000), np.arange(spp), indexing="ij")
    v1, v2 = evaluate(ps, 9, spp, p.ravel(), i.ravel(), 6)
    n = v1.size
    from scipy.stats import chi2
    counts1 = np.bincount(np.floor(v1.astype(np.float64) * 16).astype(int), minlength=16)
    cells = (np.floor(v2[:, 0].astype(np.float64) * 4) * 4 + np.floor(v2[:, 1] * 4)).astype(int)
    counts2 = np.bincount(cells, minlength=16)
    for counts in (counts1, counts2):
        stat = np.sum((counts - n / 16) ** 2 / (n / 16))
        assert chi2.sf(stat, 15) > 1e-4, counts


# ---------------------------------------------------------------------------------------------------
# Stratification (stratified only)
# ---------------------------------------------------------------------------------------------------

def expected_grid(spp: int) -> tuple[int, int]:
    """(nx, ny) from the docstring: nx the largest divisor of spp not above sqrt(spp)."""
    nx = max(d for d in range(1, math.isqrt(spp) + 1) if spp % d == 0)
    return nx, spp // nx


def check_stratified(pointset: PointSet, spp: int, seed: int, pixels, dims, block: int = 0):
    """Assert exactly one point per stratum, 1D (spp strata) and 2D (nx x ny), for the samples
    block*spp ... (block+1)*spp - 1 of each (pixel, dim); strata from float64 floor(x * n)."""
    nx, ny = expected_grid(spp)
    index = np.arange(block * spp, (block + 1) * spp)
    for pixel in pixels:
        for dim in dims:
            v1, v2 = evaluate(pointset, seed, spp, pixel, index, dim)
            s1 = np.floor(v1.astype(np.float64) * spp).astype(np.int64)
            assert np.array_equal(np.sort(s1), np.arange(spp)), (
                f"1D: spp={spp} pixel={pixel} dim={dim} block={block}: strata {sorted(s1.tolist())}")
            sx = np.floor(v2[:, 0].astype(np.float64) * nx).astype(np.int64)
            sy = np.floor(v2[:, 1].astype(np.float64) * ny).astype(np.int64)
            assert np.array_equal(np.sort(sy * nx + sx), np.arange(spp)), (
                f"2D {nx}x{ny}: spp={spp} pixel={pixel} dim={dim} block={block}: cells "
                f"{sorted(zip(sx.tolist(), sy.tolist()))}")


@pytest.mark.parametrize("spp,grid", [(1, (1, 1)), (4, (2, 2)), (16, (4, 4)), (64, (8, 8)),
                                      (256, (16, 16)), (2, (1, 2)), (3, (1, 3)), (8, (2, 4)),
                                      (12, (3, 4)), (17, (1, 17)), (18, (3, 6)), (30, (5, 6))])
def test_grid_shape_matches_docstring(spp, grid):
    assert expected_grid(spp) == grid


@pytest.mark.parametrize("spp", [1, 4, 16, 64, 256, 2, 3, 8, 12, 17])
def test_stratified_one_point_per_stratum(spp):
    ps = POINTSETS["stratified"]
    pixels = (0, 5, 99991)
    dims = (0, 2, 4, 5, 13)
    for seed in (0, 7):
        check_stratified(ps, spp, seed, pixels, dims, block=0)
        # Indices spp ... 2 spp - 1 start a new block, stratified again.
        check_stratified(ps, spp, seed, pixels, dims, block=1)


def test_stratified_blocks_and_dimensions_are_permuted_differently():
    # The stratum a sample index lands in changes between blocks and dimensions (keyed permutation):
    # over many pixels, two of them agree on about 1/spp of the indices, as independent permutations.
    ps = POINTSETS["stratified"]
    spp, npx = 64, 200
    p, i = np.meshgrid(np.arange(npx), np.arange(spp), indexing="ij")
    s = {}
    for block in (0, 1):
        for dim in (0, 1, 7):
            v1, _ = evaluate(ps, 5, spp, p.ravel(), i.ravel() + block * spp, dim)
            s[block, dim] = np.floor(v1.astype(np.float64) * spp).astype(int).reshape(npx, spp)
    keys = list(s)
    for a in range(len(keys)):
        for b in range(a + 1, len(keys)):
            agree = np.mean(s[keys[a]] == s[keys[b]])
            assert agree < 2.0 / spp, (keys[a], keys[b], agree)


def test_stratified_grid_columns_in_kernel_match_docstring():
    @wp.kernel(enable_backward=False)
    def columns(spp: wp.array(dtype=wp.uint32), out: wp.array(dtype=wp.uint32)):
        i = wp.tid()
        out[i] = grid_columns(spp[i])

    counts = np.arange(1, 1025, dtype=np.uint32)
    out = wp.zeros(len(counts), dtype=wp.uint32, device="cpu")
    wp.launch(columns, dim=len(counts), device="cpu",
              inputs=[wp.array(counts, dtype=wp.uint32, device="cpu"), out])
    assert out.numpy().tolist() == [expected_grid(int(n))[0] for n in counts]


def test_place_lands_in_its_stratum_exactly():
    # place(s, jitter, n) must satisfy floor(x * n) == s in float64 for the extreme jitters too.
    @wp.kernel(enable_backward=False)
    def placed(s: wp.array(dtype=wp.uint32), jitter: wp.array(dtype=float),
               n: wp.array(dtype=wp.uint32), out: wp.array(dtype=float)):
        i = wp.tid()
        out[i] = place(s[i], jitter[i], n[i])

    rows = []
    for n in (1, 3, 7, 10, 17, 100, 255, 1000, 4097, 65537, 1 << 20):
        for s in sorted({0, 1, n // 3, n // 2, n - 2, n - 1} - {-1}):
            if 0 <= s < n:
                for j in (0.0, 5.9604644775390625e-08, 0.5, 1.0 - 5.9604644775390625e-08):
                    rows.append((s, j, n))
    s, j, n = (np.array(c) for c in zip(*rows))
    out = wp.zeros(len(rows), dtype=float, device="cpu")
    wp.launch(placed, dim=len(rows), device="cpu",
              inputs=[wp.array(s.astype(np.uint32), dtype=wp.uint32, device="cpu"),
                      wp.array(j.astype(np.float32), dtype=float, device="cpu"),
                      wp.array(n.astype(np.uint32), dtype=wp.uint32, device="cpu"), out])
    x = out.numpy().astype(np.float64)
    assert np.array_equal(np.floor(x * n).astype(np.int64), s)
    assert np.all((x >= 0) & (x < 1))


def test_place_bits_lands_in_its_stratum_exactly_and_spans_it():
    # place_bits(s, bits, n): fixed point for a power-of-2 n below 2^24, place otherwise; the
    # extreme jitter bits must stay in stratum s, and (fixed point) reach both ends of it.
    @wp.kernel(enable_backward=False)
    def placed(s: wp.array(dtype=wp.uint32), bits: wp.array(dtype=wp.uint32),
               n: wp.array(dtype=wp.uint32), out: wp.array(dtype=float)):
        i = wp.tid()
        out[i] = place_bits(s[i], bits[i], n[i])

    rows = []
    # (Up to 2^24 strata: float32 has no value in the last stratum of 2^25.)
    for n in (1, 2, 3, 8, 64, 100, 1 << 12, 1 << 20, (1 << 23) - 1, 1 << 23, (1 << 24) - 1,
              1 << 24):
        for s in sorted({0, 1, n // 3, n // 2, n - 2, n - 1}):
            if 0 <= s < n:
                for b in (0, 1 << 8, 1 << 31, 0xFFFFFFFF):
                    rows.append((s, b, n))
    s, b, n = (np.array(c, dtype=np.int64) for c in zip(*rows))
    out = wp.zeros(len(rows), dtype=float, device="cpu")
    wp.launch(placed, dim=len(rows), device="cpu",
              inputs=[wp.array(c.astype(np.uint32), dtype=wp.uint32, device="cpu")
                      for c in (s, b, n)] + [out])
    x = out.numpy().astype(np.float64)
    assert np.array_equal(np.floor(x * n).astype(np.int64), s)
    assert np.all((x >= 0) & (x < 1))
    fixed = (n & (n - 1) == 0) & (n < 1 << 24)
    assert np.array_equal(x[fixed & (b == 0)], s[fixed & (b == 0)] / n[fixed & (b == 0)])
    top = fixed & (b == 0xFFFFFFFF)
    assert np.array_equal(x[top], (s[top] + 1) / n[top] - 2.0 ** -24)


# A deliberately broken stratified set: the stratum is index % (spp - 1), so one stratum is used twice
# and another never. The same check must reject it.
@wp.func
def _broken_stratum(index: wp.uint32, spp: wp.uint32) -> wp.uint32:
    m = wp.max(spp - wp.uint32(1), wp.uint32(1))
    return index % m


@wp.func
def broken_1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
    n = wp.max(spp, wp.uint32(1))
    jitter = unit_float(hash_key(seed, pixel, index, dim))
    return place(_broken_stratum(index % n, n), jitter, n)


@wp.func
def broken_2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
    n = wp.max(spp, wp.uint32(1))
    nx = grid_columns(n)
    ny = n / nx
    s = _broken_stratum(index % n, n)
    h = hash_key(seed, pixel, index, dim)
    return wp.vec2(place(s % nx, unit_float(h), nx), place(s / nx, unit_float(mix32(h)), ny))


BROKEN = PointSet("broken-stratified", "one stratum reused (negative control)", broken_1d, broken_2d)


@pytest.mark.parametrize("spp", [4, 16, 12, 17])
def test_negative_control_broken_stratification_is_rejected(spp):
    with pytest.raises(AssertionError, match="1D"):
        check_stratified(BROKEN, spp, 0, (0,), (0,))
    # ... and the 2D check on its own rejects it too.
    ok_1d = PointSet("broken-2d-only", "stratified 1D, broken 2D", POINTSETS["stratified"].get1d,
                     broken_2d)
    with pytest.raises(AssertionError, match="2D"):
        check_stratified(ok_1d, spp, 0, (0,), (0,))
    # The independent set is not stratified either (at these counts a collision is near-certain).
    if spp >= 12:
        with pytest.raises(AssertionError):
            check_stratified(POINTSETS["independent"], spp, 0, (0,), (0,))


# ---------------------------------------------------------------------------------------------------
# Hashing: permute is a bijection of [0, n)
# ---------------------------------------------------------------------------------------------------



@wp.kernel(enable_backward=False)
def _permute_kernel(i: wp.array(dtype=wp.uint32), n: wp.array(dtype=wp.uint32),
                    key: wp.array(dtype=wp.uint32), out: wp.array(dtype=wp.uint32)):
    t = wp.tid()
    out[t] = permute(i[t], n[t], key[t])


@wp.kernel(enable_backward=False)
def _hash_kernel(seed: wp.array(dtype=wp.uint32), pixel: wp.array(dtype=wp.uint32),
                 index: wp.array(dtype=wp.uint32), dim: wp.array(dtype=wp.uint32),
                 out: wp.array(dtype=wp.uint32)):
    t = wp.tid()
    out[t] = hash_key(seed[t], pixel[t], index[t], dim[t])


def warp_uint32(kernel, *columns) -> np.ndarray:
    n = len(columns[0])
    out = wp.zeros(n, dtype=wp.uint32, device="cpu")
    wp.launch(kernel, dim=n, device="cpu",
              inputs=[wp.array(np.asarray(c, dtype=np.uint32), dtype=wp.uint32, device="cpu")
                      for c in columns] + [out])
    return out.numpy().astype(np.int64)


PERMUTE_SIZES = [1, 2, 3, 5, 7, 8, 12, 17, 100, 255, 256, 257, 1000, 4097]
KEYS = [0, 1, 0xDEADBEEF, 0xFFFFFFFF]


@pytest.mark.parametrize("n", PERMUTE_SIZES)
def test_python_reference_permute_is_a_bijection(n):
    for key in KEYS + [py_hash_key(3, 4, 5, 6)]:
        image = [py_permute(i, n, key) for i in range(n)]
        assert sorted(image) == list(range(n)), (n, key)


def test_warp_permute_matches_reference_and_is_a_bijection():
    rows = [(i, n, key) for n in PERMUTE_SIZES for key in KEYS for i in range(n)]
    i, n, key = (np.array(c, dtype=np.int64) for c in zip(*rows))
    got = warp_uint32(_permute_kernel, i, n, key)
    expected = np.array([py_permute(int(a), int(b), int(c)) for a, b, c in rows])
    assert np.array_equal(got, expected)
    start = 0
    for size in PERMUTE_SIZES:
        for _ in KEYS:
            assert sorted(got[start:start + size].tolist()) == list(range(size))
            start += size


@pytest.mark.parametrize("n", [
    n for n in (2, 4, 8, 16, 64, 256, 3, 5, 12, 17, 100)])
def test_permute_is_uniform_over_keys(n):
    # For stratification to stay unbiased across dimensions, the stratum of sample i under a random
    # key must be uniform on [0, n) for every i (chi-square over hash-derived keys, as in use).
    keys = np.array([py_hash_key(11, pixel, 0, 3) for pixel in range(4000)], dtype=np.int64)
    i, key = np.meshgrid(np.arange(n), keys, indexing="ij")
    got = warp_uint32(_permute_kernel, i.ravel(), np.full(i.size, n), key.ravel()).reshape(n, -1)
    counts = np.stack([np.bincount(row, minlength=n) for row in got])      # counts[i, stratum]
    expected = len(keys) / n
    stat = np.sum((counts - expected) ** 2 / expected)
    from scipy.stats import chi2
    p_value = chi2.sf(stat, (n - 1) ** 2)
    assert p_value > 1e-6, f"n={n}: chi2 {stat:.0f} on {(n - 1) ** 2} dof; P(permute(i) = i) = " \
                           f"{np.mean(got == np.arange(n)[:, None]):.3f} (uniform: {1 / n:.3f})"


def test_warp_hash_key_matches_reference():
    rng = np.random.default_rng(0)
    cols = rng.integers(0, 1 << 32, size=(4, 500), dtype=np.int64)
    cols[:, :3] = [[0, 0, M32], [0, 1, M32], [0, 0, M32], [0, 0, M32]]
    got = warp_uint32(_hash_kernel, *cols)
    expected = np.array([py_hash_key(*map(int, c)) for c in cols.T])
    assert np.array_equal(got, expected)
    assert len(set(got.tolist())) == len(got)          # no collisions among 500 keys
