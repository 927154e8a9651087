"""From run records to the numbers a report needs: cells, slopes, costs, comparisons, noise floor.

A cell is (scene, sampler, spp) over its repetitions. Error statistics use the noise-floor-corrected
MSE (MSE - Var_GT); the RMSE of a cell is sqrt(mean corrected MSE), whose 95% CI is the square root
of a log-scale t interval of the corrected MSEs (`intervals.rmse_ci`: positive quantities get
intervals that stay positive). The slope of a sampler is that of the RMSE itself
(`slopes.fit_rmse_slope`, a gamma likelihood of per-run MSEs), reported beside the slope of the
typical (geometric-mean) error. The cost of a cell is its sampler's cost model
(`stats/cost_model.py`: per call + per repetition + per sample, fitted to every timed batch of that
sampler in the scene) at the cell's sample count. Comparisons with the baseline (MSE ratio,
efficiency, speed-up; whether each cell is resolved; claims corrected across the whole report) come
from `compare.py`, which the interval audit runs on simulated studies.

`analyze` returns a `results.Summary`; the report, summary.json and the CLI read that.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study.ground_truth import GroundTruth, load_ground_truth
from drtlab.experiments.study.metrics import cell_bias, mean_ci
from drtlab.experiments.study.noise_floor import floor_remedy, noise_floor, noise_floor_warnings
from drtlab.experiments.parallel import pmap
from drtlab.experiments.error_metrics import METRICS, plugin_metrics, record_key
from drtlab.experiments.study.results import (
    PER_RUN, BaselineComparison, Bias, Cell, ChainDiagnostics, Interval, MetricCell, NoiseFloor, RatioCI,
    SceneResult, SlopeFit, Speed, StudyResult, Summary, TimeToTarget, TopEfficiency,
)
from drtlab.experiments.study.compare import (compare_scene, finish_claims, fit_costs, level_load,
                                              speedup as speedup_at)
from drtlab.experiments.study.run_store import load_cell
from drtlab.experiments.seeds import short_hash
from drtlab.experiments.stats.comparisons import assign_claims
from drtlab.experiments.stats.resolution import ERRATIC_SIGMA, cell_resolution, tail_shape
from drtlab.experiments.stats.hypothesis_tests import Z_CI
from drtlab.experiments.stats.intervals import positive_mean_ci, repetitions_for_precision, rmse_ci
from drtlab.experiments.stats.slopes import STUDY_CHAIN, fit_rmse_slope, fit_typical_slope

SIGNED_METRICS = ("mean_error",)      # the others are >= 0 (in expectation): positive intervals
PRECISION = 0.1                       # cells say how many repetitions a ±10% mean MSE would need
NAN = float("nan")


def _interval(metric: str, values: list) -> Interval:
    return Interval.of(mean_ci(values) if metric in SIGNED_METRICS else positive_mean_ci(values))


def _efficiency(mse: float, seconds: float) -> float:
    return 1.0 / (mse * seconds) if mse > 0 and seconds > 0 else NAN


# ---------------------------------------------------------------------------------------------------
# One (scene, integrator, resolution) group: cells, noise floor, cost models, slope fits
# ---------------------------------------------------------------------------------------------------

@dataclass
class GroupResult:
    """The cells of one (scene, integrator, resolution), its fits, cost models and noise floor."""
    cells: dict                     # (sampler, spp) -> Cell
    slopes: dict                    # metric -> sampler -> SlopeFit
    noise_floor: NoiseFloor
    runs: dict                      # metric -> {sampler, spp, value}: every run's squared error
    batches: dict                   # {sampler, spp, seconds, reps, time}: every timed batch
    costs: dict                     # sampler -> cost_model.CostModel
    pixels: int
    fits: dict = field(default_factory=dict)    # metric -> sampler -> fit dict (with its draws)


def group_name(g) -> str:
    scene, integrator, res = g
    return f"{scene.key}__{integrator}__{res[0]}x{res[1]}"


def _run_error(rec: dict, metric: str) -> float:
    """A run's error (the root of its squared error), NaN where the noise floor's removal left none."""
    v = rec.get(record_key(metric), NAN)
    return math.sqrt(v) if v > 0 else NAN


def _pixels(g) -> int:
    return g[2][0] * g[2][1]


def _batches(runs, records: dict, calibration: dict, cpu: bool) -> dict:
    """Every timed batch of a group: the cells' own (one row per batch id, its whole seconds) and
    their timing-only batches (calibration.json)."""
    out: dict = {"sampler": [], "spp": [], "seconds": [], "reps": [], "time": []}
    seen = set()

    def add(s, n, seconds, reps, t):
        for k, v in zip(out, (s, n, seconds, reps, t)):
            out[k].append(v)

    for r in runs:
        rec = records.get(r.run_id)
        if rec is None or (r.cell, rec["batch"]) in seen:
            continue
        seen.add((r.cell, rec["batch"]))
        per = rec["cpu_seconds"] if cpu else rec["render_seconds"]
        add(r.sampler, r.spp, per * rec["batch_reps"], rec["batch_reps"], rec.get("batch_time", NAN))
    for r in {r.cell: r for r in runs}.values():
        entry = calibration.get(r.cell)
        for sec in (entry or {}).get("seconds", []):
            add(r.sampler, r.spp, sec * entry["reps"], entry["reps"], NAN)
    return out


def _cell(sampler: str, spp: int, cell_runs, records: dict, out_dir: Path, gt: GroundTruth,
          cost, pixels: int, calibrated: bool, target: dict | None, metrics=()) -> Cell:
    recs = [records[r.run_id] for r in cell_runs]
    moments = load_cell(out_dir, cell_runs[0].cell).moments
    # .get: runs stored before a metric was scored (FLIP) lack it; they count as not scored.
    stats = {m: _interval(m, [rec.get(m) for rec in recs]) for m in PER_RUN}
    b = cell_bias(moments.n, moments.mean, moments.pixel_variance(), gt.mean, gt.stderr,
                  [rec["mean_error"] for rec in recs])
    bias = Bias(**b, significant=bool(math.isfinite(b["lo"]) and (b["lo"] > 0 or b["hi"] < 0)))
    seconds = float(cost.seconds(spp * pixels))
    lo, hi = cost.seconds_interval(spp * pixels)
    builtin = [m for m in METRICS.values() if m.cell_fields]
    efficiency = {m.cell_fields[2]: _efficiency(stats[m.record].mean, seconds) for m in builtin}
    plugins = {}
    for m in plugin_metrics(metrics):
        if not any(m.record in rec for rec in recs):
            continue                                  # a cell of other studies only: not scored
        values = [rec.get(m.record, NAN) for rec in recs]
        mean = _interval(m.record, values)
        plugins[m.name] = MetricCell(Interval.of(rmse_ci(values)), mean, _efficiency(mean.mean, seconds))
    need = {m: repetitions_for_precision([rec[METRICS[m].record] for rec in recs], PRECISION)
            for m in [m.name for m in builtin] + list(plugins)}
    return Cell(sampler=sampler, spp=spp, n=len(recs), **stats, metrics=plugins,
                rmse_of_mean_mse=Interval.of(rmse_ci([rec["mse_corrected"] for rec in recs])),
                rrmse_of_mean_relmse=Interval.of(rmse_ci([rec["relmse_corrected"] for rec in recs])),
                repetitions_for_10pct={m: v["repetitions"] for m, v in need.items()},
                mse_rel_ci=need["mse"]["current_rel_halfwidth"],
                target_rel_ci=target["target_rel_ci"] if target else None,
                target_met=target["target_met"] if target else None,
                samples_needed=(target["runs_needed"] * spp if target and target["runs_needed"]
                                else None),
                bias=bias, seconds=seconds, seconds_ci=Interval(seconds, lo, hi, cost.batches),
                measured_seconds=float(np.median([rec["render_seconds"] for rec in recs])),
                timing_below_resolution=calibrated, **efficiency)


def fit_slopes(spp: list, mse: list, errors: list, seed: int, floor: float | None) -> tuple:
    """(RMSE-slope fit of the per-run MSEs, typical-error fit of the per-run errors)."""
    return (fit_rmse_slope(spp, mse, seed=seed, floor=floor, **STUDY_CHAIN),
            fit_typical_slope(spp, errors, seed=seed))


def _slope_call(g, sampler: str, metric: str, sampler_runs, records: dict, floor: float) -> tuple:
    """The `fit_slopes` call for one sampler's runs (every repetition a point), with a fixed seed.
    The MSE's noise floor is the reference's variance; relMSE has no such scale (floor left out)."""
    fit_seed = int(short_hash([g[0].key, g[1], sampler] + ([metric] if metric != "mse" else []), 8),
                   16) & 0x7FFFFFFF
    recs = [records[r.run_id] for r in sampler_runs]
    return (fit_slopes, ([r.spp for r in sampler_runs], [rec.get(record_key(metric), NAN) for rec in recs],
                         [_run_error(rec, metric) for rec in recs], fit_seed,
                         floor if metric == "mse" else None), {})


def analyze_group(g, runs, records: dict, out_dir: Path, gt_dir, batches: dict, metrics=("mse",),
                  calibration: dict | None = None, targets: dict | None = None) -> tuple:
    """(GroupResult, fits to run) of one (scene, integrator, resolution) from its timed `batches`
    (`_batches`, load leveled). Its slope fits (one per sampler and metric) come back as (metric,
    sampler, call) for `analyze` to run together, in parallel; the GroupResult's `slopes` are empty
    until then."""
    gt = load_ground_truth(gt_dir)
    pixels = _pixels(g)
    done = [r for r in runs if r.run_id in records]
    costs = fit_costs(batches, pixels)
    cells: dict = {}
    fit_calls: list = []
    samplers = list(dict.fromkeys(r.sampler for r in runs))
    for s in samplers:
        sampler_runs = [r for r in done if r.sampler == s]
        for spp in sorted({r.spp for r in sampler_runs}):
            cell_runs = [r for r in sampler_runs if r.spp == spp]
            cell = cell_runs[0].cell
            cells[(s, spp)] = _cell(s, spp, cell_runs, records, out_dir, gt, costs[s], pixels,
                                    bool((calibration or {}).get(cell)), (targets or {}).get(cell),
                                    metrics)
        if sampler_runs:
            fit_calls += [(metric, s, _slope_call(g, s, metric, sampler_runs, records, gt.variance))
                          for metric in metrics]
    table = {m: {"sampler": [r.sampler for r in done], "spp": [r.spp for r in done],
                 "value": [records[r.run_id].get(record_key(m), NAN) for r in done]} for m in metrics}
    return GroupResult(cells, {m: {} for m in metrics}, noise_floor(cells, gt, gt_dir), table, batches,
                       costs, pixels, {m: {} for m in metrics}), fit_calls


# ---------------------------------------------------------------------------------------------------
# One study: its view of each scene's group (its samplers, its ladder, its metric)
# ---------------------------------------------------------------------------------------------------

def _study_scenes(study, plan, group_results: dict) -> list:
    """(scene_ref, GroupResult, SceneComparison) of each scene of the study, claims not yet set."""
    group_of: dict = {}
    for r in plan:
        if study.name in r.studies:
            group_of.setdefault(r.scene, r.group)
    out = []
    for scene_ref in study.scenes:
        if scene_ref not in group_of:
            continue
        g = group_results[group_of[scene_ref]]
        samplers = [s for s in study.samplers if s in g.costs]
        keep = [i for i, s in enumerate(g.runs[study.metric]["sampler"]) if s in samplers]
        runs = {k: [v[i] for i in keep] for k, v in g.runs[study.metric].items()}
        seed = int(short_hash([study.name, scene_ref.key], 8), 16) & 0x7FFFFFFF
        sc = compare_scene(runs, g.batches, samplers, study.baseline, list(study.settings.spp), g.pixels,
                           fits=g.fits[study.metric], seed=seed)
        out.append((scene_ref, g, sc))
    return out


def _speed(study, g: GroupResult, sc, rows: list) -> Speed:
    """Time to the target error and the speed-up it gives: at the top of the ladder's target (the
    larger of the two fitted RMSEs there), or at the study's own `target_rmse`."""
    top = {r.sampler: r for r in rows if r.spp == max(study.settings.spp)}
    target = study.settings.target_rmse
    fits = g.fits[study.metric]
    time_to, speedup, lo, hi = {}, {}, {}, {}
    rng = np.random.default_rng(int(short_hash([study.name, "target"], 8), 16))
    for s, r in top.items():
        x = r if target is None else None
        if x is None:
            sp = speedup_at(fits.get(study.baseline), fits.get(s), sc.costs[study.baseline],
                            sc.costs[s], target, g.pixels, rng)
            n, nb, ratio, l, h = sp["n"], sp["n_base"], sp["ratio"], sp["lo"], sp["hi"]
        else:
            n, nb, ratio, l, h = (x.samples_to_target, x.baseline_samples_to_target, x.speedup,
                                  x.speedup_lo, x.speedup_hi)
        speedup[s], lo[s], hi[s] = ratio, l, h
        inside = lambda v: min(study.settings.spp) <= v <= max(study.settings.spp)
        time_to[s] = TimeToTarget(float(sc.costs[s].seconds(n * g.pixels)) if math.isfinite(n) else NAN,
                                  "interpolated" if math.isfinite(n) and inside(n) else "extrapolated")
        time_to[study.baseline] = TimeToTarget(
            float(sc.costs[study.baseline].seconds(nb * g.pixels)) if math.isfinite(nb) else NAN,
            "interpolated" if math.isfinite(nb) and inside(nb) else "extrapolated")
    if study.baseline in sc.costs:
        speedup[study.baseline], lo[study.baseline], hi[study.baseline] = 1.0, 1.0, 1.0
    tgt = target if target is not None else next((r.target_rmse for r in top.values()), NAN)
    return Speed(target_rmse=tgt, target_auto=target is None, time_to_target=time_to,
                 speedup_vs_baseline=speedup, speedup_lo=lo, speedup_hi=hi)


