"""A decomposition's outputs: the printed table, sources.json, sources.png (the image, the map of the
group that holds most of each pixel's variance, and S and T per group with their intervals) and the
manifest."""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from drtlab.experiments.sources.decompose import PILOT_SPP, Sources

FILES = ("sources.json", "sources.png", "manifest.json")


# A Sobol' index is a share of the variance, so it lies in [0, 1]. An estimate, or an end of its 95%
# interval, further outside than this (a unit in the tables' last printed digit) says the
# decomposition's samples do not resolve the index (rare, very bright samples make the pick-freeze
# estimators heavy-tailed): the tables print "not resolved" beside it and the chart draws it hollow,
# unclipped.
INDEX_SLACK = 0.01
NOT_RESOLVED = "not resolved"


def index_resolved(v: float, lo: float, hi: float) -> bool:
    """Whether an index's estimate and 95% interval stay within [0, 1] (up to INDEX_SLACK)."""
    return all(-INDEX_SLACK <= x <= 1 + INDEX_SLACK for x in (v, lo, hi) if math.isfinite(x))


def group_resolved(row: dict, key: str) -> bool:
    """`index_resolved` of a group row's `key` index ("first_order" or "total")."""
    return index_resolved(row[key], row[f"{key}_lo"], row[f"{key}_hi"])


def table_lines(s: Sources) -> list[str]:
    """The printed table: one line per group, then the interaction remainder and the variance."""
    lines = [f"{s.scene}: {s.sampler}, {s.integrator}, {s.metric}, {s.samples} samples per pixel x "
             f"{len(s.groups) + 2} pick-freeze renders, {s.image.shape[1]}x{s.image.shape[0]}",
             f"  {'group':<10} {'first order S [95% CI]':<39} total T [95% CI]"]
    for r in s.indices["groups"]:
        cols = [_ci(r[k], r[f"{k}_lo"], r[f"{k}_hi"]) + ("" if group_resolved(r, k) else f" {NOT_RESOLVED}")
                for k in ("first_order", "total")]
        lines.append(f"  {r['group']:<10} {cols[0]:<39} {cols[1]:<39}".rstrip())
    lines.append(f"  {'1 - sum S':<10} {_ci(*s.indices['interaction']):<39} (interactions)")
    if not all(group_resolved(r, k) for r in s.indices["groups"] for k in ("first_order", "total")):
        lines.append(f"  {NOT_RESOLVED}: the estimate or its 95% interval lies outside [0, 1] (an index is "
                     f"a share): {s.samples} samples per pixel do not pin it; more (--spp) do")
    v, lo, hi = s.indices["variance"]
    what = "variance" if s.metric == "mse" else "relative variance (relMSE weights)"
    lines.append(f"  {what} of one sample, mean over pixels and channels: {v:.4g} [{lo:.4g}, {hi:.4g}]")
    return lines


def _ci(v, lo, hi) -> str:
    return f"{v:6.3f} [{lo:6.3f}, {hi:6.3f}]" if math.isfinite(v) else "   n/a"


def summary(s: Sources) -> dict:
    dom, share = s.dominant()
    counted = dom >= 0
    return {"scene": s.scene, "sampler": s.sampler, "integrator": s.integrator, "metric": s.metric,
            "samples_per_pixel": s.samples, "resolution": [int(s.image.shape[1]), int(s.image.shape[0])],
            "groups": s.indices["groups"],
            "interaction": dict(zip(("value", "lo", "hi"), map(float, s.indices["interaction"]))),
            "variance": dict(zip(("value", "lo", "hi"), map(float, s.indices["variance"]))),
            "dominant_pixels": {g: int(np.sum(dom == i)) for i, g in enumerate(s.groups)},
            "pixels_without_variance": int(np.sum(~counted)),
            "seconds": round(s.seconds, 3), "render_seconds": round(s.render_seconds, 3)}


