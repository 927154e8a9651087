"""Closed forms for tests/kernels/test_closed_forms.py, in float64 numpy, sharing no code with the renderer.

Screen geometry. Every image-plane scene here uses a camera at the origin looking down -z (up +y),
so a pinhole ray through the continuous pixel position (X, Y) (pixel px covers X in [px, px + 1],
rows counted downwards) meets the plane z = -D at the world point
    x = (X - W / 2) p,   y = (H / 2 - Y) p,   p = 2 D tan(fov / 2) / H   (world units per pixel),
a linear map (the tracer's sub-pixel offset is uniform in the pixel and its screen coordinates are
linear in it). A fronto-parallel rectangle [X0, X1] x [Y0, Y1] therefore covers a pixel with the
product of two 1D interval overlaps, and every coverage below is the exact area (or area x time)
integral of that indicator, not a sample average.

Thin lens (kernels/render_kernel.py camera_ray_dir): a lens point l (uniform on the disk of radius A in the
camera's right/up plane) and the ray aimed at the pinhole ray's point on the focal plane z = -F meet
the plane z = -D at the pinhole point + (1 - D / F) l. In pixel units the lens disk is blurred into
a disk of radius rho = |1 - D / F| A / p (the circle of confusion on the emitter's plane), so a
pixel point sees an emitter half-plane {n . (X, Y) > c} with probability
    g((c - n . (X, Y)) / rho),   g(h) = (acos h - h sqrt(1 - h^2)) / pi  (|h| <= 1),
the area fraction of the unit disk beyond the chord at distance h (a circle segment).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from scene_pieces import camera_dict
from stats_util import Estimate, region_values


# ---------------------------------------------------------------------------------------------------
# Statistics glue: a render estimate against an exact image, over the regions that can be tested
# ---------------------------------------------------------------------------------------------------

def exact_regions(truth: np.ndarray, block: int) -> Estimate:
    """An exact Estimate from an (H, W) image of expected R + G + B values (region means)."""
    return Estimate.exact(region_values(np.repeat(np.asarray(truth, float)[..., None] / 3.0, 3,
                                                  axis=2), block))


def subset(est: Estimate, mask: np.ndarray) -> Estimate:
    dof = est.dof if np.ndim(est.dof) == 0 else np.asarray(est.dof)[mask]
    return Estimate(est.mean[mask], est.var[mask], dof, runs=est.runs, nonfinite=est.nonfinite,
                    negative=est.negative, min_value=est.min_value, max_value=est.max_value)


def testable_binary_regions(coverage_regions: np.ndarray, samples_per_region: int,
                            min_count: float = 100.0) -> np.ndarray:
    """Partly covered regions a two-valued estimator (0 or Le per sample) can be t-tested in.

    A region with exact coverage 0 < f < 1 is kept when it expects at least `min_count` hits and
    `min_count` misses over all its samples: with fewer, a run sees a handful of hits, so neither
    the mean nor the variance of the runs is near normal (a region that happens to see no hit at
    all has zero variance against a non-zero truth). A region left out carries at most
    min_count / samples_per_region of its value. Regions with f exactly 0 or 1 are not in the mask:
    every sample there is exactly 0 or exactly Le, which the caller checks exactly."""
    f = np.asarray(coverage_regions, float)
    n = float(samples_per_region)
    return (f > 0.0) & (f < 1.0) & (n * f >= min_count) & (n * (1.0 - f) >= min_count)


def assert_off_grid(*coords, tol: float = 1e-3) -> None:
    """Static edges (and the extremes of moving ones) must not lie on a pixel boundary: the
    tracer's quads are 1e-6 (relative) wider than their edges (geometry.EDGE_TOLERANCE), which
    would put rare hits into a pixel whose exact coverage is 0."""
    for c in coords:
        if abs(c - round(c)) < tol:
            raise ValueError(f"edge at pixel coordinate {c} lies on a pixel boundary")


def chi2_power(diff: np.ndarray, var: np.ndarray, alpha: float) -> tuple[float, float]:
    """(power, lambda) of the region chi-square test (sum of z^2 over R regions, level alpha)
    against a reference off by `diff` where the estimate's variance is `var`: noncentral
    chi-square with lambda = sum diff^2 / var (regions of zero variance are left out)."""
    diff, var = np.asarray(diff, float), np.asarray(var, float)
    keep = var > 0
    lam = float(np.sum(diff[keep] ** 2 / var[keep]))
    r = int(keep.sum())
    crit = stats.chi2.isf(alpha, r)
    return float(stats.ncx2.sf(crit, r, lam)), lam


# ---------------------------------------------------------------------------------------------------
# Screen geometry (camera at the origin looking down -z)
# ---------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Screen:
    width: int
    height: int
    fov: float          # vertical, degrees
    depth: float        # distance of the plane z = -depth the pixel coordinates refer to

    @property
    def pixel(self) -> float:
        """World units per pixel on the plane z = -depth."""
        return 2.0 * self.depth * math.tan(math.radians(self.fov) / 2.0) / self.height

    def world(self, X, Y) -> np.ndarray:
        p = self.pixel
        return np.array([(X - self.width / 2.0) * p, (self.height / 2.0 - Y) * p, -self.depth])

    def world_vector(self, dX, dY) -> np.ndarray:
        """A displacement (or velocity) in pixel units as a world vector in the plane."""
        p = self.pixel
        return np.array([dX * p, -dY * p, 0.0])

    def camera(self, aperture: float = 0.0, focus: float | None = None, shutter=None) -> dict:
        return camera_dict((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), self.fov, aperture=aperture,
                           focus=focus, shutter=shutter)

    def facing_quad(self, corner_xy, edge_a_xy, edge_b_xy, material: str, **kw) -> dict:
        """A quad on the plane given in pixel units (corner and two edges), oriented so that it
        emits towards the camera (edge_u x edge_v = +z)."""
        o = self.world(*corner_xy)
        ea = self.world_vector(*edge_a_xy)
        eb = self.world_vector(*edge_b_xy)
        if np.cross(ea, eb)[2] < 0:
            ea, eb = eb, ea
        q = {"kind": "quad", "material": material, "origin": [float(v) for v in o],
             "edge_u": [float(v) for v in ea], "edge_v": [float(v) for v in eb]}
        q.update(kw)
        return q


def scene_dict(description: str, camera: dict, materials: dict, shapes: list, res, *,
               max_depth: int = 1, integrator: str = "path", background=(0.0, 0.0, 0.0)) -> dict:
    return {"scene": {"description": description, "resolution": [int(res[0]), int(res[1])],
                      "spp": 16, "integrator": integrator, "max_depth": int(max_depth),
                      "background": [float(b) for b in background]},
            "camera": camera, "materials": materials, "shapes": shapes}


# ---------------------------------------------------------------------------------------------------
# Box-filter coverage of rectangles, static and moving
# ---------------------------------------------------------------------------------------------------

def overlap(a0, a1, b0, b1):
    """Length of [a0, a1] n [b0, b1] (elementwise)."""
    return np.maximum(0.0, np.minimum(a1, b1) - np.maximum(a0, b0))


def rect_coverage(x0, x1, y0, y1, width: int, height: int) -> np.ndarray:
    """(H, W) fraction of every pixel covered by the rectangle [x0, x1] x [y0, y1] (pixel units)."""
    px = np.arange(width, dtype=float)
    py = np.arange(height, dtype=float)
    return np.outer(overlap(py, py + 1.0, y0, y1), overlap(px, px + 1.0, x0, x1))


_GL3_X, _GL3_W = np.polynomial.legendre.leggauss(3)


def moving_rect_coverage(x0, x1, y0, y1, vx, vy, width: int, height: int,
                         density=None) -> np.ndarray:
    """(H, W) time-averaged coverage of the rectangle [x0, x1] x [y0, y1] moving by (vx, vy) pixels
    over the shutter: int_0^1 overlap_x(s) overlap_y(s) w(s) ds, s the shutter fraction with
    density w (uniform if None; else a polynomial of degree <= 3 in s, as coefficients
    highest first).

    Exact: overlap_x(s) is piecewise linear in s with kinks where an edge crosses a pixel boundary,
    so on each piece between all kinks the integrand is a polynomial of degree <= 5, which 3-point
    Gauss-Legendre integrates exactly."""
    coeffs = np.array([1.0]) if density is None else np.asarray(density, float)
    out = np.zeros((height, width))
    for py in range(height):
        for px in range(width):
            cuts = [0.0, 1.0]
            for edge, v, lo in ((x0, vx, px), (x1, vx, px), (y0, vy, py), (y1, vy, py)):
                if v != 0.0:
                    cuts += [(lo - edge) / v, (lo + 1.0 - edge) / v]
            cuts = np.unique(np.clip(cuts, 0.0, 1.0))
            a, b = cuts[:-1], cuts[1:]
            s = 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * _GL3_X[None, :]
            wq = 0.5 * (b - a)[:, None] * _GL3_W[None, :]
            f = (overlap(px, px + 1.0, x0 + vx * s, x1 + vx * s)
                 * overlap(py, py + 1.0, y0 + vy * s, y1 + vy * s) * np.polyval(coeffs, s))
            out[py, px] = float(np.sum(f * wq))
    return out


# ---------------------------------------------------------------------------------------------------
# Thin lens: an emitter half-plane blurred by the circle of confusion
# ---------------------------------------------------------------------------------------------------

def segment_fraction(h):
    """Area fraction of the unit disk on the far side of the chord at signed distance h."""
    h = np.clip(np.asarray(h, float), -1.0, 1.0)
    return (np.arccos(h) - h * np.sqrt(1.0 - h * h)) / math.pi


def segment_fraction_antiderivative(h):
    """G with G' = segment_fraction on all of R (1 for h < -1, 0 for h > 1), G(h >= 1) = 0."""
    h = np.asarray(h, float)
    c = np.clip(h, -1.0, 1.0)
    s = np.sqrt(1.0 - c * c)
    inside = (c * np.arccos(c) - s + s ** 3 / 3.0) / math.pi
    return np.where(h < -1.0, h, inside)


