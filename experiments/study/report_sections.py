"""The experiment-wide sections of report.md (ground truth and noise floor, cost models, slope-fit
diagnostics, where the runs rendered, how to reproduce) and the number formats every section uses."""
from __future__ import annotations

import math

from drtlab.experiments.stats.hypothesis_tests import Z_CI
from drtlab.experiments.study.noise_floor import NOISE_FLOOR_SHARE
from drtlab.experiments.study.results import Interval, Summary


def fmt(x, digits=3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if x == 0:
        return "0"
    a = abs(x)
    if a >= 1e4 or a < 1e-3:
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}"


def fmt_ci(m, lo, hi, digits=3) -> str:
    if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        return fmt(m, digits)
    return f"{fmt(m, digits)} [{fmt(lo, digits)}, {fmt(hi, digits)}]"


def ratio_text(x, lo, hi) -> str:
    """A ratio with its interval, as `2.1× [1.8, 2.4]`."""
    if x is None or not math.isfinite(x):
        return "–"
    txt = f"{fmt(x)}×"
    if lo is None or hi is None or math.isnan(lo) or math.isnan(hi):
        return txt
    return txt + (f" [{fmt(lo)}, {fmt(hi)}]" if math.isfinite(hi) else f" [{fmt(lo)}, ∞)")


def comparison_ratio(r, kind: str) -> str:
    """A comparison's ratio with its interval, or 'not resolved' (the estimate is no finding)."""
    if r is None:
        return "–"
    ok = r.speedup_resolved if kind == "speedup" else r.resolved
    if not ok:
        return "not resolved"
    return ratio_text(*r.ratio(kind))


def interval_text(iv: Interval) -> str:
    return fmt_ci(iv.mean, iv.lo, iv.hi)


def noise_floor_section(summary: Summary) -> list[str]:
    lines = ["## Ground truth and noise floor\n",
             "The reference is itself noisy: its mean per-pixel variance Var_GT adds to every measured MSE, "
             "and is subtracted from every MSE above (MAE and ΔE00 are not corrected: they carry about half "
             "of Var_GT ÷ MSE as a bias). What the subtraction leaves is its own error D, one offset for "
             "every cell of a scene, with standard deviation sd(D) = sqrt(2B/(B−1) Σ v²) ÷ values, from "
             "the reference's per-pixel variances v and its B batches. The limit is on D: "
             f"{Z_CI:g}·sd(D) must stay below {100 * NOISE_FLOOR_SHARE:.0f}% of the narrowest cell's 95% "
             "half-width of its mean MSE, so that the cell's interval still covers 94.9% of the time.\n",
             "| Scene / integrator / resolution | Reference spp | Var_GT | Smallest cell MSE | "
             f"Var_GT ÷ smallest MSE | sd(D) | {Z_CI:g}·sd(D) ÷ narrowest half-width |",
             "|---|---|---|---|---|---|---|"]
    for name, nf in summary.noise_floor.items():
        frac = nf.fraction_of_smallest_mse
        share = nf.share_of_half_width
        lines.append(f"| {name} | {nf.gt_spp} | {fmt(nf.gt_variance)} | {fmt(nf.smallest_mse)} | "
                     f"{fmt(100 * frac if frac is not None else float('nan'))}% | {fmt(nf.correction_sd)} | "
                     f"{fmt(100 * share)}%{' ⚠' if nf.warning else ''} |")
    if summary.warnings:
        lines.append("\n**Warnings:**\n")
        lines += [f"- {m}" for m in summary.warnings]
    lines.append("")
    return lines


def cost_section(summary: Summary) -> list[str]:
    """Each scene's cost models (one per sampler) and whether the machine's load moved."""
    lines = ["## Cost models\n",
             "CPU seconds of a batch = per call + repetitions × (per repetition + per sample × samples), "
             "fitted per scene and sampler to every timed batch (`stats/cost_model.py`); the relative "
             "residual sd is a batch's timing noise. A study's batches hold about the same number of "
             "samples, so the per-call and per-sample terms trade off against each other (one may come "
             "out negative within its noise); a cell's cost is their sum along the batches, which is "
             "well determined, with a 4.5% run-to-run factor (a process's speed, measured between fresh "
             "runs) in its interval.\n",
             "| Scene | Sampler | ns per sample | ms per repetition | ms per call | batches | "
             "residual sd |", "|---|---|---|---|---|---|---|"]
    seen = set()
    for study in summary.studies:
        for scene in study.scenes:
            for s, m in scene.costs.items():
                if (scene.scene, s) in seen:
                    continue
                seen.add((scene.scene, s))
                lines.append(f"| {scene.scene} | `{s}` | {fmt(1e9 * m.coef[2])} | {fmt(1e3 * m.coef[1])} | "
                             f"{fmt(1e3 * m.coef[0])} | {m.batches} | {fmt(100 * m.rel_sd)}% |")
    load = summary.load or {}
    if load.get("shifted"):
        lines.append(f"\n**The load moved:** {load['text']}.\n")
    elif load.get("batches"):
        lines.append(f"\nNo step in the machine's load: a step test over the {load['batches']} batches' "
                     f"residuals in time order gives p = {fmt(load['p'])} (reported below 0.01).\n")
    lines.append("")
    return lines


