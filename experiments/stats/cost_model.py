"""The CPU cost of a render as a fitted model, not a per-cell average.

A batch renders `reps` repetitions of `S` samples each in one call. Its seconds follow

    seconds(batch) = call + reps * (repetition + sample * S),

a per-call overhead, a per-repetition overhead and a per-sample cost, one model per (scene, sampler,
variant), fitted to every batch the study rendered of it at every sample count (and its timing-only
batches). A cell's cost is the model's cost of one repetition as the study renders it: `repetition +
sample * S + call x (its share of a call: the mean of 1/reps over the batches at S)`, and between
the ladder's sample counts the share is interpolated (log-linear in S). A study sizes its batches to
about the same number of samples, so the call's share falls with S as the per-sample cost rises: the
two cannot be told apart (and need not be), but their sum along the batches is known to a few
percent; the overhead of a single small render is not what a study of large images pays.

The fit is weighted least squares on relative residuals (timing noise is multiplicative: another job
slows a batch by a fraction). The coefficients are not held non-negative: batches are sized to about
the same number of samples, so the per-call term (1/reps) and the per-sample term move together and
only their sum along the batches is well determined; a bound on one of them (scipy's `nnls` was
tried) clips it in about half of the fits and its t interval then covered the true cost of a
repetition in 81-89% of simulated sweeps, against 95-97% without it (`drtlab audit-intervals`).
The covariance is the residual variance times (X'WX)^-1, and draws of the cost (`draw_seconds`)
come from the multivariate Student t with the residual degrees of freedom: with 15 batches of a
sampler the cell costs carry 2-15% intervals where a per-cell t over its two batches (one degree of
freedom, a Cauchy draw) spanned orders of magnitude.

Load that moves during a sweep (another job starts) shows in the residuals as a step in time:
`load_shift` tests for one (the largest two-sample t over split points of the time-ordered
residuals, its p-value by permutation) and says when and by how much, instead of widening every
interval.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

PARAMS = ("call", "repetition", "sample")     # seconds per call, per repetition, per sample
# A process's speed differs from the next one's on the same machine (memory layout, frequency,
# caches): between two fresh runs of the default study, the ratio of two samplers' costs moved by a
# relative sd of 6.5% (up to 15%), which batches within one run cannot see. Each sampler's cost
# carries this relative sd on top of its fit (sqrt(2) x 4.5% = 6.4% on a ratio).
PROCESS_SD = 0.045
INTERVAL_DRAWS = 20000
LOAD_SHIFT_P = 0.01                 # a step in the residuals below this p-value is reported
LOAD_SHIFT_MIN_SIDE = 4             # batches on each side of a split the test considers
LOAD_SHIFT_PERMUTATIONS = 999


@dataclass(frozen=True)
class CostModel:
    """Fitted coefficients (seconds per call, per repetition, per sample; 0 for a term left out) with
    their covariance and residual degrees of freedom, and the batch design they were fitted on
    (`design`: per sample count the mean of 1/repetitions over its batches). A coefficient may come
    out below 0 within its noise (see the module docstring); the costs it predicts are what is used."""
    coef: tuple
    cov: tuple                       # (3, 3) as nested tuples: 0 rows/columns for dropped terms
    dof: int
    rel_sd: float                    # relative residual sd of a batch
    batches: int
    residuals: tuple                 # each batch's relative residual, in the order given
    design: tuple = ()               # ((samples, mean 1/reps), ...) by increasing samples

    def _x(self, samples) -> np.ndarray:
        """Rows (share of a call, 1, samples) at `samples`: the call's share is that of the batches
        at the nearest sample counts (log-linear between them, the end values beyond)."""
        s = np.atleast_1d(np.asarray(samples, dtype=np.float64))
        return np.stack([call_share(s, self.design), np.ones_like(s), s], axis=-1)

    def seconds(self, samples) -> np.ndarray | float:
        """Cost of one repetition of `samples` samples as the study renders it: per repetition, per
        sample, and its share of its batch's call."""
        v = self._x(samples) @ np.asarray(self.coef)
        return v if np.ndim(samples) else float(v[0])

    def coef_draws(self, rng, size: int) -> np.ndarray:
        """`size` draws of the three coefficients from their multivariate t (the fitted values
        where the fit has no residual degree of freedom), each row scaled by a process factor of
        relative sd PROCESS_SD."""
        mean = np.asarray(self.coef, dtype=np.float64)
        cov = np.asarray(self.cov)
        if self.dof < 1 or not np.all(np.isfinite(cov)):
            return mean[None, :] * np.exp(PROCESS_SD * rng.standard_normal(size))[:, None]
        z = rng.multivariate_normal(np.zeros(3), cov, size=size, method="eigh")
        fit = mean[None, :] + z * np.sqrt(self.dof / rng.chisquare(self.dof, size=size))[:, None]
        return fit * np.exp(PROCESS_SD * rng.standard_normal(size))[:, None]

    def seconds_of_draws(self, coef, samples) -> np.ndarray:
        """Cost per row of `coef` (from `coef_draws`) at the matching row of `samples`, kept above a
        thousandth of the fitted cost."""
        x = self._x(samples)
        return np.maximum(np.einsum("ij,ij->i", x, coef), 1e-3 * (x @ np.asarray(self.coef)))

    def draw_seconds(self, samples, rng, size: int) -> np.ndarray:
        """`size` draws of one repetition's cost at each of `samples` (shape (size, len))."""
        s = np.atleast_1d(np.asarray(samples, dtype=np.float64))
        c = self.coef_draws(rng, size)
        return np.stack([self.seconds_of_draws(c, np.full(size, v)) for v in s], axis=1)

    def seconds_interval(self, samples, level: float = 0.95) -> tuple[float, float]:
        """The interval of one repetition's cost at `samples`: percentiles of `INTERVAL_DRAWS` draws
        (fixed seed), so that it is the interval the speed-ups' and efficiencies' draws imply."""
        if self.dof < 1 or not np.all(np.isfinite(np.asarray(self.cov))):
            return float("nan"), float("nan")
        d = self.draw_seconds([float(samples)], np.random.default_rng(0), INTERVAL_DRAWS)[:, 0]
        q = 100 * (1 - level) / 2
        lo, hi = np.percentile(d, [q, 100 - q])
        return float(lo), float(hi)

    def to_json(self) -> dict:
        return {"seconds_per_call": self.coef[0], "seconds_per_repetition": self.coef[1],
                "seconds_per_sample": self.coef[2], "dof": self.dof, "rel_sd": self.rel_sd,
                "batches": self.batches, "design": [list(d) for d in self.design]}


