"""The GGX materials (kernels/materials/ggx.py eval_ggx) as float64 formulas sharing no code with the
renderer, and their directional albedo by quadrature, for tests/kernels/test_ggx.py and the hard-case
furnaces (scene_util.sphere_furnace).

    D(m)   = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2)        Lambda(w) = (sqrt(1 + alpha^2 tan^2) - 1) / 2
    G2     = 1 / (1 + Lambda(wo) + Lambda(wi))   (height-correlated; `separable`: G1(wo) G1(wi))
    ggx:            f = albedo D G2 / (4 cos_o cos_i)
    ggx_dielectric: f = F D G2 / (4 cos_o cos_i)  (reflection),
                    f = albedo (1 - F) D G2 |wi.m| wo.m / (cos_o |cos_i| (wi.m + wo.m / eta)^2 eta^2)

Albedo quadrature: in microfacet-normal space with the measure D(m) cos(theta_m) dm = dt dphi / (2 pi),
tan^2 theta_m = alpha^2 t / (1 - t) (so a narrow lobe is as easy as a wide one), where
f |cos_i| dwi = D G2 (wo.m) / cos_o dm for the reflection and albedo (1 - F) D G2 (wo.m) / (cos_o eta^2) dm
for the transmission (the Jacobians of the half vectors): the integrand is G2 (wo.m) / (cos_o cos_m)
times the lobe's factor, cut where wi lands on the wrong side. Gauss-Legendre in t and in phi
(wo in the xz plane: phi over [0, pi], doubled).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np


@functools.lru_cache(maxsize=None)
def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.polynomial.legendre.leggauss(n)       # an eigenvalue problem: O(n^3), cached


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def fresnel(cos_i, eta: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance, eta = n_t / n_i, cos_i >= 0; 1 on total reflection."""
    c = np.asarray(cos_i, float)
    s2t = (1.0 - c * c) / (eta * eta)
    ct = np.sqrt(np.maximum(0.0, 1.0 - s2t))
    with np.errstate(divide="ignore", invalid="ignore"):     # c = ct = 0: total reflection
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
    return np.where(s2t >= 1.0, 1.0, 0.5 * (rs * rs + rp * rp))


def lam(alpha: float, c) -> np.ndarray:
    c = np.abs(np.asarray(c, float))
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = np.where(c > 0, (1.0 - c * c) / (c * c), np.inf)
        return np.where(np.isfinite(t2), 0.5 * (np.sqrt(1.0 + alpha * alpha * t2) - 1.0), np.inf)


def d_ggx(alpha: float, c) -> np.ndarray:
    c = np.asarray(c, float)
    c2 = c * c
    t = alpha * alpha * c2 + (1.0 - c2)
    return np.where(c > 0, alpha * alpha / (math.pi * t * t), 0.0)


@dataclass(frozen=True)
class GGX:
    normal: np.ndarray
    wo: np.ndarray
    alpha: float
    ior: float = 1.5
    albedo: float = 1.0
    transmits: bool = False
    separable: bool = False         # negative control: G1(wo) G1(wi) instead of height-correlated

    def d(self, c) -> np.ndarray:
        return d_ggx(self.alpha, c)

    def normal_angles(self, t):
        """(cos, sin) of the normal at t in [0, 1] of the measure D(m) cos(theta_m) dm = dt dphi / (2 pi)."""
        a2 = self.alpha * self.alpha
        q = (1.0 - t) + a2 * t
        return np.sqrt((1.0 - t) / q), np.sqrt(a2 * t / q)

    def g2(self, co, ci):
        if self.separable:
            return 1.0 / ((1.0 + lam(self.alpha, co)) * (1.0 + lam(self.alpha, ci)))
        return 1.0 / (1.0 + lam(self.alpha, co) + lam(self.alpha, ci))

    @property
    def side(self):
        """(nf, cos_o, eta) on wo's side."""
        n, wo = unit(self.normal), unit(self.wo)
        c = float(n @ wo)
        nf = n if c >= 0 else -n
        eta = (self.ior if c >= 0 else 1.0 / self.ior) if self.transmits else 1.0
        return nf, abs(c), eta

    def f_cos(self, wi) -> np.ndarray:
        """f |cos theta_i| at unit directions wi (k, 3)."""
        nf, co, eta = self.side
        wo = unit(self.wo)
        wi = np.asarray(wi, float)
        ci = wi @ nf
        refl = ci > 0
        h = np.where(refl[:, None], wo + wi, wo + eta * wi)
        m = unit(h)
        m = np.where((m @ nf)[:, None] < 0, -m, m)
        om, im = m @ wo, np.sum(m * wi, axis=-1)
        ok = (om > 0) & (ci != 0) & (refl | (im < 0))
        if not self.transmits:
            ok &= refl
        F = fresnel(np.clip(om, 0, 1), eta) if self.transmits else np.ones_like(om)
        dg = self.d(m @ nf) * self.g2(co, ci) / co
        r = np.where(refl, 0.25 * dg * (F if self.transmits else self.albedo), 0.0)
        if self.transmits:
            with np.errstate(divide="ignore", invalid="ignore"):
                d = im + om / eta
                t = self.albedo * (1 - F) * dg * np.abs(im) * om / (d * d * eta * eta)
            r = np.where(refl, r, t)
        return np.where(ok, r, 0.0)

    def albedo_value(self, nt: int = 1024, nphi: int = 512) -> float:
        """int f |cos_i| dwi (float64 quadrature in normal space, module doc)."""
        nf, co, eta = self.side
        so = math.sqrt(max(0.0, 1.0 - co * co))
        xt, wt = _gauss(nt)
        xp, wpw = _gauss(nphi)
        t = 0.5 * (xt + 1.0)
        phi = 0.5 * math.pi * (xp + 1.0)
        cm, sm = (x[:, None] for x in self.normal_angles(t))
        mx, my, mz = sm * np.cos(phi)[None, :], sm * np.sin(phi)[None, :], cm + 0 * phi[None, :]
        om = so * mx + co * mz                      # wo = (so, 0, co) in the local frame
        wr_z = 2.0 * om * mz - co                   # the reflected direction's cos
        valid = om > 0
        base = np.where(valid, om / (co * mz), 0.0)
        F = fresnel(np.clip(om, 0, 1), eta) if self.transmits else 1.0
        refl = np.where(valid & (wr_z > 0), base * self.g2(co, wr_z) * F, 0.0)
        if not self.transmits:
            refl = refl * self.albedo
        total = refl
        if self.transmits:
            s2t = (1.0 - om * om) / (eta * eta)
            ct = np.sqrt(np.maximum(0.0, 1.0 - s2t))
            # wi = -wo / eta + (om / eta - ct) m: its cos with the normal
            wt_z = -co / eta + (om / eta - ct) * mz
            ok = valid & (s2t < 1.0) & (wt_z < 0)
            total = total + np.where(ok, self.albedo * (1 - F) * base * self.g2(co, wt_z)
                                     / (eta * eta), 0.0)
        # dt dphi / (2 pi), phi over [0, pi] doubled: weights 0.5 wt, 0.5 pi wp, factor 2 / (2 pi)
        return float(np.einsum("i,ij,j->", 0.5 * wt, total, 0.5 * math.pi * wpw) / math.pi)
