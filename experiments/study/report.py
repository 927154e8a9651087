"""`report.md` from the analysed summary (a `results.Summary`), with the figures of `figures`."""
from __future__ import annotations

import math
from pathlib import Path

from drtlab.experiments.study.analysis import span_text
from drtlab.experiments.stats.comparisons import ALPHA, DRAWS
from drtlab.experiments.stats.resolution import ERRATIC_SIGMA, TAIL_FRACTION, XI_MAX
from drtlab.experiments.study.run_store import CAL_BATCHES, MIN_TIMED_SECONDS
from drtlab.experiments.study.figures import plot_files, plot_study, slug, strip_job
from drtlab.experiments.study.ground_truth import GT_SAMPLER
from drtlab.experiments.files import atomic_write_text
from drtlab.experiments.error_metrics import METRICS
from drtlab.experiments.parallel import pmap
from drtlab.experiments.study.report_sections import (
    interval_text, comparison_ratio, cost_section, diagnostics_section, noise_floor_section, ratio_text,
    reproduce_section, where_section, fmt, fmt_ci,
)
from drtlab.experiments.study.report_sources import sources_section
from drtlab.experiments.study.results import SceneResult, StudyResult, Summary
from drtlab.experiments.stats.slopes import RESOLVED_WIDTH

ERRATIC_TXT = f"{ERRATIC_SIGMA:g} in log error (a factor {math.exp(ERRATIC_SIGMA):.2f})"

INTRO = (
    "**How to read this report.** Each scene isolates one distribution effect. Every sampler renders it "
    "at each sample count N of the ladder, several times with independent seeds, and each image is "
    "compared with a high-sample reference (the *ground truth*). The error is the RMSE over pixels and "
    "colour channels, after subtracting the reference's own noise. A convergence slope *b* says how "
    "fast the error falls: RMSE ∝ N^b, so b = −0.5 is plain Monte Carlo and a more negative b is "
    "faster; it is fitted to the RMSE itself (the root of the mean MSE over repetitions), and the "
    "*typical-error* slope (of the geometric mean of the runs' errors, what most single runs show) "
    "stands beside it where heavy tails make the two differ. Brackets are 95% intervals: log-t "
    "confidence intervals over repetitions for a cell's mean error; for fitted slopes the union of the "
    "likelihood fit's credible interval and the t-interval of a regression of the cells' log mean "
    "errors. `drtlab audit-intervals` measures every kind of interval printed here on simulated studies "
    "with a known truth.\n\n"
    "**Two figures of merit, defined once.** The *speed-up* is the baseline's render time over the "
    "sampler's to reach the same error: the *target*, at each N the larger of the two samplers' fitted "
    "RMSEs there, so the worse sampler sits at N itself and the better one is interpolated within its "
    "own ladder. It is the answer to *how much faster for the same quality*. The *efficiency ratio* at N "
    "is the sampler's 1/(MSE × seconds) over the baseline's at that same N; it equals the speed-up only "
    "where both samplers converge at the same rate (a faster-converging sampler gains more efficiency at "
    "larger N than it saves time at equal error), so an efficiency ratio of 2 means *the same quality in "
    "half the time* only at equal slopes. Above 1, both favour the sampler. Every speed-up, efficiency "
    "ratio and claim below is a row of the study's comparisons (`result.comparisons`, listed in full "
    "under each study) with its 95% interval, or *not resolved*.\n\n"
    "**Costs are a fitted model.** A render's CPU seconds are fitted per scene and sampler as "
    "overhead per call + overhead per repetition + seconds per sample × samples, over every timed batch "
    "of that sampler at every N (weighted least squares on relative residuals); a cell's cost is one "
    "repetition at its N with its share of a batch's call, with the model's interval. Speed-ups and "
    "efficiencies draw the fitted convergence laws (emcee posterior) and the cost models together, "
    f"{DRAWS} draws; their intervals are the draws' percentiles.\n\n"
    "**No claim without resolution.** A cell is *not resolved* when its largest run carries over half of "
    "its error, when dropping that run moves its mean below its interval, or when its sampler's errors "
    f"have a heavy upper tail (generalized Pareto shape above {XI_MAX:g} over the top "
    f"{TAIL_FRACTION:.0%} of its pooled runs, or a scatter about the fitted law above a factor "
    f"{math.exp(ERRATIC_SIGMA):.2f}): no interval of a mean can be trusted to cover then. A comparison involving such a cell is printed as *not "
    "resolved* and makes no claim. Claims (*better*, *worse*, *no difference*) come from the resolved "
    "comparisons, with the Benjamini-Hochberg correction over every test the report states "
    f"(speed-up or efficiency, and MSE ratio, per comparison) at a {ALPHA:.0%} false-discovery rate.\n")


