"""Plots, image strips and `report.md` from the analysed summary.

Plots use the Agg backend and tell samplers apart by marker and line style (and hatch for bars) as
well as by colour, so they stay readable printed in black and white.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from drtlab.experiments.files import atomic_write_text
from drtlab.kernels.imageio import to_srgb
from drtlab.experiments.analysis import ERRATIC_SIGMA
from drtlab.experiments.parallel import pmap

ERRATIC_TXT = f"{ERRATIC_SIGMA:g} in log error (a factor {math.exp(ERRATIC_SIGMA):.2f})"

MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
LINESTYLES = ("-", "--", ":", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 2)), (0, (8, 2)), (0, (3, 1)))
HATCHES = ("", "///", "...", "xx", "\\\\\\", "++", "oo", "--")
COLOURS = ("#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#999999")


def slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.~-]+", "-", s).strip("-") or "study"


def _style(i: int) -> dict:
    return {"marker": MARKERS[i % len(MARKERS)], "linestyle": LINESTYLES[i % len(LINESTYLES)],
            "color": COLOURS[i % len(COLOURS)]}


def _plt():
    import matplotlib
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    plt.rcParams.update({"font.size": 8, "axes.titlesize": 9, "legend.fontsize": 7,
                         "savefig.dpi": 130, "figure.dpi": 100})
    return plt


def _grid(n: int):
    cols = min(3, n)
    rows = math.ceil(n / cols)
    return rows, cols


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


def _errbar(ax, xs, c_list, key, style, label):
    ys = [c[key]["mean"] for c in c_list]
    lo = [max(c[key]["mean"] - c[key]["lo"], 0) if math.isfinite(c[key]["lo"]) else 0 for c in c_list]
    hi = [max(c[key]["hi"] - c[key]["mean"], 0) if math.isfinite(c[key]["hi"]) else 0 for c in c_list]
    ax.errorbar(xs, ys, yerr=[lo, hi], fmt=style["marker"], color=style["color"], mfc="white",
                mec=style["color"], ms=5, capsize=2, elinewidth=0.8, label=label, zorder=3)


def plot_study(study: dict, plots_dir: Path) -> dict:
    plt = _plt()
    scenes = study["scenes"]
    sname = slug(study["name"])
    rows, cols = _grid(len(scenes))
    files = {}

    # 1. RMSE against spp, log-log, with the fitted line and its 95% credible band.
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.8 * rows), squeeze=False)
    for k, sc in enumerate(scenes):
        ax = axes[k // cols][k % cols]
        for i, s in enumerate(study["samplers"]):
            st = _style(i)
            cs = [c for c in sc["cells"] if c["sampler"] == s]
            if not cs:
                continue
            fit = sc["slopes"].get(s, {})
            label = s
            if fit.get("ok"):
                label = f"{s}: b={fit['slope']:.2f} [{fit['slope_lo']:.2f}, {fit['slope_hi']:.2f}]"
                ln = fit["line"]
                ax.plot(ln["n"], ln["median"], linestyle=st["linestyle"], color=st["color"], lw=1.2)
                ax.fill_between(ln["n"], ln["lo"], ln["hi"], color=st["color"], alpha=0.15, lw=0)
            _errbar(ax, [c["spp"] for c in cs], cs, "err", st, label)
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_title(sc["scene"])
        ax.set_xlabel("samples per pixel N")
        ax.set_ylabel(f"{study['metric_label']} (GT noise removed)")
        ax.grid(True, which="both", lw=0.3, color="0.8")
        ax.legend(loc="lower left", frameon=False)
    for k in range(len(scenes), rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle(f"{study['name']}: {study['metric_label']} vs samples (points: mean ± 95% CI; "
                 f"lines: fit ± 95% CrI)")
    fig.tight_layout()
    f = plots_dir / f"{sname}-rmse-vs-spp.png"
    fig.savefig(f)
    plt.close(fig)
    files["rmse_vs_spp"] = f

    # 2. RMSE against render seconds.
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.8 * rows), squeeze=False)
    for k, sc in enumerate(scenes):
        ax = axes[k // cols][k % cols]
        for i, s in enumerate(study["samplers"]):
            st = _style(i)
            cs = [c for c in sc["cells"] if c["sampler"] == s]
            if not cs:
                continue
            xs = [c["seconds"] for c in cs]
            ax.plot(xs, [c["err"]["mean"] for c in cs], linestyle=st["linestyle"],
                    color=st["color"], lw=1.0)
            _errbar(ax, xs, cs, "err", st, s)
        tgt = sc["speed"]["target_rmse"]
        if tgt and math.isfinite(tgt):
            ax.axhline(tgt, color="0.4", lw=0.8, linestyle=(0, (2, 2)))
            ax.annotate("target", (1.0, tgt), xycoords=("axes fraction", "data"), ha="right",
                        va="bottom", fontsize=6, color="0.3")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(sc["scene"])
        ax.set_xlabel("render seconds (median of repetitions, compile excluded)")
        ax.set_ylabel(study["metric_label"])
        ax.grid(True, which="both", lw=0.3, color="0.8")
        ax.legend(loc="lower left", frameon=False)
    for k in range(len(scenes), rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle(f"{study['name']}: {study['metric_label']} vs time")
    fig.tight_layout()
    f = plots_dir / f"{sname}-rmse-vs-seconds.png"
    fig.savefig(f)
    plt.close(fig)
    files["rmse_vs_seconds"] = f

    # 3. Efficiency 1/(MSE * seconds) at the top of the ladder, relative to the baseline.
    fig, ax = plt.subplots(figsize=(max(4.0, 1.1 * len(scenes) * len(study["samplers"]) * 0.6 + 2), 3.0))
    width = 0.8 / max(len(study["samplers"]), 1)
    xs = np.arange(len(scenes))
    allv = []
    for i, s in enumerate(study["samplers"]):
        vals = [sc["efficiency"].get(s, {}).get("relative", float("nan")) for sc in scenes]
        vals = [v if v and math.isfinite(v) and v > 0 else np.nan for v in vals]
        allv += [v for v in vals if np.isfinite(v)]
        pos = xs + (i - (len(study["samplers"]) - 1) / 2) * width
        ax.bar(pos, vals, width, label=s, color="white" if i == 0 else _style(i)["color"],
               alpha=1.0 if i == 0 else 0.55, edgecolor="black", hatch=HATCHES[i % len(HATCHES)], lw=0.8)
        for p_, v in zip(pos, vals):
            if np.isfinite(v):
                ax.annotate(f"{v:.2g}×", (p_, v), ha="center", va="bottom", fontsize=6,
                            xytext=(0, 1), textcoords="offset points")
    ax.axhline(1.0, color="black", lw=0.8)
    ax.set_yscale("log")
    if allv:
        ax.set_ylim(min(min(allv), 1.0) / 2.5, max(max(allv), 1.0) * 2.5)
    ax.set_xticks(xs)
    ax.set_xticklabels([sc["scene"] for sc in scenes], rotation=20, ha="right")
    ax.set_ylabel(f"efficiency / {study['baseline']}'s")
    ax.set_title(f"{study['name']}: efficiency 1/({study['mse_label']}·s) at the largest spp "
                 f"(higher is better)")
    ax.legend(frameon=False)
    ax.grid(True, axis="y", which="both", lw=0.3, color="0.8")
    fig.tight_layout()
    f = plots_dir / f"{sname}-efficiency.png"
    fig.savefig(f)
    plt.close(fig)
    files["efficiency"] = f
    return files


def choose_crop(gt: np.ndarray) -> tuple[int, int, int]:
    """(y, x, size) of a square crop where the reference has the most edge energy."""
    h, w = gt.shape[:2]
    size = min(h, w) if min(h, w) < 32 else max(16, min(h, w) // 2)
    lum = gt.mean(axis=2)
    gy, gx = np.gradient(lum)
    e = np.abs(gx) + np.abs(gy)
    ii = np.pad(e.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    best, by, bx = -1.0, 0, 0
    step = max(1, size // 8)
    for y in range(0, h - size + 1, step):
        for x in range(0, w - size + 1, step):
            v = ii[y + size, x + size] - ii[y, x + size] - ii[y + size, x] + ii[y, x]
            if v > best:
                best, by, bx = v, y, x
    return by, bx, size


def image_strip(scene_label: str, samplers, strip_spp, gt_mean, run_ids: dict, out_dir: Path,
                path: Path) -> None:
    """GT and each sampler at a few spp, the same crop; rows = samplers, columns = spp."""
    from drtlab.experiments.runner import load_run_image
    plt = _plt()
    y, x, size = choose_crop(gt_mean)
    ncol = 2 + len(strip_spp)
    nrow = len(samplers)
    fig, axes = plt.subplots(nrow, ncol, figsize=(1.45 * ncol, 1.55 * nrow + 0.3), squeeze=False)
    crop = lambda im: im[y:y + size, x:x + size]  # noqa: E731
    for r, s in enumerate(samplers):
        for c in range(ncol):
            ax = axes[r][c]
            ax.set_xticks([])
            ax.set_yticks([])
            if c == 0:
                if r == 0:
                    ax.imshow(to_srgb(gt_mean), interpolation="nearest")
                    ax.add_patch(__import__("matplotlib.patches", fromlist=["Rectangle"]).Rectangle(
                        (x - 0.5, y - 0.5), size, size, fill=False, ec="white", lw=1.0))
                    ax.add_patch(__import__("matplotlib.patches", fromlist=["Rectangle"]).Rectangle(
                        (x - 0.5, y - 0.5), size, size, fill=False, ec="black", lw=0.5, ls="--"))
                    ax.set_title("reference", fontsize=7)
                else:
                    ax.axis("off")
                continue
            if c == 1:
                if r == 0:
                    ax.imshow(to_srgb(crop(gt_mean)), interpolation="nearest")
                    ax.set_title("reference (crop)", fontsize=7)
                else:
                    ax.axis("off")
                continue
            n = strip_spp[c - 2]
            rid = run_ids.get((s, n))
            if rid is None:
                ax.axis("off")
                continue
            ax.imshow(to_srgb(crop(load_run_image(out_dir, rid))), interpolation="nearest")
            if r == 0:
                ax.set_title(f"{n} spp", fontsize=7)
            if c == 2:
                ax.set_ylabel(s, fontsize=7)
    fig.suptitle(scene_label, fontsize=8)
    fig.tight_layout(pad=0.3)
    fig.savefig(path)
    plt.close(fig)


def _strip_job(label, samplers, strip_spp, gt_dir, run_ids, out_dir, path):
    from drtlab.experiments.groundtruth import load_ground_truth
    image_strip(label, samplers, strip_spp, load_ground_truth(gt_dir).mean, run_ids, out_dir, path)
    return path


def _bound(sc: dict, s: str, base: str) -> str:
    """'≥' when the sampler beat the target at its first cell (its time is an upper bound), '≤' when
    the baseline did, '' when both times are interpolated."""
    ttt = sc["speed"]["time_to_target"]
    mine, theirs = ttt.get(s, {}).get("how"), ttt.get(base, {}).get("how")
    if s == base:
        return ""
    if mine == "at_most" and theirs != "at_most":
        return "≥"
    if theirs == "at_most" and mine != "at_most":
        return "≤"
    return ""


def _rel(p: Path, base: Path) -> str:
    return str(Path(p).relative_to(base)).replace("\\", "/")


def write_report(exp, summary: dict, plan, records: dict, out_dir: Path, gts: dict) -> None:
    out_dir = Path(out_dir)
    plots_dir = out_dir / "plots"
    images_dir = out_dir / "images"
    plots_dir.mkdir(parents=True, exist_ok=True)
    images_dir.mkdir(parents=True, exist_ok=True)

    # Figures are independent: render them in parallel (plots per study, one strip per scene).
    calls: list = []
    # Image strips: one per scene (per study's sampler set), repetition 0.
    strips: dict = {}
    for st, sd in zip(exp.studies, summary["studies"]):
        for sc in st.scenes:
            g = next((r.group for r in plan if r.scene == sc and st.name in r.studies), None)
            if g is None:
                continue
            run_ids = {(r.sampler, r.spp): r.run_id for r in plan
                       if r.group == g and r.rep == 0 and r.run_id in records}
            name = f"{slug(st.name)}--{sc.label}.png" if len(exp.studies) > 1 else f"{sc.label}.png"
            calls.append((_strip_job, (f"{sc.label} ({st.name})", st.samplers, st.settings.strip_spp,
                                       gts[g]["dir"], run_ids, out_dir, images_dir / name), {}))
            strips[(st.name, sc.label)] = images_dir / name
    study_files = {}
    for sd in summary["studies"]:
        calls.append((plot_study, (sd, plots_dir), {}))
    results = pmap(calls)
    for sd, files in zip(summary["studies"], results[-len(summary["studies"]):]):
        study_files[sd["name"]] = files

    lines: list[str] = []
    w = lines.append
    w(f"# Experiment `{exp.name}` (profile `{exp.profile}`)\n")
    w(f"{exp.description}\n")
    w("**How to read this report.** Each scene isolates one distribution effect. Every sampler renders it "
      "at each sample count N of the ladder, several times with independent seeds, and each image is "
      "compared with a high-sample reference (the *ground truth*). The error is the RMSE over pixels and "
      "colour channels, after subtracting the reference's own noise. A convergence slope *b* says how "
      "fast the error falls: RMSE ∝ N^b, so b = −0.5 is plain Monte Carlo and a more negative b is "
      "faster. Brackets are 95% intervals (confidence intervals over repetitions for measured values, "
      "credible intervals for fitted slopes). *Speed-up* compares the render time each sampler needs to "
      "reach the same error; *efficiency* is 1/(MSE × seconds), the usual figure of merit, so 2× "
      "efficiency means the same quality in half the time.\n")
    for st, sd in zip(exp.studies, summary["studies"]):
        files = study_files[sd["name"]]
        base = sd["baseline"]
        w(f"## Study: {sd['name']}\n")
        if sd["description"]:
            w(f"{sd['description']}\n")
        res = f"{sd['resolution'][0]}×{sd['resolution'][1]}" if sd["resolution"] else "each scene's own"
        w(f"Integrator `{sd['integrator']}`; samplers {', '.join(f'`{s}`' for s in sd['samplers'])} "
          f"(baseline `{base}`); N ∈ {sd['spp']}; {sd['repetitions']} repetitions per cell; resolution "
          f"{res}; reference {sd['gt_spp']} spp (`independent+importance`, same integrator); root seed "
          f"{sd['seed']}.\n")
        E, M = sd["metric_label"], sd["mse_label"]
        if sd["metric"] != "mse":
            w(f"This study ranks samplers by the {E}: the relative MSE (x − y)² / (y² + 0.01) weighs "
              f"every pixel alike, where the plain MSE would be dominated by a few very bright pixels "
              f"(directly visible small lights, whose antialiasing noise no strategy changes). "
              f"Slopes, speed-ups and efficiencies below use it; the cell table also lists the RMSE.\n")
        w(f"| Scene | Sampler | Slope b [95% CrI] | {E} at N={sd['spp'][-1]} [95% CI] | "
          f"{M} ÷ {base}'s at N={sd['spp'][-1]} | Time to target (s) | Speed-up vs {base} | "
          f"Efficiency vs {base} |")
        w("|---|---|---|---|---|---|---|---|")
        for sc in sd["scenes"]:
            for s in sd["samplers"]:
                fit = sc["slopes"].get(s, {})
                slope = fmt_ci(fit.get("slope"), fit.get("slope_lo"), fit.get("slope_hi")) if fit.get("ok") else "–"
                if fit.get("erratic"):
                    slope += " ‡"
                top = [c for c in sc["cells"] if c["sampler"] == s and c["spp"] == sd["spp"][-1]]
                rm = fmt_ci(top[0]["err"]["mean"], top[0]["err"]["lo"], top[0]["err"]["hi"]) if top else "–"
                vs = [x for x in sc["vs_baseline"].get(s, []) if x["spp"] == sd["spp"][-1]]
                mr = vs[0]["mse_ratio"] if vs else None
                mse_ratio = "1 (baseline)" if s == base else (
                    fmt_ci(1 / mr["ratio"], 1 / mr["hi"] if mr["hi"] else float("nan"),
                           1 / mr["lo"] if mr["lo"] else float("nan")) if mr else "–")
                ttt = sc["speed"]["time_to_target"].get(s, {})
                t_txt = fmt(ttt.get("seconds"))
                if ttt.get("how") in ("extrapolated", "at_most"):
                    t_txt += " (extrap.)" if ttt["how"] == "extrapolated" else " (≤)"
                sp = sc["speed"]["speedup_vs_baseline"].get(s)
                eff = sc["efficiency"].get(s, {}).get("relative")
                w(f"| {sc['scene']} | `{s}` | {slope} | {rm} | {mse_ratio} | {t_txt} | "
                  f"{_bound(sc, s, base)}{fmt(sp)}× | {fmt(eff)}× |")
        w("")
        if any(sc["slopes"].get(s, {}).get("erratic") for sc in sd["scenes"] for s in sd["samplers"]):
            w("‡ heavy-tailed errors: the scatter around the fitted line is over "
              f"{ERRATIC_TXT}, far above pixel noise; the slope is poorly determined.\n")
        w(f"Target {E} per scene: " + "; ".join(
            f"{sc['scene']} {fmt(sc['speed']['target_rmse'])}" + (" (auto: the lowest error every sampler reached)"
                                                                   if sc['speed']['target_auto'] and i == 0 else "")
            for i, sc in enumerate(sd["scenes"])) + ".\n")
        # Plain-language findings.
        w("**Findings.**\n")
        for sc in sd["scenes"]:
            bits = []
            bfit = sc["slopes"].get(base, {})
            for s in sd["samplers"]:
                if s == base:
                    continue
                fit = sc["slopes"].get(s, {})
                sp = sc["speed"]["speedup_vs_baseline"].get(s, float("nan"))
                vs = [x for x in sc["vs_baseline"].get(s, []) if x["spp"] == sd["spp"][-1]]
                txt = f"`{s}`"
                if fit.get("ok") and bfit.get("ok"):
                    txt += (f" converges as N^{fit['slope']:.2f} (95% CrI {fit['slope_lo']:.2f} to "
                            f"{fit['slope_hi']:.2f}) against N^{bfit['slope']:.2f} for `{base}`")
                if vs and math.isfinite(vs[0]["mse_ratio"]["ratio"]):
                    r = vs[0]["mse_ratio"]
                    txt += (f"; at N={sd['spp'][-1]} its {M} is {fmt(r['ratio'])}× lower "
                            f"(95% CI {fmt(r['lo'])}–{fmt(r['hi'])})" if r["ratio"] >= 1 else
                            f"; at N={sd['spp'][-1]} its {M} is {fmt(1 / r['ratio'])}× higher "
                            f"(95% CI {fmt(1 / r['hi'])}–{fmt(1 / r['lo'])})")
                if math.isfinite(sp) and sp > 0:
                    bound = {"≥": "at least ", "≤": "at most "}.get(_bound(sc, s, base), "")
                    txt += (f", and it reaches the target error {bound}{fmt(sp)}× faster" if sp >= 1 else
                            f", but it needs {fmt(1 / sp)}× more render time to reach the target error")
                bits.append(txt)
            erratic = [s for s in sd["samplers"] if sc["slopes"].get(s, {}).get("erratic")]
            if erratic:
                bits.append(f"**heavy tails**: the errors of {', '.join(f'`{s}`' for s in erratic)} scatter "
                            f"far more than pixel noise explains (rare, very bright samples), so a few "
                            f"repetitions cannot pin this scene's slope or ratios down; trust the intervals, "
                            f"not the point estimates")
            biased = [f"{c['sampler']}@{c['spp']}" for c in sc["cells"] if c["bias"]["significant"]]
            b_txt = (f" Bias screen: mean error differs from 0 at 95% in {', '.join(biased)} "
                     f"(expected in ~5% of cells by chance)." if biased else "")
            w(f"- **{sc['scene']}**: " + ("; ".join(bits) if bits else "baseline only") + "." + b_txt)
        w("")
        for key, cap in (("rmse_vs_spp", f"{E} vs samples per pixel"), ("rmse_vs_seconds", f"{E} vs render time"),
                         ("efficiency", "Relative efficiency")):
            w(f"![{sd['name']}: {cap}]({_rel(files[key], out_dir)})\n")
        w("Image strips (repetition 0; the crop is marked on the reference):\n")
        for sc in st.scenes:
            p = strips.get((st.name, sc.label))
            if p is not None:
                w(f"![{sc.label}]({_rel(p, out_dir)})\n")
        # Per-cell detail.
        w("<details><summary>Every cell (mean [95% CI] over repetitions)</summary>\n")
        w(f"| Scene | Sampler | N | RMSE | relMSE | MAE | ΔE00 | Bias (mean error) | Pixel variance | "
          f"Render s (median) | Efficiency 1/({M}·s) |")
        w("|---|---|---|---|---|---|---|---|---|---|---|")
        for sc in sd["scenes"]:
            for c in sc["cells"]:
                b = c["bias"]
                w(f"| {sc['scene']} | `{c['sampler']}` | {c['spp']} | "
                  f"{fmt_ci(c['rmse_of_mean_mse']['mean'], c['rmse_of_mean_mse']['lo'], c['rmse_of_mean_mse']['hi'])} | "
                  f"{fmt_ci(c['relmse_corrected']['mean'], c['relmse_corrected']['lo'], c['relmse_corrected']['hi'])} | "
                  f"{fmt_ci(c['mae']['mean'], c['mae']['lo'], c['mae']['hi'])} | "
                  f"{fmt_ci(c['ciede2000']['mean'], c['ciede2000']['lo'], c['ciede2000']['hi'])} | "
                  f"{fmt_ci(b['signed'], b['lo'], b['hi'])}{' ⚠' if b['significant'] else ''} | "
                  f"{fmt(c['pixel_variance'])} | {fmt(c['seconds'])} | {fmt(c['eff'])} |")
        w("\n</details>\n")

    w("## Ground truth and noise floor\n")
    w("The reference is itself noisy: its mean per-pixel variance Var_GT adds to every measured MSE. It is "
      "subtracted from every MSE above; it should stay below 1% of the smallest MSE measured.\n")
    w("| Scene / integrator / resolution | Reference spp | Var_GT | Smallest cell MSE | Var_GT ÷ smallest MSE |")
    w("|---|---|---|---|---|")
    for name, nf in summary["noise_floor"].items():
        w(f"| {name} | {nf['gt_spp']} | {fmt(nf['gt_variance'])} | {fmt(nf['smallest_mse'])} | "
          f"{fmt(100 * nf['fraction_of_smallest_mse'] if nf['fraction_of_smallest_mse'] is not None else float('nan'))}%"
          f"{' ⚠' if nf['warning'] else ''} |")
    if summary["warnings"]:
        w("\n**Warnings:**\n")
        for m in summary["warnings"]:
            w(f"- {m}")
    w("")
    ch = summary["chains"]
    w("## Slope-fit diagnostics\n")
    w(f"Model: log RMSE = a + b·log N + ε, ε ~ Normal(0, σ²), flat priors on a, b and log σ, fitted with "
      f"emcee (differential-evolution moves, fixed seed). {ch['converged']} of {ch['fits']} fits pass the "
      f"chain checks (mean acceptance fraction in [0.15, 0.8], chain longer than 50 autocorrelation "
      f"times); acceptance fractions {fmt(ch['acceptance_fraction_range'][0])}–"
      f"{fmt(ch['acceptance_fraction_range'][1])}, largest autocorrelation time "
      f"{fmt(ch['max_autocorr_time'])} steps.\n")
    w("| Scene | Sampler | Error | b | σ | Acceptance | τ (a, b, log σ) | Converged | Points (dropped) |")
    w("|---|---|---|---|---|---|---|---|---|")
    seen = set()
    for sd in summary["studies"]:
        for sc in sd["scenes"]:
            for s, f in sc["slopes"].items():
                if (sc["scene"], s, sd["metric"]) in seen or not f.get("ok"):
                    continue
                seen.add((sc["scene"], s, sd["metric"]))
                w(f"| {sc['scene']} | `{s}` | {sd['metric_label']} | {f['slope']:.3f} | {fmt(f['sigma'])} | {f['acceptance_fraction']:.2f} | "
                  f"{', '.join(f'{t:.1f}' for t in f['autocorr_time'])} | {'yes' if f['converged'] else 'NO'} | "
                  f"{f['n_points']} ({f['dropped']}) |")
    w("")
    w("## Reproduce\n")
    w(f"`drtlab experiment {exp.name} --profile {exp.profile}` reruns only what is missing; "
      f"`--fresh` starts over (the ground truth cache in `results/ground-truth/` is kept). Every run's "
      f"seed is in `runs.csv`; versions, machine and timings are in `manifest.json`; all numbers above "
      f"are in `summary.json`.\n")
    atomic_write_text(out_dir / "report.md", "\n".join(lines) + "\n")
