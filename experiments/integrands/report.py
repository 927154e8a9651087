"""The integrand study's outputs: summary.json, report.md, one log-log plot per integrand kind and
manifest.json (experiments/integrands/study.py computes what they hold)."""
from __future__ import annotations

import datetime as _dt
import io
import math
import os
import sys
from pathlib import Path

from drtlab.experiments.files import atomic_write_bytes, atomic_write_json, atomic_write_text
from drtlab.experiments.integrands.functions import KINDS
from drtlab.experiments.provenance import git_info, machine_info, package_versions, peak_rss_mib


def plot_path(kind: str) -> str:
    return f"plots/rmse-{kind}.png"


def _fmt(x, digits: int = 2) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _slope(row: dict) -> str:
    f = row["fit"]
    if not f.get("ok"):
        return "no fit"
    return f"{_fmt(f['slope'])} [{_fmt(f['slope_lo'])}, {_fmt(f['slope_hi'])}]"


# ---------------------------------------------------------------------------------------------------
# Plots
# ---------------------------------------------------------------------------------------------------

def plot_kind(summary: dict, kind: str, path: Path) -> Path | None:
    """RMSE against N, one panel per integrand of `kind`, one series per point set (95% intervals of
    the RMSE as error bars, the fitted power law as a line)."""
    from drtlab.experiments.plotting import compact_pyplot, panel_grid, series_style
    names = [n for n, v in summary["integrands"].items() if v["kind"] == kind]
    if not names:
        return None
    plt = compact_pyplot()
    rows, cols = panel_grid(len(names))
    # Each panel's legend (point set and fitted slope) sits to its right: inside, it hid data.
    fig, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 3.0 * rows), squeeze=False)
    for k, name in enumerate(names):
        ax = axes[k // cols][k % cols]
        for i, ps in enumerate(summary["pointsets"]):
            row = next(r for r in summary["results"] if r["pointset"] == ps and r["integrand"] == name)
            st = series_style(i)
            ns = [c["n"] for c in row["cells"]]
            ys = [c["rmse"]["mean"] for c in row["cells"]]
            err = [[max(y - c["rmse"]["lo"], 0) for y, c in zip(ys, row["cells"])],
                   [max(c["rmse"]["hi"] - y, 0) for y, c in zip(ys, row["cells"])]]
            label = f"{ps} {_fmt(row['fit'].get('slope'))}"
            ax.errorbar(ns, ys, yerr=err, fmt=st["marker"], color=st["color"], mfc="white",
                        mec=st["color"], ms=4, capsize=2, elinewidth=0.7, label=label, zorder=3)
            line = row["fit"].get("line")
            if line:
                ax.plot(line["n"], line["median"], linestyle=st["linestyle"], color=st["color"], lw=0.9)
        ax.set_xscale("log", base=4)
        ax.set_yscale("log")
        ax.set_title(name)
        ax.set_xlabel("N (points)")
        ax.set_ylabel("RMSE of the estimate")
        ax.grid(True, which="both", lw=0.3, color="0.8")
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False, fontsize=6,
                  title="fitted slope", title_fontsize=6)
    for k in range(len(names), rows * cols):
        axes[k // cols][k % cols].axis("off")
    fig.suptitle(f"{kind} integrands: RMSE vs N, {summary['repetitions']} runs per point "
                 f"(profile {summary['profile']})")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return path


# ---------------------------------------------------------------------------------------------------
# report.md
# ---------------------------------------------------------------------------------------------------

def _matrix(summary: dict) -> list:
    names = [n for kind in KINDS for n, v in summary["integrands"].items() if v["kind"] == kind]
    by = {(r["pointset"], r["integrand"]): r for r in summary["results"]}
    short = {"discontinuous": "disc."}
    kinds = [short.get(k, k) for k in (summary["integrands"][n]["kind"] for n in names)]
    lines = ["| point set | expected (disc. / smooth) | " + " | ".join(
                 f"{n} ({k})" for n, k in zip(names, kinds)) + " |",
             "|---|---|" + "---|" * len(names)]
    for ps in summary["pointsets"]:
        e = summary["expected"].get(ps)
        exp = f"{e['rates']['discontinuous']} / {e['rates']['smooth']}" if e else "none stated"
        cells = []
        for n in names:
            r = by[ps, n]
            mark = " **(!)**" if r["verdict"].startswith("differs") else ""
            cells.append(_slope(r) + mark)
        lines.append(f"| {ps} | {exp} | " + " | ".join(cells) + " |")
    return lines


def _details(summary: dict) -> list:
    lines = ["| point set | integrand | kind | fitted slope [95%] | expected ± tolerance | verdict | "
             "lack-of-fit p | mean-error p | chain |", "|---|---|---|---|---|---|---|---|---|"]
    for r in summary["results"]:
        f = r["fit"]
        exp = "-" if r["expected"] is None else f"{r['expected']} ± {r['tolerance']}"
        bias = _fmt(r["bias_p"], 3) + (" **biased**" if r["biased"] else "")
        chain = "ok" if f.get("converged") else "not converged"
        lines.append(f"| {r['pointset']} | {r['integrand']} | {r['kind']} | {_slope(r)} | {exp} | "
                     f"{r['verdict']} | {_fmt(f.get('lack_of_fit_p'), 3)} | {bias} | {chain} |")
    return lines


def _findings(summary: dict) -> list:
    rows = [r for r in summary["results"] if r["verdict"].startswith("differs")]
    if not rows:
        return ["Every fitted slope agrees with its expected rate (within the 95% interval widened "
                "by the tolerance)."]
    out = [f"{len(rows)} of {len(summary['results'])} ladders differ from the expected rate. "
           "These are results, not failures of the study: each says the theory quoted (its basis "
           "below) does not describe this point set on this integrand at these N.", ""]
    for r in rows:
        exp = summary["expected"][r["pointset"]]
        out.append(f"- **{r['pointset']} on {r['integrand']}** ({r['kind']}): slope {_slope(r)}, "
                   f"expected {r['expected']} ± {r['tolerance']} ({r['verdict'][9:]}). "
                   f"Basis of the expected rate: {exp['basis']}.")
    notes = {r["pointset"]: summary["expected"][r["pointset"]].get("note") for r in rows}
    out += ["", *[f"Note on {ps}: {note}" for ps, note in notes.items() if note]]
    return out


def _bias_lines(summary: dict, biased: list) -> list:
    half = summary["point_grid"] / 2
    return ["**Mean error not zero**: " + ", ".join(
        f"{r['pointset']} on {r['integrand']} (p = {r['bias_p']:.2g}; mean error "
        f"{r['cells'][-1]['mean_error']['mean']:.2g} at N = {r['cells'][-1]['n']}, RMSE "
        f"{r['cells'][-1]['rmse']['mean']:.2g})" for r in biased) + ".", "",
        f"Points are float32 multiples of {summary['point_grid']:.3g} (`hashing.unit_float` keeps the "
        f"top 24 bits of a hash, rounding down), so each coordinate's mean is 1/2 - {half:.3g}: "
        f"an estimate carries a bias of about -{half:.3g} x (integral of df/dx + df/dy), "
        f"-{half:.3g} for x·y. A mean error of that size, visible only where the RMSE gets "
        "near 1e-7, is what the float32 points carry (sobol, zsobol, pmj02 and independent emit "
        "`unit_float` values directly), not a flaw of a construction; a larger one would be."]


def markdown(summary: dict) -> str:
    biased = [r for r in summary["results"] if r["biased"]]
    n_conv = sum(bool(r["fit"].get("converged")) for r in summary["results"])
    lines = [
        "# Integrand testbed: convergence rates of every point set", "",
        summary["description"] + ".", "",
        f"Profile **{summary['profile']}**: N = {', '.join(map(str, summary['n']))}; "
        f"{summary['repetitions']} runs per N (the point set's seed differs per run; a randomised "
        f"family also draws a new member per run); root seed {summary['seed']}. Points are "
        "`points(name, N, 2, seed)` (dimensions 0 and 1, the pixel slot: the values a render "
        "uses); the estimate is the mean of f over the N points, its error the difference to the "
        "closed-form integral.", "",
        "The slope b of RMSE(N) ∝ N^b is `slopes.fit_rmse_slope` (emcee, gamma model of the per-run "
        "squared errors) with its 95% credible interval. Verdict: *as expected* when the expected "
        "rate lies in the interval widened by the tolerance, else *differs: finding*. "
        "Lack-of-fit p < 0.001 means no single power law describes the ladder; mean-error p is a "
        "test that every cell's mean error is zero (flagged *biased* below "
        f"{summary['bias_alpha_per_ladder']:.2g}, a Sidak level over all ladders).", "",
        "## Fitted RMSE slopes", "", *_matrix(summary), "",
        "**(!)** marks a slope that differs from the expected rate.", "",
        "## Findings", "", *_findings(summary), "",
    ]
    if biased:
        lines += [*_bias_lines(summary, biased), ""]
    lines += ["## Plots", ""]
    lines += [f"![{k}]({plot_path(k)})" for k in KINDS if any(
        v["kind"] == k for v in summary["integrands"].values())]
    lines += ["", "## Every ladder", "", *_details(summary), "",
              f"Chains: {n_conv} of {len(summary['results'])} converged (acceptance in [0.15, 0.8] "
              "and more than 50 autocorrelation times).", "",
              "## Integrands", "", "| name | kind | definition |", "|---|---|---|"]
    lines += [f"| {n} | {v['kind']} | `{v['what']}` |" for n, v in summary["integrands"].items()]
    lines += ["", "## Expected rates", "", "| point set | discontinuous | smooth | tolerance | basis |",
              "|---|---|---|---|---|"]
    lines += [f"| {ps} | {e['rates']['discontinuous']} | {e['rates']['smooth']} | {e['tolerance']} | "
              f"{e['basis']} |" for ps, e in summary["expected"].items()]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------------
# Everything at once
# ---------------------------------------------------------------------------------------------------

def manifest(summary: dict, study, wall_seconds: float) -> dict:
    return {
        "experiment": "integrands", "profile": study.profile, "file": study.path,
        "file_hash": study.file_hash, "command": sys.argv,
        "finished": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git": git_info(), "packages": package_versions(), "machine": machine_info(),
        "seeds": {
            "root": study.seed,
            "points": "seed of run r at N = int(blake2b(['integrands', root, point set, N, r])[:8 hex])",
            "members": "a family's members at N: numpy default_rng(blake2b(['integrand-members', root, "
                       "integrand, N])), the same for every point set",
            "fits": "blake2b(['fit', root, point set, integrand]) & 0x7fffffff",
        },
        "wall_seconds": {"this_invocation": wall_seconds, **summary["wall_seconds"]},
        "peak_rss_mib": peak_rss_mib(),
        "environment": {k: os.environ.get(k) for k in ("WARP_CACHE_PATH", "OMP_NUM_THREADS")},
    }


def write_outputs(summary: dict, study, out: Path, wall_seconds: float) -> None:
    out = Path(out)
    (out / "plots").mkdir(parents=True, exist_ok=True)
    for kind in KINDS:
        plot_kind(summary, kind, out / plot_path(kind))
    atomic_write_json(out / "summary.json", summary)
    atomic_write_text(out / "report.md", markdown(summary))
    atomic_write_json(out / "manifest.json", manifest(summary, study, wall_seconds))
