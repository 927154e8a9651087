"""A statistical battery for any point set: uniformity, stratification, independence of dimensions
and unbiasedness, one verdict and one p-value per test, so a newly registered point set gets a
verdict without anyone writing a test for it.

    from drtlab.experiments.pointsets.validate import validate, run_battery
    result = validate("sobol", seed=0, level=0.01)         # through estimators.points.points
    print("\\n".join(result.lines())); result.passed
    run_battery(my_generator, "mine")      # my_generator(n, dims, seed, pixel) -> (n, dims) array

The samples: `pixels` pixel keys (0, 1, ...) of `SPP` samples each, in the dimensions a two-bounce
path reads (19 coordinates: pixel, lens, time, and per bounce light choice, light position, lobe
choice, direction, roulette), exactly as `points(name, SPP, dims, seed, pixel)` returns them.
Pooled tests use one sample per pixel (index p mod SPP), so their samples are independent.

Each test folds its sub-tests (per coordinate, per pair, per projection) into one Sidak-adjusted
p-value (experiments/stats/hypothesis_tests.py), and the battery's level is Sidak-corrected over its
tests: a test fails when its p-value is below 1 - (1 - level)^(1 / tests). So an unbiased point
set with independent dimensions fails the battery with probability at most about `level`.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from functools import partial
from typing import Callable

import numpy as np

from drtlab.errors import InputError

# The statistics (scipy) and the point sets (Warp) load when a battery runs, not on import: the CLI
# reads this module's defaults while it builds its parser, for every command.

SPP = 64                     # a square and a power of 2: 8 x 8 strata and (0,6,2)-nets apply
BOUNCES = 2
PIXELS = 4096                # (spp - 1) E[r^2] = 1.29 (zsobol) is then ~5 standard errors out
CD_PIXELS = 256              # per-pixel discrepancies are the slow part; 256 resolve 10% of i.i.d.
MIN_PIXELS, MAX_PIXELS = CD_PIXELS, 1 << 16
DEFAULT_LEVEL = 0.01
UNIFORMITY_PROJECTIONS = ("pixel", "direction0")   # as tests/estimators/test_pointset_uniformity.py

Generator = Callable[[int, int, int, int], np.ndarray]   # (n, dims, seed, pixel) -> (n, dims)

# Test name -> what it checks. The names are tests/estimators/test_pointset_uniformity.py's where the test is
# the same, so its KNOWN_DEFECTS apply to the battery too.
TESTS = {
    "discrepancy": "uniformity: each pixel's 2D points no less uniform (centred L2 discrepancy) "
                   "than i.i.d. points",
    "joint_uniformity": "every coordinate and every pair uniform (chi-square, pooled samples)",
    "stratification": "no stratum fuller than for i.i.d. points (1D strata, 2D slot grids)",
    "pooled_correlation": "no correlation between dimensions (pooled samples)",
    "per_pixel_correlation": "no correlation between dimensions within a pixel",
    "unbiasedness": "each pixel's estimate of known integrals is unbiased (1D, products, "
                    "quadrants, diagonal edges)",
}


@dataclass
class TestResult:
    name: str
    p: float                 # Sidak-adjusted over the test's sub-tests
    level: float             # the battery's level, Sidak-corrected over its tests
    subtests: int
    worst: str               # the sub-test with the smallest p-value
    info: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return self.p >= self.level


@dataclass
class BatteryResult:
    label: str
    seed: int
    level: float
    pixels: int
    spp: int
    dims: list[int]
    tests: list[TestResult]
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return all(t.passed for t in self.tests)

    @property
    def failed(self) -> list[str]:
        return [t.name for t in self.tests if not t.passed]

    def lines(self) -> list[str]:
        per_test = self.tests[0].level if self.tests else self.level
        out = [f"{self.label}: seed {self.seed}, {self.pixels} pixels x {self.spp} samples, "
               f"{len(self.dims)} dimensions; level {self.level:g} ({per_test:.3g} per test, "
               f"Sidak over {len(self.tests)})",
               f"  {'test':22s} {'p-value':>9s}  verdict  smallest sub-test p (of n)"]
        for t in self.tests:
            out.append(f"  {t.name:22s} {t.p:9.3g}  {'pass' if t.passed else 'FAIL':7s}  "
                       f"{t.worst} ({t.subtests})")
        for t in self.tests:
            if t.info:
                out.append(f"  {t.name}: "
                           + ", ".join(f"{k} {_show(v)}" for k, v in t.info.items()))
        out.append(f"{self.label}: " + ("all tests pass" if self.passed else
                                       f"{len(self.failed)} of {len(self.tests)} tests FAIL: "
                                       + ", ".join(self.failed)))
        return out

    def to_json(self) -> dict:
        return {"label": self.label, "seed": self.seed, "level": self.level, "pixels": self.pixels,
                "spp": self.spp, "dims": self.dims, "passed": self.passed,
                "tests": [dict(name=t.name, what=TESTS[t.name], p=t.p, level=t.level,
                               passed=t.passed, subtests=t.subtests, worst=t.worst, info=t.info)
                          for t in self.tests]}


def _show(v) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k}: {_show(x)}" for k, x in v.items()) + "}"
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def sample(generator: Generator, label: str, seed: int, pixels: int,
           dims: list[int]) -> np.ndarray:
    """(pixels, SPP, len(dims)) float64: pixel keys 0 ... pixels - 1, columns `dims`."""
    top = max(dims) + 1
    u = np.empty((pixels, SPP, len(dims)))
    for p in range(pixels):
        values = np.asarray(generator(SPP, top, seed, p), dtype=np.float64)
        if values.shape != (SPP, top):
            raise ValueError(f"generator returned shape {values.shape}, wanted {(SPP, top)}")
        if not np.all((values >= 0.0) & (values < 1.0)):
            # Outside the contract of every point set (estimators/pointsets/base.py): no verdict.
            raise InputError("NAME", f"{label} returned values outside [0, 1) at pixel {p} "
                                     f"(min {values.min():.9g}, max {values.max():.9g})")
        u[p] = values[:, dims]
    return u


def _fold(name: str, subtests, level: float, info=None) -> TestResult:
    from drtlab.experiments.stats.hypothesis_tests import sidak_adjusted
    worst = min(subtests, key=lambda s: s[1])
    return TestResult(name, sidak_adjusted(p for _, p in subtests), level, len(subtests),
                      f"{worst[0]}: p = {worst[1]:.2g}", info or {})


def run_battery(generator: Generator, label: str, seed: int = 0, level: float = DEFAULT_LEVEL,
                pixels: int = PIXELS) -> BatteryResult:
    """Every test of TESTS on `generator`'s samples (module docstring)."""
    from drtlab.experiments.pointsets import stats as S
    from drtlab.experiments.stats.hypothesis_tests import sidak
    t0 = time.perf_counter()
    dims = S.tracer_dims(BOUNCES)
    labels = [S.dimension_label(d) for d in dims]
    u = sample(generator, label, seed, pixels, dims)
    pooled = u[np.arange(pixels), np.arange(pixels) % SPP]
    slots2d = S.slot_pairs(dims)
    projections = [(a, b) for a, b in slots2d if labels[a].split(".")[0] in UNIFORMITY_PROJECTIONS]
    per_test = sidak(level, len(TESTS))
    with warnings.catch_warnings():
        # A set whose values repeat across pixels (Cook's fixed table) has identical per-pixel
        # discrepancies; scipy's t-test then warns of precision loss, while its p-value (0) is
        # the verdict the battery reports.
        warnings.filterwarnings("ignore", "Precision loss occurred", RuntimeWarning)
        cd, ratios = S.discrepancy_vs_iid(u[:CD_PIXELS], projections, labels,
                                          np.random.default_rng(seed))
    strata, strata_info = S.stratification(u, labels, slots2d)
    tests = [_fold("discrepancy", cd, per_test, {"CD / i.i.d. CD": ratios}),
             _fold("joint_uniformity", S.joint_uniformity(pooled, labels), per_test),
             _fold("stratification", strata, per_test, strata_info),
             _fold("pooled_correlation", S.pooled_correlation(pooled, labels), per_test),
             _fold("per_pixel_correlation", S.per_pixel_correlation(u, labels), per_test),
             _fold("unbiasedness", S.unbiasedness(u, labels), per_test)]
    assert [t.name for t in tests] == list(TESTS)
    return BatteryResult(label, seed, level, pixels, SPP, dims, tests, time.perf_counter() - t0)


