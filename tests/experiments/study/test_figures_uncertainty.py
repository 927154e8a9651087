"""The study figures show their uncertainty and keep it readable: time intervals on the error-vs-time
plot, legends that never cover a data point, and an efficiency figure of bounded size."""
from __future__ import annotations

import struct

import numpy as np

from drtlab.experiments.study import figures as F
from synthetic_study import synthetic_study


def _png_size(path) -> tuple[int, int]:
    with open(path, "rb") as f:
        head = f.read(24)
    return struct.unpack(">II", head[16:24])


def _covered(fig) -> list[str]:
    """Panels with a data vertex inside any legend's box (the panel's own or the figure's)."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [leg.get_window_extent(renderer) for leg in fig.legends]
    out = []
    for ax in fig.axes:
        own = [ax.get_legend().get_window_extent(renderer)] if ax.get_legend() else []
        p = F._data_points(ax)
        p = p[np.all(np.isfinite(p), axis=1)]
        for b in boxes + own:
            if np.any((p[:, 0] >= b.x0) & (p[:, 0] <= b.x1) & (p[:, 1] >= b.y0) & (p[:, 1] <= b.y1)):
                out.append(ax.get_title())
    return out


def test_error_vs_seconds_draws_each_cell_s_cost_interval_as_a_horizontal_bar():
    study = synthetic_study(2, n_scenes=1)
    fig = F.plot_error_vs_seconds(study)
    ax = fig.axes[0]
    cells = study.scenes[0].cells
    # errorbar's horizontal segments: both ends at one y, spanning the cost model's interval.
    spans = sorted((round(seg[0][0], 12), round(seg[1][0], 12)) for coll in ax.collections
                   for seg in coll.get_segments() if seg[0][1] == seg[1][1])
    want = sorted((round(c.seconds_ci.lo, 12), round(c.seconds_ci.hi, 12)) for c in cells)
    assert spans == want


def test_eight_samplers_share_one_legend_outside_the_panels():
    fig = F.plot_error_vs_seconds(synthetic_study(8, n_scenes=2))
    assert all(ax.get_legend() is None for ax in fig.axes)
    assert len(fig.legends) == 1 and len(fig.legends[0].get_texts()) == 8
    assert _covered(fig) == []


def test_a_panel_legend_takes_a_free_corner_or_moves_out():
    # Errors rising with N put points in the lower left corner, where a panel's legend sits first.
    fig = F.plot_error_vs_spp(synthetic_study(2, n_scenes=2, rising=True))
    assert not fig.legends and all(ax.get_legend() is not None for ax in fig.axes)
    assert _covered(fig) == []
    # One sampler rising and one falling leave no corner free: the figure's legend, below.
    fig = F.plot_error_vs_spp(synthetic_study(2, n_scenes=2, rising=(True, False)))
    assert len(fig.legends) == 1 and all(ax.get_legend() is None for ax in fig.axes)
    assert _covered(fig) == []


def test_efficiency_figure_of_eight_samplers_and_six_scenes_stays_readable_size(tmp_path):
    study = synthetic_study(8, n_scenes=6)
    fig = F.plot_efficiency(study)                  # plot_efficiency(study, path) saves it so
    fig.savefig(tmp_path / "eff.png")
    w, h = _png_size(tmp_path / "eff.png")
    dpi = F.compact_pyplot().rcParams["savefig.dpi"]
    assert w <= F.EFF_MAX_WIDTH * dpi and h <= (F.EFF_MAX_HEIGHT + 1.0) * dpi, (w, h)
    assert w / h < 3                                  # never one long strip
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == 7 and _covered(fig) == []
    # The last sampler's comparisons are not resolved: hollow markers, no interval.
    last = next(ax for ax in panels if ax.get_title().startswith("sampler-7"))
    hollow = [ln for ln in last.lines if ln.get_marker() in ("o", "s")]
    assert hollow and all(ln.get_markerfacecolor() == "none" for ln in hollow)
    assert not any(len(c.get_segments()) for c in last.collections)
