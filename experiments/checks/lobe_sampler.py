"""`drtlab check NAME` for a lobe sampler (kernels/lobe_samplers.py): the checks the built-in lobe
sampling gets in the test suite (tests/estimators/test_chi2.py), as one scorecard.

The sampler is composed into the chi-square harness's BSDF routine for its kind (every other kind
keeps the built-in sampling) at a typical lobe (Phong exponent 20, GGX alpha 0.3, ior 1.5) seen from
three directions (10, 60 and 85 degrees from the normal). Judged lines; the p-valued ones share the
level, Sidak-corrected over TESTS:

* `directions` (3 tests): the valid samples (a delta lobe's aside) against the density `pdf` claims,
  where the BSDF is non-zero (the harness of `experiments/stats/chi2`: pooled chi-square over a
  101 x 202 sphere grid);
* `directional albedo` (3 tests): the mean sample weight f |cos| / pdf against the built-in lobe
  sampler's at the same wo (both estimate the integral of f |cos|; Welch z, per channel, smallest p):
  a density that is not what `sample` does biases the weights even where its shape is right;
* `hard cases`: grazing wo (cos 1e-4), extreme lobe shapes and indices: directions, densities and
  weights finite and non-negative;
* `renderer unbiasedness` (a diffuse sampler only): the white furnace of the point-set check,
  rendered with `importance` composed with this sampler (`check-NAME`).

Reported: the sampling cost against the built-in lobe sampling (best of 3).
"""
from __future__ import annotations

import math
import time

import numpy as np

from drtlab.experiments.checks.scorecard import Line, Scorecard, per_test

N = 200_000
TESTS = 6                  # 3 direction tests, 3 albedo tests (+1 furnace for a diffuse sampler)
ANGLES = (10.0, 60.0, 85.0)
NORMAL = (0.0, 0.0, 1.0)
ALBEDO = (0.8, 0.6, 0.4)


def _shape(kind: str) -> float:
    from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME
    k = KIND_BY_NAME[kind]
    return 20.0 if k.phong else 0.3 if k.microfacet else 0.0


def _wo(theta_deg: float) -> tuple:
    t = math.radians(theta_deg)
    return (math.sin(t), 0.0, math.cos(t))


def _case(kind: str, theta: float, shape: float | None = None, ior: float = 1.5) -> tuple:
    return (kind, ALBEDO, _shape(kind) if shape is None else shape, ior, NORMAL, _wo(theta))


def _adapters(name: str):
    from drtlab.experiments.stats import chi2 as C
    return C.BSDFAdapter(True, lobes=(name,)), C.BSDFAdapter(True)


def _direction_lines(mine, kind: str, seed: int, per_line: float) -> tuple[Line, dict]:
    from drtlab.experiments.stats import chi2 as C
    ps, samples = [], {}
    for i, theta in enumerate(ANGLES):
        case = _case(kind, theta)
        s = mine.sample(case, N, seed + i)
        samples[theta] = s
        # A delta lobe's samples (a kind with `delta_lobe`) have no density: pdf is the rest's.
        r = C.run_chi2(C.SphericalDomain(NORMAL), lambda n, sd, s=s: (s.wi, s.valid & ~s.delta),
                       mine.pdf(case), name=f"{kind} at {theta:g} deg", sample_count=N, res=(101, 202),
                       seed=seed + i,
                       test_count=TESTS)
        ps.append(r.p_value)
    return Line("directions", min(ps) >= per_line,
                f"{N} samples at wo = {', '.join(f'{a:g}' for a in ANGLES)} deg against the claimed pdf: "
                f"chi-square p = " + ", ".join(f"{p:.3g}" for p in ps), min(ps)), samples


