"""Chi-square goodness-of-fit tests of sampling routines, in the style of Mitsuba 3's `mitsuba.chi2`.

A `ChiSquareTest` draws `sample_count` (default 10^6) samples from a sampler, histograms them on a 2D
parameter grid of a `Domain`, integrates the density the code *claims* for those samples over every
grid cell to get the expected counts, and runs Pearson's test. The facts carried over from Mitsuba:

* the grid lives in a parameterisation whose measure is the sampler's measure, so no Jacobian
  appears: (cos theta, phi) for directions (d omega = d cos d phi), (x, y) for points (one domain
  here, `ConeDomain`, carries a Jacobian, see below);
* the expected count of a cell is N times the integral of the pdf over the cell, computed by a
  quadrature on an ires x ires sub-grid of the cell (Mitsuba: trapezoid with ires = 4; here the
  midpoint rule with ires = 4, and 32 x 32 in cells at an edge of the pdf's support; with an even
  ires and an odd cell count the horizon cos theta = 0 lies between sub-samples, where the midpoint
  rule integrates a step exactly);
* cells are sorted by expected count and those expecting fewer than 5 samples are pooled together,
  until each pool expects at least 5 (Mitsuba drops a final pool below 5; here it is merged into the
  last pool, so every sample is counted and the multinomial degrees of freedom are cells - 1);
* samples in a cell whose expected count is 0 reject the hypothesis outright (here: unless the cell
  borders the support, where a sliver of support may hide from the quadrature; those samples still
  weigh in the pooled statistic);
* a family of m tests is run at the Sidak-corrected level 1 - (1 - alpha)^(1/m) (alpha = 0.01), so
  that the whole family falsely rejects with probability alpha.

Additions for this project:

* **Defective distributions.** A sampler may fail (a direction under the horizon, a light point
  facing away): it then returns `valid = False`, and the claimed pdf integrates to the valid mass
  P < 1. Invalid samples, and valid ones outside the grid (the tail beyond a zoomed cap), fall into
  one extra "rest" cell expecting N (1 - integral of the pdf over the grid). So a pdf that is right in
  shape but wrong in its normalisation, or a sampler that fails more often than its pdf admits, is
  rejected as well. `result.integral` is the integral of the pdf over the grid (1, or the valid mass).
* **Sharp lobes.** `CapDomain(axis, t_max)` histograms the cap 1 - cos theta <= t_max around a lobe's
  own axis in (t = 1 - cos theta, phi). t of a sample is computed from the components perpendicular
  to the axis, t = s^2 / (1 + sqrt(1 - s^2)), so it keeps full relative precision in float32 even for
  Phong exponents of 10^6 (lobe width ~1e-6 in t); with t_max ~ 20 / (n + 1) the 10^6 samples fill
  the grid's cells as they would for a broad lobe. What limits such tests is the precision of the
  claimed pdf itself: `phong_lobe_pdf(cos, n)` takes cos in float32, whose spacing near 1 is
  2^-24, so its value carries a relative error up to ~n * 3e-8 (3% at n = 10^6); in practice the
  n = 10^6 test still passes and the integral is off by 2e-4.
* **Singular edges.** An area-sampled sphere light has a solid-angle density ~1/cos at the light,
  infinite at its silhouette; `ConeDomain` histograms the cone it subtends in (s, phi) with
  1 - cos theta = omc (1 - s^2), where that density is bounded (Jacobian 2 omc s).
* **Quadrature at support edges.** Cells where the pdf is zero at some sub-samples and not at others,
  and zero cells next to non-zero ones, are integrated again on a refine x finer sub-grid.
* **Warp adapters.** `WarpsAdapter`, `BSDFAdapter` and `LightAdapter` wrap the project's Warp
  functions (estimators/warps.py, kernels/materials.py `make_bsdf`, kernels/lights.py `make_lights`)
  in CPU kernels built by factories (`module="unique"`, no backward pass). Each kernel samples over N
  threads with the random numbers `uniform(seed, thread, dim)` = unit_float(hash_key(seed, thread,
  dim, 0)), so results are a pure function of the seed; one runtime-switched kernel per factory
  variant keeps compiles few (1 for the warps, 2 for the BSDFs, 4 for the lights). They also
  report the consistency checks a chi-square test cannot see: the pdf a sample carries against the
  pdf evaluated separately for the same direction, and the weight against f|cos|/pdf.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import warp as wp
from scipy import stats

from drtlab.estimators.hashing import hash_key, unit_float
from drtlab.kernels.device_scene import SPHERE, SceneData

ALPHA = 0.01
POOL_THRESHOLD = 5.0


def sidak(alpha: float, test_count: int) -> float:
    """Per-test level so that `test_count` independent tests falsely reject with probability alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / max(int(test_count), 1))


# ---------------------------------------------------------------------------------------------------
# Domains: a 2D parameter rectangle, the map to points/directions and back
# ---------------------------------------------------------------------------------------------------

def orthonormal_frame(axis) -> np.ndarray:
    """3x3 float64 matrix whose columns (t, b, n) are an orthonormal basis with n = axis/|axis|."""
    n = np.asarray(axis, dtype=np.float64).reshape(3)
    n = n / np.linalg.norm(n)
    s = 1.0 if n[2] >= 0.0 else -1.0
    a = -1.0 / (s + n[2])
    b = n[0] * n[1] * a
    t = np.array([1.0 + s * n[0] * n[0] * a, s * b, -s * n[0]])
    bt = np.array([b, s + n[1] * n[1] * a, -n[1]])
    return np.stack([t, bt, n], axis=1)


