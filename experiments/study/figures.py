"""The report's figures: per-study plots (error vs samples, error vs time, relative efficiency) and
per-scene image strips, drawn with experiments/plotting.py (Agg, compact style, series styles that
stay readable in black and white).
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study.ground_truth import load_ground_truth
from drtlab.experiments.study.results import Cell, Interval, SceneResult, StudyResult
from drtlab.experiments.study.run_store import first_image
from drtlab.experiments.plotting import compact_pyplot, panel_grid, series_style
from drtlab.kernels.colour import to_srgb


def slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.~-]+", "-", s).strip("-") or "study"


def _half_widths(intervals: list[Interval | None], centres: list[float]) -> list[list[float]]:
    """[below, above] distances of each interval's ends from its centre (0 where it has none)."""
    lo, hi = [], []
    for iv, m in zip(intervals, centres):
        ok = iv is not None and math.isfinite(iv.lo) and math.isfinite(iv.hi)
        lo.append(max(m - iv.lo, 0) if ok else 0)
        hi.append(max(iv.hi - m, 0) if ok else 0)
    return [lo, hi]


def _errbar(ax, xs, intervals: list[Interval], style, label, x_intervals: list[Interval | None] | None = None):
    ys = [iv.mean for iv in intervals]
    xerr = _half_widths(x_intervals, xs) if x_intervals is not None else None
    ax.errorbar(xs, ys, yerr=_half_widths(intervals, ys), xerr=xerr, fmt=style["marker"],
                color=style["color"], mfc="white", mec=style["color"], ms=5, capsize=2, elinewidth=0.8,
                label=label, zorder=3)


# Past this many samplers a legend inside a panel covers data whatever corner it takes: one legend for
# the whole figure goes below the panels instead. Up to it, each panel keeps its own (with the slopes
# in its labels) in the first corner where it covers no point, line vertex or interval end
# (`_place_panel_legends`); where a panel has no such corner, the figure's legend replaces them all.
LEGEND_INSIDE_MAX = 3


def _data_points(ax) -> np.ndarray:
    """Display coordinates of every vertex the axes draws: markers, line vertices, interval ends."""
    pts = [line.get_transform().transform(line.get_xydata()) for line in ax.lines
           if len(line.get_xydata())]
    for coll in ax.collections:                      # errorbar segments, credible bands
        paths = coll.get_paths()
        if paths:
            pts += [coll.get_transform().transform(path.vertices) for path in paths]
    pts = [p for p in pts if len(p)]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def _covers(leg, ax, renderer) -> bool:
    """Whether the legend's box holds a data vertex of `ax`."""
    box = leg.get_window_extent(renderer)
    p = _data_points(ax)
    p = p[np.all(np.isfinite(p), axis=1)]
    return bool(np.any((p[:, 0] >= box.x0) & (p[:, 0] <= box.x1) & (p[:, 1] >= box.y0) & (p[:, 1] <= box.y1)))


LEGEND_CORNERS = ("lower left", "upper right", "lower right", "upper left")


def _place_panel_legends(fig) -> bool:
    """Each axes' own legend moved to the first corner where it covers none of its data; False
    when some panel has no such corner."""
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        for loc in LEGEND_CORNERS:
            leg.set_loc(loc)
            if not _covers(leg, ax, renderer):
                break
        else:
            return False
    return True


def series_handles(samplers: list[str]) -> list:
    """One legend entry per sampler in its series style (a figure's shared legend)."""
    from matplotlib.lines import Line2D
    out = []
    for i, s in enumerate(samplers):
        st = series_style(i)
        out.append(Line2D([], [], marker=st["marker"], linestyle=st["linestyle"], color=st["color"],
                          mfc="white", mec=st["color"], ms=5, lw=1.0, label=s))
    return out


LEGEND_ROW_INCHES = 0.22


def legend_below(fig, handles: list, ncol: int, top: float = 1.0) -> None:
    """`handles` as one legend centred below the figure's panels: the figure grows by the legend's
    rows and the panels are laid out above it (`top`: the panels' upper edge, a suptitle's room)."""
    rows = math.ceil(len(handles) / ncol)
    w, h = fig.get_size_inches()
    extra = LEGEND_ROW_INCHES * rows + 0.12
    fig.set_size_inches(w, h + extra)
    fig.legend(handles=handles, loc="lower center", ncol=ncol, frameon=False,
               bbox_to_anchor=(0.5, 0.0))
    fig.tight_layout(rect=(0, extra / (h + extra), 1, top))


Draw = Callable[..., None]      # draw(ax, scene, sampler, cells, style): one sampler in one panel