def call_share(samples, design) -> np.ndarray:
    """The share of a call one repetition at `samples` pays in a study's batches: the design's mean
    1/reps at its sample counts (`design`: ((samples, mean 1/reps), ...)), log-linear between them
    and the end values beyond; 1 (a render of its own) without a design."""
    s = np.atleast_1d(np.asarray(samples, dtype=np.float64))
    if not design:
        return np.ones_like(s)
    d = np.asarray(design, dtype=np.float64)
    return np.interp(np.log(s), np.log(d[:, 0]), d[:, 1])


def fit_cost_model(seconds, reps, samples) -> CostModel:
    """The model of batches that took `seconds` (whole batches) for `reps` repetitions of `samples`
    samples each. Terms the batches cannot separate (one sample count: no per-sample slope apart
    from the overhead; one batch size: no call overhead) are left out, the per-sample term last."""
    B = np.asarray(seconds, dtype=np.float64)
    R = np.asarray(reps, dtype=np.float64)
    S = np.asarray(samples, dtype=np.float64)
    ok = np.isfinite(B) & (B > 0) & (R > 0) & (S > 0)
    B, R, S = B[ok], R[ok], S[ok]
    n = B.size
    if n == 0:
        raise ValueError("no timed batch")
    y = B / R                                            # seconds per repetition
    X = np.stack([1.0 / R, np.ones_like(S), S], axis=1)

    def separable(cs: list) -> bool:
        return np.linalg.matrix_rank(X[:, cs] / X[:, cs].max(axis=0)) == len(cs) and n > len(cs)

    # Terms the design cannot tell apart, or that leave no residual degree of freedom, leave the
    # fit: the call overhead first, then the per-repetition one; the per-sample term stays.
    active = next((cs for cs in ([0, 1, 2], [1, 2], [0, 2]) if separable(cs)), [2])
    scale_a = X[:, active].max(axis=0)
    fitted = y
    # Relative residuals, weighted by the fitted cost (iterated): weights of the observed costs
    # would favour the batches that happened to run fast.
    for _ in range(3):
        w = 1.0 / fitted
        A = X[:, active] / scale_a * w[:, None]
        sol, *_ = np.linalg.lstsq(A, y * w, rcond=None)
        fitted = np.maximum((X[:, active] / scale_a) @ sol, 1e-3 * y)
    r = y / fitted - 1.0
    dof = n - len(active)
    wr = (y - fitted) * w
    s2 = float(np.sum(wr ** 2) / dof) if dof > 0 else float("nan")
    coef = np.zeros(3)
    coef[active] = sol / scale_a
    cov = np.zeros((3, 3))
    if dof > 0:
        inv = np.linalg.pinv(A.T @ A) * s2
        cov[np.ix_(active, active)] = inv / np.outer(scale_a, scale_a)
    else:
        cov[:] = np.nan
    rel_sd = math.sqrt(s2) if dof > 0 else float("nan")
    design = tuple((float(v), float(np.mean(1.0 / R[S == v]))) for v in np.unique(S))
    return CostModel(tuple(float(v) for v in coef), tuple(tuple(float(v) for v in row) for row in cov),
                     int(dof), rel_sd, int(n), tuple(float(v) for v in r), design)


