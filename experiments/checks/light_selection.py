"""`drtlab check NAME` for a light selection (kernels/light_selection.py; a plugin's or a built-in's):
the checks its built-in peers get in the test suite, as one scorecard.

The check scene has four lights of very different sizes and powers (a unit sphere, a 2 x 2 quad, a
sphere of radius 1e-3 and a 200 x 200 quad 60 units away) and three shading points: the origin, a
point 0.4 from the sphere's surface, and a point in the plane of the small quad (grazing it).
Judged lines; the p-valued ones share the level, Sidak-corrected over TESTS:

* `pmf`: at each point the probabilities it claims for the four lights sum to 1 (within 1e-5) and
  each is above 0 (every light can contribute there);
* `pick frequencies` (3 tests): how often each light is picked, N picks per point, against the pmf
  the selection claims (chi-square, cells expecting few picks pooled as the harness pools them);
* `directions`: the light-sample directions from the origin against the density MIS evaluates
  (the chi-square harness of `experiments/stats/chi2`, light choice included; the 1e-3 sphere's
  samples, whose cone no histogram bin resolves, counted as lost);
* `MIS density`: the density returned with each sample equals the one `light_pdf` evaluates for
  that direction (relative error 1e-4): the pmf is what pick does;
* `hard cases`: picks, pmfs, densities and directions finite and non-negative at every point;
* `renderer unbiasedness`: the white furnace (six emitting walls, every pixel exactly Le (1 + rho))
  rendered with `importance` sampling composed with this selection (`check-NAME`).

Reported: the furnace render time against the built-in `power` pick's (best of 3).
"""

import time

import numpy as np

from drtlab.experiments.checks.pointset import furnace_cost, furnace_unbiased
from drtlab.experiments.checks.scorecard import Line, Scorecard, per_test

N = 200_000
TESTS = 5                  # 3 pick-frequency tests, the directions, the furnace
POINTS = {"origin": (0.0, 0.0, 0.0), "near the sphere": (1.5, 0.5, 1.6), "grazing the quad": (2.0, 0.0, 2.0)}
SCENE = {
    "scene": {"description": "the light-selection check", "resolution": [4, 4], "integrator": "path"},
    "camera": {"position": [0, 0, -5], "look_at": [0, 0, 0]},
    "materials": {"warm": {"kind": "emitter", "emission": [4.0, 3.0, 2.0]},
                  "cool": {"kind": "emitter", "emission": [1.0, 1.0, 2.0]},
                  "spark": {"kind": "emitter", "emission": [50.0, 50.0, 50.0]},
                  "sky": {"kind": "emitter", "emission": [0.2, 0.2, 0.3]}},
    "shapes": [{"kind": "sphere", "material": "warm", "center": [1.5, 0.5, 3.0], "radius": 1.0},
               {"kind": "quad", "material": "cool", "origin": [-3.0, -1.0, 2.0], "edge_u": [0.0, 2.0, 0.0],
                "edge_v": [2.0, 0.0, 0.0]},
               {"kind": "sphere", "material": "spark", "center": [-1.0, 1.5, 1.0], "radius": 1.0e-3},
               {"kind": "quad", "material": "sky", "origin": [-100.0, 60.0, -100.0],
                "edge_u": [200.0, 0.0, 0.0], "edge_v": [0.0, 0.0, 200.0]}]}
LIGHTS = 4
SPARK = 2                  # the 1e-3 sphere's light index


def _samples(name: str, seed: int) -> dict:
    from drtlab.experiments.stats import chi2 as C
    sd = C.upload_scene(SCENE)[0]
    ad = C.LightAdapter(True, name)
    return {label: (ad, sd, x, ad.sample(sd, np.array(x), N, seed + i))
            for i, (label, x) in enumerate(POINTS.items())}


def _pmf_kernel(name: str):
    """A kernel evaluating selection `name`'s pmf of every light at the given points."""
    import warp as wp
    from drtlab.kernels.device_scene import SceneData
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    pmf = LIGHT_SELECTIONS[name].pmf

    @wp.kernel(enable_backward=False, module="unique")
    def k(sd: SceneData, xs: wp.array(dtype=wp.vec3), out: wp.array2d(dtype=float)):
        i, li = wp.tid()
        out[i, li] = pmf(sd, xs[i], li)
    return k


def _claimed_pmf(name: str) -> np.ndarray:
    """(points, lights): the probability the selection claims for each light at each point."""
    import warp as wp
    from drtlab.experiments.stats import chi2 as C
    sd = C.upload_scene(SCENE)[0]
    xs = wp.array(np.array(list(POINTS.values()), dtype=np.float32), dtype=wp.vec3, device="cpu")
    out = wp.zeros((len(POINTS), LIGHTS), dtype=float, device="cpu")
    wp.launch(_pmf_kernel(name), dim=(len(POINTS), LIGHTS), inputs=[sd, xs, out], device="cpu")
    return out.numpy().astype(np.float64)


