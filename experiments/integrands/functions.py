"""2D integrands on [0, 1]^2 with exact integrals: the analytic testbed of `integrands.study`.

Each integrand is a small frozen dataclass: `f(x, y)` evaluates it, vectorised (numpy broadcasting),
`integral()` is its closed-form integral over the unit square, `kind` says which convergence theory
applies ("discontinuous": an indicator with a boundary crossing the strata; "smooth": infinitely
differentiable on the square). Parameters may be scalars (one integrand) or arrays of shape
(members, 1) (a batch of members of a randomised family, evaluated on points of shape
(members, n) at once); `integral()` then has one value per member.

Families (`Family`) draw members from a seeded numpy Generator, so a convergence rate measured over
many members does not hinge on one lucky or unlucky alignment of a shape with the strata. Both
kinds of entry of `INTEGRANDS` answer `members(rng, count)` -> a batch of `count` integrands (a
fixed integrand ignores `rng` and repeats itself), which is what the study evaluates.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import special

from drtlab.errors import InputError

DISCONTINUOUS, SMOOTH = "discontinuous", "smooth"
KINDS = (DISCONTINUOUS, SMOOTH)


def _column(v) -> np.ndarray | float:
    """A batch parameter as a (members, 1) column, so it broadcasts against (members, n) points."""
    a = np.asarray(v, dtype=np.float64)
    return float(a) if a.ndim == 0 else a.reshape(-1, 1)


class _Fixed:
    """`members` of a fixed integrand: itself, `count` times (its parameters stay scalars, so it
    broadcasts against any (count, n) batch of points; `integral()` is repeated to (count,))."""

    def members(self, rng: np.random.Generator | None, count: int):
        return _Repeated(self, count)


@dataclass(frozen=True)
class _Repeated:
    base: object
    count: int

    def f(self, x, y):
        return self.base.f(x, y)

    def exact(self) -> np.ndarray:
        return np.full(self.count, float(self.base.integral()))


# ---------------------------------------------------------------------------------------------------
# Discontinuous integrands (indicators)
# ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Disk(_Fixed):
    """Indicator of the disk |p - c| < r, which must lie inside the square: integral pi r^2."""
    cx: object
    cy: object
    r: object
    kind = DISCONTINUOUS

    def __post_init__(self):
        cx, cy, r = (np.asarray(v, dtype=np.float64) for v in (self.cx, self.cy, self.r))
        margin = np.minimum(np.minimum(cx, 1 - cx), np.minimum(cy, 1 - cy))
        if not np.all((r > 0) & (r <= margin)):
            raise InputError("disk", "the disk must lie inside [0, 1]^2 with radius > 0 "
                                     "(otherwise its integral is not pi r^2)")

    def f(self, x, y):
        dx, dy = x - _column(self.cx), y - _column(self.cy)
        return (dx * dx + dy * dy < _column(self.r) ** 2).astype(np.float64)

    def integral(self):
        return math.pi * np.asarray(self.r, dtype=np.float64) ** 2


@dataclass(frozen=True)
class Triangle(_Fixed):
    """Indicator of the triangle with vertices a, b, c ((x, y) pairs inside the square):
    integral = its area |cross(b - a, c - a)| / 2."""
    a: tuple
    b: tuple
    c: tuple
    kind = DISCONTINUOUS

    def __post_init__(self):
        v = np.array([self.a, self.b, self.c], dtype=np.float64)
        if v.shape != (3, 2) or np.any((v < 0) | (v > 1)) or self.integral() <= 0:
            raise InputError("triangle", "needs three (x, y) vertices in [0, 1]^2 spanning an area > 0")

    def _signed_area(self) -> float:
        (ax, ay), (bx, by), (cx, cy) = self.a, self.b, self.c
        return 0.5 * ((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))

    def f(self, x, y):
        s = math.copysign(1.0, self._signed_area())     # orientation: inside = left of every edge
        inside = np.ones(np.broadcast(x, y).shape, dtype=bool)
        for (px, py), (qx, qy) in ((self.a, self.b), (self.b, self.c), (self.c, self.a)):
            inside &= s * ((qx - px) * (y - py) - (qy - py) * (x - px)) >= 0
        return inside.astype(np.float64)

    def integral(self):
        return abs(self._signed_area())


_SQUARE = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))


def half_plane_area(angle: float, offset: float) -> float:
    """Area of {p in [0, 1]^2 : cos(angle) x + sin(angle) y <= offset}: the unit square clipped by
    the half-plane (one Sutherland-Hodgman step, exact up to rounding) and measured by the shoelace
    formula. Clipping, not the inclusion-exclusion closed form sum +-max(t, 0)^2 / (2ab): that one
    divides by the normal's components and cancels catastrophically near axis-aligned angles."""
    nx, ny = math.cos(angle), math.sin(angle)
    d = [nx * px + ny * py - offset for px, py in _SQUARE]      # <= 0: inside
    poly = []
    for i, (p, dp) in enumerate(zip(_SQUARE, d)):
        q, dq = _SQUARE[(i + 1) % 4], d[(i + 1) % 4]
        if dp <= 0:
            poly.append(p)
        if (dp < 0 < dq) or (dq < 0 < dp):
            t = dp / (dp - dq)              # |dp| + |dq| in the denominator: no cancellation
            poly.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
    twice = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]))
    return min(max(0.5 * twice, 0.0), 1.0)


