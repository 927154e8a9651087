"""Pixel reconstruction filters: what a pixel's value is, and the two estimators of it.

A pixel (px, py) with filter f is the filter-weighted mean of the radiance on the image plane,
    I(p) = integral f(x - c) L(x) dx / integral f,        c = (px + 0.5, py + 0.5),
over the filter's support [-radius, radius]^2 around the pixel centre (pixel units). The box of
radius 0.5 is today's pixel (the mean over the pixel's square); every other filter is separable,
f(x, y) = f1(x) f1(y), with the radius and parameters of pbrt-v4's (`src/pbrt/filters.{h,cpp}`):
    gaussian          radius 1.5, sigma 0.5, f1(x) = max(0, g(x) - g(radius)), g the normal density
    mitchell          radius 2, B = C = 1/3, f1(x) = M(2x / radius) (Mitchell-Netravali 1988);
                      negative lobes for 1 < |x| < 2
    blackman_harris   radius 2 (pbrt-v4 has none: Sunflow's default size 4), the 4-term window
                      f1(x) = a0 - a1 cos(2 pi t) + a2 cos(4 pi t) - a3 cos(6 pi t), t = (x + r) / 2r;
                      non-negative (6e-5 at the ends), so it has no negative lobes
    mitsuba_gaussian  Mitsuba 3's default (src/rfilters/gaussian.cpp): stddev s (camera `filter_stddev`,
                      default 0.5), radius r = 4 s, g(x) = max(0, exp(-x^2 / 2s^2) - exp(-8)), as
                      Mitsuba's CPU (scalar) variants weigh a sample: not g itself but the table
                      ReconstructionFilter::eval_discretized reads (include/mitsuba/core/rfilter.h,
                      src/core/rfilter.cpp; ImageBlock::put in src/render/imageblock.cpp), 32 float32
                      values, v[i] = g(r i / 31) for i < 31 and v[31] = 0, f1(x) = v[min(floor(|x| 31 / r),
                      31)]: piecewise constant, each bin holding g at its inner end, a slightly wider
                      filter than g (its reference images were rendered so; Mitsuba's CPU build's g is a
                      degree-9 Remez fit of the exponential, within 4.1e-4 of it, the table here the
                      exact formula at the bin starts). Its mitchell is tabulated the same way; drtlab's
                      mitchell stays pbrt-v4's continuous one

Truncated to the film (camera `filter_clip`, Mitsuba's films without sample_border): a pixel within
the margin of the border sees only the image plane inside the film, so its filter is f restricted to
the film, normalised by the integral of that restriction (`clip_table`).

Filter importance sampling (Ernst et al. 2006; pbrt-v4's FilterSampler, but with separable 1D
tables): the pixel dimensions are mapped through the inverse CDF of a piecewise-constant density
proportional to |f1| on TABLE_BINS bins (the bin masses integrated in float64), and a sample weighs
    w = f(x) / (p(x) integral f)   ~ sign(f(x)) integral |f| / integral f,
evaluated exactly (f at the sampled point, p the table's density), so the plain mean of w L is
unbiased for I(p) whatever the table's resolution; the pixel stays an independent estimate.

Splatting (weighted accumulation): every pixel's samples stay uniform in its own square, and a pixel
is sum_k f(x_k - c) L_k / sum_k f(x_k - c) over every sample within the radius, its neighbours'
included (a ratio estimator: consistent, biased at low spp). See kernels/splat.py for the gather.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

BOX = "box"
# Bins per axis, a power of two (the device's search halves the table). pbrt-v4 tabulates the 2D
# filter at 32 bins per unit radius (48-64 a side) and weighs a sample by the bin's value over its
# density, which estimates the tabulated filter; here the weight uses f itself, so the table's size
# sets only the variance (f / p within a bin), never the pixel's definition.
TABLE_BINS = 256


@dataclass(frozen=True)
class Filter:
    name: str
    radius: float
    description: str

    @property
    def margin(self) -> int:
        """Neighbour pixels on each side whose samples can fall within the radius of a pixel's centre."""
        return max(0, math.ceil(self.radius - 0.5))

    def f1(self, x):
        """The 1D profile in float64 (numpy), zero outside [-radius, radius]."""
        x = np.asarray(x, dtype=np.float64)
        return np.where(np.abs(x) <= self.radius, _PROFILES[self.name](x, self.radius), 0.0)

    @property
    def integral1(self) -> float:
        """Integral of f1 over its support (closed form)."""
        return _INTEGRALS[self.name](self.radius)

    @property
    def integral(self) -> float:
        return self.integral1 ** 2

    def truncated_integral1(self, lo: float, hi: float) -> float:
        """Integral of f1 over [lo, hi] within the support (scipy's adaptive quadrature, split at
        the profile's kinks so that it is exact to rounding)."""
        from scipy.integrate import quad
        lo, hi = max(lo, -self.radius), min(hi, self.radius)
        kinks = [k for k in self.kinks if lo < k < hi]
        return quad(lambda x: float(self.f1(x)), lo, hi, points=kinks or None, epsabs=0.0, epsrel=1e-13,
                    limit=200 + 2 * len(kinks))[0]

    @property
    def kinks(self) -> tuple:
        """Points of [-radius, radius] where f1 or its derivatives jump (Mitsuba's table: its bin edges)."""
        r = self.radius
        if self.name == MITSUBA_GAUSSIAN:
            n = MITSUBA_FILTER_RESOLUTION
            return tuple(r * i / n for i in range(-n + 1, n))
        return (-r / 2, 0.0, r / 2)

    def value(self, x, y):
        """f(x, y) in float64."""
        return self.f1(x) * self.f1(y)


