"""Domains of the chi-square harness: a 2D parameter rectangle whose measure is the sampler's measure
(solid angle or area), with the map from points/directions to parameters and back."""
from __future__ import annotations

import math

import numpy as np


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


class RectangleDomain(Domain):
    """Directions from x through the rectangle q0 + s u + t v (u, v orthogonal) as its coordinates
    (s, t) in [0, 1]^2: d omega = |u x v| cos_l / d^2 ds dt, cos_l and d at the point. Made for
    rectangle lights seen at any angle: a light seen nearly edge-on from nearly its own plane is a
    sliver in any grid of directions, but fills this one."""
    dim = 3

    def __init__(self, x, q0, u, v):
        self.x, self.q0, self.u, self.v = (np.asarray(a, dtype=np.float64) for a in (x, q0, u, v))
        n = np.cross(self.u, self.v)
        self.area = float(np.linalg.norm(n))
        self.n = n / self.area
        self.bounds = np.array([(0.0, 1.0), (0.0, 1.0)], dtype=np.float64)
        self.name = "rectangle(s, t)"

    def to_param(self, pts):
        w = np.asarray(pts, dtype=np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.dot(self.q0 - self.x, self.n) / (w @ self.n)     # <= 0 or NaN: not in the grid
            p = self.x + w * np.where(t > 0.0, t, np.nan)[:, None] - self.q0
        return np.stack([p @ self.u / (self.u @ self.u), p @ self.v / (self.v @ self.v)], axis=1)

    def from_param(self, prm):
        return self.q0 + prm[:, :1] * self.u + prm[:, 1:2] * self.v - self.x

    def jacobian(self, prm):
        d = self.from_param(prm)
        d2 = np.einsum("ij,ij->i", d, d)
        return self.area * np.abs(d @ self.n) / (d2 * np.sqrt(d2))


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


class LatLongDomain(Domain):
    """Directions as the environment's lat-long coordinates (v = theta / pi from +y, u = phi / 2 pi
    from +x towards +z; kernels/scene_model/environment_map.py): d omega = 2 pi^2 sin(pi v) dv du. A grid whose
    cells are whole texels integrates a piecewise-constant map's density exactly."""
    dim = 3

    def __init__(self):
        self.bounds = np.array([(0.0, 1.0), (0.0, 1.0)], dtype=np.float64)
        self.name = "lat-long"

    def to_param(self, pts):
        p = np.asarray(pts, dtype=np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            p = p / np.linalg.norm(p, axis=1, keepdims=True)
        v = np.arccos(np.clip(p[:, 1], -1.0, 1.0)) / math.pi
        u = np.mod(np.arctan2(p[:, 2], p[:, 0]), 2.0 * math.pi) / (2.0 * math.pi)
        return np.stack([v, u], axis=1)

    def from_param(self, prm):
        theta, phi = prm[:, 0] * math.pi, prm[:, 1] * 2.0 * math.pi
        s = np.sin(theta)
        return np.stack([s * np.cos(phi), np.cos(theta), s * np.sin(phi)], axis=1)

    def jacobian(self, prm):
        return 2.0 * math.pi ** 2 * np.sin(math.pi * prm[:, 0])