def circle_of_confusion(depth: float, focus: float, aperture: float, pixel: float) -> float:
    """Blur radius in pixels on the plane z = -depth of a thin lens (aperture radius, focus)."""
    return abs(1.0 - depth / focus) * aperture / pixel


def blurred_halfplane_coverage(normal, c: float, rho: float, width: int, height: int,
                               n_gauss: int = 24) -> np.ndarray:
    """(H, W) box-filtered probability that a pixel sample sees the emitter {n . (X, Y) > c} through
    a lens whose blur disk has radius rho pixels: int over the pixel of g((c - n.(X, Y)) / rho).

    The X integral is exact (the antiderivative G of g); the Y integral is Gauss-Legendre on the
    pieces between the kinks of the X-integrated function (where an end of the X range crosses
    |h| = 1), so each piece is smooth and n_gauss nodes reach ~1e-10."""
    nx, ny = float(normal[0]), float(normal[1])
    if nx == 0.0:
        raise ValueError("the edge must not be horizontal (n_x != 0)")
    xg, wg = np.polynomial.legendre.leggauss(n_gauss)
    out = np.zeros((height, width))

    def inner(px, Y):
        # int_px^{px+1} g((c - nx X - ny Y) / rho) dX
        h0 = (c - nx * px - ny * Y) / rho
        h1 = (c - nx * (px + 1.0) - ny * Y) / rho
        G = segment_fraction_antiderivative
        return (G(h0) - G(h1)) * rho / nx

    for py in range(height):
        for px in range(width):
            cuts = [float(py), float(py) + 1.0]
            if ny != 0.0:
                for xe in (px, px + 1.0):
                    for hh in (-1.0, 1.0):
                        cuts.append((c - nx * xe - hh * rho) / ny)
            cuts = np.unique(np.clip(cuts, py, py + 1.0))
            total = 0.0
            for a, b in zip(cuts[:-1], cuts[1:]):
                Y = 0.5 * (a + b) + 0.5 * (b - a) * xg
                total += 0.5 * (b - a) * float(np.sum(wg * inner(px, Y)))
            out[py, px] = total
    return out


