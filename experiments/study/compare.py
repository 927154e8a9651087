"""One scene of one study: each sampler's cells, tail, cost model and convergence law, and its
comparisons with the baseline at every N of the ladder. Every interval the report prints about them
comes from here; `experiments/audit/coverage.py` (`drtlab audit-intervals`) feeds simulated studies
with a known truth through the same functions.

Inputs are plain tables, so a synthetic study needs no renderer:
  runs     sampler, spp, value                    one row per run (its squared error: MSE or relMSE)
  batches  sampler, spp, seconds, reps[, time]    one row per timed batch (seconds of the whole batch)

A comparison at N (`Comparison`) holds the MSE ratio (baseline's / sampler's, > 1: the sampler's
error is lower), the efficiency ratio at N (1/(MSE x seconds), sampler's over baseline's) and the
speed-up: the baseline's time over the sampler's to reach the *target*, the larger of the two fitted
RMSEs at N, so the worse sampler sits at N itself and the better one reaches it at a smaller N* of
its own. A speed-up whose N* lies more than a factor `EXTRAPOLATION` outside the ladder is flagged
`extrapolated` and makes no claim. The claim of a row rests on its speed-up where that is resolved,
else on its efficiency ratio; `finish_claims` corrects them across a report.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from drtlab.experiments.stats import comparisons as cmp
from drtlab.experiments.stats.cost_model import CostModel, fit_cost_model, load_shift
from drtlab.experiments.stats.intervals import positive_mean_ci
from drtlab.experiments.stats.resolution import ERRATIC_SIGMA, cell_resolution, tail_shape

EXTRAPOLATION = 2.0
NAN = float("nan")


@dataclass(frozen=True)
class CellEstimate:
    """A cell's mean squared error with its log-t interval, whether it is resolved, and its cost of
    one repetition from the sampler's cost model."""
    sampler: str
    spp: int
    n: int
    mean: float
    lo: float
    hi: float
    resolved: bool
    why: str | None
    seconds: float
    seconds_lo: float
    seconds_hi: float


@dataclass(frozen=True)
class Comparison:
    """One row of `result.comparisons`: a sampler against the baseline at N."""
    sampler: str
    baseline: str
    spp: int
    mse_ratio: float
    mse_ratio_lo: float
    mse_ratio_hi: float
    efficiency: float
    efficiency_lo: float
    efficiency_hi: float
    speedup: float
    speedup_lo: float
    speedup_hi: float
    target_rmse: float
    samples_to_target: float             # the sampler's N* (the baseline's when it is the better)
    baseline_samples_to_target: float
    extrapolated: bool
    resolved: bool                       # both cells resolved: ratios may make claims
    speedup_resolved: bool               # ... and both fits, within the ladder
    why: str | None
    p_mse_ratio: float = NAN
    p_efficiency: float = NAN
    p_speedup: float = NAN
    claim_on: str = "speedup"            # which ratio the claim rests on
    claim: str = "not resolved"          # better / worse / no difference / not resolved
    p_adjusted: float = NAN              # Benjamini-Hochberg over the report's tests
    mse_claim: str = "not resolved"
    p_mse_ratio_adjusted: float = NAN

    def ratio(self, kind: str) -> tuple[float, float, float]:
        return getattr(self, kind), getattr(self, f"{kind}_lo"), getattr(self, f"{kind}_hi")


@dataclass
class SceneComparison:
    cells: dict                          # (sampler, spp) -> CellEstimate
    tails: dict                          # sampler -> resolution.tail_shape(...)
    costs: dict                          # sampler -> CostModel
    fits: dict                           # sampler -> slopes.fit_rmse_slope(...) dict (with draws)
    rows: list = field(default_factory=list)    # Comparison, one per (sampler != baseline, N)


def _groups(table: dict, key: str) -> dict:
    """{sampler: {spp: np.array of column `key`}} of a runs table (dict of equal-length columns)."""
    out: dict = {}
    for s, n, v in zip(table["sampler"], table["spp"], table[key]):
        out.setdefault(s, {}).setdefault(int(n), []).append(float(v))
    return {s: {n: np.asarray(v) for n, v in per.items()} for s, per in out.items()}


def _columns(table) -> dict:
    """A pandas DataFrame or a dict of columns, as a dict of lists."""
    if hasattr(table, "to_dict"):
        return {k: list(v) for k, v in table.to_dict("list").items()}
    return {k: list(v) for k, v in table.items()}


def fit_costs(batches, pixels: int) -> dict:
    """sampler -> CostModel from every timed batch of it (`batches` as in the module docstring)."""
    b = _columns(batches)
    out = {}
    for s in dict.fromkeys(b["sampler"]):
        idx = [i for i, x in enumerate(b["sampler"]) if x == s]
        out[s] = fit_cost_model([b["seconds"][i] for i in idx], [b["reps"][i] for i in idx],
                                [b["spp"][i] * pixels for i in idx])
    return out


