"""What a point set looks like in one 2D projection: scatter, periodogram, radially averaged power
spectrum, discrepancies and the minimum toroidal distance, over R realisations (seeds).

    from drtlab.experiments.pointsets.analysis import analyse, write_analysis
    result = analyse("stratified", 256, dims=(0, 1), realisations=16, seed=0)
    write_analysis(result, Path("results/pointsets/stratified_n256_d0-1"))

Realisation r is `points(name, n, max(dims) + 1, seed=seed + r, pixel=0)` restricted to columns
(i, j): one pixel's n samples (spp = n), exactly as the render kernels produce them.

* Periodogram (as UTK's spectrum tools): P(k) = |sum_j exp(-2 pi i k.x_j)|^2 / N at integer
  frequencies k in [-K, K]^2, averaged over realisations. For i.i.d. uniform points E[P(k)] = 1 at
  every k != 0 (and P(0) = N), so 1 is the white-noise reference; blue noise sits below 1 at low
  frequencies. K = min(128, max(16, 4 ceil(sqrt N))): the spectrum up to 4x the blue-noise peak
  radius ~ sqrt(N).
* Radial power: the mean of P(k) over the annulus round(|k|) = r, r = 1 ... K, per realisation;
  mean and standard error over realisations.
* Discrepancies: `scipy.stats.qmc.discrepancy` with each of its methods, values as scipy returns
  them (CD, WD and MD are squared L2 discrepancies, L2-star is not squared).
* Minimum distance on the unit torus (`scipy.spatial.cKDTree`, boxsize 1), also relative to the
  largest possible, sqrt(2 / (sqrt(3) N)) (hexagonal packing), and the mean nearest-neighbour
  distance.
Every number is the mean over realisations with its standard error (sd / sqrt(R); None at R = 1).
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drtlab.errors import InputError
from drtlab.experiments.paths import results_root
from drtlab.fields import MAX_SEED

MIN_N, MAX_N = 2, 16384          # two points for a distance; O(N^2) discrepancies beyond
MAX_DIM = 255                    # 31 bounces of the tracer's layout
MAX_REALISATIONS = 1024
DEFAULT_REALISATIONS = 16
DISCREPANCY_METHODS = ("L2-star", "CD", "WD", "MD")
# The ones scipy returns squared (a table printing them beside L2-star says so).
SQUARED_DISCREPANCIES = ("CD", "WD", "MD")
FILES = ("scatter.png", "periodogram.png", "radial_spectrum.png", "analysis.json",
         "periodogram.npz", "manifest.json")


def default_out_dir(name: str, n: int, dims: tuple[int, int]) -> Path:
    return results_root() / "pointsets" / f"{name}_n{n}_d{dims[0]}-{dims[1]}"


def parse_dims(text: str, field: str = "--dims") -> tuple[int, int]:
    """`i,j`: two different dimensions in [0, MAX_DIM]."""
    allowed = f"must be two different dimensions i,j in [0, {MAX_DIM}] (e.g. 0,1: pixel.x, pixel.y)"
    parts = text.split(",") if isinstance(text, str) else []
    try:
        i, j = (int(p) for p in parts)
    except ValueError:
        raise InputError(field, f"{allowed}; got {text!r}") from None
    if i == j or not (0 <= i <= MAX_DIM and 0 <= j <= MAX_DIM):
        raise InputError(field, f"{allowed}; got {text!r}")
    return i, j


def check_request(name: str, n: int, realisations: int, seed: int) -> None:
    """Everything `analyse` needs that the flag types cannot check alone (InputError naming the
    flag): the point set exists and supports n, and the seeds seed ... seed + R - 1 fit 32 bits."""
    from drtlab.experiments.pointsets.validate import check_pointset, spp_problem
    pointset = check_pointset(name)
    if not MIN_N <= n <= MAX_N:
        raise InputError("--n", f"must be an integer in [{MIN_N}, {MAX_N}], got {n}")
    problem = spp_problem(pointset, n)
    if problem is not None:
        raise InputError("--n", f"{name} needs n {problem}, got {n}")
    if not 1 <= realisations <= MAX_REALISATIONS:
        raise InputError("--realisations", f"must be in [1, {MAX_REALISATIONS}], got {realisations}")
    if not 0 <= seed <= MAX_SEED - (realisations - 1):
        raise InputError("--seed", f"must be in [0, {MAX_SEED - (realisations - 1)}] so that the "
                                   f"{realisations} seeds seed ... seed + {realisations - 1} fit "
                                   f"32 bits, got {seed}")


# ---------------------------------------------------------------------------------------------------
# The measures, on arrays
# ---------------------------------------------------------------------------------------------------

def frequency_limit(n: int) -> int:
    return min(128, max(16, 4 * math.ceil(math.sqrt(n))))


def periodogram(xy: np.ndarray, k_max: int) -> np.ndarray:
    """(2K+1, 2K+1) P[a, b] = |sum_j exp(-2 pi i (kx x_j + ky y_j))|^2 / N, kx = a - K, ky = b - K.
    The exponential factorises, so the sum over points is one (2K+1) x N x (2K+1) product."""
    k = np.arange(-k_max, k_max + 1)
    ex = np.exp(-2j * np.pi * np.outer(xy[:, 0], k))
    ey = np.exp(-2j * np.pi * np.outer(xy[:, 1], k))
    s = ex.T @ ey
    return (s.real ** 2 + s.imag ** 2) / len(xy)


def radial_bins(k_max: int) -> np.ndarray:
    """(2K+1, 2K+1) annulus index round(|k|) of each frequency; -1 for k = 0 and beyond K."""
    k = np.arange(-k_max, k_max + 1)
    r = np.rint(np.hypot(k[:, None], k[None, :])).astype(np.int64)
    return np.where((r >= 1) & (r <= k_max), r, -1)


def radial_average(p: np.ndarray, bins: np.ndarray, k_max: int) -> np.ndarray:
    """(K,) mean of P over each annulus r = 1 ... K."""
    keep = bins >= 1
    sums = np.bincount(bins[keep], weights=p[keep], minlength=k_max + 1)
    counts = np.bincount(bins[keep], minlength=k_max + 1)
    return sums[1:] / counts[1:]


def discrepancies(xy: np.ndarray) -> dict[str, float]:
    from scipy.stats import qmc
    return {m: float(qmc.discrepancy(xy, method=m)) for m in DISCREPANCY_METHODS}


def toroidal_distances(xy: np.ndarray) -> tuple[float, float]:
    """(minimum, mean) nearest-neighbour distance on the unit torus."""
    from scipy.spatial import cKDTree
    d, _ = cKDTree(xy, boxsize=1.0).query(xy, k=2)
    return float(d[:, 1].min()), float(d[:, 1].mean())


def max_min_distance(n: int) -> float:
    """The largest minimum distance n points can have on the unit torus (hexagonal packing)."""
    return math.sqrt(2.0 / (math.sqrt(3.0) * n))


def mean_se(values) -> dict:
    v = np.asarray(values, dtype=np.float64)
    se = float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else None
    return {"mean": float(v.mean()), "se": se, "values": v.tolist()}


# ---------------------------------------------------------------------------------------------------
# The analysis
# ---------------------------------------------------------------------------------------------------

@dataclass
class Analysis:
    name: str
    n: int
    dims: tuple[int, int]
    seeds: list[int]
    first: np.ndarray            # (n, 2) the first realisation's points
    power: np.ndarray            # (R, 2K+1, 2K+1) periodograms
    radial: np.ndarray           # (R, K) radial averages
    summary: dict                # the JSON's numbers
    seconds: float


def analyse(name: str, n: int, dims=(0, 1), realisations: int = DEFAULT_REALISATIONS,
            seed: int = 0) -> Analysis:
    from drtlab.estimators.points import points
    from drtlab.experiments.pointsets.stats import dimension_label
    dims = tuple(dims)
    check_request(name, n, realisations, seed)
    t0 = time.perf_counter()
    k_max = frequency_limit(n)
    bins = radial_bins(k_max)
    seeds = [seed + r for r in range(realisations)]
    first, power, radial, disc, dmin, dmean = None, [], [], [], [], []
    for s in seeds:
        xy = points(name, n, max(dims) + 1, seed=s, pixel=0)[:, list(dims)]
        first = xy if first is None else first
        power.append(periodogram(xy, k_max))
        radial.append(radial_average(power[-1], bins, k_max))
        disc.append(discrepancies(xy))
        dmin_r, dmean_r = toroidal_distances(xy)
        dmin.append(dmin_r)
        dmean.append(dmean_r)
    power, radial = np.array(power), np.array(radial)
    nonzero = np.ones(power.shape[1:], dtype=bool)
    nonzero[k_max, k_max] = False
    summary = {
        "pointset": name, "n": n, "dims": list(dims),
        "dim_labels": [dimension_label(d) for d in dims],
        "realisations": realisations, "seeds": [seeds[0], seeds[-1]], "pixel": 0,
        "discrepancy": {m: mean_se([d[m] for d in disc]) for m in DISCREPANCY_METHODS},
        "min_distance": mean_se(dmin),
        "min_distance_relative": mean_se(np.array(dmin) / max_min_distance(n)),
        "mean_nn_distance": mean_se(dmean),
        "periodogram": {
            "frequency_limit": k_max,
            "mean_nonzero": mean_se(power[:, nonzero].mean(axis=1)),
            "low_frequency_power": mean_se(radial[:, :max(1, math.isqrt(n) // 2)].mean(axis=1)),
            "radial": {"radius": list(range(1, k_max + 1)),
                       "mean": radial.mean(axis=0).tolist(),
                       "se": (radial.std(axis=0, ddof=1) / math.sqrt(realisations)).tolist()
                       if realisations > 1 else None},
        },
    }
    return Analysis(name, n, dims, seeds, first, power, radial, summary, time.perf_counter() - t0)


def write_analysis(result: Analysis, out_dir: Path, argv=None) -> list[Path]:
    """The PNGs, analysis.json, periodogram.npz and manifest.json into out_dir (all rendered in
    memory first, each file then written atomically, the manifest last)."""
    from drtlab.experiments.pointsets import plots
    from drtlab.experiments.files import atomic_savez, atomic_write_bytes, atomic_write_json
    pngs = {"scatter.png": plots.scatter_png(result),
            "periodogram.png": plots.periodogram_png(result),
            "radial_spectrum.png": plots.radial_png(result)}
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, data in pngs.items():
        atomic_write_bytes(out_dir / name, data)
    atomic_write_json(out_dir / "analysis.json", result.summary)
    se = result.power.std(axis=0, ddof=1) / math.sqrt(len(result.power)) \
        if len(result.power) > 1 else np.full(result.power.shape[1:], np.nan)
    k = result.summary["periodogram"]["frequency_limit"]
    atomic_savez(out_dir / "periodogram.npz", mean=result.power.mean(axis=0), se=se,
                 frequencies=np.arange(-k, k + 1), radial=result.radial)
    atomic_write_json(out_dir / "manifest.json", _manifest(result, argv))
    return [out_dir / f for f in FILES]


def _manifest(result: Analysis, argv) -> dict:
    import datetime as dt
    from drtlab.version import __version__
    from drtlab.experiments.provenance import machine_info, package_versions, peak_rss_mib
    from drtlab.kernels import CODE_VERSION
    return {"what": "drtlab pointset analysis", "command": argv if argv is not None else sys.argv,
            "finished": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
            "version": __version__, "code_version": CODE_VERSION,
            "pointset": result.name, "n": result.n, "dims": list(result.dims),
            "seeds": {"scheme": "realisation r: points(name, n, max(dims) + 1, seed + r, pixel 0)",
                      "first": result.seeds[0], "last": result.seeds[-1]},
            "packages": package_versions(), "machine": machine_info(),
            "wall_seconds": round(result.seconds, 3), "peak_rss_mib": peak_rss_mib(),
            "files": list(FILES)}
