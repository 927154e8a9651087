"""`drtlab check NAME`: the battery a built-in point set gets, as one scorecard, for any registered
set (a plugin's included): one line per check with its verdict and the figure behind it.

Judged lines (pass / FAIL); the four that are tests, the battery, the renderer's unbiasedness and
the two convergence lines, share the level, Sidak-corrected over the four (the battery corrects
within its six tests):

* `purity`: the same (seed, pixel, index, dimension) gives the same value on every call
  (`points()` twice at four keys); `seeds`: another seed gives other values;
* `threads and tiles`: a render is bit-identical on 1 thread with 8-pixel tiles and on 2 threads
  with 16-pixel tiles (the furnace scene below, 4 spp);
* `range`: every value of the battery's samples lies in [0, 1) (a failure stops the battery);
* `battery`: uniformity, stratification, correlation and per-pixel unbiasedness on 19 path
  dimensions (`validate.run_battery`);
* `renderer unbiasedness`: the white furnace of `experiments/audit/renderer.py` (every pixel
  exactly Le (1 + rho)) rendered at `FURNACE_RUNS` seeds: the runs' mean image error is 0 (t test);
* `convergence`: on a smooth and a discontinuous integrand over the pixel dimensions (closed-form
  integrals), the RMSE over `CONVERGENCE_PIXELS` pixels falls at least as fast as independent
  points' N^-1/2: FAIL when the slope is surely shallower, the share of `BOOTSTRAP` resampled
  slopes (pixels resampled) at or below `MC_SLOPE` = -0.5 (the p-value of b <= -0.5) under the
  line's level; the 95% bootstrap interval and the built-ins' slopes are printed beside it.

Reported, not judged: the render time of the furnace against `independent`'s (best of 3), and the
battery's stratification figures.
"""
from __future__ import annotations

import math
import time
import numpy as np

from drtlab.errors import InputError
from drtlab.experiments.checks.scorecard import Line, Scorecard, per_test

FURNACE_RUNS, FURNACE_SPP, FURNACE_RES = 48, 4, (32, 24)
CONVERGENCE_N = (16, 64, 256)
CONVERGENCE_PIXELS = 128
BOOTSTRAP = 4000           # resamples: p-values resolved to 1/4000, well below a line's level
BESIDE = ("independent", "stratified", "sobol")
# Independent points' RMSE falls as N^-1/2 on any square-integrable integrand: a point set whose
# slope is surely shallower (its whole bootstrap interval above this) converges slower than plain
# Monte Carlo, or not at all (a bias floor). Before, any slope below 0 passed (-0.05 did).
MC_SLOPE = -0.5
TESTS = 4                  # the p-valued lines: battery, renderer unbiasedness, two convergences


def _per_line(level: float) -> float:
    return per_test(level, TESTS)


def _purity(name: str) -> list[Line]:
    from drtlab.estimators.points import points
    keys = ((0, 0), (1, 5), (12345, 77), (2 ** 31, 4095))
    same = all(np.array_equal(points(name, 32, 12, seed=s, pixel=p), points(name, 32, 12, seed=s, pixel=p))
               for s, p in keys)
    other = not np.array_equal(points(name, 32, 12, seed=0, pixel=0), points(name, 32, 12, seed=1, pixel=0))
    return [Line("purity", same, f"identical on repeated calls at {len(keys)} (seed, pixel) keys: "
                                 f"{'yes' if same else 'NO'}"),
            Line("seeds", other, "seed 1 gives other values than seed 0 (repetitions independent): "
                                 f"{'yes' if other else 'NO, the set ignores its seed'}")]


def furnace(sampler: str, seeds: list[int], threads=None, tile=None):
    from drtlab.experiments.audit.renderer import furnace_scene
    from drtlab.kernels.render import render_batch_with_stats
    from drtlab.kernels.scene_model.scene_file import scene_from_dict
    scene_dict, exact = furnace_scene(FURNACE_RES)
    b = render_batch_with_stats(scene_from_dict(scene_dict), seeds, spp=FURNACE_SPP, sampler=sampler,
                                threads=threads, tile=tile, progress=False)
    return np.asarray(b.images), exact, float(b.render_seconds)


def _threads_tiles(name: str) -> Line:
    a, _, _ = furnace(name, [11, 12], threads=1, tile=8)
    b, _, _ = furnace(name, [11, 12], threads=2, tile=16)
    same = np.array_equal(a, b)
    return Line("threads and tiles", same, "furnace at 4 spp, 1 thread / 8-pixel tiles against 2 threads / "
                                          f"16-pixel tiles: {'bit-identical' if same else 'DIFFERENT images'}")


def furnace_cost(sampler: str, reference: str, words: str) -> Line:
    """The reported render-cost line: the furnace's render time against `reference`'s, each the
    best of 3 (the machine is shared: a ratio from the same run, not seconds)."""
    ref = min(furnace(reference, [1, 2, 3, 4])[2] for _ in range(3))
    mine = min(furnace(sampler, [1, 2, 3, 4])[2] for _ in range(3))
    return Line("render cost", None, f"furnace render {mine / ref:.2f}x {words} (best of 3, "
                                     f"{FURNACE_RES[0]}x{FURNACE_RES[1]}, 4 seeds)")


