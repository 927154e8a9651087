"""`drtlab check NAME` for an integrator (estimators/integrators.py: a built-in's or a plugin's): the
checks its built-in peers get in the test suite, as one scorecard. Every render goes through
`render_runs(scene, integrator, seeds, spp, faults)`, so a test can score a built-in integrator with
a deliberately wrong estimator compiled in (features.FAULTS) as if it were a broken plugin.

Scenes (experiments/checks/integrator_scenes.py): one per effect the integrator claims (`handles`;
every effect of estimators/integrators.EFFECTS has one), the white furnace (every
pixel exactly Le (1 + rho)) and the hard cases. Sampler `SAMPLER` (independent points, so the runs'
pixels are independent), RUNS renders of RES pixels at SPP per scene, fixed seeds from `seed`.

Lines; the p-valued ones share the level, Sidak-corrected over them (TESTS: the furnace and one per
claimed effect), and are judged only when the integrator claims to be unbiased (`unbiased`, else
`not biased`); a biased one gets them reported:

* `unbiased: EFFECT` (one per claimed effect): the runs' region means against `path`'s on the same
  scene (the region test of experiments/stats/region_tests.py: Welch t per 4 x 4-pixel region, the
  equal-p normal deviates' squares summed to a chi-square over the 12 regions);
* `white furnace`: the region means against the exact value (the same test, exact reference);
* `threads and tiles` (judged): the direct scene at 32 x 24, 1 thread with 8-pixel tiles against 2
  threads with 16-pixel tiles, bit-identical;
* `hard cases` (judged): finite and non-negative pixels at a grazing view, a 1e-3 light 2e-3 above
  the floor, a 200 x 200 light, a Phong exponent of 1e4, a mirror and glass of ior 1.01, to depth 6;
* `convergence` (judged for an unbiased integrator): the furnace's RMSE at CONVERGENCE_N samples per
  pixel falls at least as N^-0.4 (the fitted slope's bootstrap 97.5% end below SLOPE_MAX; independent
  samples give -0.5 to any unbiased integrator, a bias flattens it), `path`'s slope beside it.

Reported: the furnace's render time against `path`'s (best of 3) and the efficiency, 1 / (MSE x
time), against `path`'s at the largest N.
"""
from __future__ import annotations

import math
import time

import numpy as np

from drtlab.experiments.checks import integrator_scenes as S
from drtlab.experiments.checks.scorecard import Line, Scorecard, per_test

SAMPLER = "independent+importance"
REFERENCE = "path"
RUNS, SPP, BLOCK = 24, 16, 4
CONVERGENCE_N = (4, 16, 64)
CONVERGENCE_RUNS = 8
BOOTSTRAP = 400
# Independent samples: an unbiased integrator's RMSE falls as N^-0.5; a bias flattens the slope
# towards 0 as N grows. Judged: the slope's bootstrap 97.5% end below SLOPE_MAX.
SLOPE_MAX = -0.4
# What an entry that names no effect (`handles` empty) is checked on.
DEFAULT_CLAIMS = ("direct",)


def claims(name: str) -> tuple[str, ...]:
    """The effects integrator `name` claims to handle: its registration's `handles` (each one of
    estimators/integrators.EFFECTS, every one with a scene), else DEFAULT_CLAIMS."""
    from drtlab.estimators.integrators import INTEGRATORS
    handles = getattr(INTEGRATORS[name], "handles", None)
    return tuple(handles) if handles else DEFAULT_CLAIMS


def claims_unbiased(name: str) -> bool:
    from drtlab.estimators.integrators import INTEGRATORS
    integ = INTEGRATORS[name]
    return bool(getattr(integ, "unbiased", not integ.biased))