def _albedo_line(built_in, kind: str, samples: dict, seed: int, per_line: float) -> Line:
    from scipy import stats
    ps, words = [], []
    for i, theta in enumerate(ANGLES):
        s = samples[theta]
        ref = built_in.sample(_case(kind, theta), N, seed + 100 + i)
        w = np.where(s.valid[:, None], s.weight, 0.0).astype(np.float64)
        w_ref = np.where(ref.valid[:, None], ref.weight, 0.0).astype(np.float64)
        se = np.sqrt(w.var(axis=0) / N + w_ref.var(axis=0) / N)
        z = np.abs(w.mean(axis=0) - w_ref.mean(axis=0)) / np.maximum(se, 1e-300)
        # Sidak over the three channels within the test: its p is the smallest channel's, adjusted.
        p = float(1.0 - (1.0 - 2.0 * stats.norm.sf(z.max())) ** 3)
        ps.append(p)
        words.append(f"{w.mean(axis=0)[0]:.4f} vs {w_ref.mean(axis=0)[0]:.4f}")
    return Line("directional albedo", min(ps) >= per_line,
                "mean weight (red) against the built-in sampler's at the 3 angles: " + ", ".join(words)
                + "; p = " + ", ".join(f"{p:.3g}" for p in ps), min(ps))


def _hard_cases(mine, kind: str, seed: int) -> Line:
    from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME
    k = KIND_BY_NAME[kind]
    shapes = (1.0, 1e4) if k.phong else (1e-3, 1.0) if k.microfacet else (0.0,)
    iors = (1.01, 3.0) if k.ior else (1.5,)
    bad, n = [], 20_000
    for theta in (89.9943, 0.0):                      # cos theta = 1e-4, and the normal itself
        for shape in shapes:
            for ior in iors:
                s = mine.sample(_case(kind, theta, shape, ior), n, seed)
                v = s.valid
                ok = (np.all(np.isfinite(s.wi[v])) and np.all(np.isfinite(s.pdf[v])) and np.all(s.pdf[v] >= 0)
                      and np.all(np.isfinite(s.weight[v])) and np.all(s.weight[v] >= 0))
                if not ok:
                    bad.append(f"theta {theta:g}, shape {shape:g}, ior {ior:g}")
    return Line("hard cases", not bad,
                f"grazing (cos 1e-4) and normal wo, shapes {', '.join(f'{x:g}' for x in shapes)}, "
                f"ior {', '.join(f'{x:g}' for x in iors)}: "
                + ("directions, densities and weights finite and non-negative" if not bad else
                   "non-finite or negative values at " + "; ".join(bad)))


def _cost(mine, built_in, kind: str) -> Line:
    case = _case(kind, 60.0)

    def best(ad) -> float:
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            ad.sample(case, N, 0)
            times.append(time.perf_counter() - t0)
        return min(times)
    return Line("sampling cost", None, f"{best(mine) / best(built_in):.2f}x the built-in lobe sampling "
                                       f"({N} samples at 60 deg, best of 3)")


def check(name: str, seed: int = 0, level: float = 0.01) -> Scorecard:
    """The scorecard of registered lobe sampler `name` (module docstring)."""
    from drtlab.estimators.plugin_checks import add_strategy
    from drtlab.kernels.strategy_composition import compose_strategy
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
    t0 = time.perf_counter()
    kind = LOBE_SAMPLERS[name].kind
    tests = TESTS + (kind == "diffuse")
    per_line = per_test(level, tests)
    card = Scorecard(name, level, tests)
    mine, built_in = _adapters(name)
    line, samples = _direction_lines(mine, kind, seed, per_line)
    card.lines.append(line)
    card.lines.append(_albedo_line(built_in, kind, samples, seed, per_line))
    card.lines.append(_hard_cases(mine, kind, seed))
    if kind == "diffuse":
        from drtlab.experiments.checks.pointset import furnace_unbiased
        strategy = f"check-{name}"
        if strategy not in STRATEGIES:
            add_strategy(compose_strategy(strategy, f"importance with the {name} lobe sampler",
                                          like="importance", lobe_samplers=[name]))
        card.lines.append(furnace_unbiased(f"independent+{strategy}", seed, per_line))
    card.lines.append(_cost(mine, built_in, kind))
    card.seconds = time.perf_counter() - t0
    return card