def diagnostics_section(summary: Summary) -> list[str]:
    ch = summary.chains
    lines = ["## Slope-fit diagnostics\n",
             f"Model (`slopes.fit_rmse_slope`): each run's MSE is Gamma-distributed with mean "
             f"A·N^(2b) and a coefficient of variation that changes smoothly (log-linearly) with N, so b is "
             f"the slope of the RMSE itself, the root of the mean MSE, whatever the shape of the per-run "
             f"law (heavy tails included); runs below the reference's noise floor count as censored. Flat "
             f"priors, emcee (differential-evolution moves, fixed seed). Lack of fit: an F test of the "
             f"cell means against one slope. The typical-error slope fits log RMSE = a + b·log N + ε per "
             f"run. {ch.converged} of {ch.fits} fits pass "
             f"the chain checks (mean acceptance fraction in [0.15, 0.8], chain longer than 50 "
             f"autocorrelation times); acceptance fractions {fmt(ch.acceptance_fraction_range[0])}–"
             f"{fmt(ch.acceptance_fraction_range[1])}, largest autocorrelation time "
             f"{fmt(ch.max_autocorr_time)} steps.\n",
             "| Scene | Sampler | Error | b | Lack of fit p | σ | Acceptance | τ | Converged | Points (dropped) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    seen = set()
    for study in summary.studies:
        for scene in study.scenes:
            for s, f in scene.slopes.items():
                if (scene.scene, s, study.metric) in seen or not f.ok:
                    continue
                seen.add((scene.scene, s, study.metric))
                lines.append(
                    f"| {scene.scene} | `{s}` | {study.metric_label} | {f.slope:.3f} | "
                    f"{fmt(f.lack_of_fit_p)} | {fmt(f.sigma)} | "
                    f"{f.acceptance_fraction:.2f} | {', '.join(f'{t:.1f}' for t in f.autocorr_time)} | "
                    f"{'yes' if f.converged else 'NO'} | {f.n_points} ({f.dropped}) |")
    lines.append("")
    return lines


def where_section(records: dict) -> list[str]:
    """How many runs each process rendered (`worker` in runs.csv: local, or a Dask worker)."""
    counts: dict[str, int] = {}
    for rec in records.values():
        w = rec.get("worker") or "local"
        counts[w] = counts.get(w, 0) + 1
    if not counts:
        return []
    return ["## Where the runs rendered\n",
            "; ".join(f"`{w}`: {n} runs" for w, n in sorted(counts.items())) + ".\n"]


def reproduce_command(exp, out_dir) -> str | None:
    """The command that reruns this study as printed, from any folder: the experiment by its
    built-in name or its file's absolute path, the profile, this output folder; None for an
    experiment given as a dict (it has no file)."""
    import shlex
    from pathlib import Path
    from drtlab.experiments.study.experiment_model import EXPERIMENT_DIR
    path = Path(exp.path).resolve()
    if "<dict>" in exp.sources or not path.is_file():
        return None
    target = exp.name if path.parent == EXPERIMENT_DIR.resolve() else str(path)
    return (f"drtlab experiment {shlex.quote(target)} --profile {shlex.quote(exp.profile)} "
            f"--out {shlex.quote(str(Path(out_dir).resolve()))}")


def reproduce_section(exp, out_dir) -> list[str]:
    command = reproduce_command(exp, out_dir)
    rerun = (f"`{command}`" if command else
             "`drtlab.run_experiment` with the same dict, profile and `out_dir`")
    return ["## Reproduce\n",
            f"{rerun} reruns only what is missing; "
            f"`--fresh` starts over (the ground truth cache in `results/ground-truth/` is kept). Every run's "
            f"seed is in `runs.csv`; versions, machine and timings are in `manifest.json`; all numbers above "
            f"are in `summary.json`.\n"]
