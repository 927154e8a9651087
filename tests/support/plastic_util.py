"""The plastic BSDF (kernels/materials/plastic.py eval_plastic) as a float64 formula, sharing no code with the
renderer, and its directional albedo by quadrature, for tests/kernels/test_plastic.py.

    f(wo, wi) = min(F_o, F_i) (n + 2) / (2 pi) cos^n(alpha) + albedo (1 - F_o)(1 - F_i) / (pi (1 - Fbar))

for wo and wi on the same side of the surface, F_x = Fresnel(|cos theta_x|, ior), alpha the angle
between wi and the mirror direction of wo (the coat lobe only where cos alpha > 0), and
Fbar = 2 int_0^1 F(mu) mu dmu, here by its closed form (the kernel integrates it numerically).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from closed_forms_util import GlossyDielectric, fresnel, unit


def fresnel_v(cos_i, eta: float) -> np.ndarray:
    """closed_forms_util.fresnel, vectorised (eta > 1: no total reflection from outside)."""
    c = np.asarray(cos_i, float)
    ct = np.sqrt(1.0 - (1.0 - c * c) / (eta * eta))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return 0.5 * (rs * rs + rp * rp)


def fresnel_average(eta: float) -> float:
    """Closed form of 2 int_0^1 F(mu) mu dmu for a dielectric of relative index eta > 1, seen from
    outside (the classical result for unpolarised light, e.g. Walsh 1926 / Molenaar et al. 1999;
    checked against a brute-force quadrature in test_plastic.test_quadratures_are_exact)."""
    e = float(eta)
    e2, e4 = e * e, e ** 4
    return (0.5 + (e - 1) * (3 * e + 1) / (6 * (e + 1) ** 2)
            + e2 * (e2 - 1) ** 2 / (e2 + 1) ** 3 * math.log((e - 1) / (e + 1))
            - 2 * e ** 3 * (e2 + 2 * e - 1) / ((e2 + 1) * (e4 - 1))
            + 8 * e4 * (e4 + 1) / ((e2 + 1) * (e4 - 1) ** 2) * math.log(e))


def _gauss(a: float, b: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (a + b) + 0.5 * (b - a) * x, 0.5 * (b - a) * w


@dataclass(frozen=True)
class Plastic:
    normal: np.ndarray
    wo: np.ndarray
    exponent: float
    ior: float
    albedo: float = 1.0
    fbar_scale: float = 1.0     # negative controls: a wrong base normalisation (0: none) ...
    coat_min: bool = True       # ... or the coat weighted by F_o alone (not reciprocal)

    @property
    def frame(self):
        """(nf, cos_o, F_o, mirror direction) on wo's side."""
        n, wo = unit(self.normal), unit(self.wo)
        c = float(n @ wo)
        nf = n if c >= 0 else -n
        co = abs(c)
        return nf, co, fresnel(co, self.ior), 2.0 * co * nf - wo

    def f_cos(self, wi) -> np.ndarray:
        """f |cos theta_i| at unit directions wi (..., 3)."""
        nf, _, fo, r = self.frame
        ci = wi @ nf
        fi = fresnel_v(np.abs(ci), self.ior)
        ca = wi @ r
        coat = np.where(ca > 0, self._coat_weight(fo, fi) * (self.exponent + 2) / (2 * math.pi)
                        * np.maximum(ca, 0.0) ** self.exponent, 0.0)
        base = self.albedo * (1 - fo) * (1 - fi) / (math.pi * (1 - self.fbar_scale
                                                               * fresnel_average(self.ior)))
        return np.where(ci > 0, (coat + base) * ci, 0.0)

    def _coat_weight(self, fo: float, fi: np.ndarray) -> np.ndarray:
        return np.minimum(fo, fi) if self.coat_min else np.full_like(fi, fo)

    def base_albedo(self, n_mu: int = 64) -> float:
        """int of the base term over the hemisphere: 2 pi x a 1D integral over mu = cos theta_i."""
        _, _, fo, _ = self.frame
        mu, w = _gauss(0.0, 1.0, n_mu)
        integral = 2 * math.pi * float(np.sum(w * (1 - fresnel_v(mu, self.ior)) * mu))
        return self.albedo * (1 - fo) / (math.pi * (1 - self.fbar_scale
                                                    * fresnel_average(self.ior))) * integral

    def coat_albedo(self, n_v: int = 24, n_phi: int = 32) -> float:
        """int over the hemisphere of min(F_o, F_i) (n + 2)/(2 pi) cos^n(alpha) cos_i. In the lobe's
        frame (alpha, phi) with v = cos^(n + 1)(alpha) (so cos^n sin d alpha = dv / (n + 1)), the
        direction has cos_i = a + b cos(phi), a = cos(alpha) cos_o, b = sin(alpha) sin_o. By symmetry
        phi runs over [0, pi] (x2); the integrand has kinks where cos_i = cos_o (the min switches)
        and cos_i = 0 (horizon), and in alpha where those kinks appear: alpha = pi/2 - theta_o and
        2 theta_o. Gauss-Legendre on every smooth piece, in phi and in v."""
        _, co, fo, _ = self.frame
        so = math.sqrt(max(0.0, 1 - co * co))
        th = math.acos(min(1.0, co))
        n1 = self.exponent + 1
        kinks_a = (0.0, math.pi / 2, *(a for a in (math.pi / 2 - th, 2 * th) if 0 < a < math.pi / 2))
        # cos(alpha) = v^(1/(n + 1)) is not smooth at v = 0: geometric cuts 10^-1 ... 10^-15 make
        # every piece smooth on its own scale; below 10^-15 lies less than 10^-15 of the integral.
        cuts = sorted({math.cos(a) ** n1 for a in kinks_a} | {10.0 ** -k for k in range(1, 16)})
        cuts = [c for c in cuts if c >= 1e-15]
        v, wv = np.concatenate([np.stack(_gauss(lo, hi, n_v)) for lo, hi in zip(cuts[:-1], cuts[1:])],
                               axis=1)
        ca = np.exp(np.log(v) / n1)
        sa = np.sqrt(np.maximum(0.0, 1 - ca * ca))
        inner = self._phi_integral(ca * co, sa * so, co, fo, n_phi)
        return (self.exponent + 2) / (2 * math.pi * n1) * 2 * float(np.sum(wv * inner))

    def _phi_integral(self, a, b, co: float, fo: float, n_phi: int) -> np.ndarray:
        """int_0^pi min(F_o, F(cos_i)) max(cos_i, 0) dphi with cos_i = a + b cos(phi), per (a, b):
        Gauss-Legendre on the three pieces between 0, the phis where cos_i = 0 and = cos_o, and pi
        (a root outside [0, pi] clips to an end: its piece is empty)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            roots = [np.where(b > 0, np.arccos(np.clip((c - a) / np.where(b > 0, b, 1.0), -1, 1)), 0.0)
                     for c in (0.0, co)]
        cuts = np.sort(np.stack([np.zeros_like(a), *roots, np.full_like(a, math.pi)], axis=1), axis=1)
        x, w = np.polynomial.legendre.leggauss(n_phi)
        lo, hi = cuts[:, :-1, None], cuts[:, 1:, None]
        phi = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x
        ci = a[:, None, None] + b[:, None, None] * np.cos(phi)
        weight = self._coat_weight(fo, fresnel_v(np.clip(ci, 0.0, 1.0), self.ior))
        f = np.where(ci > 0, weight * ci, 0.0)
        return np.sum(0.5 * (hi - lo) * w * f, axis=(1, 2))

    def albedo_value(self) -> float:
        return self.coat_albedo() + self.base_albedo()

    def albedo_bruteforce(self, n_theta: int = 1200, n_phi: int = 2400) -> float:
        """The same integral on a plain midpoint grid in (cos theta_i, phi) about the normal: a
        check of the lobe-frame reduction (accurate for small exponents)."""
        nf, _, _, _ = self.frame
        e1 = unit(np.cross(nf, [0.3, 0.5, 0.8]))
        e2 = np.cross(nf, e1)
        mu = (np.arange(n_theta) + 0.5) / n_theta
        ph = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
        M, P = np.meshgrid(mu, ph, indexing="ij")
        s = np.sqrt(1 - M * M)
        d = (s * np.cos(P))[..., None] * e1 + (s * np.sin(P))[..., None] * e2 + M[..., None] * nf
        f = self.f_cos(d.reshape(-1, 3))
        return float(f.sum()) * (1.0 / n_theta) * (2 * math.pi / n_phi)

    def lobe_mass(self) -> float:
        """Mass above the horizon of the coat's sampling lobe (the normalised Phong lobe
        (n + 1)/(2 pi) cos^n about the mirror direction), from closed_forms_util."""
        r = self.frame[3]
        return GlossyDielectric(self.normal, self.wo, self.exponent, self.ior).lobe_mass(r, +1.0)

    def valid_mass(self, lobe: bool) -> float:
        """Probability that sample_bsdf returns a valid sample: the coat lobe (chosen with
        probability F_o) loses its part below the horizon; the cosine and uniform lobes lose
        nothing (albedo > 0 makes f > 0 everywhere above)."""
        if not lobe:
            return 1.0
        fo = self.frame[2]
        return fo * self.lobe_mass() + (1 - fo)