@dataclass(frozen=True)
class HalfPlane(_Fixed):
    """Indicator of the step cos(angle) x + sin(angle) y <= offset (a straight edge at any angle):
    integral = the clipped area (`half_plane_area`)."""
    angle: object
    offset: object
    kind = DISCONTINUOUS

    def f(self, x, y):
        a, c = _column(self.angle), _column(self.offset)
        return (np.cos(a) * x + np.sin(a) * y <= c).astype(np.float64)

    def integral(self):
        a, c = np.broadcast_arrays(np.asarray(self.angle, float), np.asarray(self.offset, float))
        return np.vectorize(half_plane_area, otypes=[float])(a, c)


# ---------------------------------------------------------------------------------------------------
# Smooth integrands
# ---------------------------------------------------------------------------------------------------

def _gauss_1d(c, sigma):
    """Integral over [0, 1] of exp(-(t - c)^2 / (2 sigma^2))."""
    s = np.sqrt(2.0) * sigma
    return sigma * np.sqrt(np.pi / 2.0) * (special.erf((1.0 - c) / s) + special.erf(c / s))


@dataclass(frozen=True)
class Gaussian(_Fixed):
    """Isotropic Gaussian bump exp(-|p - c|^2 / (2 sigma^2)), truncated by the square: the integral
    factorises into two 1D erf integrals."""
    cx: object
    cy: object
    sigma: object
    kind = SMOOTH

    def __post_init__(self):
        if not np.all(np.asarray(self.sigma, dtype=np.float64) > 0):
            raise InputError("gaussian", "sigma must be > 0")

    def f(self, x, y):
        dx, dy = x - _column(self.cx), y - _column(self.cy)
        return np.exp(-(dx * dx + dy * dy) / (2.0 * _column(self.sigma) ** 2))

    def integral(self):
        cx, cy, s = (np.asarray(v, dtype=np.float64) for v in (self.cx, self.cy, self.sigma))
        return _gauss_1d(cx, s) * _gauss_1d(cy, s)


@dataclass(frozen=True)
class Bilinear(_Fixed):
    """a + b x + c y + d x y: integral a + b/2 + c/2 + d/4. Its interaction term d x y is what
    Latin hypercube sampling cannot stratify away."""
    a: float = 0.0
    b: float = 0.0
    c: float = 0.0
    d: float = 1.0
    kind = SMOOTH

    def f(self, x, y):
        return self.a + self.b * x + self.c * y + self.d * x * y

    def integral(self):
        return self.a + self.b / 2 + self.c / 2 + self.d / 4


# ---------------------------------------------------------------------------------------------------
# Randomised families
# ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Family:
    """Members drawn by `draw(rng, count)` -> one batched integrand of `kind`."""
    kind: str
    description: str
    draw: Callable[[np.random.Generator, int], object]

    def members(self, rng: np.random.Generator, count: int):
        return _Batch(self.draw(rng, count))


@dataclass(frozen=True)
class _Batch:
    members_: object

    def f(self, x, y):
        return self.members_.f(x, y)

    def exact(self) -> np.ndarray:
        return np.ravel(np.asarray(self.members_.integral(), dtype=np.float64))


def _random_disks(rng, count):
    r = rng.uniform(0.05, 0.3, count)
    return Disk(rng.uniform(r, 1 - r), rng.uniform(r, 1 - r), r)


def _random_gaussians(rng, count):
    return Gaussian(rng.uniform(0.2, 0.8, count), rng.uniform(0.2, 0.8, count),
                    rng.uniform(0.1, 0.3, count))


def _random_half_planes(rng, count):
    # Any direction, the edge through a point well inside the square: the step always cuts it.
    angle = rng.uniform(0.0, 2 * np.pi, count)
    px, py = rng.uniform(0.2, 0.8, count), rng.uniform(0.2, 0.8, count)
    return HalfPlane(angle, np.cos(angle) * px + np.sin(angle) * py)


# The fixed members avoid alignments with 4^k grids (an axis-aligned edge at 1/2 has zero error
# under stratification: no slope to fit); the families cover alignments at random.
INTEGRANDS: dict[str, object] = {
    "disk": Disk(0.48, 0.53, 0.3),
    "triangle": Triangle((0.1, 0.15), (0.85, 0.3), (0.35, 0.9)),
    "half-plane": HalfPlane(1.1, math.cos(1.1) * 0.5 + math.sin(1.1) * 0.45),
    "gaussian": Gaussian(0.45, 0.55, 0.2),
    "bilinear": Bilinear(),
    "random-disks": Family(DISCONTINUOUS, "disks, radius U(0.05, 0.3), centre uniform inside",
                           _random_disks),
    "random-gaussians": Family(SMOOTH, "Gaussians, centre U(0.2, 0.8)^2, sigma U(0.1, 0.3)",
                               _random_gaussians),
    "random-half-planes": Family(DISCONTINUOUS, "steps at a uniform angle through a point of "
                                                "U(0.2, 0.8)^2", _random_half_planes),
}


def describe(name: str) -> str:
    """One line for the report: the family's description, or the integrand's parameters."""
    entry = INTEGRANDS[name]
    return entry.description if isinstance(entry, Family) else repr(entry)