def _rel(p: Path, base: Path) -> str:
    return str(Path(p).relative_to(base)).replace("\\", "/")


# ---------------------------------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------------------------------

IMAGES_DIR, PLOTS_DIR = "images", "plots"


def strip_name(exp, study, scene) -> str:
    """The file name of a study's image strip of `scene` (a SceneRef), in `images/`."""
    return f"{slug(study.name)}--{scene.label}.png" if len(exp.studies) > 1 else f"{scene.label}.png"


def figure_files(exp) -> list[str]:
    """Every figure a report of `exp` may write, relative to its folder; two studies whose names
    would give one file (`a b` and `a-b`) are refused (InputError), neither overwriting the other."""
    from drtlab.errors import InputError
    seen: dict = {}
    for i, study in enumerate(exp.studies):
        for f in [f"{IMAGES_DIR}/{strip_name(exp, study, scene)}" for scene in study.scenes] + \
                 [f"{PLOTS_DIR}/{n}" for n in plot_files(study.name).values()]:
            other = seen.setdefault(f, study.name)
            if other != study.name:
                raise InputError(f"study[{i}].name", f"'{study.name}' and '{other}' would write the same "
                                                     f"file ({f}): give the studies distinct names")
    return list(seen)


def _render_figures(exp, summary: Summary, plan, records: dict, out_dir: Path, gts: dict):
    """Every figure, in parallel (they are independent): one image strip per scene of each study
    (repetition 0), three plots per study. Returns (strips: (study, scene label) -> file,
    plots: study name -> {plot kind: file})."""
    plots_dir, images_dir = out_dir / PLOTS_DIR, out_dir / IMAGES_DIR
    plots_dir.mkdir(parents=True, exist_ok=True)
    images_dir.mkdir(parents=True, exist_ok=True)
    calls: list = []
    strips: dict = {}
    for study in exp.studies:
        for scene in study.scenes:
            g = next((r.group for r in plan if r.scene == scene and study.name in r.studies), None)
            if g is None:
                continue
            first = [r for r in plan if r.group == g and r.rep == 0 and r.run_id in records]
            run_ids = {(r.sampler, r.spp): r.cell for r in first}
            # The shown image's own HDR-FLIP (stored when the cell's flip_runs reaches repetition 0).
            flips = {(r.sampler, r.spp): records[r.run_id].get("flip") for r in first}
            name = strip_name(exp, study, scene)
            calls.append((strip_job, (f"{scene.label} ({study.name})", study.samplers,
                                      study.settings.strip_spp, gts[g]["dir"], run_ids, out_dir,
                                      images_dir / name), {"flips": flips}))
            strips[(study.name, scene.label)] = images_dir / name
    n_strips = len(calls)
    calls += [(plot_study, (study, plots_dir), {}) for study in summary.studies]
    results = pmap(calls)
    plots = {study.name: files for study, files in zip(summary.studies, results[n_strips:])}
    return strips, plots


# ---------------------------------------------------------------------------------------------------
# One study
# ---------------------------------------------------------------------------------------------------

def _study_intro(study: StudyResult) -> list[str]:
    lines = [f"## Study: {study.name}\n"]
    if study.description:
        lines.append(f"{study.description}\n")
    res = f"{study.resolution[0]}×{study.resolution[1]}" if study.resolution else "each scene's own"
    per_cell = (f" (equal samples: at least {study.samples_per_cell} per pixel in every cell, so that "
                f"rare bright samples are as likely in each)" if study.samples_per_cell else "")
    lines.append(
        f"Integrator `{study.integrator}`; samplers {', '.join(f'`{s}`' for s in study.samplers)} "
        f"(baseline `{study.baseline}`); N ∈ {study.spp}; {study.repetitions_text}{per_cell}; "
        f"resolution {res}; reference {study.gt_spp} spp (`{GT_SAMPLER}`, same integrator); "
        f"root seed {study.seed}.\n")
    if study.metric == "relmse":
        from drtlab.kernels.error_sums import REL_EPS
        lines.append(
            f"This study ranks samplers by the {study.metric_label}: the relative MSE (x − y)² / (y² + {REL_EPS:g}) "
            f"weighs every pixel alike, where the plain MSE would be dominated by a few very bright pixels "
            f"(directly visible small lights, whose antialiasing noise no strategy changes). "
            f"Slopes, speed-ups and efficiencies below use it; the cell table also lists the RMSE.\n")
    elif study.metric != "mse":
        m = METRICS[study.metric]
        lines.append(f"This study ranks samplers by the {m.label}, the root of `{m.name}` (a plugin's metric: "
                     f"{m.description or 'no description'}). Slopes, speed-ups and efficiencies below use "
                     f"it; the cell table also lists the RMSE.\n")
    return lines