GAUSSIAN_SIGMA = 0.5
MITCHELL_B = MITCHELL_C = 1.0 / 3.0
BH_COEFFS = (0.35875, 0.48829, 0.14128, 0.01168)
MITSUBA_GAUSSIAN = "mitsuba_gaussian"
MITSUBA_STDDEV = 0.5            # Mitsuba's default stddev; its radius is MITSUBA_RADIUS_STDDEVS of them
MITSUBA_RADIUS_STDDEVS = 4.0
STDDEV_MIN, STDDEV_MAX = 0.25, 4.0      # pixels: filter_stddev's range (radius 1 to 16)


def _normal(x):
    return np.exp(-0.5 * (np.asarray(x) / GAUSSIAN_SIGMA) ** 2) / (math.sqrt(2 * math.pi) * GAUSSIAN_SIGMA)


def _gaussian(x, r):
    return np.maximum(0.0, _normal(x) - _normal(r))


def _gaussian_integral(r):
    return math.erf(r / (GAUSSIAN_SIGMA * math.sqrt(2.0))) - 2.0 * r * float(_normal(r))


def _mitchell(x, r):
    b, c = MITCHELL_B, MITCHELL_C
    x = np.abs(2.0 * x / r)
    inner = ((12 - 9 * b - 6 * c) * x ** 3 + (-18 + 12 * b + 6 * c) * x ** 2 + (6 - 2 * b)) / 6.0
    outer = ((-b - 6 * c) * x ** 3 + (6 * b + 30 * c) * x ** 2 + (-12 * b - 48 * c) * x
             + (8 * b + 24 * c)) / 6.0
    return np.where(x <= 1.0, inner, np.where(x <= 2.0, outer, 0.0))


def _blackman_harris(x, r):
    a0, a1, a2, a3 = BH_COEFFS
    t = 2.0 * np.pi * (np.asarray(x) + r) / (2.0 * r)
    return a0 - a1 * np.cos(t) + a2 * np.cos(2 * t) - a3 * np.cos(3 * t)


# Mitsuba's MI_FILTER_RESOLUTION (include/mitsuba/core/rfilter.h): bins of its filter table over [0, radius].
MITSUBA_FILTER_RESOLUTION = 31


@lru_cache(maxsize=None)
def mitsuba_gaussian_table(r: float) -> np.ndarray:
    """(MITSUBA_FILTER_RESOLUTION + 1,) float32: Mitsuba's discretized Gaussian of radius r, the
    formula at the bin starts r i / 31 (computed in float32 as init_discretization does), then 0."""
    n = MITSUBA_FILTER_RESOLUTION
    x = (np.float32(r) * np.arange(n, dtype=np.float32)) / np.float32(n)
    s = r / MITSUBA_RADIUS_STDDEVS
    g = np.exp(-0.5 * (x.astype(np.float64) / s) ** 2) - math.exp(-0.5 * MITSUBA_RADIUS_STDDEVS ** 2)
    table = np.zeros(n + 1, dtype=np.float32)
    table[:n] = np.maximum(0.0, g)
    table.flags.writeable = False
    return table


def mitsuba_bin(x, r: float) -> np.ndarray:
    """The table index eval_discretized reads at x: min(uint(|x| * (31 / r)), 31), in float32."""
    scale = np.float32(MITSUBA_FILTER_RESOLUTION) / np.float32(r)
    t = np.abs(np.asarray(x, dtype=np.float64)).astype(np.float32) * scale
    return np.minimum(np.floor(np.minimum(t, np.float32(MITSUBA_FILTER_RESOLUTION))),
                      MITSUBA_FILTER_RESOLUTION).astype(np.int64)


def _mitsuba_gaussian(x, r):
    return mitsuba_gaussian_table(r)[mitsuba_bin(x, r)].astype(np.float64)


def _mitsuba_gaussian_integral(r):
    # Bins of width r / 31 on each side (the last, [30 r / 31, r), holds v[30] > 0; v[31] is beyond).
    table = mitsuba_gaussian_table(r).astype(np.float64)
    return 2.0 * (r / MITSUBA_FILTER_RESOLUTION) * float(np.sum(table[:MITSUBA_FILTER_RESOLUTION]))