def furnace_unbiased(sampler: str, seed: int, per_line: float) -> Line:
    """The renderer-unbiasedness line: `sampler`'s white furnace at FURNACE_RUNS seeds, t test of
    the runs' mean error against 0 at `per_line`."""
    from scipy import stats
    from drtlab.experiments.seeds import run_seed
    seeds = [run_seed(seed, "check-furnace", sampler, "path", list(FURNACE_RES), FURNACE_SPP, k)
             for k in range(FURNACE_RUNS)]
    images, exact, _ = furnace(sampler, seeds)
    err = images.mean(axis=(1, 2, 3)) - exact
    sd = float(err.std(ddof=1))
    if sd == 0:
        p = 1.0 if np.all(err == 0) else 0.0
    else:
        p = float(2 * stats.t.sf(abs(err.mean()) / (sd / math.sqrt(err.size)), err.size - 1))
    ok = p >= per_line
    return Line("renderer unbiasedness", ok, f"white furnace, {FURNACE_RUNS} runs x {FURNACE_SPP} spp: "
                                            f"mean error {err.mean():+.2e} (exact {exact:g}, sd of a run "
                                            f"{sd:.2e}), t test p = {p:.3g}", p)


def _slope(name: str, f, exact: float, seed: int, rng) -> tuple[float, float, float, float]:
    from drtlab.estimators.points import points
    errs = np.array([[f(points(name, n, 2, seed=seed, pixel=p)).mean() - exact
                      for p in range(CONVERGENCE_PIXELS)] for n in CONVERGENCE_N])
    x = np.log(CONVERGENCE_N)

    def fit(e):
        return float(np.polyfit(x, 0.5 * np.log(np.mean(e ** 2, axis=1) + 1e-300), 1)[0])
    boot = [fit(errs[:, rng.integers(0, CONVERGENCE_PIXELS, CONVERGENCE_PIXELS)]) for _ in range(BOOTSTRAP)]
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return fit(errs), float(lo), float(hi), float(np.mean(np.asarray(boot) <= MC_SLOPE))


INTEGRANDS = {
    "smooth": (lambda u: np.sin(np.pi * u[:, 0]) * np.sin(np.pi * u[:, 1]), (2 / np.pi) ** 2),
    "disk edge": (lambda u: ((u[:, 0] - 0.5) ** 2 + (u[:, 1] - 0.5) ** 2 < 0.16).astype(float),
                  np.pi * 0.16),
}


def convergence(name: str, seed: int, per_line: float) -> list[Line]:
    """One line per integrand: pass unless the slope is surely shallower than MC_SLOPE (bootstrap
    p of "b <= MC_SLOPE", the share of resampled slopes at or below it, under `per_line`)."""
    rng = np.random.default_rng(seed)
    out = []
    for label, (f, exact) in INTEGRANDS.items():
        b, lo, hi, p = _slope(name, f, exact, seed, rng)
        beside = ", ".join(f"{o} {_slope(o, f, exact, seed, rng)[0]:+.2f}" for o in BESIDE if o != name)
        out.append(Line(f"convergence: {label}", bool(p >= per_line),
                        f"RMSE ~ N^b over N = {', '.join(map(str, CONVERGENCE_N))} ({CONVERGENCE_PIXELS} "
                        f"pixels): b = {b:+.2f} [{lo:+.2f}, {hi:+.2f}], at most {MC_SLOPE:+.1f} "
                        f"(independent points') p = {p:.3g}; {beside}", p))
    return out


def check(name: str, seed: int = 0, level: float = 0.01, pixels: int | None = None) -> Scorecard:
    """The scorecard of registered point set `name` (module docstring)."""
    from drtlab.experiments.pointsets import validate as V
    t0 = time.perf_counter()
    V.check_pointset(name)
    card = Scorecard(name, level, TESTS)
    card.lines += _purity(name)
    card.lines.append(_threads_tiles(name))
    try:
        battery = V.validate(name, seed=seed, level=_per_line(level), pixels=pixels or V.PIXELS)
    except InputError as e:
        if "outside [0, 1)" not in e.message:
            raise
        card.lines.append(Line("range", False, e.message))
    else:
        card.lines.append(Line("range", True, f"{battery.pixels} pixels x {battery.spp} samples x "
                                              f"{len(battery.dims)} dimensions in [0, 1)"))
        worst = min(battery.tests, key=lambda t: t.p)
        card.lines.append(Line("battery", battery.passed,
                               f"{len(battery.tests)} tests at {battery.level:.3g}: "
                               + ("all pass" if battery.passed else "FAIL " + ", ".join(battery.failed))
                               + f"; smallest p {worst.p:.3g} ({worst.name}, Sidak over its {worst.subtests} "
                                 f"sub-tests; the worst of them: {worst.worst})", worst.p))
        strat = next((t.info for t in battery.tests if t.name == "stratification"), {})
        if strat:
            card.lines.append(Line("stratification claims", None,
                                   ", ".join(f"{k} {v:.3g}" for k, v in strat.items())))
    card.lines.append(furnace_unbiased(name, seed, _per_line(level)))
    card.lines += convergence(name, seed, _per_line(level))
    card.lines.append(furnace_cost(name, "independent", "independent's"))
    card.seconds = time.perf_counter() - t0
    return card