def _scene_result(study, scene_ref, g: GroupResult, sc, rows: list) -> SceneResult:
    samplers, ladder = list(study.samplers), study.settings.spp
    cells = [replace(g.cells[(s, n)], resolved=sc.cells[(s, n)].resolved,
                     unresolved_why=sc.cells[(s, n)].why)
             for s in samplers for n in ladder if (s, n) in g.cells and (s, n) in sc.cells]
    slopes = g.slopes[study.metric]
    vs = {s: [BaselineComparison(spp=r.spp, mse_ratio=RatioCI(r.mse_ratio, r.mse_ratio_lo, r.mse_ratio_hi),
                                 efficiency_ratio=r.efficiency, efficiency_ratio_lo=r.efficiency_lo,
                                 efficiency_ratio_hi=r.efficiency_hi) for r in rows if r.sampler == s]
          for s in samplers}
    top_n = {s: max((c.spp for c in cells if c.sampler == s), default=None) for s in samplers}
    eff = {}
    for s, n in top_n.items():
        if n is None:
            continue
        c = next(c for c in cells if c.sampler == s and c.spp == n)
        r = next((r for r in rows if r.sampler == s and r.spp == n), None)
        eff[s] = TopEfficiency(spp=n, efficiency=c.efficiency_of(study.metric),
                               relative=1.0 if s == study.baseline else (r.efficiency if r else NAN),
                               relative_lo=1.0 if s == study.baseline else (r.efficiency_lo if r else NAN),
                               relative_hi=1.0 if s == study.baseline else (r.efficiency_hi if r else NAN))
    return SceneResult(
        scene=scene_ref.label, scene_name=scene_ref.name, overrides=scene_ref.overrides_dict,
        cells=cells, slopes={s: slopes[s] for s in samplers if s in slopes},
        noise_floor=g.noise_floor, speed=_speed(study, g, sc, rows), vs_baseline=vs, efficiency=eff,
        comparisons=rows, tails={s: sc.tails[s] for s in samplers if s in sc.tails},
        costs={s: sc.costs[s] for s in samplers if s in sc.costs})


