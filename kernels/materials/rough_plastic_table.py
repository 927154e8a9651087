"""The host half of the rough plastic kinds (rough_plastic.py): each material's row of the flat
per-material table (MaterialData.table), as Mitsuba 3's `roughplastic` precomputes it in
`parameters_changed` (src/bsdfs/roughplastic.cpp; include/mitsuba/render/microfacet.h
`eval_transmittance`, `eval_reflectance`), here in float64.

    T(mu): the coat's external transmittance at incident cosine mu, at RES = 64 cosines
           mu_j = max(1e-6, j / 63), the integral over visible normals m of wi (drawn from two
           uniform numbers by Mitsuba's sample_visible_11) of (1 - F(wi.m)) G1(wt, m) over the
           refracted wt below; a Gauss-Legendre rule of 32 x 32 nodes in the unit square
           (128 x 128 where the index is below 1)
    R_int = 2 mean_j(mu_j R(mu_j)), R(mu) the coat's reflectance seen from inside (index 1/eta):
           the integral of F(wi.m) G1(wr, m) over the reflected wr above, the same rule
    w = 1 / (1 + mean(albedo)): Mitsuba's specular sampling weight (s_mean = 1)
Row: T (RES floats), R_int, w, 1 for GGX (0 Beckmann), 1 for `nonlinear`. The device reads T by
linear interpolation at mu * 63 (Mitsuba's lerp_gather)."""
from __future__ import annotations

import functools

import numpy as np
from scipy.special import erf, erfinv, roots_legendre

RES = 64
ROW = RES + 4
R_INT, WEIGHT, GGX, NONLINEAR = RES, RES + 1, RES + 2, RES + 3
# kind -> (microfacet distribution, nonlinear): the rows of the kind table whose model is rough_plastic.
VARIANTS = {"beckmann_plastic": ("beckmann", False), "ggx_plastic": ("ggx", False),
            "beckmann_plastic_nonlinear": ("beckmann", True), "ggx_plastic_nonlinear": ("ggx", True)}