def render_runs(scene: dict, integrator: str, seeds, spp: int, faults=(), threads=None, tile=None):
    """(images (R, H, W, 3), render seconds) of `scene` (a dict) with `integrator`, one run per seed;
    `faults` compiles a deliberately wrong estimator in (the tests' negative controls)."""
    from drtlab.kernels.render import render_batch_with_stats
    from drtlab.kernels.scene_model.scene_file import scene_from_dict
    b = render_batch_with_stats(scene_from_dict(scene), list(seeds), spp=spp, sampler=SAMPLER,
                                integrator=integrator, threads=threads, tile=tile, progress=False,
                                faults=tuple(faults))
    return np.asarray(b.images), float(b.render_seconds)


def _seeds(seed: int, *key, runs: int = RUNS) -> list[int]:
    from drtlab.experiments.seeds import run_seed
    return [run_seed(seed, "check-integrator", SAMPLER, "/".join(map(str, key)), list(S.RES), SPP, k)
            for k in range(runs)]


def _estimate(images):
    from drtlab.experiments.stats.region_tests import Estimate
    return Estimate.from_images(np.where(np.isfinite(images), images, 0.0).sum(axis=3), BLOCK)


def _unbiased_lines(name: str, faults, seed: int, per_line: float, judged: bool) -> list[Line]:
    from drtlab.experiments.stats.region_tests import Estimate, compare, region_values
    out = []
    for effect in claims(name):
        if effect not in S.EFFECTS:
            out.append(Line(f"unbiased: {effect}", None, f"no check scene for {effect!r} (the checked "
                                                         f"effects: {', '.join(S.EFFECTS)})"))
            continue
        scene = S.effect_scene(effect)
        mine, _ = render_runs(scene, name, _seeds(seed, name, effect), SPP, faults)
        ref, _ = render_runs(scene, REFERENCE, _seeds(seed, REFERENCE, effect, "reference"), SPP)
        c = compare(_estimate(mine), _estimate(ref), per_line)
        worst = int(np.argmax(np.abs(c.z)))
        out.append(Line(f"unbiased: {effect}", (not c.rejected) if judged else None,
                        f"{RUNS} runs x {SPP} spp against {REFERENCE}'s, {c.regions} regions: chi2 {c.chi2:.1f}, "
                        f"p = {c.p:.3g}; largest |z| {abs(c.z[worst]):.1f} (region {worst})", c.p))
    scene, exact = S.furnace()
    images, _ = render_runs(scene, name, _seeds(seed, name, "furnace"), SPP, faults)
    est = _estimate(images)
    c = compare(est, Estimate.exact(region_values(np.full(images.shape[1:], exact), BLOCK)), per_line)
    out.append(Line("white furnace", (not c.rejected) if judged else None,
                    f"{RUNS} runs x {SPP} spp against the exact {exact:g}: mean {est.mean.mean() / 3:.4f}, "
                    f"chi2 {c.chi2:.1f} over {c.regions} regions, p = {c.p:.3g}", c.p))
    return out


def _threads_tiles(name: str, faults) -> Line:
    scene = S.effect_scene("direct", res=(32, 24))
    a, _ = render_runs(scene, name, [11, 12], 4, faults, threads=1, tile=8)
    b, _ = render_runs(scene, name, [11, 12], 4, faults, threads=2, tile=16)
    same = np.array_equal(a, b)
    return Line("threads and tiles", same, "direct scene at 4 spp, 1 thread / 8-pixel tiles against 2 "
                                          f"threads / 16-pixel tiles: {'bit-identical' if same else 'DIFFERENT images'}")


def _hard_cases(name: str, faults, seed: int) -> Line:
    images, _ = render_runs(S.hard_cases(), name, _seeds(seed, name, "hard", runs=4), SPP, faults)
    nonfinite = int(np.sum(~np.isfinite(images)))
    negative = int(np.sum(images[np.isfinite(images)] < 0))
    ok = nonfinite == 0 and negative == 0
    return Line("hard cases", ok, "grazing view, a 1e-3 light 2e-3 above the floor, a 200 x 200 light, Phong "
                                  "1e4, a mirror, glass of ior 1.01, depth 6: "
                + ("every pixel finite and non-negative" if ok else
                   f"{nonfinite} non-finite and {negative} negative values"))