def _study_result(study, scenes: list) -> StudyResult:
    settings, metric = study.settings, METRICS[study.metric]
    return StudyResult(
        name=study.name, description=study.description, experiment=study.experiment,
        integrator=study.integrator, samplers=list(study.samplers), baseline=study.baseline,
        metric=study.metric, metric_label=metric.label, mse_label=metric.mse_label,
        spp=list(settings.spp), repetitions=settings.repetitions,
        runs_per_spp=settings.runs_per_spp, samples_per_cell=settings.samples_per_cell,
        resolution=list(settings.resolution) if settings.resolution else None,
        gt_spp=settings.gt_spp, seed=study.seed, strip_spp=list(settings.strip_spp), scenes=scenes)


# ---------------------------------------------------------------------------------------------------
# The experiment
# ---------------------------------------------------------------------------------------------------

def span_text(values, spec: str = ".1f", sep: str = "-") -> str:
    """'lo-hi' of `values` as `spec` prints them, or the one value when both print alike (one scene
    is '7.2', not '7.2-7.2')."""
    lo, hi = format(min(values), spec), format(max(values), spec)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def _chains(group_results: dict) -> ChainDiagnostics:
    fits = [(g, s, f) for g, v in group_results.items() for per in v.slopes.values() for s, f in per.items()]
    ok = [f for _, _, f in fits if f.ok]
    return ChainDiagnostics(
        fits=len(fits), converged=sum(1 for _, _, f in fits if f.converged),
        not_converged=[f"{g[0].label}/{s}" for g, s, f in fits if f.ok and not f.converged],
        acceptance_fraction_range=[min((f.acceptance_fraction for f in ok), default=NAN),
                                   max((f.acceptance_fraction for f in ok), default=NAN)],
        max_autocorr_time=max((max(f.autocorr_time) for f in ok), default=NAN))