def _pmf_lines(name: str, runs: dict, per_line: float) -> list[Line]:
    from scipy import stats
    from drtlab.experiments.stats import chi2 as C
    claimed = _claimed_pmf(name)
    sums = claimed.sum(axis=1)
    zero = [f"light {li} at {label}" for label, row in zip(runs, claimed) for li in range(LIGHTS)
            if not row[li] > 0]
    ps = []
    for (label, (_, _, _, s)), row in zip(runs.items(), claimed):
        counts = np.bincount(s.light.clip(0, LIGHTS - 1), minlength=LIGHTS)
        stat, dof, _, _ = C.pooled_chi2(counts, N * row / max(row.sum(), 1e-300))
        ps.append(float(stats.chi2.sf(stat, dof)) if dof > 0 else 1.0)
    ok_sum = bool(np.all(np.abs(sums - 1.0) <= 1e-5)) and not zero
    worst = int(np.argmin(ps))
    return [Line("pmf", ok_sum, "sums " + ", ".join(f"{x:.6f}" for x in sums) + " at the 3 points"
                 + (f"; zero: {', '.join(zero)}" if zero else "; every light above 0")),
            Line("pick frequencies", min(ps) >= per_line,
                 f"{N} picks per point against the claimed pmf: p = " + ", ".join(f"{p:.3g}" for p in ps)
                 + f" (smallest at {list(runs)[worst]})", min(ps))]


def _directions(runs: dict, per_line: float) -> Line:
    from drtlab.experiments.stats import chi2 as C
    ad, sd, x, s = runs["origin"]
    # The 1e-3 sphere's cone (~1e-7 sr) lies far below the histogram's bins: its samples are left
    # out (as lost mass), the claimed density's quadrature misses it alike.
    valid = s.valid & (s.light != SPARK)
    r = C.run_chi2(C.SphericalDomain((0.0, 0.0, 1.0)), lambda n, seed: (s.wi, valid),
                   ad.pdf(sd, np.array(x)), name="light selection", sample_count=N, res=(101, 202), seed=12,
                   test_count=TESTS)
    return Line("directions", r.p_value >= per_line,
                f"light-sample directions from the origin against the density MIS evaluates "
                f"(the 1e-3 sphere's left out): chi-square p = {r.p_value:.3g}", r.p_value)


def _mis_and_hard_cases(runs: dict) -> list[Line]:
    from drtlab.experiments.stats import chi2 as C
    worst, bad = 0.0, []
    for label, (_, _, _, s) in runs.items():
        v = s.valid
        if v.any():
            worst = max(worst, float(np.max(C.relative_error(s.pdf[v], s.pdf_eval[v]))))
        finite = (np.all((s.light >= 0) & (s.light < LIGHTS)) and np.all(np.isfinite(s.pmf))
                  and np.all((s.pmf >= 0) & (s.pmf <= 1)) and np.all(np.isfinite(s.pdf[v]))
                  and np.all(s.pdf[v] >= 0) and np.all(np.isfinite(s.wi[v])))
        if not finite:
            bad.append(label)
    return [Line("MIS density", worst <= 1e-4, f"largest relative error between a sample's density and "
                                                f"light_pdf's: {worst:.2e} (limit 1e-4)"),
            Line("hard cases", not bad, "a 1e-3 sphere, a 200 x 200 quad 60 away, a grazing point: "
                 + ("picks, pmfs, densities and directions finite and non-negative" if not bad else
                    "non-finite or negative values at " + ", ".join(bad)))]


def check(name: str, seed: int = 0, level: float = 0.01) -> Scorecard:
    """The scorecard of registered light selection `name` (module docstring)."""
    from drtlab.estimators.plugin_checks import add_strategy
    from drtlab.kernels.strategy_composition import compose_strategy
    from drtlab.estimators.strategies import STRATEGIES
    t0 = time.perf_counter()
    per_line = per_test(level, TESTS)
    card = Scorecard(name, level, TESTS)
    runs = _samples(name, seed)
    card.lines += _pmf_lines(name, runs, per_line)
    card.lines.append(_directions(runs, per_line))
    card.lines += _mis_and_hard_cases(runs)
    strategy = f"check-{name}"
    if strategy not in STRATEGIES:
        add_strategy(compose_strategy(strategy, f"importance with the {name} light selection",
                                      like="importance", light_selection=name))
    sampler = f"independent+{strategy}"
    card.lines.append(furnace_unbiased(sampler, seed, per_line))
    card.lines.append(furnace_cost(sampler, "independent+importance", "the power pick's"))
    card.seconds = time.perf_counter() - t0
    return card