def check_pointset(name: str, field: str = "NAME"):
    """The registered point set `name`, or an InputError listing the registered ones."""
    from drtlab.estimators.registry import POINTSETS
    if name not in POINTSETS:
        raise InputError(field, f"unknown point set {name!r}; allowed: {', '.join(POINTSETS)}")
    return POINTSETS[name]


def spp_problem(pointset, n: int) -> str | None:
    """None if the point set supports n samples per pixel, else what it supports. A point set
    declares a restriction with an attribute `spp_rule = (text, predicate)` (e.g. ("a power of 4",
    lambda n: ...)); every registered set takes any count (their docstrings say where it
    stratifies), so only such a declaration, or a custom PointSet subclass, restricts n."""
    rule = getattr(pointset, "spp_rule", None)
    if rule is None:
        return None
    text, allows = rule
    return None if allows(n) else text


def validate(name: str, seed: int = 0, level: float = DEFAULT_LEVEL,
             pixels: int = PIXELS) -> BatteryResult:
    """The battery on registered point set `name`, through `points()` (the kernels' own values)."""
    from drtlab.estimators.points import points
    if not MIN_PIXELS <= pixels <= MAX_PIXELS:
        raise InputError("--pixels", f"must be in [{MIN_PIXELS}, {MAX_PIXELS}], got {pixels}")
    problem = spp_problem(check_pointset(name), SPP)
    if problem is not None:
        raise InputError("NAME", f"{name} needs spp {problem}; the battery uses spp = {SPP}")
    return run_battery(partial(points, name), name, seed=seed, level=level, pixels=pixels)