# ---------------------------------------------------------------------------------------------------
# Irradiance of unoccluded area lights (exact)
# ---------------------------------------------------------------------------------------------------

def sphere_irradiance(x, n, center, radius, le):
    """Irradiance at points x (normal n) from a uniform sphere light entirely above x's horizon:
    E = pi Le (r / d)^2 cos(theta) (the sphere acts as a point of intensity pi r^2 Le)."""
    d = np.asarray(center, float) - x
    d2 = np.sum(d * d, axis=-1)
    cos = np.sum(d * np.asarray(n, float), axis=-1) / np.sqrt(d2)
    if np.any(cos * np.sqrt(d2) <= radius):
        raise ValueError("the sphere light must lie entirely above every point's horizon")
    return math.pi * le * radius ** 2 / d2 * cos


def polygon_irradiance(x, n, verts, le):
    """Lambert's formula: irradiance at x (normal n) from a uniform convex polygon entirely above
    its horizon, E = (Le / 2) |sum_i Theta_i n . (u_i x u_{i+1}) / |u_i x u_{i+1}||,
    u_i = unit(v_i - x), Theta_i the angle between u_i and u_{i+1}."""
    n = np.asarray(n, float)
    u = [np.asarray(v, float) - x for v in verts]
    for v in u:
        if np.any(np.sum(v * n, axis=-1) <= 0):
            raise ValueError("the polygon must lie entirely above every point's horizon")
    u = [v / np.linalg.norm(v, axis=-1, keepdims=True) for v in u]
    total = np.zeros(np.shape(x)[:-1])
    for a, b in zip(u, u[1:] + u[:1]):
        cr = np.cross(a, b)
        ncr = np.linalg.norm(cr, axis=-1)
        theta = np.arctan2(ncr, np.sum(a * b, axis=-1))
        total += theta * np.sum(cr * n, axis=-1) / ncr
    return 0.5 * le * np.abs(total)