def figure(s: Sources):
    """The decomposition's figure (a matplotlib Figure): the image, the map of the group holding most
    of each pixel's variance, and S and T per group with their intervals. Indices that are not
    resolved (`index_resolved`) are hollow dashed bars, drawn at their estimate, never clipped."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    from drtlab.experiments.plotting import COLOURS, compact_pyplot
    from drtlab.kernels.colour import to_srgb
    plt = compact_pyplot()
    fig, ax = plt.subplots(1, 3, figsize=(11.5, 3.2), gridspec_kw={"width_ratios": [1, 1, 1.15]})
    ax[0].imshow(to_srgb(s.image))
    ax[0].set_title(f"{s.scene}: mean of {s.samples} samples")
    dom, share = s.dominant()
    colours = [COLOURS[(i + 1) % len(COLOURS)] for i in range(len(s.groups))]
    rgb = np.asarray(ListedColormap(colours)(np.clip(dom, 0, None)))[..., :3]
    alpha = np.where(dom >= 0, np.nan_to_num(np.clip(share, 0, 1)), 0.0)[..., None]
    ax[1].imshow(rgb * alpha + (1 - alpha))           # white where the share is low or no variance
    ax[1].set_title("group with the largest total index\n(opacity: its share of the pixel's variance)")
    for i, g in enumerate(s.groups):
        ax[1].plot([], [], "s", color=colours[i], label=g)
    ax[1].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), frameon=False)
    for a in ax[:2]:
        a.set_xticks([])
        a.set_yticks([])
    rows = s.indices["groups"]
    x = np.arange(len(rows))
    ends = [0.0, 1.0]
    unresolved = False
    for k, (key, label) in enumerate((("first_order", "first order S"), ("total", "total T"))):
        v = np.array([r[key] for r in rows])
        err = np.array([[r[key] - r[f"{key}_lo"], r[f"{key}_hi"] - r[key]] for r in rows]).T
        ok = np.array([group_resolved(r, key) for r in rows])
        colour = ("#0072B2", "#D55E00")[k]
        bars = ax[2].bar(x + (k - 0.5) * 0.38, v, 0.38, yerr=np.nan_to_num(err), capsize=2, label=label,
                         color=colour, hatch=("", "///")[k], edgecolor="black", linewidth=0.4)
        for bar, good in zip(bars, ok):
            if not good:
                bar.set_facecolor("none")
                bar.set_edgecolor(colour)
                bar.set_linestyle("--")
                bar.set_linewidth(1.0)
        unresolved |= not ok.all()
        ends += [e for r in rows for e in (r[f"{key}_lo"], r[f"{key}_hi"]) if math.isfinite(e)]
    ax[2].axhline(1.0, color="0.3", lw=0.6, ls=":")
    ax[2].set_xticks(x, [r["group"] for r in rows])
    ax[2].set_ylim(min(0.0, min(ends) - 0.02), max(1.05, max(ends) + 0.05))
    ax[2].set_title(f"share of the {'' if s.metric == 'mse' else 'relative '}variance (95% CI); "
                    f"1 - sum S = {s.indices['interaction'][0]:.3f}")
    handles, labels = ax[2].get_legend_handles_labels()
    if unresolved:
        handles.append(Patch(facecolor="none", edgecolor="0.3", linestyle="--",
                             label=f"{NOT_RESOLVED}: outside [0, 1]"))
        labels.append(handles[-1].get_label())
    ax[2].legend(handles, labels, frameon=False)
    fig.tight_layout()
    return fig


def figure_png(s: Sources) -> bytes:
    from drtlab.experiments.plotting import png_bytes
    return png_bytes(figure(s))


def write_sources(s: Sources, out_dir: Path, argv=None) -> list[Path]:
    """sources.json, sources.png and manifest.json (the figure made first, each file atomic, the
    manifest last)."""
    import datetime as dt

    from drtlab.version import __version__
    from drtlab.experiments.files import atomic_write_bytes, atomic_write_json
    from drtlab.experiments.provenance import git_info, machine_info, package_versions, peak_rss_mib
    from drtlab.kernels import CODE_VERSION
    png = figure_png(s)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "sources.json", summary(s))
    atomic_write_bytes(out / "sources.png", png)
    atomic_write_json(out / "manifest.json", {
        "what": "drtlab sources", "command": argv if argv is not None else sys.argv,
        "finished": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"), "version": __version__,
        "code_version": CODE_VERSION, "git": git_info(),
        "seeds": {"scheme": "base sample n: pickfreeze seeds (seed + n) | code << 24, code 0 = A, "
                            f"255 = B, g + 1 = A_B^g; pilot: seed + samples, {PILOT_SPP} spp",
                  "seed": s.seed},
        "packages": package_versions(), "machine": machine_info(),
        "wall_seconds": round(s.seconds, 3), "render_seconds": round(s.render_seconds, 3),
        "peak_rss_mib": peak_rss_mib(), "files": list(FILES)})
    return [out / f for f in FILES]