def level_load(tables: list, pixels: list) -> tuple[list, dict]:
    """The timed batches of a sweep (one table per scene group, with a `time` column) with a step in
    the machine's load taken out: every group's cost models are fitted, their relative residuals
    pooled in time order and tested (`cost_model.load_shift`); on a step, batches from its time on
    are divided by its ratio, so each model is fitted on one load level (the earlier one) and its
    residuals keep the batch-to-batch spread alone. Left in, the step inflated every residual sd
    and the efficiency and speed-up intervals covered 0.99 in the audit's load-step setting.
    Returns the (possibly rescaled) tables as dicts of lists and the test's result."""
    cols = [_columns(t) for t in tables]
    times, resid = [], []
    for b, px in zip(cols, pixels):
        models = fit_costs(b, px)
        for s, sec, reps, n, t in zip(b["sampler"], b["seconds"], b["reps"], b["spp"], b["time"]):
            c = models[s].coef
            predicted = c[0] + reps * (c[1] + c[2] * n * px)
            if sec > 0 and predicted > 0 and math.isfinite(sec):
                times.append(t)
                resid.append(sec / predicted - 1.0)
    load = load_shift(times, resid)
    load["leveled"] = bool(load["shifted"])
    if load["shifted"]:
        for b in cols:
            b["seconds"] = [sec / load["ratio"] if t >= load["at"] else sec
                            for sec, t in zip(b["seconds"], b["time"])]
    return cols, load


def fit_law(spp, values, seed: int, floor: float | None, chain: dict) -> dict:
    """The convergence law of one sampler (`slopes.fit_rmse_slope` on its per-run squared errors)."""
    from drtlab.experiments.stats.slopes import fit_rmse_slope
    return fit_rmse_slope(spp, values, seed=seed, floor=floor, **chain)


def _cell(s: str, n: int, v: np.ndarray, tail: dict, cost: CostModel, pixels: int) -> CellEstimate:
    ci = positive_mean_ci(v)
    ok, why = cell_resolution(v, ci["lo"] if ci["method"] != "t-upper" else NAN, tail["heavy"],
                              tail.get("erratic", False))
    if ci["method"] == "t-upper":
        ok, why = False, why or "mean at or below the noise floor"
    lo, hi = cost.seconds_interval(n * pixels)
    return CellEstimate(s, n, ci["n"], ci["mean"], ci["lo"], ci["hi"], ok, why,
                        float(cost.seconds(n * pixels)), lo, hi)


def _line(fit: dict | None):
    """(point (a, b), draws) of a usable fit, else (None, None)."""
    if not fit or not fit.get("ok") or fit.get("draws") is None:
        return None, None
    return np.array([fit["intercept"], fit["slope"]]), np.asarray(fit["draws"])


def speedup(fit_b: dict | None, fit_s: dict | None, cost_b: CostModel, cost_s: CostModel,
            target: float, pixels: int, rng) -> dict:
    """The baseline's time over the sampler's to reach `target` RMSE: point (fitted medians), 95%
    interval and p from draws of both laws and both cost models; N* of each."""
    pb, db = _line(fit_b)
    ps, ds = _line(fit_s)
    out = {"ratio": NAN, "lo": NAN, "hi": NAN, "p": NAN, "n": NAN, "n_base": NAN}
    if pb is None or ps is None or not (target > 0 and math.isfinite(target)):
        return out
    nb, ns = float(cmp.samples_to_reach(pb, target)[0]), float(cmp.samples_to_reach(ps, target)[0])
    tb = cost_b.seconds(nb * pixels) if math.isfinite(nb) else math.inf
    ts = cost_s.seconds(ns * pixels) if math.isfinite(ns) else math.inf
    point = tb / ts if math.isfinite(tb) and math.isfinite(ts) else NAN
    k = cmp.DRAWS
    lines_b = db[rng.integers(0, len(db), size=k)]
    lines_s = ds[rng.integers(0, len(ds), size=k)]
    with np.errstate(invalid="ignore"):
        t_b = cost_b.seconds_of_draws(cost_b.coef_draws(rng, k), cmp.samples_to_reach(lines_b, target) * pixels)
        t_s = cost_s.seconds_of_draws(cost_s.coef_draws(rng, k), cmp.samples_to_reach(lines_s, target) * pixels)
    d = cmp.log_time_ratio(t_b, t_s)
    out.update(cmp.interval_of_draws(d, point))
    out.update(n=ns, n_base=nb)
    return out


