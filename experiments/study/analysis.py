"""From run records to the numbers a report needs: cells, slopes, speed against error, noise floor.

A cell is (scene, sampler, spp) over its repetitions. Error statistics use the noise-floor-corrected
MSE (MSE - Var_GT); the RMSE of a cell is sqrt(mean corrected MSE), whose 95% CI is the square root
of a log-scale t interval of the corrected MSEs (`intervals.rmse_ci`: positive quantities get
intervals that stay positive). The slope of a sampler is that of the RMSE itself
(`slopes.fit_rmse_slope`, a gamma likelihood of per-run MSEs), reported beside the slope of the
typical (geometric-mean) error. The time of a cell is its measured cost per repetition
(`run_store.CellTiming`): the mean over its batches of each batch's CPU seconds over its repetitions
(the faster half; 95% t interval over them plus a systematic term), or over timing-only batches for
cells too short to time; speed-ups carry a bootstrap interval (repetitions resampled, each cell's
cost drawn from its t law), efficiency ratios a delta-method one.

`analyze` returns a `results.Summary`; the report, summary.json and the CLI read that.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study.ground_truth import GroundTruth, load_ground_truth
from drtlab.experiments.study.metrics import cell_bias, mean_ci
from drtlab.experiments.parallel import pmap
from drtlab.experiments.study.results import (
    METRICS, BaselineComparison, Bias, Cell, ChainDiagnostics, Interval, NoiseFloor, RatioCI,
    SceneResult, SlopeFit, Speed, StudyResult, Summary, TimeToTarget, TopEfficiency,
)
from drtlab.experiments.study.run_store import CellTiming, cell_timing, load_cell
from drtlab.experiments.seeds import short_hash
from drtlab.experiments.stats.hypothesis_tests import Z_CI
from drtlab.experiments.stats.intervals import positive_mean_ci, repetitions_for_precision, rmse_ci
from drtlab.experiments.stats.slopes import STUDY_CHAIN, fit_rmse_slope, fit_typical_slope

NOISE_FLOOR_FRACTION = 0.01
ERRATIC_SIGMA = 0.25        # log-error scatter above which a sampler's errors are called heavy-tailed
CELL_METRICS = ("rmse", "rmse_corrected", "mse", "mse_corrected", "relmse", "relmse_corrected", "mae",
                "ciede2000", "mean_error", "render_seconds", "compile_seconds", "wall_seconds")
SIGNED_METRICS = ("mean_error",)      # the others are >= 0 (in expectation): positive intervals
PRECISION = 0.1                       # cells say how many repetitions a ±10% mean MSE would need
NAN = float("nan")
BOOTSTRAP = 400             # bootstrap replicates of each speed-up (repetitions x cost)


# ---------------------------------------------------------------------------------------------------
# Small statistics
# ---------------------------------------------------------------------------------------------------

def _interval(metric: str, values: list) -> Interval:
    return Interval.of(mean_ci(values) if metric in SIGNED_METRICS else positive_mean_ci(values))


def _interp_loglog(x0, y0, x1, y1, y):
    """x at which the log-log line through (x0, y0), (x1, y1) reaches y."""
    ly0, ly1 = math.log(y0), math.log(y1)
    if ly1 == ly0:
        return x1
    t = (math.log(y) - ly0) / (ly1 - ly0)
    lx = math.log(x0) + t * (math.log(x1) - math.log(x0))
    # A nearly flat extrapolation (a bootstrap replicate of a heavy-tailed cell) can need 10^300 s.
    return math.exp(lx) if lx < 700.0 else float("inf")


def time_to_target(times, rmses, target: float) -> dict:
    """Seconds a sampler needs to reach `target` RMSE, from its cells (ordered by spp).

    Interpolated log-log between the first cell at or below the target and the one before it;
    extrapolated from the last two cells (flagged) when the ladder never gets there; `at_most` when
    even the first cell is already below the target.
    """
    pts = [(t, e) for t, e in zip(times, rmses) if t > 0 and e > 0 and math.isfinite(t) and math.isfinite(e)]
    if not pts:
        return {"seconds": float("nan"), "how": "no data"}
    for i, (t, e) in enumerate(pts):
        if e <= target:
            if i == 0:
                return {"seconds": t, "how": "at_most"}
            t0, e0 = pts[i - 1]
            return {"seconds": _interp_loglog(t0, e0, t, e, target), "how": "interpolated"}
    if len(pts) >= 2:
        (t0, e0), (t1, e1) = pts[-2], pts[-1]
        if e1 < e0 and t1 > t0:
            return {"seconds": _interp_loglog(t0, e0, t1, e1, target), "how": "extrapolated"}
    return {"seconds": float("inf"), "how": "not reached"}


def _rel_var(x: Interval) -> float:
    """Variance of log(mean) by the delta method: (sd / mean)^2 / n."""
    sd = x.sd if x.sd is not None else NAN
    return (sd / x.mean) ** 2 / x.n if x.n > 1 and math.isfinite(sd) else NAN


def _ratio_ci(a: Interval, b: Interval) -> RatioCI:
    """Ratio a/b of two means with a delta-method 95% interval on the log scale."""
    if not (a.mean > 0 and b.mean > 0):
        return RatioCI(NAN, NAN, NAN)
    r = a.mean / b.mean
    va, vb = _rel_var(a), _rel_var(b)
    s = math.sqrt(va + vb) if math.isfinite(va + vb) else NAN
    return RatioCI(r, r * math.exp(-Z_CI * s) if math.isfinite(s) else NAN,
                   r * math.exp(Z_CI * s) if math.isfinite(s) else NAN)


def _log_sd(x: Interval | None) -> float:
    return math.sqrt(_rel_var(x)) if x is not None else NAN


def _efficiency_ratio(c, b, metric: str) -> tuple:
    """(ratio, lo, hi): c's efficiency over b's, 95% delta-method interval on the log scale from
    both cells' squared errors and calibrated costs."""
    e, be = c.efficiency_of(metric), b.efficiency_of(metric)
    if c is b and math.isfinite(e) and e > 0:
        return 1.0, 1.0, 1.0
    if not (be and math.isfinite(be) and math.isfinite(e) and e > 0):
        return NAN, NAN, NAN
    r = e / be
    s = math.sqrt(sum(_log_sd(x) ** 2 for x in (c.error_mse(metric), b.error_mse(metric),
                                                  c.seconds_ci, b.seconds_ci)))
    return (r, r * math.exp(-Z_CI * s), r * math.exp(Z_CI * s)) if math.isfinite(s) else (r, NAN, NAN)