CLAIM_MARK = {"better": "**better**", "worse": "**worse**", "no difference": "no difference",
              "not resolved": "not resolved"}


def _table_row(study: StudyResult, scene: SceneResult, s: str) -> str:
    base, top_n = study.baseline, study.spp[-1]
    fit = scene.fit(s)
    slope = fmt_ci(fit.slope, fit.slope_lo, fit.slope_hi) if fit else "–"
    if fit and fit.resolved is False:
        slope += " §"
    if fit and fit.erratic:
        slope += " ‡"
    typical = fmt_ci(fit.typical_slope, fit.typical_slope_lo, fit.typical_slope_hi) \
        if fit and fit.typical_slope is not None else "–"
    top = scene.cell(s, top_n)
    error = (interval_text(top.error(study.metric)) + ("" if top.resolved is not False else " ◊")) if top else "–"
    r = scene.row(s, top_n)
    if s == base:
        return (f"| {scene.scene} | `{s}` | {slope} | {typical} | {error} | 1 (baseline) | – | – | – |")
    mr = "–" if r is None else ("not resolved" if not r.resolved else
                                fmt_ci(1 / r.mse_ratio, 1 / r.mse_ratio_hi, 1 / r.mse_ratio_lo))
    claim = CLAIM_MARK[r.claim] if r else "–"
    return (f"| {scene.scene} | `{s}` | {slope} | {typical} | {error} | {mr} | {comparison_ratio(r, 'speedup')} | "
            f"{comparison_ratio(r, 'efficiency')} | {claim} |")


