"""Streaming per-pixel moments (Welford): one image in memory at a time, float64, no cancellation.

Used by the ground truth (moments over batch means) and by the cells of an experiment (moments over
the repetitions of one sampler at one spp). The update is always the same float64 operations in the
same order, so a reference resumed from its stored (n, mean, m2) is bit-identical to one computed
without interruption.
"""
from __future__ import annotations

import numpy as np


class RunningMoments:
    """n, the running mean and m2 (the sum of squared deviations from it) of equally shaped arrays."""

    def __init__(self, n: int = 0, mean: np.ndarray | None = None, m2: np.ndarray | None = None):
        self.n = n
        self.mean = mean
        self.m2 = m2

    def add(self, x: np.ndarray) -> None:
        x = np.asarray(x, dtype=np.float64)
        self.n += 1
        if self.mean is None:
            self.mean = x.copy()
            self.m2 = np.zeros_like(x)
            return
        delta = x - self.mean
        self.mean += delta / self.n
        self.m2 += delta * (x - self.mean)

    def variance(self) -> np.ndarray:
        """Per-element sample variance (n - 1 in the denominator); NaN with fewer than 2 values."""
        if self.n < 2:
            return np.full_like(self.mean, np.nan)
        return self.m2 / (self.n - 1)

    def standard_error(self) -> np.ndarray:
        """Per-element standard error of the mean, sqrt(variance / n); infinite with fewer than 2
        values (nothing is known about the spread yet)."""
        if self.n < 2:
            return np.full_like(self.m2, np.inf)
        return np.sqrt(self.m2 / (self.n - 1) / self.n)