def _efficiency(mse: float, seconds: float) -> float:
    return 1.0 / (mse * seconds) if mse > 0 and seconds > 0 else NAN


# ---------------------------------------------------------------------------------------------------
# One (scene, integrator, resolution) group: cells, noise floor, slope fits
# ---------------------------------------------------------------------------------------------------

@dataclass
class GroupResult:
    """The cells of one (scene, integrator, resolution), its slope fits and its noise floor."""
    cells: dict                     # (sampler, spp) -> Cell
    slopes: dict                    # metric -> sampler -> SlopeFit
    noise_floor: NoiseFloor
    timings: dict = None            # (sampler, spp) -> run_store.CellTiming
    mse_runs: dict = None           # (sampler, spp) -> metric -> per-run squared errors (bootstrap)


def group_name(g) -> str:
    scene, integrator, res = g
    return f"{scene.key}__{integrator}__{res[0]}x{res[1]}"


def _run_error(rec: dict, metric: str) -> float:
    if metric == "relmse":
        v = rec["relmse_corrected"]
        return math.sqrt(v) if v > 0 else float("nan")
    return rec["rmse_corrected"]


def _cell_time(timing: CellTiming, recs: list) -> dict:
    """A cell's cost per repetition (its batches' mean), its interval and the median it replaces."""
    measured = float(np.median([rec["render_seconds"] for rec in recs]))
    seconds, h, n = timing.mean, timing.t_halfwidth(), timing.samples.size
    sd = h / Z_CI * math.sqrt(n) if n > 1 else None     # so that sd/sqrt(n) is h's
    ci = Interval(seconds, seconds - h if math.isfinite(h) else NAN,
                  seconds + h if math.isfinite(h) else NAN, int(n), sd)
    return {"seconds": seconds, "seconds_ci": ci, "measured_seconds": measured,
            "timing_below_resolution": bool(timing.calibrated)}


