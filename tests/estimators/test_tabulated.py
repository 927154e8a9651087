"""Point sets from tables (estimators/pointsets/tabulated.py): each randomization keeps what its
docstring says it keeps (nets under Owen scrambling and the digital shift, a lattice's spacing under
the Cranley-Patterson shift), padding keeps each dimension's strata, and the statistical battery
(experiments/pointsets/validate.py, level 0.01 Sidak-corrected over its six tests) passes an Owen-
scrambled Sobol' table (5 dimensions read jointly) and rejects the unrandomized table (the negative
control: the same points in every pixel) and the joint use of two correlated Sobol' dimensions."""
import numpy as np
import pytest
from scipy.stats import qmc

from drtlab.errors import InputError
from drtlab.estimators.points import points
from drtlab.estimators.pointsets.tabulated import MAX_VALUES, read_table, tabulated

SOBOL = qmc.Sobol(4, scramble=False).random(256)
FIB_N, FIB_K = 89, 55                     # Fibonacci lattice: x_i = (i / 89, frac(55 i / 89))
LATTICE = np.stack([np.arange(FIB_N) / FIB_N, np.mod(FIB_K * np.arange(FIB_N), FIB_N) / FIB_N], axis=1)


def _is_net(xy: np.ndarray, m: int) -> bool:
    """Every elementary interval 2^-a x 2^-(m-a) holds exactly one of the 2^m points."""
    for a in range(m + 1):
        cells = np.floor(xy[:, 0] * 2 ** a) * 2 ** (m - a) + np.floor(xy[:, 1] * 2 ** (m - a))
        if np.unique(cells).size != 2 ** m:
            return False
    return True


@pytest.mark.parametrize("randomize", ["owen", "xor"])
def test_digital_randomizations_keep_the_nets_in_every_pixel(randomize):
    ps = tabulated(f"t-{randomize}", SOBOL, randomize=randomize)
    for seed, pixel in ((0, 0), (1, 17), (5, 4000)):
        u = points(ps, 64, 8, seed=seed, pixel=pixel)
        assert _is_net(u[:, 0:2], 6)                              # joint columns 0, 1
        assert _is_net(u[:, 6:8], 6)                              # padded pair: columns 0, 1 permuted
        assert np.unique(np.floor(u[:, 5] * 64)).size == 64       # a padded 1D dimension: 64 strata
    assert not np.array_equal(points(ps, 64, 2, seed=0, pixel=0), points(ps, 64, 2, seed=0, pixel=1))


def test_the_shift_keeps_a_lattice_and_breaks_nothing_else():
    ps = tabulated("t-shift", LATTICE, randomize="shift")
    a, b = points(ps, FIB_N, 2, seed=0, pixel=3), points(ps, FIB_N, 2, seed=9, pixel=11)
    # a shifted lattice is the lattice: seen from any of its points, the others are lattice points
    def seen_from_first(x):
        d = np.mod(np.round((x - x[0]) * FIB_N), FIB_N)
        return d[np.lexsort(d.T[::-1])]
    lattice = np.round(LATTICE * FIB_N)
    for x in (a, b):
        np.testing.assert_array_equal(seen_from_first(x), lattice[np.lexsort(lattice.T[::-1])])
    assert np.abs(a - b).max() > 0.05
    # the lattice's minimum toroidal distance survives the shift
    def min_dist(x):
        d = np.abs(x[:, None] - x[None])
        d = np.minimum(d, 1 - d)
        r = np.sqrt((d ** 2).sum(-1)) + np.eye(len(x))
        return r.min()
    assert min_dist(a) == pytest.approx(min_dist(LATTICE), abs=1e-6)


def test_past_the_table_blocks_are_randomized_anew():
    ps = tabulated("t-small", SOBOL[:16], randomize="owen")
    u = points(ps, 48, 2, seed=2, pixel=0)          # spp 48 > 16 rows: three blocks of 16
    assert (u >= 0).all() and (u < 1).all()
    assert not np.allclose(u[:16], u[16:32])
    for block in (u[:16], u[16:32], u[32:]):
        assert _is_net(block, 4)


def test_battery_passes_the_scrambled_table_and_rejects_the_raw_one():
    from drtlab.experiments.pointsets.validate import run_battery
    good = tabulated("t-battery", qmc.Sobol(5, scramble=False), n=1024, randomize="owen")
    # Sobol' dimensions 1 and 7 of the first 64 points are correlated: read jointly (pixel.y and
    # light_pos0.y) the battery finds the table's own defect, (spp - 1) E[r^2] = 4.4 against 1.
    deep = tabulated("t-deep", qmc.Sobol(8, scramble=False), n=1024, randomize="owen")
    raw = tabulated("t-raw", qmc.Sobol(8, scramble=False), n=1024, randomize="none")
    assert raw.biased and not good.biased
    same = points(raw, 64, 4, seed=0, pixel=0)
    assert np.array_equal(same, points(raw, 64, 4, seed=3, pixel=999))

    def gen(ps):
        return lambda n, dims, seed, pixel: points(ps, n, dims, seed=seed, pixel=pixel)
    ok = run_battery(gen(good), "t-battery", seed=0, pixels=512)
    bad = run_battery(gen(raw), "t-raw", seed=0, pixels=512)
    assert ok.passed, "\n".join(ok.lines())
    assert not bad.passed
    failed = [t.name for t in run_battery(gen(deep), "t-deep", seed=0, pixels=512).tests if not t.passed]
    assert failed == ["per_pixel_correlation"]


def test_tables_are_read_from_files_and_engines(tmp_path):
    np.save(tmp_path / "t.npy", SOBOL)
    np.testing.assert_array_equal(read_table(tmp_path / "t.npy"), SOBOL)
    (tmp_path / "t.txt").write_text("# UTK points\n0.25 0.5\n0.75 0.125\n")
    np.testing.assert_array_equal(read_table(tmp_path / "t.txt"), [[0.25, 0.5], [0.75, 0.125]])
    assert read_table(qmc.Halton(3, scramble=False), n=8).shape == (8, 3)


@pytest.mark.parametrize("source, kw, words", [
    (np.array([[0.5, 1.0]]), {}, "must lie in [0, 1)"),
    (np.array([0.1, 0.2]), {}, "D >= 2 dimensions"),
    (np.zeros((MAX_VALUES, 2)), {}, "at most"),
    (qmc.Sobol(2, scramble=False), {}, "needs the number of points"),
    ("absent.npy", {}, "no file"),
    (SOBOL, {"randomize": "rotate"}, "must be one of owen, xor, shift, none"),
])
def test_bad_tables_are_one_line(source, kw, words):
    with pytest.raises(InputError) as e:
        tabulated("t-bad", source, **kw)
    assert words in e.value.message