def _row(s: str, base: str, n: int, cells: dict, costs: dict, fits: dict, ladder: list, pixels: int,
         values: dict, rng) -> Comparison:
    cb, cs = cells[(base, n)], cells[(s, n)]
    mr = cmp.mean_ratio(values[base][n], values[s][n])
    k = cmp.DRAWS
    tb = costs[base].draw_seconds([n * pixels], rng, k)[:, 0]
    ts = costs[s].draw_seconds([n * pixels], rng, k)[:, 0]
    eff_point = mr["ratio"] * cb.seconds / cs.seconds
    eff = cmp.interval_of_draws(cmp.draw_log_ratio(mr, rng, k) + np.log(tb) - np.log(ts), eff_point)
    pb, _ = _line(fits.get(base))
    ps, _ = _line(fits.get(s))
    target = NAN
    if pb is not None and ps is not None:
        target = float(max(math.exp(pb[0] + pb[1] * math.log(n)), math.exp(ps[0] + ps[1] * math.log(n))))
    sp = speedup(fits.get(base), fits.get(s), costs[base], costs[s], target, pixels, rng)
    lo_n, hi_n = ladder[0] / EXTRAPOLATION, ladder[-1] * EXTRAPOLATION
    extrapolated = not all(lo_n <= x <= hi_n for x in (sp["n"], sp["n_base"]) if math.isfinite(x)) \
        or not (math.isfinite(sp["n"]) and math.isfinite(sp["n_base"]))
    resolved = cb.resolved and cs.resolved
    fits_ok = all(f and f.get("ok") and f.get("resolved") for f in (fits.get(base), fits.get(s)))
    why = None
    if not resolved:
        who = cb if not cb.resolved else cs
        why = f"{who.sampler} at N={n}: {who.why}"
    return Comparison(
        sampler=s, baseline=base, spp=n,
        mse_ratio=mr["ratio"], mse_ratio_lo=mr["lo"], mse_ratio_hi=mr["hi"],
        efficiency=eff["ratio"], efficiency_lo=eff["lo"], efficiency_hi=eff["hi"],
        speedup=sp["ratio"], speedup_lo=sp["lo"], speedup_hi=sp["hi"], target_rmse=target,
        samples_to_target=sp["n"], baseline_samples_to_target=sp["n_base"], extrapolated=bool(extrapolated),
        resolved=bool(resolved), speedup_resolved=bool(resolved and fits_ok and not extrapolated),
        why=why, p_mse_ratio=mr["p"], p_efficiency=eff["p"], p_speedup=sp["p"])


def compare_scene(runs, batches, samplers: list, baseline: str, ladder: list, pixels: int, *,
                  fits: dict | None = None, seed: int = 0, floor: float | None = None,
                  chain: dict | None = None) -> SceneComparison:
    """Everything the report says about one scene of one study. `fits` (sampler -> fit dict) are
    fitted here when not given (`fit_law` with `floor` and `chain`, default slopes.STUDY_CHAIN)."""
    from drtlab.experiments.stats.slopes import STUDY_CHAIN
    values = _groups(_columns(runs), "value")
    ladder = sorted(int(n) for n in ladder)
    costs = fit_costs(batches, pixels)
    if fits is None:
        fits = {}
        for i, s in enumerate(samplers):
            per = values.get(s, {})
            spp = [n for n in ladder if n in per for _ in per[n]]
            vals = [x for n in ladder if n in per for x in per[n]]
            fits[s] = fit_law(spp, vals, seed + 7919 * i, floor, chain or STUDY_CHAIN)
    tails = {s: tail_shape([values[s][n] for n in ladder if n in values.get(s, {})]) for s in samplers}
    for s in samplers:
        f = fits.get(s) or {}
        tails[s]["erratic"] = bool(f.get("ok") and f["sigma"] > ERRATIC_SIGMA)
    cells = {(s, n): _cell(s, n, values[s][n], tails[s], costs[s], pixels)
             for s in samplers for n in ladder if n in values.get(s, {}) and s in costs}
    rng = np.random.default_rng(seed)
    rows = [_row(s, baseline, n, cells, costs, fits, ladder, pixels, values, rng)
            for s in samplers if s != baseline for n in ladder
            if (s, n) in cells and (baseline, n) in cells]
    return SceneComparison(cells, tails, costs, fits, rows)


def finish_claims(rows: list[Comparison]) -> list[Comparison]:
    """Claims for every row of a report, Benjamini-Hochberg over all its tests at once: each row's
    claim test (its speed-up where resolved, else its efficiency ratio) and its MSE-ratio test."""
    tests = []
    for r in rows:
        on = "speedup" if r.speedup_resolved and math.isfinite(r.p_speedup) else "efficiency"
        ratio, p = (r.speedup, r.p_speedup) if on == "speedup" else (r.efficiency, r.p_efficiency)
        tests.append({"p": p, "resolved": r.resolved, "direction": math.log(ratio) if ratio > 0 else 0.0,
                      "on": on})
        tests.append({"p": r.p_mse_ratio, "resolved": r.resolved,
                      "direction": math.log(r.mse_ratio) if r.mse_ratio > 0 else 0.0, "on": "mse"})
    done = cmp.assign_claims(tests)
    return [replace(r, claim_on=done[2 * i]["on"], claim=done[2 * i]["claim"],
                    p_adjusted=done[2 * i]["p_adjusted"], mse_claim=done[2 * i + 1]["claim"],
                    p_mse_ratio_adjusted=done[2 * i + 1]["p_adjusted"])
            for i, r in enumerate(rows)]