def _study_table(study: StudyResult) -> list[str]:
    E, M, base, top_n = study.metric_label, study.mse_label, study.baseline, study.spp[-1]
    lines = [f"| Scene | Sampler | Slope b [95% interval] | Typical-error slope | {E} at N={top_n} [95% CI] | "
             f"{M} ÷ {base}'s at N={top_n} | Speed-up vs {base} at equal error [95%] | "
             f"Efficiency ratio vs {base} at N={top_n} [95%] | Claim |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [_table_row(study, scene, s) for scene in study.scenes for s in study.samplers]
    lines.append("")
    if any(scene.slopes[s].resolved is False for scene in study.scenes for s in study.samplers
           if s in scene.slopes):
        lines.append(f"§ slope not resolved: the 95% interval is wider than {RESOLVED_WIDTH}, one run "
                     "carries nearly all of a cell's error, or the likelihood fit and the regression of "
                     "the cell means disagree, so these runs cannot tell N^-0.5 from N^-0.75 "
                     "or N^-1 (rare, huge samples that most runs miss); more samples per cell "
                     "(`samples_per_cell`, `repetitions`) resolve it.\n")
    if any(scene.slopes[s].erratic for scene in study.scenes for s in study.samplers if s in scene.slopes):
        lines.append("‡ heavy-tailed errors: the scatter around the fitted line is over "
                     f"{ERRATIC_TXT}, far above pixel noise; the slope is poorly determined.\n")
    if any(c.resolved is False for scene in study.scenes for c in scene.cells):
        lines.append("◊ cell not resolved (reasons in the cell table): its interval is printed, but no "
                     "comparison built on it makes a claim.\n")
    lines.append(f"Target {E} of the speed-ups at N={top_n} (each comparison's: the larger of the two fitted "
                 f"{E}s there): " + "; ".join(_targets(study, scene) for scene in study.scenes) + ".\n")
    return lines


def _targets(study: StudyResult, scene: SceneResult) -> str:
    """A scene's target errors at the top of the ladder, one per compared sampler (each pair has its
    own: the larger of its two fitted errors)."""
    rows = [scene.row(s, study.spp[-1]) for s in study.samplers if s != study.baseline]
    rows = [r for r in rows if r is not None]
    if len(rows) == 1:
        return f"{scene.scene} {fmt(rows[0].target_rmse)}"
    return f"{scene.scene} " + ", ".join(f"{fmt(r.target_rmse)} (`{r.sampler}`)" for r in rows) if rows else \
        f"{scene.scene} –"


def _finding(study: StudyResult, scene: SceneResult, s: str) -> str:
    """One sampler against the baseline, in words: its claim at the top of the ladder, the figures
    behind it, and the slopes."""
    base, top_n, M = study.baseline, study.spp[-1], study.mse_label
    fit, bfit = scene.fit(s), scene.fit(base)
    r = scene.row(s, top_n)
    txt = f"`{s}`"
    if fit and bfit:
        rate = (f"N^{fit.slope:.2f} (95% interval {fit.slope_lo:.2f} to {fit.slope_hi:.2f})"
                if fit.stated else
                f"a rate these {'heavy-tailed ' if fit.erratic else ''}runs do not resolve (95% "
                f"interval N^{fit.slope_lo:.2f} to N^{fit.slope_hi:.2f})")
        base_rate = (f"N^{bfit.slope:.2f}" if bfit.stated else
                     f"an unresolved{' (heavy-tailed)' if bfit.erratic else ''} rate")
        txt += f" converges as {rate} against {base_rate} for `{base}`"
    if r is None:
        return txt
    if not r.resolved:
        return txt + f"; **not resolved** at N={top_n} ({r.why}): no claim is made"
    ratio, lo, hi = r.ratio(r.claim_on)
    what = "reaches the target error"
    if r.claim == "no difference":
        txt += (f"; it makes **no resolved difference** at N={top_n} ({'speed-up' if r.claim_on == 'speedup' else 'efficiency ratio'} "
                f"{fmt(ratio)}×, 95% CI {fmt(lo)}–{fmt(hi)}×)")
    else:
        if r.claim_on == "speedup":
            txt += (f"; it {what} {fmt(ratio)}× faster (95% CI {fmt(lo)}–{fmt(hi)}×)" if ratio >= 1 else
                    f"; it needs {fmt(1 / ratio)}× more render time to reach the target error "
                    f"(95% CI {fmt(1 / hi)}–{fmt(1 / lo)}×)")
        else:
            txt += f"; its efficiency ratio at N={top_n} is {fmt(ratio)}× (95% CI {fmt(lo)}–{fmt(hi)}×)"
        txt += f": **{r.claim}** (adjusted p = {fmt(r.p_adjusted)})"
    m_lo, m_hi = 1 / r.mse_ratio_hi, 1 / r.mse_ratio_lo
    if r.mse_claim in ("better", "worse"):
        txt += (f"; at N={top_n} its {M} is {fmt(r.mse_ratio)}× lower (95% CI {fmt(r.mse_ratio_lo)}–"
                f"{fmt(r.mse_ratio_hi)})" if r.mse_ratio >= 1 else
                f"; at N={top_n} its {M} is {fmt(1 / r.mse_ratio)}× higher (95% CI {fmt(m_lo)}–{fmt(m_hi)})")
    else:
        txt += f"; its {M} at N={top_n} is not distinguishable from the baseline's (ratio {fmt(1 / r.mse_ratio)}, 95% CI {fmt(m_lo)}–{fmt(m_hi)})"
    return txt


def _repetitions_needed(study: StudyResult, scene: SceneResult, samplers: list[str]) -> str:
    """How many repetitions the heavy-tailed cells would need for a ±10% mean MSE (a lower bound:
    a small sample usually misses its own rare, huge values)."""
    counts = [c.repetitions_for_10pct.get(study.metric) for c in scene.cells if c.sampler in samplers]
    counts = [n for n in counts if n]
    if not counts:
        return ""
    return (f"; a ±10% {study.mse_label} per cell would need at least {span_text(counts, 'd', '–')} "
            f"repetitions (now: {study.repetitions_text})")


def _findings(study: StudyResult) -> list[str]:
    lines = ["**Findings.**\n"]
    for scene in study.scenes:
        bits = [_finding(study, scene, s) for s in study.samplers if s != study.baseline]
        erratic = [s for s in study.samplers if s in scene.slopes and scene.slopes[s].erratic]
        if erratic:
            need = _repetitions_needed(study, scene, erratic)
            bits.append(f"**heavy tails**: the errors of {', '.join(f'`{s}`' for s in erratic)} scatter "
                        f"far more than pixel noise explains (rare, very bright samples), so a few "
                        f"repetitions cannot pin this scene's slope or ratios down" + need)
        biased = [f"{c.sampler}@{c.spp}" for c in scene.cells if c.bias.significant]
        b_txt = (f" Bias screen: the mean error differs from 0 in {', '.join(biased)} (Benjamini-Hochberg "
                 f"over every cell of the experiment at a 5% false-discovery rate)." if biased else "")
        lines.append(f"- **{scene.scene}**: " + ("; ".join(bits) if bits else "baseline only") + "." + b_txt)
    lines.append("")
    return lines


def _figure_links(study: StudyResult, study_cfg, plots: dict, strips: dict, out_dir: Path) -> list[str]:
    E = study.metric_label
    lines = [f"![{study.name}: {cap}]({_rel(plots[key], out_dir)})\n"
             for key, cap in (("rmse_vs_spp", f"{E} vs samples per pixel"),
                              ("rmse_vs_seconds", f"{E} vs render time"),
                              ("efficiency", "Speed-up and efficiency ratio"))]
    lines.append("Image strips (repetition 0; the crop is marked on the reference):\n")
    for scene in study_cfg.scenes:
        p = strips.get((study_cfg.name, scene.label))
        if p is not None:
            lines.append(f"![{scene.label}]({_rel(p, out_dir)})\n")
    return lines


RESOLUTION_NOTE = (f"† the cell's batches took under {MIN_TIMED_SECONDS:g} s in all: cost from "
                   f"{CAL_BATCHES} timing-only batches.")


def _seconds(c) -> str:
    ci = c.seconds_ci
    return fmt_ci(c.seconds, ci.lo, ci.hi) if ci is not None else fmt(c.seconds)


def _resolution_warning(study: StudyResult) -> list[str]:
    low = [f"{scene.scene}/{c.sampler}@{c.spp}" for scene in study.scenes for c in scene.cells
           if c.timing_below_resolution]
    if not low:
        return []
    return [f"**Too short to time** in {len(low)} of {sum(len(sc.cells) for sc in study.scenes)} "
            f"cells (batches under {MIN_TIMED_SECONDS:g} s in all: "
            f"{', '.join(low[:8])}{', ...' if len(low) > 8 else ''}): cost from timing-only batches.\n"]


def _precision_section(study: StudyResult) -> list[str]:
    """Which precision-targeted cells met their target and, for the rest, what they would need."""
    cells = [(scene.scene, c) for scene in study.scenes for c in scene.cells
             if c.target_rel_ci is not None]
    if not cells:
        return []
    met = [x for x in cells if x[1].target_met]
    target = cells[0][1].target_rel_ci
    lines = [f"**Precision target** (95% interval of a cell's mean MSE within ±{100 * target:g}%): "
             f"{len(met)} of {len(cells)} cells met it.", ""]
    missed = [x for x in cells if not x[1].target_met]
    if missed:
        lines += ["| Scene | Sampler | N | Repetitions | Reached ± | Samples per pixel it would need |",
                  "|---|---|---|---|---|---|"]
        for scene, c in missed:
            need = f"≥ {c.samples_needed:,}" if c.samples_needed else "–"
            lines.append(f"| {scene} | `{c.sampler}` | {c.spp} | {c.n} | {fmt(100 * c.mse_rel_ci)}% | "
                         f"{need} |")
        lines.append("\nA heavy-tailed cell underestimates its spread from few repetitions, so what it "
                     "would need is a lower bound.\n")
    return lines + [""]


def _comparison_table(study: StudyResult) -> list[str]:
    """Every comparison of the study (each sampler against the baseline at each N)."""
    lines = ["<details><summary>Every comparison with the baseline (`result.comparisons`)</summary>\n",
             f"| Scene | Sampler | N | {study.mse_label} ratio ({study.baseline}'s ÷ sampler's) | "
             f"Efficiency ratio | Target {study.metric_label} | Sampler's N* | Speed-up | Claim | "
             f"Adjusted p | Not resolved because |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for scene in study.scenes:
        for r in scene.comparisons:
            sp = ratio_text(*r.ratio("speedup")) + (" (extrap.)" if r.extrapolated else "")
            lines.append(f"| {scene.scene} | `{r.sampler}` | {r.spp} | {ratio_text(*r.ratio('mse_ratio'))} | "
                         f"{ratio_text(*r.ratio('efficiency'))} | {fmt(r.target_rmse)} | "
                         f"{fmt(r.samples_to_target)} | {sp} | {r.claim} (on {r.claim_on}) | "
                         f"{fmt(r.p_adjusted)} | {r.why or ''} |")
    lines.append("\nEstimates of comparisons that are not resolved are listed for completeness; they are "
                 "not findings.\n\n</details>\n")
    return lines


# The cell table's per-run columns beside the estimator's RMSE: (header, Cell field), each the mean
# [95% CI] of the runs that scored it (CIEDE2000 and FLIP: a cell's first runs).
PER_RUN_COLUMNS = (("relMSE", "relmse_corrected"), ("MAE", "mae"), ("ΔE00", "ciede2000"), ("FLIP", "flip"))


def _cell_table(study: StudyResult) -> list[str]:
    per_run = " | ".join(name for name, _ in PER_RUN_COLUMNS)
    lines = ["<details><summary>Every cell (mean [95% CI] over repetitions)</summary>\n",
             f"| Scene | Sampler | N | RMSE | {per_run} | Bias (mean error) | Pixel variance | "
             f"Render s per repetition [95% CI] (cost model) | Measured s (median) | "
             f"Efficiency 1/({study.mse_label}·s) | Resolved |",
             "|---" * (len(PER_RUN_COLUMNS) + 10) + "|"]
    for scene in study.scenes:
        for c in scene.cells:
            b = c.bias
            values = " | ".join(interval_text(getattr(c, f)) for _, f in PER_RUN_COLUMNS)
            lines.append(
                f"| {scene.scene} | `{c.sampler}` | {c.spp} | {interval_text(c.rmse_of_mean_mse)} | {values} | "
                f"{fmt_ci(b.signed, b.lo, b.hi)}{' ⚠' if b.significant else ''} | "
                f"{fmt(b.pixel_variance)} | {_seconds(c)} | {fmt(c.measured_seconds)}"
                f"{' †' if c.timing_below_resolution else ''} | {fmt(c.efficiency_of(study.metric))} | "
                f"{'yes' if c.resolved is not False else 'no: ' + (c.unresolved_why or '')} |")
    lines.append("\n" + RESOLUTION_NOTE + "\n\n</details>\n")
    return lines


# ---------------------------------------------------------------------------------------------------
# Experiment-wide sections
# ---------------------------------------------------------------------------------------------------

def write_report(exp, summary: Summary, plan, records: dict, out_dir: Path, gts: dict) -> None:
    """Figures under `plots/` and `images/`, then `report.md` and `report.html`, all in `out_dir`."""
    from drtlab.experiments.study.report_html import write_report_html
    out_dir = Path(out_dir)
    strips, plots = _render_figures(exp, summary, plan, records, out_dir, gts)
    lines = [f"# Experiment `{exp.name}` (profile `{exp.profile}`)\n", f"{exp.description}\n", INTRO]
    tables: dict = {}           # the page shows report.md's own table lines
    for study_cfg, study in zip(exp.studies, summary.studies):
        table, comparisons = _study_table(study), _comparison_table(study)
        tables[study.name] = table + comparisons
        lines += _study_intro(study)
        lines += table
        lines += _findings(study)
        lines += sources_section(study, study_cfg, out_dir)
        lines += _resolution_warning(study)
        lines += _precision_section(study)
        lines += _figure_links(study, study_cfg, plots[study.name], strips, out_dir)
        lines += comparisons
        lines += _cell_table(study)
    lines += noise_floor_section(summary)
    lines += cost_section(summary)
    lines += diagnostics_section(summary)
    lines += where_section(records)
    lines += reproduce_section(exp, out_dir)
    atomic_write_text(out_dir / "report.md", "\n".join(lines) + "\n")
    write_report_html(exp, summary, plan, records, out_dir, gts, plots, tables)
