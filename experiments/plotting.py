"""matplotlib for every figure drtlab writes: pyplot on the Agg backend (files only, so no display is
needed and none is opened), the compact style of the report's and the point-set figures, the series
styles that tell samplers apart in black and white too, and a figure as PNG bytes.

A leaf module: every plotting module imports it, and it imports nothing of drtlab."""
from __future__ import annotations

import io
import math

# Samplers differ by marker and line style (and hatch for bars) as well as by colour, so figures stay
# readable printed in black and white.
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
LINESTYLES = ("-", "--", ":", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 2)), (0, (8, 2)), (0, (3, 1)))
COLOURS = ("#000000", "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#999999")

# Panels of about 3.4 inches: matplotlib's default 10-point text would run into itself there.
COMPACT_STYLE = {"font.size": 8, "axes.titlesize": 9, "legend.fontsize": 7, "savefig.dpi": 130,
                 "figure.dpi": 100}

_agg = False


def pyplot():
    """matplotlib.pyplot on the Agg backend (selected on the first call; matplotlib loads then)."""
    global _agg
    import matplotlib
    if not _agg:
        matplotlib.use("Agg", force=True)
        _agg = True
    import matplotlib.pyplot as plt
    return plt


def compact_pyplot():
    """`pyplot()` with COMPACT_STYLE applied (to matplotlib's global rcParams)."""
    plt = pyplot()
    plt.rcParams.update(COMPACT_STYLE)
    return plt


def series_style(i: int) -> dict:
    """Marker, line style and colour of the i-th series of a panel."""
    return {"marker": MARKERS[i % len(MARKERS)], "linestyle": LINESTYLES[i % len(LINESTYLES)],
            "color": COLOURS[i % len(COLOURS)]}


def panel_grid(n: int) -> tuple[int, int]:
    """(rows, columns) of a figure of n panels, at most three to a row."""
    cols = min(3, n)
    return math.ceil(n / cols), cols


def png_bytes(fig) -> bytes:
    """The figure as PNG bytes, closed afterwards: a command writes its files only once every figure
    exists, so that a failing one leaves nothing behind."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight")
    fig.clf()
    pyplot().close(fig)
    return buf.getvalue()