def _cell(sampler: str, spp: int, cell_runs, records: dict, out_dir: Path, gt: GroundTruth,
          timing: CellTiming, target: dict | None) -> Cell:
    recs = [records[r.run_id] for r in cell_runs]
    moments = load_cell(out_dir, cell_runs[0].cell).moments
    stats = {m: _interval(m, [rec[m] for rec in recs]) for m in CELL_METRICS}
    b = cell_bias(moments.n, moments.mean, moments.pixel_variance(), gt.mean, gt.stderr,
                  [rec["mean_error"] for rec in recs])
    bias = Bias(**b, significant=bool(math.isfinite(b["lo"]) and (b["lo"] > 0 or b["hi"] < 0)))
    time_ = _cell_time(timing, recs)
    efficiency = {m.efficiency: _efficiency(stats[m.mse].mean, time_["seconds"]) for m in METRICS.values()}
    need = {m: repetitions_for_precision([rec[METRICS[m].mse] for rec in recs], PRECISION)
            for m in METRICS}
    return Cell(sampler=sampler, spp=spp, n=len(recs), **stats,
                rmse_of_mean_mse=Interval.of(rmse_ci([rec["mse_corrected"] for rec in recs])),
                rrmse_of_mean_relmse=Interval.of(rmse_ci([rec["relmse_corrected"] for rec in recs])),
                repetitions_for_10pct={m: need[m]["repetitions"] for m in METRICS},
                mse_rel_ci=need["mse"]["current_rel_halfwidth"],
                target_rel_ci=target["target_rel_ci"] if target else None,
                target_met=target["target_met"] if target else None,
                samples_needed=(target["runs_needed"] * spp if target and target["runs_needed"]
                                else None),
                bias=bias, **efficiency, **time_)


def _noise_floor(cells: dict, gt: GroundTruth, gt_dir) -> NoiseFloor:
    mses = [c.mse.mean for c in cells.values() if math.isfinite(c.mse.mean)]
    min_mse = min(mses) if mses else NAN
    return NoiseFloor(gt_dir=str(gt_dir), gt_spp=gt.spp, gt_variance=gt.variance, smallest_mse=min_mse,
                      fraction_of_smallest_mse=gt.variance / min_mse if min_mse > 0 else NAN,
                      warning=bool(min_mse > 0 and gt.variance > NOISE_FLOOR_FRACTION * min_mse))


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
    return (fit_slopes, ([r.spp for r in sampler_runs], [rec[METRICS[metric].mse] for rec in recs],
                         [_run_error(rec, metric) for rec in recs], fit_seed,
                         floor if metric == "mse" else None), {})


def analyze_group(g, runs, records: dict, out_dir: Path, gt_dir, metrics=("mse",),
                  calibration: dict | None = None, targets: dict | None = None,
                  cpu: bool = True) -> tuple:
    """(GroupResult, fits to run) of one (scene, integrator, resolution). Its slope fits (one per
    sampler and metric) come back as (metric, sampler, call) for `analyze` to run together, in
    parallel; the GroupResult's `slopes` are empty until then."""
    gt = load_ground_truth(gt_dir)
    cells: dict = {}
    mse_runs: dict = {}
    timings: dict = {}
    fit_calls: list = []
    samplers = list(dict.fromkeys(r.sampler for r in runs))
    done = {s: [r for r in runs if r.sampler == s and r.run_id in records] for s in samplers}
    for s in samplers:
        sampler_runs = done[s]
        for spp in sorted({r.spp for r in sampler_runs}):
            cell_runs = [r for r in sampler_runs if r.spp == spp]
            recs = [records[r.run_id] for r in cell_runs]
            cell = cell_runs[0].cell
            timings[(s, spp)] = cell_timing(recs, (calibration or {}).get(cell), cpu)
            cells[(s, spp)] = _cell(s, spp, cell_runs, records, out_dir, gt, timings[(s, spp)],
                                    (targets or {}).get(cell))
            mse_runs[(s, spp)] = {m: np.array([records[r.run_id][METRICS[m].mse] for r in cell_runs])
                                  for m in METRICS}
        if sampler_runs:
            fit_calls += [(metric, s, _slope_call(g, s, metric, sampler_runs, records, gt.variance))
                          for metric in metrics]
    return GroupResult(cells, {m: {} for m in metrics}, _noise_floor(cells, gt, gt_dir), timings,
                       mse_runs), fit_calls


# ---------------------------------------------------------------------------------------------------
# One study: its view of each scene's group (its samplers, its ladder, its metric)
# ---------------------------------------------------------------------------------------------------