def analyze(exp, plan, records: dict, out_dir: Path, gts: dict, log: Callable[[str], None],
            calibration: dict | None = None, targets: dict | None = None,
            cpu: bool = True) -> Summary:
    """The summary of a sweep: `gts` is the runner's ground-truth info per group (its `dir` read);
    `calibration` the runner's timing-only batches per cell (calibration.json; cells without them
    are timed by their own batches), `targets` the precision-target outcome per cell, `cpu` whether
    costs are CPU seconds (the CPU backend) or wall seconds."""
    groups: dict = {}
    for r in plan:
        groups.setdefault(r.group, []).append(r)
    by_name = {study.name: study for study in exp.studies}
    metrics_of: dict = {}
    for r in plan:
        for name in r.studies:
            metrics_of.setdefault(r.group, {})[by_name[name].metric] = None
    timed = {g: _batches([r for r in runs if r.run_id in records], records, calibration or {}, cpu)
             for g, runs in groups.items()}
    leveled, load = level_load(list(timed.values()), [_pixels(g) for g in timed])
    group_results: dict = {}
    fit_calls: list = []
    for (g, runs), batches in zip(groups.items(), leveled):
        group_results[g], calls = analyze_group(g, runs, records, Path(out_dir), gts[g]["dir"], batches,
                                                tuple(metrics_of[g]), calibration, targets)
        fit_calls += [(g, metric, s, call) for metric, s, call in calls]
    for (g, metric, s, _), (fit, typical) in zip(fit_calls, pmap([call for *_, call in fit_calls])):
        # Scatter of log error around the line far above what Gaussian pixel noise gives (~0.05):
        # the errors are heavy-tailed (rare, very bright samples), and so is every number built on them.
        group_results[g].slopes[metric][s] = SlopeFit.of(fit, ERRATIC_SIGMA, typical)
        group_results[g].fits[metric][s] = fit
    _screen_bias(group_results)
    per_study = [(study, _study_scenes(study, plan, group_results)) for study in exp.studies]
    # One family for the whole report: every claim it states is corrected together.
    rows = finish_claims([row for _, scenes in per_study for _, _, sc in scenes for row in sc.rows])
    studies, i = [], 0
    for study, scenes in per_study:
        results = []
        for scene_ref, g, sc in scenes:
            results.append(_scene_result(study, scene_ref, g, sc, rows[i:i + len(sc.rows)]))
            i += len(sc.rows)
        studies.append(_study_result(study, results))
    load = _load_text(load, log)
    return Summary(
        experiment=exp.name, description=exp.description, profile=exp.profile, studies=studies,
        noise_floor={group_name(g): v.noise_floor for g, v in group_results.items()},
        warnings=noise_floor_warnings(group_results, log, floor_remedy(exp), group_name)
        + ([load["text"]] if load["shifted"] else []),
        chains=_chains(group_results), load=load,
        ground_truth={group_name(g): {k: v for k, v in info.items() if k != "seeds"}
                      for g, info in gts.items()})