def _two_and_five_labels():
    """A log axis's minor-tick formatter that labels only 2 x and 5 x 10^k: matplotlib labels every
    minor tick of an axis showing fewer than two powers of ten, and in a 3.4-inch panel those labels
    run into each other."""
    from matplotlib.ticker import LogFormatterSciNotation

    class TwoAndFive(LogFormatterSciNotation):
        def __call__(self, x, pos=None):
            mantissa = x / 10.0 ** math.floor(math.log10(x)) if x > 0 else 0.0
            if not any(abs(mantissa - m) < 1e-6 for m in (2.0, 5.0)):
                return ""
            return super().__call__(x, pos)

    return TwoAndFive(labelOnlyBase=False)


def scene_panels(study: StudyResult, path: Path | None, draw: Draw, *, title: str, xlabel: str, ylabel: str,
            xscale: dict, extra: Callable[..., None] | None = None, outside_note: str | None = None):
    """One log-log panel per scene, one series per sampler (`draw`), then `extra(ax, scene)`;
    saved to `path` (returned), or without a path the matplotlib Figure itself (for a notebook).
    `outside_note` joins the title when the panels' legends give way to the figure's (it says where
    what their labels held went)."""
    plt = compact_pyplot()
    scenes = study.scenes
    rows, cols = panel_grid(len(scenes))
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.8 * rows), squeeze=False)
    inside = len(study.samplers) <= LEGEND_INSIDE_MAX
    for k, scene in enumerate(scenes):
        ax = axes[k // cols][k % cols]
        for i, s in enumerate(study.samplers):
            cells = [c for c in scene.cells if c.sampler == s]
            if cells:
                draw(ax, scene, s, cells, series_style(i))
        if extra is not None:
            extra(ax, scene)
        ax.set_xscale("log", **xscale)
        ax.set_yscale("log")
        if xscale.get("base", 10) == 10:
            ax.xaxis.set_minor_formatter(_two_and_five_labels())
        ax.yaxis.set_minor_formatter(_two_and_five_labels())
        ax.set_title(scene.scene)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", lw=0.3, color="0.8")
        if inside:
            ax.legend(loc="lower left", frameon=False)
    for k in range(len(scenes), rows * cols):
        axes[k // cols][k % cols].axis("off")
    # Wrapped to the figure's width: one panel is narrower than a study's title.
    fig.suptitle(title, wrap=True)
    fig.tight_layout()
    if inside and study.samplers and not _place_panel_legends(fig):
        inside = False
        for ax in fig.axes:
            if ax.get_legend() is not None:
                ax.get_legend().remove()
    if not inside:
        if outside_note:
            fig.suptitle(f"{title}; {outside_note}", wrap=True)
        legend_below(fig, series_handles(study.samplers), ncol=min(len(study.samplers), 4))
    if path is None:
        return fig
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_error_vs_spp(study: StudyResult, path: Path | None = None):
    """Error against spp, log-log, with the fitted line and its 95% credible band; a slope that is
    not `stated` (not resolved, or heavy-tailed runs) gets no line (its points and their intervals
    say all the runs know)."""
    def draw(ax, scene: SceneResult, s: str, cells: list[Cell], style: dict) -> None:
        fit = scene.fit(s)
        label = s
        if fit is not None:
            label = f"{s}: {fit.slope_text()}"
        if fit is not None and fit.stated and fit.line is not None:
            ax.plot(fit.line.n, fit.line.median, linestyle=style["linestyle"], color=style["color"], lw=1.2)
            ax.fill_between(fit.line.n, fit.line.lo, fit.line.hi, color=style["color"], alpha=0.15, lw=0)
        _errbar(ax, [c.spp for c in cells], [c.error(study.metric) for c in cells], style, label)

    return scene_panels(study, path, draw, xscale={"base": 2}, xlabel="samples per pixel N",
                   outside_note="each slope b with its 95% interval: the report's table",
                   ylabel=f"{study.metric_label} (GT noise removed)",
                   title=f"{study.name}: {study.metric_label} vs samples (points: mean ± 95% CI; "
                         f"lines: likelihood fit ± 95% CrI, where resolved)")


def plot_error_vs_seconds(study: StudyResult, path: Path | None = None):
    """Error against render seconds, with the scene's target error. A point's horizontal bar is its
    cost's 95% interval (`Cell.seconds_ci`: the cost model's t interval, the one the speed-ups and
    efficiencies draw from), its vertical bar the error's."""
    def draw(ax, scene: SceneResult, s: str, cells: list[Cell], style: dict) -> None:
        xs = [c.seconds for c in cells]
        errors = [c.error(study.metric) for c in cells]
        ax.plot(xs, [e.mean for e in errors], linestyle=style["linestyle"], color=style["color"], lw=1.0)
        _errbar(ax, xs, errors, style, s, x_intervals=[c.seconds_ci for c in cells])

    def target(ax, scene: SceneResult) -> None:
        # Each comparison at the top of the ladder has its own target (the larger of its pair's fitted
        # errors): one line per compared sampler, in its colour where there are several.
        rows = [(i, scene.row(s, study.spp[-1])) for i, s in enumerate(study.samplers) if s != study.baseline]
        rows = [(i, r) for i, r in rows if r is not None and r.target_rmse > 0 and math.isfinite(r.target_rmse)]
        for i, r in rows:
            colour = "0.4" if len(rows) == 1 else series_style(i)["color"]
            ax.axhline(r.target_rmse, color=colour, lw=0.8, linestyle=(0, (2, 2)))
        if len(rows) == 1:
            ax.annotate("target", (1.0, rows[0][1].target_rmse), xycoords=("axes fraction", "data"),
                        ha="right", va="bottom", fontsize=6, color="0.3")

    return scene_panels(study, path, draw, extra=target, xscale={},
                   xlabel="render seconds (calibrated cost, compile excluded)",
                   ylabel=study.metric_label,
                   title=f"{study.name}: {study.metric_label} vs time (points: mean ± 95% CI of the error; "
                         f"horizontal bars: 95% interval of the cost model; dotted: the speed-ups' target "
                         f"error at N={study.spp[-1]})")


def _plain_ratio_labels(major: bool):
    """Ratios as plain numbers (0.5, 2, 10): the major ticks, or of the minor ones only 2 x and
    5 x 10^k (labels on every minor tick of a log axis run into each other)."""
    from matplotlib.ticker import FuncFormatter

    def label(x, pos=None):
        if not x > 0:
            return ""
        mantissa = x / 10.0 ** math.floor(math.log10(x))
        return f"{x:g}" if major or any(abs(mantissa - m) < 1e-6 for m in (2.0, 5.0)) else ""
    return FuncFormatter(label)


# The efficiency figure's bounds: one panel per compared sampler, at most this many to a row, and the
# whole figure at most this wide and (before its legend) this tall, whatever the study's size.
EFF_MAX_COLS = 4
EFF_MAX_WIDTH = 9.0
EFF_MAX_HEIGHT = 5.6


def plot_efficiency(study: StudyResult, path: Path | None = None):
    """Speed-up at equal error and efficiency ratio at the largest N against the baseline (the
    report's definitions), as points with their 95% intervals on a log axis around 1, one panel per
    compared sampler with the scenes along x; comparisons that are not resolved are hollow grey
    markers at their estimate (they make no claim). Panels wrap into rows, so the figure stays within
    EFF_MAX_WIDTH x EFF_MAX_HEIGHT inches (plus its legend) for any number of samplers and scenes."""
    from matplotlib.lines import Line2D
    plt = compact_pyplot()
    scenes = study.scenes
    others = [s for s in study.samplers if s != study.baseline]
    top_n = study.spp[-1]
    kinds = (("speedup", "speed-up at equal error", "o"), ("efficiency", f"efficiency ratio at N={top_n}", "s"))
    n = max(1, len(others))
    cols = min(n, 3 if n <= 6 else EFF_MAX_COLS)
    rows = math.ceil(n / cols)
    width = min(EFF_MAX_WIDTH, cols * (1.6 + 0.8 * max(1, len(scenes))))
    height = min(EFF_MAX_HEIGHT, 3.2 * rows)
    fig, axes = plt.subplots(rows, cols, figsize=(width, height), squeeze=False, sharex=True, sharey=True)
    xs = np.arange(len(scenes))
    allv = [1.0]
    for i, s in enumerate(others):
        ax = axes[i // cols][i % cols]
        colour = series_style(study.samplers.index(s))["color"]
        for j, (kind, _, marker) in enumerate(kinds):
            for x, scene in zip(xs + (j - 0.5) * 0.3, scenes):
                r = scene.row(s, top_n)
                if r is None or not (r.ratio(kind)[0] > 0):
                    continue
                v, lo, hi = r.ratio(kind)
                ok = r.speedup_resolved if kind == "speedup" else r.resolved
                if ok and lo > 0 and hi > 0:
                    ax.errorbar([x], [v], yerr=[[v - lo], [hi - v]], fmt=marker, color=colour, ms=4,
                                capsize=2, lw=0.9)
                    allv += [lo, hi]
                else:
                    ax.plot([x], [v], marker, mfc="none", color="0.5", ms=4)
                    allv.append(v)
        ax.axhline(1.0, color="black", lw=0.8)
        ax.set_title(f"{s} vs {study.baseline}")
        ax.grid(True, axis="y", which="both", lw=0.3, color="0.8")
    for k in range(len(others), rows * cols):
        axes[k // cols][k % cols].axis("off")
    ax0 = axes[0][0]
    ax0.set_yscale("log")
    fin = [v for v in allv if np.isfinite(v) and v > 0]
    ax0.set_ylim(min(fin) / 1.5, max(fin) * 1.5)
    ax0.yaxis.set_major_formatter(_plain_ratio_labels(major=True))
    ax0.yaxis.set_minor_formatter(_plain_ratio_labels(major=False))
    for k in range(len(others)):
        ax = axes[k // cols][k % cols]
        ax.set_xticks(xs)
        # The scene names under the lowest panel of each column (sharex hides the others').
        if k + cols >= len(others):
            ax.tick_params(labelbottom=True)
            ax.set_xticklabels([scene.scene for scene in scenes], rotation=30, ha="right")
        if k % cols == 0:
            ax.set_ylabel(f"× {study.baseline} (above 1: better)")
    fig.suptitle(f"{study.name}: speed-up and efficiency ratio against {study.baseline}, 95% intervals",
                 wrap=True)
    fig.tight_layout()
    if others:                                   # a study of its baseline alone has nothing to mark
        handles = [Line2D([], [], marker=m, linestyle="none", color="0.15", ms=4, label=label)
                   for _, label, m in kinds]
        handles.append(Line2D([], [], marker="o", linestyle="none", mfc="none", color="0.5", ms=4,
                              label="hollow grey: not resolved (estimate only, no claim)"))
        legend_below(fig, handles, ncol=3, top=1.0)
    if path is None:
        return fig
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_files(study_name: str) -> dict:
    """The file names of a study's three plots: {"rmse_vs_spp", "rmse_vs_seconds", "efficiency"} -> name."""
    name = slug(study_name)
    return {"rmse_vs_spp": f"{name}-rmse-vs-spp.png", "rmse_vs_seconds": f"{name}-rmse-vs-seconds.png",
            "efficiency": f"{name}-efficiency.png"}


def plot_study(study: StudyResult, plots_dir: Path) -> dict:
    """The three plots of a study: {"rmse_vs_spp", "rmse_vs_seconds", "efficiency"} -> file."""
    names = plot_files(study.name)
    return {"rmse_vs_spp": plot_error_vs_spp(study, plots_dir / names["rmse_vs_spp"]),
            "rmse_vs_seconds": plot_error_vs_seconds(study, plots_dir / names["rmse_vs_seconds"]),
            "efficiency": plot_efficiency(study, plots_dir / names["efficiency"])}


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


def image_strip(scene_label: str, samplers, strip_spp, gt_mean, cells: dict, out_dir: Path,
                path: Path | None, flips: dict | None = None):
    """GT and each sampler at a few spp, the same crop; rows = samplers, columns = spp; under each
    crop its whole image's HDR-FLIP against the reference where `flips` has it ((sampler, spp) ->
    value). Saved to `path`, or without one the matplotlib Figure returned."""
    from matplotlib.patches import Rectangle
    plt = compact_pyplot()
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
            if c < 2:                              # the reference, whole and cropped: first row only
                if r > 0:
                    ax.axis("off")
                elif c == 0:
                    ax.imshow(to_srgb(gt_mean), interpolation="nearest")
                    ax.add_patch(Rectangle((x - 0.5, y - 0.5), size, size, fill=False, ec="white", lw=1.0))
                    ax.add_patch(Rectangle((x - 0.5, y - 0.5), size, size, fill=False, ec="black", lw=0.5,
                                           ls="--"))
                    ax.set_title("reference", fontsize=7)
                else:
                    ax.imshow(to_srgb(crop(gt_mean)), interpolation="nearest")
                    ax.set_title("reference (crop)", fontsize=7)
                continue
            n = strip_spp[c - 2]
            cell = cells.get((s, n))
            if cell is None:
                ax.axis("off")
                continue
            ax.imshow(to_srgb(crop(first_image(out_dir, cell))), interpolation="nearest")
            if r == 0:
                ax.set_title(f"{n} spp", fontsize=7)
            fl = (flips or {}).get((s, n))
            if fl is not None and math.isfinite(fl):
                ax.set_xlabel(f"FLIP {fl:.3f}", fontsize=6, labelpad=1)
            if c == 2:
                ax.set_ylabel(s, fontsize=7)
    fig.suptitle(scene_label, fontsize=8)
    fig.tight_layout(pad=0.3)
    if path is None:
        return fig
    fig.savefig(path)
    plt.close(fig)


def strip_job(label, samplers, strip_spp, gt_dir, cells, out_dir, path, flips=None) -> Path:
    """`image_strip` with the reference read from its folder (a job for `parallel.pmap`)."""
    image_strip(label, samplers, strip_spp, load_ground_truth(gt_dir).mean, cells, out_dir, path, flips)
    return path