def _furnace_errors(name: str, faults, seed: int) -> tuple[list[np.ndarray], float]:
    """Per N of CONVERGENCE_N: the furnace's squared errors (runs x pixels, channels averaged), and
    the render seconds at the largest N."""
    scene, exact = S.furnace()
    out, seconds = [], 0.0
    for n in CONVERGENCE_N:
        images, seconds = render_runs(scene, name, _seeds(seed, name, "convergence", n,
                                                          runs=CONVERGENCE_RUNS), n, faults)
        out.append(((images.mean(axis=3) - exact) ** 2).reshape(CONVERGENCE_RUNS, -1))
    return out, seconds


def _slope(sq: list[np.ndarray], rng) -> tuple[float, float, float]:
    x = np.log(CONVERGENCE_N)

    def fit(cols):
        return float(np.polyfit(x, [0.5 * math.log(e[:, cols].mean() + 1e-300) for e in sq], 1)[0])
    pixels = sq[0].shape[1]
    boot = [fit(rng.integers(0, pixels, pixels)) for _ in range(BOOTSTRAP)]
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return fit(np.arange(pixels)), float(lo), float(hi)


def _convergence_and_cost(name: str, faults, seed: int, judged: bool) -> list[Line]:
    rng = np.random.default_rng(seed)
    mine, _ = _furnace_errors(name, faults, seed)
    ref, _ = _furnace_errors(REFERENCE, (), seed + 1)
    b, lo, hi = _slope(mine, rng)
    b_ref = _slope(ref, rng)[0]
    scene, _ = S.furnace()
    n = CONVERGENCE_N[-1]
    t_mine = min(render_runs(scene, name, [1, 2, 3, 4], n, faults)[1] for _ in range(3))
    t_ref = min(render_runs(scene, REFERENCE, [1, 2, 3, 4], n)[1] for _ in range(3))
    efficiency = (ref[-1].mean() * t_ref) / max(mine[-1].mean() * t_mine, 1e-300)
    exact = all(float(e.max()) <= 1e-12 for e in mine)       # no error to fit a slope to
    return [Line("convergence", bool(exact or hi < SLOPE_MAX) if judged else None,
                 f"furnace RMSE ~ N^b over N = {', '.join(map(str, CONVERGENCE_N))} ({CONVERGENCE_RUNS} runs): "
                 + ("exact at every N" if exact else f"b = {b:+.2f} [{lo:+.2f}, {hi:+.2f}]") + f"; {REFERENCE} {b_ref:+.2f}"),
            Line("cost", None, f"furnace render {t_mine / t_ref:.2f}x {REFERENCE}'s (best of 3, {n} spp, 4 runs); "
                               f"efficiency 1 / (MSE x time) {efficiency:.2f}x {REFERENCE}'s")]


def check(name: str, seed: int = 0, level: float = 0.01, faults=()) -> Scorecard:
    """The scorecard of registered integrator `name` (module docstring); `faults` (tests only)
    compiles a deliberately wrong estimator into every render of `name`."""
    t0 = time.perf_counter()
    judged = claims_unbiased(name)
    tests = len([e for e in claims(name) if e in S.EFFECTS]) + 1 if judged else 0
    per_line = per_test(level, max(tests, 1))
    label = name + (f" ({'+'.join(faults)})" if faults else "")
    card = Scorecard(label, level, tests)
    card.lines += _unbiased_lines(name, faults, seed, per_line, judged)
    card.lines.append(_threads_tiles(name, faults))
    card.lines.append(_hard_cases(name, faults, seed))
    card.lines += _convergence_and_cost(name, faults, seed, judged)
    card.seconds = time.perf_counter() - t0
    return card
