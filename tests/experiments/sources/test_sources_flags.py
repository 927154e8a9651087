"""Indices outside [0, 1] (a share of the variance cannot be) are flagged "not resolved" in the
printed table and drawn hollow and unclipped in the chart."""
from __future__ import annotations

import numpy as np

from drtlab.experiments.sources import report
from drtlab.experiments.sources.decompose import Sources


def _row(group, s, t, half_t=0.01):
    return {"group": group, "first_order": s, "first_order_lo": s - 0.005, "first_order_hi": s + 0.005,
            "total": t, "total_lo": t - half_t, "total_hi": t + half_t}


def _sources() -> Sources:
    rows = [_row("pixel", 0.40, 0.50), _row("direction", 0.001, 1.12, half_t=0.3),
            _row("light", -0.003, 0.02)]
    h, w = 4, 5
    total = np.stack([np.full((h, w), r["total"]) for r in rows])
    return Sources(scene="synthetic", sampler="pickfreeze+uniform", integrator="drt", metric="mse",
                   samples=32, seed=0, groups=tuple(r["group"] for r in rows),
                   indices={"groups": rows, "interaction": (0.2, 0.1, 0.3), "variance": (1.0, 0.9, 1.1)},
                   terms=None, image=np.full((h, w, 3), 0.5), pixel_variance=np.ones((h, w)),
                   pixel_total=total, seconds=0.0, render_seconds=0.0)


def test_an_index_is_resolved_only_inside_the_unit_interval():
    assert report.index_resolved(0.5, 0.4, 0.6)
    assert report.index_resolved(0.994, 0.983, 1.006)            # within a printed digit of 1
    assert not report.index_resolved(1.02, 0.96, 1.08)           # the estimate above 1
    assert not report.index_resolved(0.74, 0.22, 1.25)           # its interval reaches far past 1
    assert not report.index_resolved(-0.05, -0.08, -0.02)


def test_table_and_chart_mark_the_index_above_one():
    s = _sources()
    lines = report.table_lines(s)
    direction = next(line for line in lines if line.strip().startswith("direction"))
    assert direction.count(report.NOT_RESOLVED) == 1 and direction.rstrip().endswith(report.NOT_RESOLVED)
    assert all(report.NOT_RESOLVED not in line for line in lines if line.strip().startswith(("pixel", "light")))
    fig = report.figure(s)
    bars_ax = fig.axes[2]
    bars = [p for p in bars_ax.patches if p.get_height() != 0]
    hollow = [p for p in bars if p.get_facecolor()[3] == 0]
    assert [round(p.get_height(), 3) for p in hollow] == [1.12]
    top = bars_ax.get_ylim()[1]
    assert top >= 1.12 + 0.3                                     # the bar and its interval, unclipped
    assert any(report.NOT_RESOLVED in t.get_text() for t in bars_ax.get_legend().get_texts())
