"""From run records to the numbers a report needs: cells, slopes, speed against error, noise floor.

A cell is (scene, sampler, spp) over its repetitions. Error statistics use the noise-floor-corrected
MSE (MSE - Var_GT); the RMSE of a cell is sqrt(mean corrected MSE), whose 95% CI is the square root
of the Student-t interval of the corrected MSEs. The time of a cell is the median render time of its
repetitions (compile excluded): robust to a run slowed down by other work on the machine.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.groundtruth import load_ground_truth
from drtlab.experiments.metrics import CellAccumulator, mean_ci
from drtlab.experiments.seeds import short_hash
from drtlab.experiments.parallel import pmap
from drtlab.experiments.slopes import fit_slope

NOISE_FLOOR_FRACTION = 0.01
ERRATIC_SIGMA = 0.25        # log-error scatter above which a sampler's errors are called heavy-tailed
# The error a study ranks samplers by. "mse": RMSE over pixels and channels (noise floor removed).
# "relmse": relative MSE (x - y)^2 / (y^2 + 0.01), for scenes whose RMSE is dominated by a few very
# bright pixels (directly seen small lights), reported as its square root ("relative RMSE").
METRICS = {
    "mse": {"err": "rmse_of_mean_mse", "mse": "mse_corrected", "eff": "efficiency",
            "run": "rmse_corrected", "label": "RMSE", "mse_label": "MSE"},
    "relmse": {"err": "rrmse_of_mean_relmse", "mse": "relmse_corrected", "eff": "efficiency_relmse",
               "run": "rrmse_corrected", "label": "relative RMSE (√relMSE)", "mse_label": "relMSE"},
}
CELL_METRICS = ("rmse", "rmse_corrected", "mse", "mse_corrected", "relmse", "relmse_corrected", "mae",
                "ciede2000", "mean_error", "render_seconds", "compile_seconds", "wall_seconds")


def _sqrt_ci(ci: dict) -> dict:
    f = lambda v: math.sqrt(v) if v is not None and math.isfinite(v) and v > 0 else 0.0  # noqa: E731
    return {"mean": f(ci["mean"]), "lo": f(ci["lo"]) if math.isfinite(ci["lo"]) else float("nan"),
            "hi": f(ci["hi"]) if math.isfinite(ci["hi"]) else float("nan"), "n": ci["n"]}


def _interp_loglog(x0, y0, x1, y1, y):
    """x at which the log-log line through (x0, y0), (x1, y1) reaches y."""
    ly0, ly1 = math.log(y0), math.log(y1)
    if ly1 == ly0:
        return x1
    t = (math.log(y) - ly0) / (ly1 - ly0)
    return math.exp(math.log(x0) + t * (math.log(x1) - math.log(x0)))


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


def _ratio_ci(a: dict, b: dict) -> dict:
    """Ratio a/b of two means with a delta-method 95% interval on the log scale."""
    if not (a["mean"] > 0 and b["mean"] > 0):
        return {"ratio": float("nan"), "lo": float("nan"), "hi": float("nan")}
    r = a["mean"] / b["mean"]
    va = (a["sd"] / a["mean"]) ** 2 / a["n"] if a.get("n", 0) > 1 and math.isfinite(a.get("sd", float("nan"))) else float("nan")
    vb = (b["sd"] / b["mean"]) ** 2 / b["n"] if b.get("n", 0) > 1 and math.isfinite(b.get("sd", float("nan"))) else float("nan")
    s = math.sqrt(va + vb) if math.isfinite(va + vb) else float("nan")
    return {"ratio": r, "lo": r * math.exp(-1.96 * s) if math.isfinite(s) else float("nan"),
            "hi": r * math.exp(1.96 * s) if math.isfinite(s) else float("nan")}


def _group_name(g) -> str:
    sc, integ, res = g
    return f"{sc.key}__{integ}__{res[0]}x{res[1]}"


def _run_error(rec: dict, metric: str) -> float:
    if metric == "relmse":
        v = rec["relmse_corrected"]
        return math.sqrt(v) if v > 0 else float("nan")
    return rec["rmse_corrected"]


def analyze_group(g, runs, records, out_dir: Path, gt_dir, log, fits: list, metrics=("mse",)) -> dict:
    """Cells and noise floor of one (scene, integrator, resolution); its slope fits (one per sampler
    and metric) are appended to `fits` as (group, metric, sampler, call), to be run together (in
    parallel) by `analyze`."""
    from drtlab.experiments.runner import load_run_image
    gt = load_ground_truth(gt_dir)
    samplers = list(dict.fromkeys(r.sampler for r in runs))
    cells: dict = {}
    for s in samplers:
        s_runs = [r for r in runs if r.sampler == s and r.run_id in records]
        ladder = sorted({r.spp for r in s_runs})
        for spp in ladder:
            cell_runs = [r for r in s_runs if r.spp == spp]
            recs = [records[r.run_id] for r in cell_runs]
            acc = CellAccumulator()
            for r in cell_runs:                       # one image in memory at a time
                acc.add(load_run_image(out_dir, r.run_id))
            c = {"sampler": s, "spp": spp, "n": len(recs)}
            for m in CELL_METRICS:
                c[m] = mean_ci([rec[m] for rec in recs])
            c["rmse_of_mean_mse"] = _sqrt_ci(c["mse_corrected"])
            c["rrmse_of_mean_relmse"] = _sqrt_ci(c["relmse_corrected"])
            c["bias"] = acc.bias(gt.mean, gt.stderr, [rec["mean_error"] for rec in recs])
            c["bias"]["significant"] = bool(math.isfinite(c["bias"]["lo"]) and
                                            (c["bias"]["lo"] > 0 or c["bias"]["hi"] < 0))
            c["pixel_variance"] = c["bias"]["pixel_variance"]
            # Time per cell: the median over repetitions, robust to a run slowed by other load.
            c["seconds"] = float(np.median([rec["render_seconds"] for rec in recs]))
            t = c["seconds"]
            for m in METRICS.values():
                mse = c[m["mse"]]["mean"]
                c[m["eff"]] = 1.0 / (mse * t) if mse > 0 and t > 0 else float("nan")
            cells[(s, spp)] = c
        for metric in metrics:
            fit_seed = int(short_hash([g[0].key, g[1], s] + ([metric] if metric != "mse" else []), 8),
                           16) & 0x7FFFFFFF
            fits.append((g, metric, s, (fit_slope, ([r.spp for r in s_runs],
                                                    [_run_error(records[r.run_id], metric) for r in s_runs]),
                                        {"seed": fit_seed})))
    mses = [c["mse"]["mean"] for c in cells.values() if math.isfinite(c["mse"]["mean"])]
    min_mse = min(mses) if mses else float("nan")
    floor = {
        "gt_dir": str(gt_dir), "gt_spp": gt.spp, "gt_variance": gt.variance,
        "smallest_mse": min_mse,
        "fraction_of_smallest_mse": gt.variance / min_mse if min_mse > 0 else float("nan"),
    }
    floor["warning"] = bool(min_mse > 0 and gt.variance > NOISE_FLOOR_FRACTION * min_mse)
    return {"cells": cells, "slopes": {m: {} for m in metrics}, "noise_floor": floor}


def _study_scene(st, sc, gres: dict) -> dict:
    samplers = list(st.samplers)
    ladder = st.settings.spp
    K = METRICS[st.metric]
    # Study-level views of the group's cells: `err`, `err_mse` and `eff` are the study's metric.
    view = {}
    for key, c in gres["cells"].items():
        if key[0] in samplers and key[1] in ladder:
            view[key] = dict(c, err=c[K["err"]], err_mse=c[K["mse"]], eff=c[K["eff"]])
    gres = dict(gres, cells=view)
    cells = [view[(s, n)] for s in samplers for n in ladder if (s, n) in view]
    slopes = gres["slopes"][st.metric]
    out = {"scene": sc.label, "scene_name": sc.name, "overrides": sc.overrides_dict,
           "cells": cells, "slopes": {s: slopes[s] for s in samplers if s in slopes},
           "noise_floor": gres["noise_floor"]}
    # Speed against error.
    best = {}
    for s in samplers:
        cs = [gres["cells"][(s, n)] for n in ladder if (s, n) in gres["cells"]]
        best[s] = min((c["err"]["mean"] for c in cs if c["err"]["mean"] > 0),
                      default=float("nan"))
    target = st.settings.target_rmse
    auto = target is None
    if auto:
        vals = [v for v in best.values() if math.isfinite(v)]
        target = max(vals) if vals else float("nan")
    ttt = {}
    for s in samplers:
        cs = [gres["cells"][(s, n)] for n in ladder if (s, n) in gres["cells"]]
        ttt[s] = time_to_target([c["seconds"] for c in cs],
                                [c["err"]["mean"] for c in cs], target) \
            if math.isfinite(target) else {"seconds": float("nan"), "how": "no data"}
    base = st.baseline
    tb = ttt.get(base, {}).get("seconds", float("nan"))
    speed = {"target_rmse": target, "target_auto": auto, "time_to_target": ttt,
             "speedup_vs_baseline": {s: (tb / ttt[s]["seconds"]) if ttt[s]["seconds"] and
                                     math.isfinite(ttt[s]["seconds"]) and math.isfinite(tb) else float("nan")
                                     for s in samplers}}
    out["speed"] = speed
    # Comparisons against the baseline at each spp, and efficiency at the top of the ladder.
    comp = {}
    for s in samplers:
        rows = []
        for n in ladder:
            if (s, n) in gres["cells"] and (base, n) in gres["cells"]:
                c, b = gres["cells"][(s, n)], gres["cells"][(base, n)]
                rows.append({"spp": n,
                             "mse_ratio": _ratio_ci(b["err_mse"], c["err_mse"]),
                             "efficiency_ratio": (c["eff"] / b["eff"])
                             if b["eff"] and math.isfinite(b["eff"]) else float("nan")})
        comp[s] = rows
    out["vs_baseline"] = comp
    top = {}
    for s in samplers:
        n = max((n for n in ladder if (s, n) in gres["cells"]), default=None)
        if n is not None:
            top[s] = {"spp": n, "efficiency": gres["cells"][(s, n)]["eff"]}
    be = top.get(base, {}).get("efficiency", float("nan"))
    for s in top:
        top[s]["relative"] = top[s]["efficiency"] / be if be and math.isfinite(be) else float("nan")
    out["efficiency"] = top
    return out


def analyze(exp, plan, records: dict, out_dir: Path, gts: dict, log: Callable[[str], None]) -> dict:
    groups: dict = {}
    for r in plan:
        groups.setdefault(r.group, []).append(r)
    by_name = {st.name: st for st in exp.studies}
    needed: dict = {}
    for r in plan:
        for name in r.studies:
            needed.setdefault(r.group, {})[by_name[name].metric] = None
    fit_calls: list = []
    gres = {g: analyze_group(g, runs, records, Path(out_dir), gts[g]["dir"], log, fit_calls,
                             tuple(needed[g]))
            for g, runs in groups.items()}
    for (g, metric, s, _), f in zip(fit_calls, pmap([c for *_, c in fit_calls])):
        # Scatter of log error around the line far above what Gaussian pixel noise gives (~0.05):
        # the errors are heavy-tailed (rare, very bright samples), and so is every number built on them.
        f["erratic"] = bool(f.get("ok") and f["sigma"] > ERRATIC_SIGMA)
        gres[g]["slopes"][metric][s] = f
    studies = []
    for st in exp.studies:
        res_of = {}
        for r in plan:
            if st.name in r.studies:
                res_of.setdefault(r.scene, r.group)
        studies.append({
            "name": st.name, "description": st.description, "experiment": st.experiment,
            "integrator": st.integrator, "samplers": list(st.samplers), "baseline": st.baseline,
            "metric": st.metric, "metric_label": METRICS[st.metric]["label"],
            "mse_label": METRICS[st.metric]["mse_label"],
            "spp": list(st.settings.spp), "repetitions": st.settings.repetitions,
            "resolution": list(st.settings.resolution) if st.settings.resolution else None,
            "gt_spp": st.settings.gt_spp, "seed": st.seed,
            "strip_spp": list(st.settings.strip_spp),
            "scenes": [_study_scene(st, sc, gres[res_of[sc]]) for sc in st.scenes if sc in res_of],
        })
    warnings = [f"{_group_name(g)}: ground-truth variance is {100 * v['noise_floor']['fraction_of_smallest_mse']:.1f}% "
                f"of the smallest MSE (> {100 * NOISE_FLOOR_FRACTION:.0f}%)"
                for g, v in gres.items() if v["noise_floor"]["warning"]]
    flagged = [(g, v["noise_floor"]) for g, v in gres.items() if v["noise_floor"]["warning"]]
    if flagged:
        fr = [100 * nf["fraction_of_smallest_mse"] for _, nf in flagged]
        log(f"warning: in {len(flagged)} of {len(gres)} scenes ({', '.join(g[0].label for g, _ in flagged)}) "
            f"the reference's own variance is {min(fr):.1f}-{max(fr):.1f}% of the smallest MSE measured "
            f"(limit {100 * NOISE_FLOOR_FRACTION:.0f}%); it is subtracted from every MSE, but a larger "
            f"gt_spp (e.g. --profile full) lowers the floor")
    fits = [(g, s, f) for g, v in gres.items() for per in v["slopes"].values() for s, f in per.items()]
    chains = {
        "fits": len(fits),
        "converged": sum(1 for _, _, f in fits if f.get("converged")),
        "not_converged": [f"{g[0].label}/{s}" for g, s, f in fits if f.get("ok") and not f.get("converged")],
        "acceptance_fraction_range": [min((f["acceptance_fraction"] for *_, f in fits if f.get("ok")), default=float("nan")),
                                      max((f["acceptance_fraction"] for *_, f in fits if f.get("ok")), default=float("nan"))],
        "max_autocorr_time": max((max(f["autocorr_time"]) for *_, f in fits if f.get("ok")), default=float("nan")),
    }
    return {
        "experiment": exp.name, "description": exp.description, "profile": exp.profile,
        "studies": studies,
        "noise_floor": {_group_name(g): v["noise_floor"] for g, v in gres.items()},
        "warnings": warnings,
        "chains": chains,
    }