def _speedup_draws(study, by_sampler: dict, group: GroupResult, target: float, seed: int) -> dict:
    """Bootstrap replicates of each sampler's speed-up over the baseline at the fixed target: each
    cell's repetitions resampled and its cost drawn from its t law."""
    rng = np.random.default_rng(seed)
    key = study.metric
    draws: dict = {s: [] for s in by_sampler}
    for _ in range(BOOTSTRAP):
        times = {}
        for s, cells in by_sampler.items():
            errs = [math.sqrt(max(float(np.mean(rng.choice(v, v.size))), 0.0))
                    for v in (group.mse_runs[(s, c.spp)][key] for c in cells)]
            secs = [group.timings[(s, c.spp)].draw(rng) for c in cells]
            times[s] = time_to_target(secs, errs, target)["seconds"]
        tb = times.get(study.baseline, NAN)
        for s, t in times.items():
            draws[s].append(tb / t if t and math.isfinite(t) and math.isfinite(tb) else NAN)
    return draws


def _speed(study, by_sampler: dict, group: GroupResult | None = None) -> Speed:
    """Time to a common target error and the speed-up over the baseline that gives, with a 95%
    bootstrap interval."""
    metric = study.metric
    best = {s: min((c.error(metric).mean for c in cells if c.error(metric).mean > 0), default=NAN)
            for s, cells in by_sampler.items()}
    target = study.settings.target_rmse
    auto = target is None
    if auto:
        vals = [v for v in best.values() if math.isfinite(v)]
        target = max(vals) if vals else NAN
    time_to = {}
    for s, cells in by_sampler.items():
        time_to[s] = TimeToTarget(**time_to_target([c.seconds for c in cells],
                                                   [c.error(metric).mean for c in cells], target)) \
            if math.isfinite(target) else TimeToTarget(NAN, "no data")
    tb = time_to[study.baseline].seconds if study.baseline in time_to else NAN
    speedup = {s: (tb / t.seconds) if t.seconds and math.isfinite(t.seconds) and math.isfinite(tb) else NAN
               for s, t in time_to.items()}
    lo, hi = {s: NAN for s in speedup}, {s: NAN for s in speedup}
    if group is not None and group.timings and math.isfinite(target) and study.baseline in by_sampler:
        seed = int(short_hash([study.name, [c.spp for cs in by_sampler.values() for c in cs]], 8), 16)
        for s, d in _speedup_draws(study, by_sampler, group, target, seed).items():
            d = np.array([x for x in d if math.isfinite(x)])
            if d.size >= BOOTSTRAP // 2:
                lo[s], hi[s] = (float(x) for x in np.percentile(d, [2.5, 97.5]))
    return Speed(target_rmse=target, target_auto=auto, time_to_target=time_to,
                 speedup_vs_baseline=speedup, speedup_lo=lo, speedup_hi=hi)


def _vs_baseline(study, cells: dict) -> dict:
    """Per sampler, against the baseline at each spp both have: MSE ratio and efficiency ratio."""
    base, metric = study.baseline, study.metric
    out = {}
    for s in study.samplers:
        rows = []
        for n in study.settings.spp:
            if (s, n) in cells and (base, n) in cells:
                c, b = cells[(s, n)], cells[(base, n)]
                r, lo, hi = _efficiency_ratio(c, b, metric)
                rows.append(BaselineComparison(
                    spp=n, mse_ratio=_ratio_ci(b.error_mse(metric), c.error_mse(metric)),
                    efficiency_ratio=r, efficiency_ratio_lo=lo, efficiency_ratio_hi=hi))
        out[s] = rows
    return out


def _top_efficiency(study, cells: dict) -> dict:
    """Per sampler, the efficiency at the top of its ladder, also relative to the baseline's."""
    top = {}
    for s in study.samplers:
        n = max((n for n in study.settings.spp if (s, n) in cells), default=None)
        if n is not None:
            top[s] = (n, cells[(s, n)])
    b = top[study.baseline][1] if study.baseline in top else None
    out = {}
    for s, (n, c) in top.items():
        r, lo, hi = _efficiency_ratio(c, b, study.metric) if b is not None else (NAN, NAN, NAN)
        out[s] = TopEfficiency(spp=n, efficiency=c.efficiency_of(study.metric), relative=r,
                               relative_lo=lo, relative_hi=hi)
    return out