def pinhole_rays(cam: dict, width: int, height: int, n_pix: int = 6):
    """Gauss-Legendre rays of every pixel of a pinhole camera, as camera_ray_dir defines them
    (screen x, y linear in the sub-pixel offset; direction right * x + up * y + forward):
    origins (3,), unit directions (H, W, Q, 3), weights (Q,) summing to 1."""
    pos = np.asarray(cam["position"], float)
    fwd = np.asarray(cam["look_at"], float) - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, np.asarray(cam["up"], float))
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    hh = math.tan(math.radians(cam["fov"]) / 2.0)
    hw = hh * width / height
    g, w = np.polynomial.legendre.leggauss(n_pix)
    g, w = 0.5 * (g + 1.0), 0.5 * w
    u0, u1 = [a.ravel() for a in np.meshgrid(g, g, indexing="ij")]
    wq = np.outer(w, w).ravel()
    px = np.arange(width)[None, :, None]
    py = np.arange(height)[:, None, None]
    sx = (2.0 * (px + u0) / width - 1.0) * hw
    sy = (1.0 - 2.0 * (py + u1) / height) * hh
    sx, sy = np.broadcast_arrays(sx, sy)
    d = right * sx[..., None] + up * sy[..., None] + fwd
    return pos, d / np.linalg.norm(d, axis=-1, keepdims=True), wq / wq.sum()