def _to_local(pts: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """pts @ frame, written out: numpy's matmul of a tall (M, 3) array by a 3x3 one is slow."""
    p = np.asarray(pts, dtype=np.float64)
    return np.stack([p[:, 0] * frame[0, k] + p[:, 1] * frame[1, k] + p[:, 2] * frame[2, k]
                     for k in range(3)], axis=1)


def _to_world(x: np.ndarray, y: np.ndarray, z: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """frame @ (x, y, z) for arrays of local coordinates."""
    return np.stack([x * frame[k, 0] + y * frame[k, 1] + z * frame[k, 2] for k in range(3)], axis=1)


class Domain:
    """bounds[k] = (lo, hi) of parameter k; `to_param` maps (M, dim) points to (M, 2) parameters
    (NaN where a point is not in the domain at all); `from_param` is its inverse. The measure of the
    parameter rectangle equals the sampler's measure (solid angle or area)."""
    bounds: np.ndarray
    dim: int
    name: str = "domain"

    def to_param(self, pts: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def from_param(self, prm: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, prm: np.ndarray):
        """d(measure) / d(parameters) at prm; 1 for the measure-preserving parameterisations."""
        return 1.0


class SphericalDomain(Domain):
    """Directions as (cos theta, phi) about `axis`, cos theta in `cos_range` (the whole sphere by
    default, (0, 1) for the hemisphere around the axis), phi in [-pi, pi)."""
    dim = 3

    def __init__(self, axis=(0.0, 0.0, 1.0), cos_range=(-1.0, 1.0)):
        self.frame = orthonormal_frame(axis)
        self.bounds = np.array([cos_range, (-math.pi, math.pi)], dtype=np.float64)
        self.name = f"sphere(cos in [{cos_range[0]:g}, {cos_range[1]:g}])"

    def to_param(self, pts):
        loc = _to_local(pts, self.frame)
        norm = np.sqrt(loc[:, 0] ** 2 + loc[:, 1] ** 2 + loc[:, 2] ** 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = loc[:, 2] / norm
        return np.stack([cos, np.arctan2(loc[:, 1], loc[:, 0])], axis=1)

    def from_param(self, prm):
        cos = prm[:, 0]
        sin = np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
        return _to_world(sin * np.cos(prm[:, 1]), sin * np.sin(prm[:, 1]), cos, self.frame)


class CapDomain(Domain):
    """The cap 1 - cos theta <= t_max around `axis` as (t = 1 - cos theta, phi): a zoomed grid for
    sharp lobes and small cones, histogrammed in the lobe's own frame. d omega = dt dphi."""
    dim = 3

    def __init__(self, axis, t_max: float):
        self.frame = orthonormal_frame(axis)
        self.t_max = float(t_max)
        self.bounds = np.array([(0.0, self.t_max), (-math.pi, math.pi)], dtype=np.float64)
        self.name = f"cap(t_max={self.t_max:.3g})"

    def to_param(self, pts):
        loc = _to_local(pts, self.frame)
        norm2 = loc[:, 0] ** 2 + loc[:, 1] ** 2 + loc[:, 2] ** 2
        with np.errstate(invalid="ignore", divide="ignore"):
            s2 = (loc[:, 0] ** 2 + loc[:, 1] ** 2) / norm2
            cos = loc[:, 2] / np.sqrt(norm2)
            t = np.where(cos > 0.5, s2 / (1.0 + np.sqrt(np.maximum(0.0, 1.0 - s2))), 1.0 - cos)
        return np.stack([t, np.arctan2(loc[:, 1], loc[:, 0])], axis=1)

    def from_param(self, prm):
        t = prm[:, 0]
        sin = np.sqrt(np.maximum(0.0, t * (2.0 - t)))
        return _to_world(sin * np.cos(prm[:, 1]), sin * np.sin(prm[:, 1]), 1.0 - t, self.frame)


class ConeDomain(Domain):
    """The cone 1 - cos theta <= omc around `axis` as (s, phi) with 1 - cos theta = omc (1 - s^2):
    s = 1 on the axis, s = 0 on the cone's edge; d omega = 2 omc s ds dphi (the one parameterisation
    here with a Jacobian). Made for sphere lights seen from outside: area sampling has a solid-angle
    density ~ 1/cos at the light, which diverges at the silhouette like 1/sqrt(distance to the edge)
    and defeats any quadrature in (cos theta, phi); in s it is bounded and smooth."""
    dim = 3

    def __init__(self, axis, omc: float):
        self.frame = orthonormal_frame(axis)
        self.omc = float(omc)
        self.bounds = np.array([(0.0, 1.0), (-math.pi, math.pi)], dtype=np.float64)
        self.name = f"cone(1-cos={self.omc:.3g})"
        self._cap = CapDomain(axis, 2.0)

    def to_param(self, pts):
        prm = self._cap.to_param(pts)
        with np.errstate(invalid="ignore"):
            s = np.sqrt(1.0 - prm[:, 0] / self.omc)       # NaN outside the cone: not in the grid
        return np.stack([s, prm[:, 1]], axis=1)

    def from_param(self, prm):
        t = self.omc * (1.0 - prm[:, 0] ** 2)
        return self._cap.from_param(np.stack([t, prm[:, 1]], axis=1))

    def jacobian(self, prm):
        return 2.0 * self.omc * prm[:, 0]


class PlanarDomain(Domain):
    """Points (x, y) of a rectangle (the lens disk in [-1, 1]^2, a unit square); dA = dx dy."""
    dim = 2

    def __init__(self, bounds=((-1.0, 1.0), (-1.0, 1.0))):
        self.bounds = np.array(bounds, dtype=np.float64)
        self.name = f"plane({self.bounds.tolist()})"

    def to_param(self, pts):
        return np.asarray(pts, dtype=np.float64)[:, :2].copy()

    def from_param(self, prm):
        return prm.copy()


# ---------------------------------------------------------------------------------------------------
# The test
# ---------------------------------------------------------------------------------------------------

def pooled_chi2(observed: np.ndarray, expected: np.ndarray, threshold: float = POOL_THRESHOLD):
    """Pearson's statistic with Mitsuba-style pooling of cells expecting fewer than `threshold`.

    Returns (statistic, dof, pooled_in, pooled_out). Cells with expected == observed == 0 are
    skipped; the final pool below the threshold is merged into the previous pooled cell (or, when
    there is none, into the smallest regular cell), so the cells partition all samples.
    """
    obs = np.asarray(observed, dtype=np.float64).ravel()
    exp = np.asarray(expected, dtype=np.float64).ravel()
    keep = ~((exp == 0.0) & (obs == 0.0))
    obs, exp = obs[keep], exp[keep]
    order = np.argsort(exp, kind="stable")
    obs, exp = obs[order], exp[order]
    small = exp < threshold
    n_small = int(np.count_nonzero(small))
    cells_o: list[float] = []
    cells_e: list[float] = []
    po = pe = 0.0
    pooled_out = 0
    for o, e in zip(obs[:n_small], exp[:n_small]):
        po += o
        pe += e
        if pe >= threshold:
            cells_o.append(po)
            cells_e.append(pe)
            po = pe = 0.0
            pooled_out += 1
    big_o, big_e = obs[n_small:], exp[n_small:]
    if pe > 0.0 or po > 0.0:
        if cells_o:
            cells_o[-1] += po
            cells_e[-1] += pe
        elif big_o.size:
            big_o = big_o.copy()
            big_e = big_e.copy()
            big_o[0] += po
            big_e[0] += pe
        else:
            cells_o.append(po)
            cells_e.append(pe)
            pooled_out += 1
    o_all = np.concatenate([np.array(cells_o), big_o])
    e_all = np.concatenate([np.array(cells_e), big_e])
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(e_all > 0.0, (o_all - e_all) ** 2 / e_all, np.where(o_all > 0, np.inf, 0.0))
    return float(np.sum(terms)), int(o_all.size) - 1, n_small, pooled_out


@dataclass
class ChiSquareResult:
    name: str
    statistic: float
    dof: int
    p_value: float
    alpha: float                 # the (corrected) level the p-value was compared with
    passed: bool
    integral: float              # integral of the claimed pdf over the grid
    in_grid: float               # fraction of the samples that were valid and fell in the grid
    rest_expected: float         # expected count of the rest cell (invalid or outside the grid)
    rest_observed: int
    n_samples: int
    pooled_in: int
    pooled_out: int
    zero_cells_hit: int          # samples found in cells whose expected count is 0
    refined_cells: int = 0       # cells integrated again finely (edges of the pdf's support)
    messages: list[str] = field(default_factory=list)    # the hard failures, if any
    histogram: np.ndarray | None = field(default=None, repr=False)
    expected: np.ndarray | None = field(default=None, repr=False)

    @property
    def rejected(self) -> bool:
        return not self.passed

    def summary(self) -> str:
        return (f"{self.name}: {'accepted' if self.passed else 'REJECTED'} p={self.p_value:.4g} "
                f"(alpha={self.alpha:.3g}) chi2={self.statistic:.1f} dof={self.dof} "
                f"integral={self.integral:.6f} in_grid={self.in_grid:.6f} "
                f"rest {self.rest_observed}/{self.rest_expected:.1f} pooled {self.pooled_in}->"
                f"{self.pooled_out} refined {self.refined_cells} zero-cell hits {self.zero_cells_hit}"
                + ("" if not self.messages else " | " + "; ".join(self.messages)))


SampleFunc = Callable[[int, int], "np.ndarray | tuple[np.ndarray, np.ndarray]"]
PdfFunc = Callable[[np.ndarray], np.ndarray]


class ChiSquareTest:
    """Pearson's chi-square test of a sampler against the density it claims.

    sample_func(n, seed) -> points (n, dim) [, valid (n,) bool]: the sampler's output (directions as
        unit 3-vectors, planar points as 2-vectors); invalid samples go to the rest cell.
    pdf_func(points (M, dim) float64) -> (M,) float64: the claimed density (solid angle or area).
    res: (cells along parameter 0, cells along parameter 1); an odd count along cos theta puts the
        horizon in the middle of a cell, as Mitsuba's default 101 does.
    ires: sub-samples per cell and axis for the midpoint quadrature of the pdf; cells at an edge of
        the pdf's support are integrated again with refine * ires sub-samples per axis.
    """

    def __init__(self, domain: Domain, sample_func: SampleFunc, pdf_func: PdfFunc,
                 sample_count: int = 1_000_000, res=(101, 202), ires: int = 4, seed: int = 0,
                 name: str = "chi2", refine: int = 8, chunk_points: int = 1 << 19):
        if ires < 1:
            raise ValueError("ires must be >= 1")
        self.domain = domain
        self.sample_func = sample_func
        self.pdf_func = pdf_func
        self.sample_count = int(sample_count)
        self.res = (int(res[0]), int(res[1]))
        self.ires = int(ires)
        self.seed = int(seed)
        self.name = name
        self.refine = int(refine)
        self.chunk_points = int(chunk_points)
        self.refined_cells = 0
        self.histogram: np.ndarray | None = None
        self.rest_observed = 0
        self.pdf: np.ndarray | None = None       # expected mass per cell (not yet times N)
        self.failures: list[str] = []

    # -- histogram -----------------------------------------------------------------------------
    def tabulate_histogram(self) -> np.ndarray:
        out = self.sample_func(self.sample_count, self.seed)
        if isinstance(out, tuple):
            pts, valid = out
            valid = np.asarray(valid, dtype=bool).reshape(-1)
        else:
            pts, valid = out, None
        pts = np.asarray(pts)
        if pts.shape[0] != self.sample_count:
            raise ValueError(f"sampler returned {pts.shape[0]} samples, asked for {self.sample_count}")
        if valid is None:
            valid = np.ones(self.sample_count, dtype=bool)
        vp = pts[valid]
        bad = ~np.all(np.isfinite(vp), axis=1)
        if np.any(bad):
            self.failures.append(f"{int(np.count_nonzero(bad))} valid samples are not finite")
        prm = self.domain.to_param(vp)
        idx = self._cell_index(prm)
        inside = idx >= 0
        hist = np.bincount(idx[inside], minlength=self.res[0] * self.res[1]).astype(np.float64)
        self.histogram = hist.reshape(self.res)
        self.rest_observed = int(self.sample_count - np.count_nonzero(inside))
        return self.histogram

    def _cell_index(self, prm: np.ndarray) -> np.ndarray:
        """Flat cell index, or -1 outside the grid; parameters within 1e-6 of the grid's extent
        outside it are clamped in (float rounding at cos theta = +-1, phi = pi)."""
        lo = self.domain.bounds[:, 0]
        ext = self.domain.bounds[:, 1] - lo
        eps = 1e-6
        idx = np.zeros(prm.shape[0], dtype=np.int64)
        ok = np.ones(prm.shape[0], dtype=bool)
        for k in range(2):
            x = (prm[:, k] - lo[k]) / ext[k]          # in [0, 1] inside the grid; NaN fails both
            ok &= (x >= -eps) & (x <= 1.0 + eps)
            i = np.clip(np.floor(np.where(ok, x, 0.0) * self.res[k]), 0, self.res[k] - 1)
            idx = idx * self.res[k] + i.astype(np.int64)
        idx[~ok] = -1
        return idx

    # -- expected counts -----------------------------------------------------------------------
    def tabulate_pdf(self) -> np.ndarray:
        """Integral of the claimed pdf over every cell: the midpoint rule on ires x ires points, then
        again on (refine * ires)^2 points in the cells next to a discontinuity of the pdf (cells whose
        sub-samples are partly zero, and zero cells bordering non-zero ones), so the support's edge
        (a disk's rim, a horizon crossing a lobe-aligned grid) is integrated finely."""
        lo = self.domain.bounds[:, 0]
        h = (self.domain.bounds[:, 1] - lo) / np.array(self.res, dtype=np.float64)
        ncell = self.res[0] * self.res[1]
        out, mixed = self._integrate(np.arange(ncell), self.ires, lo, h)
        nz = out.reshape(self.res) > 0.0
        refine = mixed.reshape(self.res) | (_dilate(nz) & ~nz)
        cells = np.flatnonzero(refine.ravel())
        if self.refine > 1 and cells.size:
            out[cells], _ = self._integrate(cells, self.ires * self.refine, lo, h)
        self.refined_cells = int(cells.size) if self.refine > 1 else 0
        self.pdf = out.reshape(self.res)
        return self.pdf

    def _integrate(self, cells_all: np.ndarray, ires: int, lo, h):
        k = (np.arange(ires) + 0.5) / ires
        sub = np.stack(np.meshgrid(k, k, indexing="ij"), axis=-1).reshape(-1, 2)   # (ires^2, 2)
        out = np.empty(cells_all.size, dtype=np.float64)
        mixed = np.zeros(cells_all.size, dtype=bool)
        w = h[0] * h[1] / (ires * ires)
        chunk = max(1, self.chunk_points // (ires * ires))
        for c0 in range(0, cells_all.size, chunk):
            sl = slice(c0, min(cells_all.size, c0 + chunk))
            cells = cells_all[sl]
            ij = np.stack([cells // self.res[1], cells % self.res[1]], axis=1).astype(np.float64)
            prm = lo + (ij[:, None, :] + sub[None, :, :]) * h           # (cells, ires^2, 2)
            prm = prm.reshape(-1, 2)
            pdf = np.asarray(self.pdf_func(self.domain.from_param(prm)), dtype=np.float64)
            pdf = (pdf * self.domain.jacobian(prm)).reshape(len(cells), -1)
            if not np.all(np.isfinite(pdf)):
                self._note("the pdf is not finite somewhere")
                pdf = np.nan_to_num(pdf, nan=0.0, posinf=0.0, neginf=0.0)
            if np.any(pdf < 0.0):
                self._note("the pdf is negative somewhere")
            out[sl] = pdf.sum(axis=1) * w
            zero = pdf == 0.0
            mixed[sl] = zero.any(axis=1) & ~zero.all(axis=1)
        return out, mixed

    def _note(self, msg: str):
        if msg not in self.failures:
            self.failures.append(msg)

    # -- the test ------------------------------------------------------------------------------
    def run(self, alpha: float = ALPHA, test_count: int = 1) -> ChiSquareResult:
        """Compare histogram and expected counts; `test_count` tests share the family level alpha
        through the Sidak correction. Hard failures (no p-value needed): non-finite samples or pdf
        values, a negative pdf, a pdf integrating to more than 1.01 over the grid, samples in a cell
        expecting none, fewer than two cells after pooling."""
        if self.histogram is None:
            self.tabulate_histogram()
        if self.pdf is None:
            self.tabulate_pdf()
        n = float(self.sample_count)
        integral = float(self.pdf.sum())
        failures = list(self.failures)
        if integral > 1.0 + 1e-2:
            failures.append(f"the pdf integrates to {integral:.6f} > 1 over the grid")
        exp = np.append(self.pdf.ravel() * n, max(0.0, 1.0 - integral) * n)
        obs = np.append(self.histogram.ravel(), float(self.rest_observed))
        # A cell expecting nothing but holding samples rejects outright, unless it borders the pdf's
        # support: there a sliver of support thinner than the fine quadrature's spacing can hide
        # (a hard-edged lobe crossing the grid); such cells enter the pooled cells with their
        # samples, so samples outside the support in numbers still reject through the statistic.
        support = _dilate(self.pdf > 0.0).ravel()
        far = np.append(~support, False)
        zero_hit = int(obs[(exp == 0.0) & (obs > 0) & far].sum())
        if zero_hit:
            failures.append(f"{zero_hit} samples in cells of expected count 0 away from the "
                            f"pdf's support")
        stat, dof, pin, pout = pooled_chi2(obs, exp)
        if dof < 1:
            failures.append("fewer than 2 cells after pooling: no test possible")
        p = float(stats.chi2.sf(stat, max(dof, 1))) if np.isfinite(stat) else 0.0
        level = sidak(alpha, test_count)
        passed = not failures and p >= level
        return ChiSquareResult(
            name=self.name, statistic=stat, dof=dof, p_value=p, alpha=level, passed=passed,
            integral=integral, in_grid=float(self.histogram.sum() / n),
            rest_expected=float(exp[-1]), rest_observed=self.rest_observed,
            n_samples=self.sample_count, pooled_in=pin, pooled_out=pout, zero_cells_hit=zero_hit,
            refined_cells=self.refined_cells, messages=failures,
            histogram=self.histogram, expected=self.pdf * n)


def _dilate(mask: np.ndarray) -> np.ndarray:
    """Cells within one cell (8-neighbourhood) of a True cell; wraps along parameter 1 (phi)."""
    pad = np.pad(mask, ((1, 1), (0, 0)))
    rows = pad[:-2] | pad[1:-1] | pad[2:]
    return rows | np.roll(rows, 1, axis=1) | np.roll(rows, -1, axis=1)


def run_chi2(domain: Domain, sample_func: SampleFunc, pdf_func: PdfFunc, *, name: str = "chi2",
             test_count: int = 1, alpha: float = ALPHA, **kw) -> ChiSquareResult:
    return ChiSquareTest(domain, sample_func, pdf_func, name=name, **kw).run(alpha, test_count)


def relative_error(a, b, floor: float = 1e-30) -> np.ndarray:
    """|a - b| / max(|a|, |b|) elementwise (0 where both are 0)."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    den = np.maximum(np.maximum(np.abs(a), np.abs(b)), floor)
    return np.abs(a - b) / den


# ---------------------------------------------------------------------------------------------------
# Warp adapters: samplers and claimed densities of the project's Warp functions
# ---------------------------------------------------------------------------------------------------

from drtlab.kernels.warp_runtime import warp as _wp  # noqa: E402


@wp.func
def uniform(seed: wp.uint32, thread: wp.uint32, dim: int) -> float:
    """The harness's random number `dim` of sample `thread`: unit_float(hash_key(seed, thread, dim,
    0)). The dimension goes in hash_key's `index` slot, which two mixing rounds follow; in its own
    `dim` slot, which only one round follows, consecutive dimensions are not jointly uniform (see
    tests/test_pointset_uniformity.py), and that would be blamed on the warps under test."""
    return unit_float(hash_key(seed, thread, wp.uint32(dim), wp.uint32(0)))


def _vec3_array(pts: np.ndarray):
    wp = _wp()
    a = np.ascontiguousarray(np.asarray(pts, dtype=np.float32).reshape(-1, 3))
    return wp.array(a, dtype=wp.vec3, device="cpu")


def _as_vec3(v):
    wp = _wp()
    v = np.asarray(v, dtype=np.float64).reshape(3)
    return wp.vec3(float(v[0]), float(v[1]), float(v[2]))


# Which warp `WarpsAdapter` runs (a runtime switch of one kernel).
UNIFORM_HEMISPHERE, UNIFORM_SPHERE, COSINE_HEMISPHERE, PHONG, CONE, DISK, SQUARE = range(7)
WARP_NAMES = {UNIFORM_HEMISPHERE: "uniform_hemisphere", UNIFORM_SPHERE: "uniform_sphere",
              COSINE_HEMISPHERE: "cosine_hemisphere", PHONG: "phong_lobe", CONE: "cone",
              DISK: "concentric_disk", SQUARE: "identity (the harness's own random input)"}


class WarpsAdapter:
    """estimators/warps.py in the local z-up frame: `sampler(which, param)` and `pdf(which, param)`.

    param: the Phong exponent, or 1 - cos(theta_max) of the cone. The disk's points are returned as
    (x, y) in [-1, 1]^2 and its claimed density is 1/pi inside the unit disk (the concentric map is
    area-preserving; warps.py has no disk pdf). SQUARE returns the random input (u0, u1) itself, to
    test the harness's generator. The cone's support is t <= 1 - cos(theta_max), t
    computed from the perpendicular components (see CapDomain) so tiny cones keep their edge."""

    _kernel = None

    @classmethod
    def kernel(cls):
        if cls._kernel is None:
            cls._kernel = _make_warps_kernel()
        return cls._kernel

    @classmethod
    def launch(cls, mode: int, which: int, param: float, n: int, seed: int = 0, pts=None):
        wp = _wp()
        k = cls.kernel()
        inp = _vec3_array(pts) if pts is not None else wp.zeros(1, dtype=wp.vec3, device="cpu")
        n = int(n if pts is None else inp.shape[0])
        out_v = wp.zeros(n if mode == 0 else 1, dtype=wp.vec3, device="cpu")
        out_p = wp.zeros(n, dtype=float, device="cpu")
        wp.launch(k, dim=n, device="cpu", inputs=[int(mode), int(which), float(param),
                                                  wp.uint32(seed), inp, out_v, out_p])
        return out_v.numpy(), out_p.numpy()

    @classmethod
    def sampler(cls, which: int, param: float = 0.0) -> SampleFunc:
        def sample(n, seed):
            v, _ = cls.launch(0, which, param, n, seed)
            return v[:, :2] if which in (DISK, SQUARE) else v
        return sample

    @classmethod
    def pdf(cls, which: int, param: float = 0.0) -> PdfFunc:
        def pdf(pts):
            pts = np.asarray(pts, dtype=np.float64)
            if which in (DISK, SQUARE):
                pts = np.concatenate([pts[:, :2], np.zeros((pts.shape[0], 1))], axis=1)
            return cls.launch(1, which, param, 0, 0, pts)[1].astype(np.float64)
        return pdf


def _make_warps_kernel():
    wp = _wp()
    from drtlab.estimators import warps as W

    @wp.func
    def cap_t(v: wp.vec3) -> float:
        s2 = (v[0] * v[0] + v[1] * v[1]) / wp.dot(v, v)
        if v[2] > 0.0:
            return s2 / (1.0 + wp.sqrt(wp.max(0.0, 1.0 - s2)))
        return 1.0 - v[2] / wp.length(v)

    @wp.kernel(enable_backward=False, module="unique")
    def warps_kernel(mode: int, which: int, param: float, seed: wp.uint32,
                     pts: wp.array(dtype=wp.vec3), out_v: wp.array(dtype=wp.vec3),
                     out_p: wp.array(dtype=float)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            u = wp.vec2(uniform(seed, i, 0), uniform(seed, i, 1))
            v = wp.vec3(0.0)
            if which == 0:
                v = W.square_to_uniform_hemisphere(u)
            elif which == 1:
                v = W.square_to_uniform_sphere(u)
            elif which == 2:
                v = W.square_to_cosine_hemisphere(u)
            elif which == 3:
                v = W.square_to_phong_lobe(u, param)
            elif which == 4:
                v = W.square_to_cone(u, param)
            elif which == 5:
                d = W.square_to_disk(u)
                v = wp.vec3(d[0], d[1], 0.0)
            else:
                v = wp.vec3(u[0], u[1], 0.0)
            out_v[tid] = v
        else:
            v = pts[tid]
            p = float(0.0)
            if which == 0:
                p = W.uniform_hemisphere_pdf(v[2])
            elif which == 1:
                p = W.INV_4PI
            elif which == 2:
                p = W.cosine_hemisphere_pdf(v[2])
            elif which == 3:
                p = W.phong_lobe_pdf(v[2], param)
            elif which == 4:
                if cap_t(v) <= param:
                    p = W.cone_pdf(param)
            elif which == 5:
                if v[0] * v[0] + v[1] * v[1] <= 1.0:
                    p = W.INV_PI
            else:
                if v[0] >= 0.0 and v[0] < 1.0 and v[1] >= 0.0 and v[1] < 1.0:
                    p = 1.0
            out_p[tid] = p

    return warps_kernel


# Material kinds in the order of scene_model.MATERIAL_KINDS (the kernels' integer kind).
KIND_INDEX = {"diffuse": 0, "glossy": 1, "mirror": 2, "dielectric": 3, "glossy_dielectric": 4,
              "emitter": 5}
ALL_KINDS = frozenset(KIND_INDEX)


@dataclass
class BSDFSamples:
    wi: np.ndarray          # (n, 3)
    pdf: np.ndarray         # the pdf the sample carries
    weight: np.ndarray      # (n, 3)
    valid: np.ndarray       # bool
    delta: np.ndarray       # bool
    pdf_eval: np.ndarray    # pdf_bsdf(wi) evaluated separately (valid non-delta samples)
    f_eval: np.ndarray      # eval_bsdf(wi) = f|cos| evaluated separately


class BSDFAdapter:
    """`make_bsdf(ALL_KINDS, lobe)` wrapped in one kernel per `lobe` (mode 0 samples, mode 1
    evaluates pdf_bsdf and eval_bsdf at given directions). A case is (kind, albedo, exponent, ior,
    n, wo); u_lobe, u.x, u.y of thread i are `uniform(seed, i, 0|1|2)`."""

    _kernels: dict = {}

    def __init__(self, lobe: bool):
        self.lobe = bool(lobe)
        if self.lobe not in BSDFAdapter._kernels:
            BSDFAdapter._kernels[self.lobe] = _make_bsdf_kernel(self.lobe)
        self.kernel = BSDFAdapter._kernels[self.lobe]

    def _launch(self, mode, case, n, seed, pts=None):
        wp = _wp()
        kind, albedo, exponent, ior, nrm, wo = case
        inp = _vec3_array(pts) if pts is not None else wp.zeros(1, dtype=wp.vec3, device="cpu")
        n = int(n if pts is None else inp.shape[0])
        arrays = [wp.zeros(n, dtype=wp.vec3, device="cpu"), wp.zeros(n, dtype=float, device="cpu"),
                  wp.zeros(n, dtype=wp.vec3, device="cpu"), wp.zeros(n, dtype=int, device="cpu"),
                  wp.zeros(n, dtype=float, device="cpu"), wp.zeros(n, dtype=wp.vec3, device="cpu")]
        kind_i = KIND_INDEX[kind] if isinstance(kind, str) else int(kind)
        wp.launch(self.kernel, dim=n, device="cpu",
                  inputs=[int(mode), kind_i, _as_vec3(albedo), float(exponent), float(ior),
                          _as_vec3(nrm), _as_vec3(wo), wp.uint32(seed), inp, *arrays])
        return [a.numpy() for a in arrays]

    def sample(self, case, n: int, seed: int = 0) -> BSDFSamples:
        wi, pdf, weight, flags, pdf_eval, f_eval = self._launch(0, case, n, seed)
        return BSDFSamples(wi=wi, pdf=pdf.astype(np.float64), weight=weight,
                           valid=(flags & 1) == 1, delta=(flags & 2) == 2,
                           pdf_eval=pdf_eval.astype(np.float64), f_eval=f_eval)

    def evaluate(self, case, wi) -> tuple[np.ndarray, np.ndarray]:
        """(pdf_bsdf, eval_bsdf) at directions wi."""
        _, _, _, _, pdf, f = self._launch(1, case, 0, 0, wi)
        return pdf.astype(np.float64), f

    def sampler(self, case) -> SampleFunc:
        def sample(n, seed):
            s = self.sample(case, n, seed)
            return s.wi, s.valid
        return sample

    def pdf(self, case, masked: bool = True) -> PdfFunc:
        """The density of *valid* samples: pdf_bsdf where f|cos| > 0 (sample_bsdf drops a proposal
        whose f is zero, e.g. a uniform proposal outside a Phong lobe); masked=False: pdf_bsdf."""
        def pdf(pts):
            p, f = self.evaluate(case, pts)
            if masked:
                p = np.where(np.any(f > 0.0, axis=1), p, 0.0)
            return p
        return pdf


def _make_bsdf_kernel(lobe: bool):
    wp = _wp()
    from drtlab.kernels.materials import make_bsdf

    b = make_bsdf(ALL_KINDS, lobe)
    sample_bsdf, pdf_bsdf, eval_bsdf = b.sample_bsdf, b.pdf_bsdf, b.eval_bsdf

    @wp.kernel(enable_backward=False, module="unique")
    def bsdf_kernel(mode: int, kind: int, albedo: wp.vec3, exponent: float, ior: float,
                    n: wp.vec3, wo: wp.vec3, seed: wp.uint32, pts: wp.array(dtype=wp.vec3),
                    out_wi: wp.array(dtype=wp.vec3), out_pdf: wp.array(dtype=float),
                    out_weight: wp.array(dtype=wp.vec3), out_flags: wp.array(dtype=int),
                    out_pdf_eval: wp.array(dtype=float), out_f_eval: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            u_lobe = uniform(seed, i, 0)
            u = wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2))
            s = sample_bsdf(kind, albedo, exponent, ior, n, wo, u_lobe, u)
            out_wi[tid] = s.wi
            out_pdf[tid] = s.pdf
            out_weight[tid] = s.weight
            out_flags[tid] = s.valid + 2 * s.delta
            if s.valid == 1 and s.delta == 0:
                out_pdf_eval[tid] = pdf_bsdf(kind, exponent, ior, n, wo, s.wi)
                out_f_eval[tid] = eval_bsdf(kind, albedo, exponent, ior, n, wo, s.wi)
        else:
            wi = pts[tid]
            out_pdf_eval[tid] = pdf_bsdf(kind, exponent, ior, n, wo, wi)
            out_f_eval[tid] = eval_bsdf(kind, albedo, exponent, ior, n, wo, wi)

    return bsdf_kernel


@dataclass
class LightSamples:
    wi: np.ndarray          # (n, 3)
    dist: np.ndarray
    pdf: np.ndarray         # the solid-angle pdf the sample carries (light choice included)
    valid: np.ndarray       # bool
    light: np.ndarray       # picked light index
    pdf_eval: np.ndarray    # light_pdf at the sampled point, evaluated separately
    radiance: np.ndarray    # (n, 3)
    pmf: np.ndarray         # light_pick_pmf of the picked light


class LightAdapter:
    """`make_lights(False, solid_angle, power_pick)` on an uploaded SceneData, seen from a point x.

    Sampling: li = pick_light(u0), then sample_light(li, x, (u1, u2)). The claimed density of a
    direction w is the sum over lights of light_pdf(li, x, y, ny) where y is the nearest point at
    which the ray x + t w meets light li's shape and ny its normal (spheres: outward; quads: their
    normal), counted only where that point faces x (a one-sided quad seen from behind, or a sphere
    point facing away, is never a valid sample). `wrong_jacobian` compiles the renderer's fault
    (area samples converted to solid angle without the cosine at the light): a negative control for
    the pdf consistency check, which a chi-square test of the directions cannot see."""

    _kernels: dict = {}

    def __init__(self, solid_angle: bool, power_pick: bool, wrong_jacobian: bool = False):
        key = (bool(solid_angle), bool(power_pick), bool(wrong_jacobian))
        if key not in LightAdapter._kernels:
            LightAdapter._kernels[key] = _make_light_kernel(*key)
        self.kernel = LightAdapter._kernels[key]

    def _launch(self, mode, sd, x, n, seed, pts=None):
        wp = _wp()
        inp = _vec3_array(pts) if pts is not None else wp.zeros(1, dtype=wp.vec3, device="cpu")
        n = int(n if pts is None else inp.shape[0])
        arrays = [wp.zeros(n, dtype=wp.vec3, device="cpu"), wp.zeros(n, dtype=float, device="cpu"),
                  wp.zeros(n, dtype=float, device="cpu"), wp.zeros(n, dtype=int, device="cpu"),
                  wp.zeros(n, dtype=int, device="cpu"), wp.zeros(n, dtype=float, device="cpu"),
                  wp.zeros(n, dtype=wp.vec3, device="cpu"), wp.zeros(n, dtype=float, device="cpu")]
        wp.launch(self.kernel, dim=n, device="cpu",
                  inputs=[int(mode), sd, _as_vec3(x), wp.uint32(seed), inp, *arrays])
        return [a.numpy() for a in arrays]

    def sample(self, sd, x, n: int, seed: int = 0) -> LightSamples:
        wi, dist, pdf, valid, li, pdf_eval, rad, pmf = self._launch(0, sd, x, n, seed)
        return LightSamples(wi=wi, dist=dist, pdf=pdf.astype(np.float64), valid=valid == 1,
                            light=li, pdf_eval=pdf_eval.astype(np.float64), radiance=rad,
                            pmf=pmf.astype(np.float64))

    def sampler(self, sd, x) -> SampleFunc:
        def sample(n, seed):
            s = self.sample(sd, x, n, seed)
            return s.wi, s.valid
        return sample

    def pdf(self, sd, x) -> PdfFunc:
        def pdf(pts):
            return self._launch(1, sd, x, 0, 0, pts)[5].astype(np.float64)
        return pdf


def _make_light_kernel(solid_angle: bool, power_pick: bool, wrong_jacobian: bool):
    wp = _wp()
    from drtlab.kernels.geometry import hit_quad, hit_sphere
    from drtlab.kernels.lights import make_lights

    L = make_lights(False, solid_angle, power_pick, wrong_jacobian)
    pick_light, light_pdf, sample_light, pick_pmf = (L.pick_light, L.light_pdf, L.sample_light,
                                                     L.light_pick_pmf)

    @wp.kernel(enable_backward=False, module="unique")
    def light_kernel(mode: int, sd: SceneData, x: wp.vec3, seed: wp.uint32,
                     pts: wp.array(dtype=wp.vec3), out_wi: wp.array(dtype=wp.vec3),
                     out_dist: wp.array(dtype=float), out_pdf: wp.array(dtype=float),
                     out_valid: wp.array(dtype=int), out_light: wp.array(dtype=int),
                     out_pdf_eval: wp.array(dtype=float), out_rad: wp.array(dtype=wp.vec3),
                     out_pmf: wp.array(dtype=float)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            u0 = uniform(seed, i, 0)
            u = wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2))
            li = pick_light(sd, u0)
            ls = sample_light(sd, li, x, u, 0.0)
            out_light[tid] = li
            out_pmf[tid] = pick_pmf(sd, li)
            out_valid[tid] = ls.valid
            if ls.valid == 1:
                out_wi[tid] = ls.wi
                out_dist[tid] = ls.dist
                out_pdf[tid] = ls.pdf
                out_rad[tid] = ls.radiance
                # The pdf of the same point evaluated on its own, as MIS does from a BSDF hit.
                y = x + ls.wi * ls.dist
                s = sd.light_shape[li]
                ny = wp.vec3(0.0)
                if sd.light_shape_kind[li] == SPHERE:
                    ny = wp.normalize(y - sd.sph_center[s])
                else:
                    ny = sd.quad_normal[s]
                out_pdf_eval[tid] = light_pdf(sd, li, x, y, ny, 0.0)
        else:
            w = wp.normalize(pts[tid])
            total = float(0.0)
            for li in range(sd.n_lights):
                s = sd.light_shape[li]
                t = float(1.0e30)
                ny = wp.vec3(0.0)
                if sd.light_shape_kind[li] == SPHERE:
                    c = sd.sph_center[s]
                    t = hit_sphere(x, w, c, sd.sph_radius[s], 1.0e30)
                    if t < 1.0e30:
                        ny = wp.normalize(x + w * t - c)
                else:
                    t = hit_quad(x, w, sd.quad_origin[s], sd.quad_u[s], sd.quad_v[s], 1.0e30)
                    ny = sd.quad_normal[s]
                if t < 1.0e30:
                    if wp.dot(ny, w) < 0.0:
                        total += light_pdf(sd, li, x, x + w * t, ny, 0.0)
            out_pdf_eval[tid] = total

    return light_kernel


def upload_scene(scene_dict: dict):
    """SceneData on the CPU for a scene dict (kernels/SCENE_FORMAT.md), and the Scene itself."""
    from drtlab.kernels.render import upload
    from drtlab.kernels.scene_file import scene_from_dict
    scene = scene_from_dict(scene_dict, name="chi2")
    return upload(scene, "cpu"), scene