def _screen_bias(group_results: dict) -> None:
    """The bias screen as one family: each cell's mean error against 0, Benjamini-Hochberg over every
    cell of the experiment (the report's other claims are corrected the same way)."""
    from scipy import stats
    keys = [(g, k) for g, v in group_results.items() for k in v.cells]
    resolved = {}
    for g, v in group_results.items():
        # A cell whose squared errors are not resolved has heavy-tailed mean errors too: no claim.
        metric, runs = next(iter(v.runs.items()))
        per = {}
        for s, n, x in zip(runs["sampler"], runs["spp"], runs["value"]):
            per.setdefault(s, {}).setdefault(n, []).append(x)
        for s, cells in per.items():
            heavy = tail_shape(list(cells.values()))["heavy"]
            erratic = bool(getattr(v.slopes[metric].get(s), "erratic", False))
            for n, x in cells.items():
                resolved[(g, (s, n))] = cell_resolution(x, positive_mean_ci(x)["lo"], heavy, erratic)[0]
    tests = []
    for g, k in keys:
        b = group_results[g].cells[k].bias
        se = (b.hi - b.lo) / (2 * Z_CI)
        p = float(2 * stats.norm.sf(abs(b.signed) / se)) if se > 0 and math.isfinite(se) else NAN
        tests.append({"p": p, "resolved": resolved.get((g, k), False) and math.isfinite(p),
                      "direction": b.signed})
    for (g, k), t in zip(keys, assign_claims(tests)):
        c = group_results[g].cells[k]
        group_results[g].cells[k] = replace(c, bias=replace(
            c.bias, significant=t["claim"] in ("better", "worse"), p=t["p"], p_adjusted=t["p_adjusted"]))


def _load_text(load: dict, log: Callable[[str], None]) -> dict:
    """`compare.level_load`'s test with the warning that names when the load moved and by how much."""
    out = dict(load, text="")
    if out["shifted"]:
        import time as _time
        at = _time.strftime("%H:%M:%S", _time.localtime(out["at"]))
        out["text"] = (f"the machine's load moved during the sweep: batches from {at} on cost "
                       f"{out['ratio']:.2f}x those before (step test over {out['batches']} batches' cost "
                       f"residuals, p = {out['p']:.3g}); they were scaled back to the earlier load "
                       f"before the cost models were fitted")
        log(f"warning: {out['text']}")
    return out
