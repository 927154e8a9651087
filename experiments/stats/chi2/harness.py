"""The chi-square test itself: Mitsuba-style pooling, the expected counts by quadrature of the claimed
pdf over a Domain's grid, Pearson's statistic and the Sidak-corrected level (the method is described
in the package's docstring, drtlab.experiments.stats.chi2)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import stats

from drtlab.experiments.stats.chi2.domains import Domain
from drtlab.experiments.stats.hypothesis_tests import sidak

ALPHA = 0.01
POOL_THRESHOLD = 5.0


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
