"""Region tests of images: K independent renders of a scene reduced to one value per block x block
region (the mean of R + G + B), and two such estimates (or an estimate and exact values) compared
region by region. The estimator checks of the test suite (tests/support/stats_util.py) and
`drtlab check INTEGRATOR` (experiments/checks/integrator.py) share it.

An estimate's region mean has the variance of the per-pixel spread over the K runs (pixels and runs
are independent), with Satterthwaite's effective degrees of freedom (`Estimate.from_images`). Two
estimates are compared with Welch's t per region,
    t_r = (mean_a - mean_b) / sqrt(var_a + var_b + floor_r^2),  Welch-Satterthwaite dof,
each t_r mapped to the standard normal deviate z_r with the same two-sided p-value (so a small K does
not inflate the false-alarm rate the way treating t as z would), and the regions combined by
    X = sum_r z_r^2  ~  chi-square(R)   under H0 (regions are disjoint pixels: independent).
`floor_r` = REL_FLOOR |reference| + ABS_FLOOR absorbs float32 rounding of the tracer (the renders
trace in float32) and the quadrature error of closed forms (< 1e-7 relative, 2e-6 for the thin
lens); it is far below every standard error the tests reach, so it never hides a bias a test sees.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

REL_FLOOR = 1e-5
ABS_FLOOR = 1e-9



def region_values(img: np.ndarray, block: int) -> np.ndarray:
    """(R,) mean of R+G+B over each block x block region (the image is cropped to whole blocks)."""
    h, w = img.shape[0] // block * block, img.shape[1] // block * block
    if h == 0 or w == 0:
        raise ValueError(f"image {img.shape[:2]} smaller than one {block}x{block} region")
    s = img[:h, :w].sum(axis=2)
    return s.reshape(h // block, block, w // block, block).mean(axis=(1, 3)).ravel()


@dataclass
class Estimate:
    mean: np.ndarray            # (R,) region means
    var: np.ndarray             # (R,) variance of the mean
    dof: np.ndarray | float     # (R,) degrees of freedom of var (inf for exact values)
    runs: int = 0
    nonfinite: int = 0          # non-finite pixel values over all runs
    negative: int = 0           # negative pixel values over all runs
    min_value: float = 0.0
    max_value: float = 0.0

    @classmethod
    def from_images(cls, images: np.ndarray, block: int, **kw) -> "Estimate":
        """Region means of K independent images (K, H, W) (R + G + B per pixel) and the variance of
        each region mean from the per-pixel spread: pixels of one render are independent (every
        point set keys its samples by pixel) and so are the renders, so
            Var(region mean) = sum_p s_p^2 / (P^2 K),   s_p^2 = pixel p's sample variance over K runs,
        with Satterthwaite's effective degrees of freedom (sum s_p^2)^2 / sum(s_p^4 / (K - 1)).
        Compared with the spread of K region means (K - 1 dof) this variance estimate has up to
        P (K - 1) dof, so a few runs that happen to agree cannot make a region look precise; where a
        few pixels carry the variance (heavy tails) the dof drops towards K - 1 by itself."""
        images = np.asarray(images, dtype=np.float64)
        k = images.shape[0]
        if k < 2:
            raise ValueError("an estimate needs at least 2 independent runs")
        h, w = images.shape[1] // block * block, images.shape[2] // block * block
        if h == 0 or w == 0:
            raise ValueError(f"image {images.shape[1:]} smaller than one {block}x{block} region")
        x = images[:, :h, :w].reshape(k, h // block, block, w // block, block)
        x = x.transpose(0, 1, 3, 2, 4).reshape(k, -1, block * block)      # (K, R, P)
        p = block * block
        mean = x.mean(axis=(0, 2))
        s2 = x.var(axis=0, ddof=1)                                         # (R, P)
        var = s2.sum(axis=1) / (p * p * k)
        den = np.sum(s2 ** 2, axis=1) / (k - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            dof = np.where(den > 0, s2.sum(axis=1) ** 2 / np.where(den > 0, den, 1.0), np.inf)
        return cls(mean, var, dof, runs=k, **kw)

    @classmethod
    def exact(cls, values: np.ndarray) -> "Estimate":
        values = np.asarray(values, dtype=np.float64).ravel()
        return cls(values, np.zeros_like(values), math.inf)


@dataclass
class Comparison:
    z: np.ndarray               # (R,) signed normal deviates
    chi2: float
    regions: int
    p: float
    alpha: float
    rel_err: np.ndarray         # (R,) |a - b| / |b| (b = reference)
    diff: np.ndarray = field(repr=False, default=None)

    @property
    def rejected(self) -> bool:
        return self.p < self.alpha

    @property
    def max_abs_z(self) -> float:
        return float(np.max(np.abs(self.z)))

    def worst_rel_err(self, ref: np.ndarray, min_fraction: float = 0.05) -> float:
        """Worst relative error over regions whose reference is not negligible (>= min_fraction of
        the largest region value: a relative error of a near-black region means nothing)."""
        ref = np.abs(np.asarray(ref))
        keep = ref >= min_fraction * ref.max() if ref.max() > 0 else np.ones_like(ref, bool)
        return float(np.max(self.rel_err[keep])) if keep.any() else 0.0

    def summary(self) -> str:
        i = int(np.argmax(np.abs(self.z)))
        return (f"chi2={self.chi2:.1f} (dof {self.regions}) p={self.p:.3g} alpha={self.alpha:.3g} "
                f"max|z|={self.max_abs_z:.2f} (region {i}, rel err {self.rel_err[i]:.3g}) "
                f"-> {'REJECT' if self.rejected else 'accept'}")


def compare(a: Estimate, b: Estimate, alpha: float) -> Comparison:
    """Welch t per region -> equal-p normal deviate -> chi-square over regions (see module doc)."""
    diff = a.mean - b.mean
    floor = REL_FLOOR * np.abs(b.mean) + ABS_FLOOR
    v = a.var + b.var + floor ** 2
    t = diff / np.sqrt(v)
    # Welch-Satterthwaite: v^2 / sum(v_i^2 / dof_i); exact terms (dof inf) contribute nothing.
    den = np.zeros_like(v)
    for var, dof in ((a.var, a.dof), (b.var, b.dof)):
        dof = np.broadcast_to(np.asarray(dof, dtype=np.float64), v.shape)
        den = den + np.where(np.isfinite(dof), var ** 2 / np.where(np.isfinite(dof), dof, 1.0), 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = np.where(den > 0, v ** 2 / np.where(den > 0, den, 1.0), np.inf)
    p_two = np.where(np.isfinite(dof), 2.0 * stats.t.sf(np.abs(t), np.where(np.isfinite(dof), dof, 1.0)),
                     2.0 * stats.norm.sf(np.abs(t)))
    p_two = np.clip(p_two, 1e-300, 1.0)
    z = np.sign(t) * stats.norm.isf(p_two / 2.0)
    chi2 = float(np.sum(z ** 2))
    p = float(stats.chi2.sf(chi2, len(z)))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(diff) / np.maximum(np.abs(b.mean), 1e-300)
    return Comparison(z=z, chi2=chi2, regions=len(z), p=p, alpha=alpha, rel_err=rel, diff=diff)