def ray_hits_sphere(o, d, center, radius):
    oc = np.asarray(center, float) - o
    tc = np.sum(oc * d, axis=-1)
    disc = radius ** 2 - (np.sum(oc * oc, axis=-1) - tc ** 2)
    return (disc >= 0) & (tc + np.sqrt(np.maximum(disc, 0.0)) > 0)


def ray_hits_parallelogram(o, d, p0, eu, ev):
    n = np.cross(eu, ev)
    denom = d @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((np.asarray(p0) - o) @ n) / denom
        x = o + d * t[..., None] - p0
    w = n / np.dot(n, n)
    a = np.cross(x, ev) @ w
    b = np.cross(eu, x) @ w
    return (denom != 0) & (t > 0) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1)


def segment_clears_sphere(p, q, center, radius, margin: float) -> bool:
    """Whether every segment p_i -> q_j stays more than radius + margin from the sphere's centre."""
    p = np.asarray(p, float).reshape(-1, 1, 3)
    q = np.asarray(q, float).reshape(1, -1, 3)
    d = q - p
    t = np.clip(np.sum((np.asarray(center) - p) * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
    closest = p + d * t[..., None]
    return bool(np.all(np.linalg.norm(closest - center, axis=-1) > radius + margin))


# ---------------------------------------------------------------------------------------------------
# Glossy dielectric (kernels/materials/dielectric.py eval_glossy_dielectric) in float64
# ---------------------------------------------------------------------------------------------------

def fresnel(cos_i: float, eta: float) -> float:
    """Unpolarised Fresnel reflectance, eta = n_transmitted / n_incident; 1 on total reflection."""
    sin2_t = (1.0 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1.0:
        return 1.0
    cos_t = math.sqrt(1.0 - sin2_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


@dataclass(frozen=True)
class GlossyDielectric:
    """The glossy dielectric BSDF as a formula: with wo on the side of nf (eta = n_t / n_i, F the
    Fresnel reflectance at |cos theta_o|),
        f(wo, wi) |cos theta_i| = F P_n(r . wi)                          if nf . wi > 0,
                                = albedo (1 - F) / eta^2 P_n(t . wi)     if nf . wi < 0,
    r the mirror and t the refracted direction (no t under total reflection: F = 1) and
    P_n(cos a) = (n + 1) / (2 pi) cos^n a (cos a > 0) the normalised Phong lobe. The part of a lobe
    on the other side of the surface is lost, so the directional albedo is
        A(wo) = F M(r, +) + albedo (1 - F) / eta^2 M(t, -),
    M(axis, side) the mass of P_n about `axis` on that side of the surface."""
    normal: np.ndarray
    wo: np.ndarray
    exponent: float
    ior: float
    albedo: float = 1.0

    @property
    def frame(self):
        n, wo = unit(self.normal), unit(self.wo)
        cos_o = float(np.dot(n, wo))
        nf, eta = (n, self.ior) if cos_o >= 0 else (-n, 1.0 / self.ior)
        co = abs(cos_o)
        F = fresnel(co, eta)
        r = 2.0 * co * nf - wo
        t = None
        if F < 1.0:
            sin2_t = (1.0 - co * co) / (eta * eta)
            t = unit(-wo / eta + (co / eta - math.sqrt(1.0 - sin2_t)) * nf)
        return nf, eta, F, r, t

    def lobe(self, axis, wi):
        c = wi @ axis
        return np.where(c > 0, (self.exponent + 1.0) / (2 * math.pi)
                        * np.maximum(c, 0.0) ** self.exponent, 0.0)

    def f_cos(self, wi) -> np.ndarray:
        """f |cos theta_i| at unit directions wi (..., 3)."""
        nf, eta, F, r, t = self.frame
        ci = wi @ nf
        refl = F * self.lobe(r, wi)
        trans = 0.0 if t is None else self.albedo * (1.0 - F) / eta ** 2 * self.lobe(t, wi)
        return np.where(ci > 0, refl, np.where(ci < 0, trans, 0.0))

    def lobe_mass(self, axis, side: float, n_gauss: int = 64) -> float:
        """Mass of P_n about `axis` on the side sign(side) of the surface. With x = cos a about the
        axis and v = x^(n + 1) (so that P_n d omega = dv dphi / (2 pi)), the ring at x is on that
        side over the fraction phi(x) / pi of its circle, phi = acos(-A / B) for
        nf . w = A + B cos(phi) (A = side x cos b, B = sqrt(1 - x^2) sin b, b the angle between
        axis and normal); M = int_0^1 frac(v) dv, Gauss-Legendre split at the kink |A| = B."""
        nf = self.frame[0]
        cb = float(np.dot(unit(axis), nf)) * side
        sb = math.sqrt(max(0.0, 1.0 - cb * cb))
        n1 = self.exponent + 1.0
        # |A| = B  <=>  x^2 cb^2 = (1 - x^2) sb^2  <=>  x = sb, i.e. v = sb^(n + 1).
        kinks = np.unique(np.clip([0.0, 1.0, sb ** n1 if sb > 0 else 0.0], 0.0, 1.0))
        xg, wg = np.polynomial.legendre.leggauss(n_gauss)
        total = 0.0
        for a, b in zip(kinks[:-1], kinks[1:]):
            v = 0.5 * (a + b) + 0.5 * (b - a) * xg
            x = np.exp(np.log(v) / n1)
            A = x * cb
            B = np.sqrt(np.maximum(0.0, 1.0 - x * x)) * sb
            with np.errstate(divide="ignore", invalid="ignore"):
                frac = np.where(A >= B, 1.0, np.where(A <= -B, 0.0,
                                np.arccos(np.clip(-A / np.where(B > 0, B, 1.0), -1, 1)) / math.pi))
            total += 0.5 * (b - a) * float(np.sum(wg * frac))
        return total

    def albedo_value(self) -> float:
        nf, eta, F, r, t = self.frame
        a = F * self.lobe_mass(r, +1.0)
        if t is not None:
            a += self.albedo * (1.0 - F) / eta ** 2 * self.lobe_mass(t, -1.0)
        return a

    def albedo_bruteforce(self, n_theta: int = 1500, n_phi: int = 1500) -> float:
        """The same integral on a plain (theta, phi) midpoint grid about each lobe's axis, with the
        side test done per direction: a check of the 1D reduction (accurate for small exponents)."""
        nf, eta, F, r, t = self.frame
        total = 0.0
        for axis, weight, side in ((r, F, 1.0), (t, None, -1.0)):
            if axis is None:
                continue
            w = weight if weight is not None else self.albedo * (1.0 - F) / eta ** 2
            a = (np.arange(n_theta) + 0.5) * (math.pi / 2) / n_theta
            ph = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
            A, P = np.meshgrid(a, ph, indexing="ij")
            e1 = unit(np.cross(axis, [0.3, 0.5, 0.8]))
            e2 = np.cross(axis, e1)
            d = (np.sin(A)[..., None] * (np.cos(P)[..., None] * e1 + np.sin(P)[..., None] * e2)
                 + np.cos(A)[..., None] * axis)
            on_side = (d @ nf) * side > 0
            dens = (self.exponent + 1.0) / (2 * math.pi) * np.cos(A) ** self.exponent
            dw = np.sin(A) * (math.pi / 2 / n_theta) * (2 * math.pi / n_phi)
            total += w * float(np.sum(dens * dw * on_side))
        return total


def mean_weight_estimate(weights: np.ndarray) -> tuple[float, float]:
    """(mean, standard error) of i.i.d. sample weights."""
    w = np.asarray(weights, float)
    return float(w.mean()), float(w.std(ddof=1) / math.sqrt(len(w)))