def load_shift(times, residuals, seed: int = 0) -> dict:
    """A step in time of relative cost residuals (pooled over every model of a sweep): the split
    with the largest two-sample t of log(1 + residual), its permutation p-value, the time of the
    split and the cost ratio after/before. `shifted` when p < LOAD_SHIFT_P."""
    t = np.asarray(times, dtype=np.float64)
    r = np.log1p(np.clip(np.asarray(residuals, dtype=np.float64), -0.99, None))
    keep = np.isfinite(t) & np.isfinite(r)
    t, r = t[keep], r[keep]
    out = {"batches": int(r.size), "p": float("nan"), "shifted": False, "at": float("nan"),
           "ratio": float("nan")}
    m = LOAD_SHIFT_MIN_SIDE
    if r.size < 2 * m + 1:
        return out
    order = np.argsort(t, kind="stable")
    x = r[order]

    def stat(v: np.ndarray) -> np.ndarray:           # v: (k, n) -> largest |t| over splits per row
        n = v.shape[1]
        k = np.arange(1, n)
        c = np.cumsum(v, axis=1)[:, :-1]
        total = v.sum(axis=1, keepdims=True)
        d = (total - c) / (n - k) - c / k
        s = np.std(v, axis=1, ddof=1, keepdims=True)
        tt = np.abs(d) / (s * np.sqrt(1.0 / k + 1.0 / (n - k)) + 1e-300)
        tt[:, :m - 1] = 0.0
        tt[:, n - m:] = 0.0
        return tt

    obs = stat(x[None, :])[0]
    best = int(np.argmax(obs))
    rng = np.random.default_rng(seed)
    perms = np.stack([rng.permutation(x) for _ in range(LOAD_SHIFT_PERMUTATIONS)])
    null = stat(perms).max(axis=1)
    p = (1 + int(np.sum(null >= obs[best]))) / (LOAD_SHIFT_PERMUTATIONS + 1)
    k = best + 1
    out.update(p=float(p), shifted=bool(p < LOAD_SHIFT_P), at=float(t[order][k]),
               ratio=float(math.exp(x[k:].mean() - x[:k].mean())))
    return out