def fresnel(c: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mitsuba's fresnel(cos_theta_i, eta) (fresnel.h): (F, signed cos_theta_t, eta_ti)."""
    outside = c >= 0
    eta_it = np.where(outside, eta, 1 / eta)
    eta_ti = 1 / eta_it
    ct2 = 1 - (1 - c * c) * eta_ti * eta_ti
    ci, ct = np.abs(c), np.sqrt(np.maximum(ct2, 0))
    a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
    a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    f = np.where(ci == 0, 1.0, 0.5 * (a_s * a_s + a_p * a_p))
    return f, -np.copysign(ct, c), eta_ti


def smith_g1(distribution: str, alpha: float, v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Mitsuba's smith_g1 (Beckmann: Walter's rational fit), 0 where v sees m's back."""
    xy = alpha * alpha * (v[..., 0] ** 2 + v[..., 1] ** 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = xy / v[..., 2] ** 2
        if distribution == "beckmann":
            a = 1 / np.sqrt(t2)
            g = np.where(a >= 1.6, 1.0, (3.535 * a + 2.181 * a * a) / (1 + 2.276 * a + 2.577 * a * a))
        else:
            g = 2 / (1 + np.sqrt(1 + t2))
    g = np.where(xy == 0, 1.0, g)
    return np.where(np.sum(v * m, axis=-1) * v[..., 2] <= 0, 0.0, g)


def _visible_slopes(distribution: str, c: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba's sample_visible_11: slopes of a visible normal of the unit-roughness distribution
    seen at cosine c, from u (..., 2)."""
    if distribution == "beckmann":
        with np.errstate(divide="ignore"):
            tan = np.sqrt(np.maximum(1 - c * c, 0)) / c
            cot = 1 / tan
        maxval = erf(cot)
        u = np.clip(u, 1e-6, 1 - 1e-6)
        x = maxval - (maxval + 1) * erf(np.sqrt(-np.log(u[..., 0])))
        target = u[..., 0] * (1 + maxval + tan * np.exp(-cot * cot) / np.sqrt(np.pi))
        for _ in range(3):
            slope = erfinv(x)
            value = 1 + x + tan * np.exp(-slope * slope) / np.sqrt(np.pi) - target
            x = x - value / (1 - slope * tan)
        return erfinv(x), erfinv(2 * u[..., 1] - 1)
    # GGX: the concentric disk, squeezed by the projection (Heitz 2018 in Mitsuba's form).
    a, b = 2 * u[..., 0] - 1, 2 * u[..., 1] - 1
    q13 = np.abs(a) < np.abs(b)
    r, rp = np.where(q13, b, a), np.where(q13, a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        phi = 0.25 * np.pi * rp / r
    phi = np.where(q13, 0.5 * np.pi - phi, phi)
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    px, py = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1 + c)
    py = np.sqrt(np.maximum(1 - px * px, 0)) * (1 - s) + py * s
    pz = np.sqrt(np.maximum(1 - px * px - py * py, 0))
    sin = np.sqrt(np.maximum(1 - c * c, 0))
    norm = 1 / (sin * py + c * pz)
    return (c * py - sin * pz) * norm, px * norm


def _visible_normals(distribution: str, alpha: float, wi: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Mitsuba's MicrofacetDistribution::sample with visible normals (isotropic): wi (N, 1, 3) with
    y = 0, u (Q, 2) -> m (N, Q, 3)."""
    wp_ = np.stack([alpha * wi[..., 0], alpha * wi[..., 1], wi[..., 2]], axis=-1)
    wp_ /= np.linalg.norm(wp_, axis=-1, keepdims=True)
    s2 = 1 - wp_[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_phi = np.where(s2 <= 4 * np.finfo(np.float32).eps, 1.0, np.clip(wp_[..., 0] / np.sqrt(s2), -1, 1))
        sin_phi = np.where(s2 <= 4 * np.finfo(np.float32).eps, 0.0, np.clip(wp_[..., 1] / np.sqrt(s2), -1, 1))
    sx, sy = _visible_slopes(distribution, wp_[..., 2], u)
    m = np.stack([-(cos_phi * sx - sin_phi * sy) * alpha, -(sin_phi * sx + cos_phi * sy) * alpha,
                  np.ones_like(sx)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _rule(eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Mitsuba's 2D Gauss-Legendre rule on the unit square: (nodes (Q, 2), weights (Q,))."""
    x, w = roots_legendre(32 if eta > 1 else 128)
    gx, gy = np.meshgrid(0.5 * x + 0.5, 0.5 * x + 0.5)
    wx, wy = np.meshgrid(w, w)
    return np.stack([gx.ravel(), gy.ravel()], axis=-1), 0.25 * (wx * wy).ravel()


def cosines() -> np.ndarray:
    return np.maximum(1e-6, np.linspace(0.0, 1.0, RES))


def _directions(mu: np.ndarray) -> np.ndarray:
    return np.stack([np.sqrt(1 - mu * mu), np.zeros_like(mu), mu], axis=-1)[:, None, :]


def transmittance(distribution: str, alpha: float, eta: float, mu: np.ndarray) -> np.ndarray:
    """Mitsuba's eval_transmittance at incident cosines mu."""
    u, w = _rule(eta)
    wi = _directions(mu)
    m = _visible_normals(distribution, alpha, wi, u)
    c = np.sum(wi * m, axis=-1)
    f, ct, eta_ti = fresnel(c, eta)
    wt = m * (c * eta_ti + ct)[..., None] - wi * eta_ti[..., None]
    g = smith_g1(distribution, alpha, wt, m) * (1 - f)
    g = np.where(wt[..., 2] * wi[..., 2] >= 0, 0.0, g)
    return g @ w


def reflectance(distribution: str, alpha: float, eta: float, mu: np.ndarray) -> np.ndarray:
    """Mitsuba's eval_reflectance at incident cosines mu."""
    u, w = _rule(eta)
    wi = _directions(mu)
    m = _visible_normals(distribution, alpha, wi, u)
    c = np.sum(wi * m, axis=-1)
    wr = 2 * c[..., None] * m - wi
    g = smith_g1(distribution, alpha, wr, m) * fresnel(c, eta)[0]
    g = np.where((wr[..., 2] <= 0) | (wi[..., 2] <= 0), 0.0, g)
    return g @ w


@functools.lru_cache(maxsize=64)
def coat(distribution: str, alpha: float, eta: float) -> tuple[np.ndarray, float]:
    """(T at the RES cosines, R_int) of a coat: Mitsuba's alpha is at least 1e-4."""
    alpha = max(alpha, 1e-4)
    mu = cosines()
    return transmittance(distribution, alpha, eta, mu), 2 * float(np.mean(reflectance(distribution, alpha, 1 / eta, mu) * mu))


def table_row(kind: str, albedo, alpha: float, eta: float) -> np.ndarray:
    """The material's row of MaterialData.table (module doc), float32."""
    distribution, nonlinear = VARIANTS[kind]
    t, r_int = coat(distribution, float(alpha), float(eta))
    return np.concatenate([t, [r_int, 1 / (1 + float(np.mean(albedo))), distribution == "ggx", nonlinear]]
                          ).astype(np.float32)