def _scene_result(study, scene_ref, group: GroupResult) -> SceneResult:
    samplers, ladder = list(study.samplers), study.settings.spp
    cells = {key: c for key, c in group.cells.items() if key[0] in samplers and key[1] in ladder}
    by_sampler = {s: [cells[(s, n)] for n in ladder if (s, n) in cells] for s in samplers}
    slopes = group.slopes[study.metric]
    return SceneResult(
        scene=scene_ref.label, scene_name=scene_ref.name, overrides=scene_ref.overrides_dict,
        cells=[c for s in samplers for c in by_sampler[s]],
        slopes={s: slopes[s] for s in samplers if s in slopes},
        noise_floor=group.noise_floor, speed=_speed(study, by_sampler, group),
        vs_baseline=_vs_baseline(study, cells), efficiency=_top_efficiency(study, cells))


def _study_result(study, plan, group_results: dict) -> StudyResult:
    group_of: dict = {}
    for r in plan:
        if study.name in r.studies:
            group_of.setdefault(r.scene, r.group)
    settings, metric = study.settings, METRICS[study.metric]
    return StudyResult(
        name=study.name, description=study.description, experiment=study.experiment,
        integrator=study.integrator, samplers=list(study.samplers), baseline=study.baseline,
        metric=study.metric, metric_label=metric.label, mse_label=metric.mse_label,
        spp=list(settings.spp), repetitions=settings.repetitions,
        runs_per_spp=settings.runs_per_spp, samples_per_cell=settings.samples_per_cell,
        resolution=list(settings.resolution) if settings.resolution else None,
        gt_spp=settings.gt_spp, seed=study.seed, strip_spp=list(settings.strip_spp),
        scenes=[_scene_result(study, scene_ref, group_results[group_of[scene_ref]])
                for scene_ref in study.scenes if scene_ref in group_of])


# ---------------------------------------------------------------------------------------------------
# The experiment
# ---------------------------------------------------------------------------------------------------

def _floor_remedy(exp) -> str:
    """What lowers the reference's noise floor: a larger-reference profile when the file has one."""
    if "full" in exp.profiles and exp.profile != "full":
        return "a larger gt_spp (e.g. --profile full) lowers the floor"
    return "a larger gt_spp in the experiment file lowers the floor"


def span_text(values, spec: str = ".1f", sep: str = "-") -> str:
    """'lo-hi' of `values` as `spec` prints them, or the one value when both print alike (one scene
    is '7.2', not '7.2-7.2')."""
    lo, hi = format(min(values), spec), format(max(values), spec)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def _noise_floor_warnings(group_results: dict, log: Callable[[str], None], remedy: str) -> list[str]:
    flagged = [(g, v.noise_floor) for g, v in group_results.items() if v.noise_floor.warning]
    if flagged:
        fr = [100 * nf.fraction_of_smallest_mse for _, nf in flagged]
        log(f"warning: in {len(flagged)} of {len(group_results)} scenes "
            f"({', '.join(g[0].label for g, _ in flagged)}) "
            f"the reference's own variance is {span_text(fr)}% of the smallest MSE measured "
            f"(limit {100 * NOISE_FLOOR_FRACTION:.0f}%); it is subtracted from every MSE, but {remedy}")
    return [f"{group_name(g)}: ground-truth variance is {100 * nf.fraction_of_smallest_mse:.1f}% "
            f"of the smallest MSE (> {100 * NOISE_FLOOR_FRACTION:.0f}%)" for g, nf in flagged]


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
    group_results: dict = {}
    fit_calls: list = []
    for g, runs in groups.items():
        group_results[g], calls = analyze_group(g, runs, records, Path(out_dir), gts[g]["dir"],
                                                tuple(metrics_of[g]), calibration, targets, cpu)
        fit_calls += [(g, metric, s, call) for metric, s, call in calls]
    for (g, metric, s, _), (fit, typical) in zip(fit_calls, pmap([call for *_, call in fit_calls])):
        # Scatter of log error around the line far above what Gaussian pixel noise gives (~0.05):
        # the errors are heavy-tailed (rare, very bright samples), and so is every number built on them.
        group_results[g].slopes[metric][s] = SlopeFit.of(fit, ERRATIC_SIGMA, typical)
    studies = [_study_result(study, plan, group_results) for study in exp.studies]
    return Summary(
        experiment=exp.name, description=exp.description, profile=exp.profile, studies=studies,
        noise_floor={group_name(g): v.noise_floor for g, v in group_results.items()},
        warnings=_noise_floor_warnings(group_results, log, _floor_remedy(exp)), chains=_chains(group_results),
        ground_truth={group_name(g): {k: v for k, v in info.items() if k != "seeds"}
                      for g, info in gts.items()})
