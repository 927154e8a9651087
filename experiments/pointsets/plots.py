"""The three PNGs of `drtlab pointset` (experiments/pointsets/analysis.py), rendered to bytes
(experiments/plotting.py) so that nothing touches the output folder until every figure exists."""
from __future__ import annotations

import math

import numpy as np

from drtlab.experiments.plotting import compact_pyplot, png_bytes


def _head(result) -> str:
    return (f"{result.name}, N = {result.n}, dims {result.dims[0]},{result.dims[1]} "
            f"({', '.join(result.summary['dim_labels'])})")


def _title(result, what: str) -> str:
    r = result.summary["realisations"]
    seeds = f"seed {result.seeds[0]}" if r == 1 else f"mean of {r} seeds"
    return f"{_head(result)}: {what} ({seeds})"


def scatter_png(result) -> bytes:
    """The first realisation, with the sqrt(N) x sqrt(N) grid where N is a square (the strata a
    jittered set fills one point each) and the minimum distance in the caption."""
    plt = compact_pyplot()
    fig, ax = plt.subplots(figsize=(4.6, 4.9))
    g = math.isqrt(result.n)
    if g * g == result.n and g <= 32:         # finer grids hide the points
        for t in np.arange(1, g) / g:
            ax.axvline(t, color="0.88", lw=0.5, zorder=0)
            ax.axhline(t, color="0.88", lw=0.5, zorder=0)
    size = float(np.clip(2000.0 / result.n, 0.3, 16.0))
    ax.scatter(result.first[:, 0], result.first[:, 1], s=size, c="black", linewidths=0)
    ax.set(xlim=(0, 1), ylim=(0, 1), aspect="equal", xlabel=f"dim {result.dims[0]}",
           ylabel=f"dim {result.dims[1]}")
    ax.set_title(f"{_head(result)}, seed {result.seeds[0]}")
    dmin = result.summary["min_distance_relative"]
    ax.text(0.0, -0.13, f"toroidal min distance / hexagonal max: {dmin['values'][0]:.3f} (this "
                        f"seed), {dmin['mean']:.3f} mean", transform=ax.transAxes, fontsize=7)
    return png_bytes(fig)


def periodogram_png(result) -> bytes:
    """The mean periodogram, k = 0 left out (it is N), on a linear scale up to twice the white-noise
    level, so blue noise's dark centre and ring show (UTK's display)."""
    plt = compact_pyplot()
    k = result.summary["periodogram"]["frequency_limit"]
    p = result.power.mean(axis=0).copy()
    p[k, k] = np.nan
    fig, ax = plt.subplots(figsize=(5.0, 4.3))
    im = ax.imshow(p.T, origin="lower", extent=(-k - 0.5, k + 0.5, -k - 0.5, k + 0.5),
                   cmap="gray", vmin=0.0, vmax=2.0, interpolation="nearest")
    fig.colorbar(im, ax=ax, label="P(k)   (i.i.d. points: 1)", shrink=0.85)
    ax.set(xlabel="k_x", ylabel="k_y")
    ax.set_title(_title(result, "periodogram"), fontsize=7)
    return png_bytes(fig)


def radial_png(result) -> bytes:
    """Radially averaged power with a +-2 standard-error band, the i.i.d. level 1 dashed."""
    plt = compact_pyplot()
    radial = result.summary["periodogram"]["radial"]
    r, mean = np.array(radial["radius"]), np.array(radial["mean"])
    fig, ax = plt.subplots(figsize=(5.6, 3.4))
    if radial["se"] is not None:
        se = np.array(radial["se"])
        ax.fill_between(r, mean - 2 * se, mean + 2 * se, color="0.8", lw=0,
                        label="+-2 standard errors")
    ax.plot(r, mean, color="black", lw=1.0, label="radial mean of P(k)")
    ax.axhline(1.0, color="#D55E00", ls="--", lw=0.8, label="i.i.d. (white noise)")
    ax.axvline(math.sqrt(result.n), color="#0072B2", ls=":", lw=0.8, label="|k| = sqrt(N)")
    ax.set(xlabel="|k|", ylabel="power", xlim=(0, r[-1]),
           ylim=(0, max(2.0, float(mean.max()) * 1.05)))
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(_title(result, "radial power spectrum"), fontsize=7)
    return png_bytes(fig)