_PROFILES = {"gaussian": _gaussian, MITSUBA_GAUSSIAN: _mitsuba_gaussian, "mitchell": _mitchell, "blackman_harris": _blackman_harris,
             BOX: lambda x, r: np.ones_like(np.asarray(x, dtype=np.float64))}
_INTEGRALS = {"gaussian": _gaussian_integral, MITSUBA_GAUSSIAN: _mitsuba_gaussian_integral, "mitchell": lambda r: r / 2.0,
              "blackman_harris": lambda r: 2.0 * r * BH_COEFFS[0], BOX: lambda r: 2.0 * r}

FILTERS = {f.name: f for f in (
    Filter(BOX, 0.5, "the pixel's square (no filter code is compiled)"),
    Filter("gaussian", 1.5, "Gaussian, sigma 0.5, minus its value at the radius (pbrt-v4)"),
    Filter("mitchell", 2.0, "Mitchell-Netravali B = C = 1/3, negative lobes (pbrt-v4)"),
    Filter("blackman_harris", 2.0, "4-term Blackman-Harris window, non-negative"),
    Filter(MITSUBA_GAUSSIAN, MITSUBA_RADIUS_STDDEVS * MITSUBA_STDDEV,
           "Mitsuba 3's Gaussian, stddev `filter_stddev` (0.5), radius 4 stddev, minus its value there, "
           "tabulated in 31 bins as its CPU variants weigh samples"),
)}
FILTER_NAMES = tuple(FILTERS)
# The filters with a `filter_stddev` (the others' shapes are fixed).
STDDEV_FILTERS = (MITSUBA_GAUSSIAN,)


def get_filter(name: str, stddev: float = 0.0) -> Filter:
    """The filter `name`; a STDDEV_FILTERS one with `stddev` > 0 gets the radius of that stddev."""
    if stddev > 0.0 and name in STDDEV_FILTERS:
        return Filter(name, MITSUBA_RADIUS_STDDEVS * float(stddev), FILTERS[name].description)
    return FILTERS[name]


@lru_cache(maxsize=None)
def filter_cdf(filt: Filter | str, bins: int = TABLE_BINS) -> np.ndarray:
    """(bins + 1,) float32 CDF of the piecewise-constant density proportional to |f1| on `bins`
    equal bins of [-radius, radius]: each bin's mass is its integral of |f1| (Gauss-Legendre, 16
    nodes per bin or per piece between the kinks within it, float64); cdf[0] = 0 and cdf[bins] = 1
    exactly."""
    filt = FILTERS[filt] if isinstance(filt, str) else filt
    name = filt.name
    nodes, weights = np.polynomial.legendre.leggauss(16)

    def masses(lo, hi):
        half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
        x = mid[:, None] + half[:, None] * nodes[None, :]
        return np.sum(np.abs(filt.f1(x)) * weights[None, :], axis=1) * half
    edges = np.linspace(-filt.radius, filt.radius, bins + 1)
    mass = masses(edges[:-1], edges[1:])
    # A bin with a kink (a step of Mitsuba's table) inside it: summed over the pieces between them.
    for i in np.unique(np.searchsorted(edges, filt.kinks, side="right") - 1):
        cuts = np.array(sorted({edges[i], edges[i + 1]} | {k for k in filt.kinks if edges[i] < k < edges[i + 1]}))
        mass[i] = masses(cuts[:-1], cuts[1:]).sum()
    cdf = np.concatenate(([0.0], np.cumsum(mass) / mass.sum())).astype(np.float32)
    cdf[-1] = 1.0
    if np.any(np.diff(cdf) <= 0):
        raise RuntimeError(f"filter {name}: a table bin has no mass (the sampler needs every bin > 0)")
    return cdf


@lru_cache(maxsize=None)
def clip_table(filt: Filter, bins: int = TABLE_BINS) -> np.ndarray:
    """(margin, 3) float32: for a pixel k = 0 .. margin - 1 pixels from the film's edge, whose filter
    is cut at k + 0.5 from its centre on that side: the sampling table's CDF at -(k + 0.5) and at
    +(k + 0.5) (piecewise linear in the float32 table, as the device reads it: the sampler draws from
    the table restricted to the film) and the exact integral of f1 beyond the cut, over
    [-radius, -(k + 0.5)] (f1 is even, so either side)."""
    cdf = filter_cdf(filt, bins).astype(np.float64)
    edges = np.linspace(-filt.radius, filt.radius, bins + 1)
    cuts = np.arange(filt.margin) + 0.5
    rows = [(np.interp(-c, edges, cdf), np.interp(c, edges, cdf), filt.truncated_integral1(-filt.radius, -c))
            for c in cuts]
    return np.asarray(rows, dtype=np.float32).reshape(filt.margin, 3)
