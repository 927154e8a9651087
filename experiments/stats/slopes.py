"""Convergence-slope fits: the RMSE slope sampled with emcee, the typical-error slope drawn from its
exact posterior. Two estimands, reported side by side:

RMSE slope (`fit_rmse_slope`): the slope b of RMSE(N) = sqrt(E[MSE at N]) ∝ N^b, the quantity the
variance theory speaks of (plain Monte Carlo: E[MSE] = Var / N exactly, so b = -0.5 in every scene).
Model, on the per-run MSEs m_{N,r} (noise floor already removed):

    m_{N,r} ~ Gamma(mean mu_N, shape k_N),   log mu_N = a + 2 b log N,
    1 / k_N = CV^2 of a run's MSE at N = exp(d0 + d1 log N).

Priors are flat in (a, b, d0) within wide boxes and in d1 within [-5, 0]: a run's MSE is an average
of more samples at larger N, so its relative spread does not grow with N (for independent sampling
CV^2 = c1 / N + c0 exactly). The bound matters when rare huge samples are missed by every run at
small N and caught at large N: the small-N cells then look precise and low, and without it the fit
trusts them and reports a rising error. With it, the spread seen at large N is also assumed at small
N, where the few quiet runs then say little about the mean. The likelihood is parameterized by the
mean: for given k_N its score for (a, b) is sum k_N (m / mu_N - 1) (1, log N), which has expectation
zero whatever the true law of m, so b estimates the slope of the mean MSE and not of a typical run's
MSE. Heavy tails (rare, very bright samples: most runs at small N have small error, a few a huge
one) show as a large CV^2 at small N. The dispersion is a smooth law in N, fitted jointly (for
independent sampling CV^2 = c1 / N + c0 exactly, which a log-linear law follows over a ladder), so a
small-N cell where no rare sample happened to land cannot claim a precision its own spread suggests:
it inherits the dispersion the other cells reveal, and gets little weight. Values at or below
`floor` (a corrected MSE <= 0: below the noise floor) are left-censored there. `lack_of_fit_p` is an
F test of the cell means' scatter about the power law against the runs' scatter within cells: a
small value (< 0.001; about 1% of calibrated ladders reach 0.01) means no single slope describes the
ladder, e.g. a plateau from a bias. Where the fit shows strain (scatter above LIGHT_SIGMA, a heavy
pooled tail by `resolution.tail_shape`, a cell carried by one run, lack of fit p < 0.01, or the two
estimates disagreeing) the reported interval
(`slope_lo`, `slope_hi`) is the union of this fit's credible interval
(`model_slope_lo/hi`) and a model-free one (`cell_means_*`: least squares of log sqrt(cell-mean MSE)
on log N, Student-t on C - 2 degrees of freedom, from 4 cells on), because the Gamma law is wrong
in a regime the renderer reaches: when bright samples are so rare that a cell holds a handful, its
shape is set by the quiet bulk of the runs, the cells with many runs are trusted as if precise,
and the likelihood interval misses (42/60 covering on the test's ladders at q = 0.001). Each
interval holds under its own assumptions, so the union holds where either does (59/60 there, 58/60
on Gaussian ladders at 1.4x the exact width). Under heavy tails only equal samples per cell
(`samples_per_cell`) make the slope estimable: every cell then has the same chance to see the rare
samples (tests/experiments/stats/test_slope_fit.py). `resolved` is False when the slope interval is wider than
RESOLVED_WIDTH (0.5), when one run carries nearly all of a cell's error (`saturated_cells`: its
CV at 0.9 of the largest R runs can show, sqrt(R)), or when the two intervals do not
overlap (`estimates_agree`): the runs do not tell the
rates apart, and reports say so instead of quoting the median. A single end cell off the line is instead absorbed by
the dispersion law (and gets little weight); a cell at the noise floor (median at or below it) is
left out of the fit and listed in `at_floor`, besides the noise-floor check of the analysis.

Typical-error slope (`fit_typical_slope`): log RMSE_run = a + b log N + eps,
eps ~ Normal(0, sigma^2), over the per-run RMSEs: the slope of the geometric mean of the error, what a
single run typically shows. Priors are flat in a and b (a wide box) and flat in log sigma, under which
the marginal posterior of b is the Student-t of ordinary least squares: the 95% credible interval is
then also a 95% confidence interval. That posterior is known in closed form, so it is drawn exactly
(no chain: a third of the analysis's fitting time was spent sampling it with emcee). With heavy
tails it is not the RMSE slope (it is far shallower).

Every fit uses a fixed seed, so reports are reproducible. The RMSE fit's chains are checked: the mean acceptance
fraction should lie in [0.15, 0.8] and the chain should be longer than 50 integrated autocorrelation
times (emcee's own criterion); `converged` says whether both hold. `tests/experiments/stats/test_slope_fit.py` checks
both fits' interval coverage on synthetic ladders with known slopes, Gaussian and heavy-tailed.
"""
from __future__ import annotations

import logging
import math
import warnings

import numpy as np
from scipy import special, stats

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL
from drtlab.experiments.stats.resolution import tail_shape

A_BOX = 100.0
B_BOX = 10.0
LOG_SIGMA_BOX = (-12.0, 4.0)
LOG_DISP_BOX = (-25.0, 10.0)     # log CV^2 of a run's MSE, in every cell (shape k up to e^25)
DISP_SLOPE_BOX = 5.0             # -d log CV^2 / d log N lies in [0, this]: the CV never grows with N
# A slope interval wider than this cannot tell the rates the studies compare (-0.5, -0.75, -1) apart:
# the fit reports it as not resolved by these runs rather than as an estimate.
RESOLVED_WIDTH = 0.5
SATURATION = 0.9        # a cell's CV at this fraction of sqrt(runs) or more: one run carries it
LIGHT_SIGMA = 0.25      # scatter of a run's log RMSE below which the likelihood interval stands alone
CELL_MEANS_MIN_CELLS = 4  # the model-free interval needs C - 2 >= 2 degrees of freedom (t(1) is 12.7)
LOG_CDF_MIN = -700.0             # log P(m <= floor) is clipped here (gammainc underflows to 0)
# The chain of every study's RMSE fit: the renderer's analysis and the integrand testbed report
# slopes side by side, so they fit them alike (fit_rmse_slope's own default serves the tests).
STUDY_CHAIN = {"nsteps": 2000, "burn": 400}


def ols(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """(intercept, slope, residual sd) of the least-squares line."""
    X = np.stack([np.ones_like(x), x], axis=1)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    dof = max(len(x) - 2, 1)
    return float(coef[0]), float(coef[1]), float(math.sqrt(max(np.sum(resid ** 2) / dof, 1e-300)))


def _sample(log_prob, p0: np.ndarray, args: tuple, *, nsteps: int, burn: int, seed: int) -> dict:
    """Run emcee from `p0` (walkers x dims) and return the flat chain with its diagnostics."""
    import emcee

    nwalkers, ndim = p0.shape
    # Differential-evolution proposals mix about 3x faster than the default stretch move on these
    # nearly Gaussian low-dimensional posteriors (integrated autocorrelation time ~11 steps vs ~30).
    moves = [(emcee.moves.DEMove(), 0.9), (emcee.moves.StretchMove(), 0.1)]
    sampler = emcee.EnsembleSampler(nwalkers, ndim, log_prob, args=args, vectorize=True, moves=moves)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(p0, nsteps, progress=False)
    chain = sampler.get_chain(discard=burn, flat=True)
    acc = float(np.mean(sampler.acceptance_fraction))
    log = logging.getLogger("emcee.autocorr")   # a short chain is reported via `converged` instead
    level_before = log.level
    log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tau = sampler.get_autocorr_time(discard=burn, quiet=True)
    except Exception:                                    # noqa: BLE001 - reported, not fatal
        tau = np.full(ndim, np.nan)
    finally:
        log.setLevel(level_before)
    kept = nsteps - burn
    tau_max = float(np.nanmax(tau)) if np.any(np.isfinite(tau)) else float("nan")
    ok_tau = math.isfinite(tau_max) and tau_max > 0
    return {
        "chain": chain,
        "acceptance_fraction": acc,
        "autocorr_time": [float(t) for t in tau],
        "steps": nsteps, "burn": burn, "walkers": nwalkers,
        "effective_samples": float(nwalkers * kept / tau_max) if ok_tau else float("nan"),
        "converged": bool(0.15 <= acc <= 0.8 and ok_tau and kept >= 50 * tau_max),
        "seed": seed,
    }


def _quantiles(level: float) -> list[float]:
    return [50.0 * (1 - level), 50.0, 100.0 - 50.0 * (1 - level)]


def _band(lines: np.ndarray, grid: np.ndarray, level: float) -> dict:
    """Median and credible band of fitted log-RMSE lines (rows: posterior draws) on log-N `grid`."""
    l_lo, l_med, l_hi = np.percentile(lines, _quantiles(level), axis=0)
    return {"n": np.exp(grid).tolist(), "median": np.exp(l_med).tolist(),
            "lo": np.exp(l_lo).tolist(), "hi": np.exp(l_hi).tolist()}


def fit_typical_slope(n, rmse, *, seed: int = 0, draws: int = 20000, level: float = CI_LEVEL,
                      line_points: int = 24) -> dict:
    """Typical-error slope: fit log RMSE = a + b log N over per-run RMSEs, with a fitted noise term.

    `n` and `rmse` are per-run values (repetitions included); non-positive or non-finite RMSE values
    (a corrected MSE below zero) are dropped and counted in `dropped`. The posterior is drawn exactly
    (`draws` independent draws, no chain): sigma^2 from dof s^2 / chi^2(dof), then (a, b) from the
    normal about the least-squares line; the slope's and intercept's intervals are its Student-t
    quantiles, the band of the fitted line the draws' percentiles.
    """
    n = np.asarray(n, dtype=np.float64)
    rmse = np.asarray(rmse, dtype=np.float64)
    keep = np.isfinite(rmse) & (rmse > 0) & np.isfinite(n) & (n > 0)
    x_all, y_all = np.log(n[keep]), np.log(rmse[keep])
    out: dict = {"n_points": int(keep.sum()), "dropped": int((~keep).sum()), "level": level}
    if x_all.size < 3 or np.unique(x_all).size < 2:
        out.update({"ok": False, "reason": "fewer than 3 usable points on at least 2 sample counts"})
        return out
    xm = float(x_all.mean())
    x = x_all - xm
    a0, b0, s0 = ols(x, y_all)
    dof = x.size - 2
    sxx = float(np.sum(x * x))
    rng = np.random.default_rng(seed)
    sigma2 = dof * s0 * s0 / rng.chisquare(dof, draws)
    b = b0 + np.sqrt(sigma2 / sxx) * rng.standard_normal(draws)
    a_c = a0 + np.sqrt(sigma2 / x.size) * rng.standard_normal(draws)
    t = float(stats.t.ppf(0.5 + level / 2, dof))
    a = a0 - b0 * xm                                    # intercept at N = 1 (log N = 0)
    se_b = s0 / math.sqrt(sxx)
    se_a = s0 * math.sqrt(1.0 / x.size + xm * xm / sxx)
    grid = np.linspace(x_all.min(), x_all.max(), line_points)
    sub = slice(0, min(draws, 2000))
    lines = (a_c[sub, None] - b[sub, None] * xm) + b[sub, None] * grid[None, :]
    out.update({
        "ok": True,
        "slope": float(b0), "slope_lo": b0 - t * se_b, "slope_hi": b0 + t * se_b,
        "intercept": float(a), "intercept_lo": a - t * se_a, "intercept_hi": a + t * se_a,
        "sigma": float(np.median(np.sqrt(sigma2))),
        "ols_slope": float(b0), "seed": seed,
        "line": _band(lines, grid, level),
    })
    return out


# ---------------------------------------------------------------------------------------------------
# RMSE slope
# ---------------------------------------------------------------------------------------------------

def _gamma_loglik(log_mu: np.ndarray, log_cv2: np.ndarray, cells: dict) -> np.ndarray:
    """Log-likelihood of the runs, rows of (k, cells) arrays of log mean and log CV^2 per cell.

    Per uncensored run, log Gamma(m; mean mu, shape k) up to a constant (-log m) is
    k (log r - r + 1) + k log k - k - lgamma(k) with r = m / mu; `cells` holds per-cell sums.
    A censored run adds log P(m <= floor).
    """
    log_k = -np.clip(log_cv2, *LOG_DISP_BOX)
    k = np.exp(log_k)
    u = cells["uncensored"]
    fit = cells["sum_log"] - u * log_mu - cells["sum"] * np.exp(-log_mu) + u
    lp = np.sum(k * fit + u * (k * log_k - k - special.gammaln(k)), axis=1)
    if cells["any_censored"]:
        with np.errstate(divide="ignore"):
            cdf = np.log(special.gammainc(k, k * np.exp(cells["log_floor"] - log_mu)))
        lp = lp + np.sum(cells["censored"] * np.maximum(cdf, LOG_CDF_MIN), axis=1)
    return lp


def _gamma_log_prob(theta: np.ndarray, x: np.ndarray, cells: dict) -> np.ndarray:
    """Vectorized over walkers: theta (k, 4) = (a, b, d0, d1); log mu_N = a + 2 b x, log CV^2 = d0 + d1 x."""
    a, b, d0, d1 = theta[:, 0:1], theta[:, 1:2], theta[:, 2:3], theta[:, 3:4]
    log_cv2 = d0 + d1 * x[None, :]
    ok = ((np.abs(a[:, 0]) < 2 * A_BOX) & (np.abs(b[:, 0]) < B_BOX)
          & (d1[:, 0] <= 0.0) & (d1[:, 0] > -DISP_SLOPE_BOX)
          & np.all((log_cv2 > LOG_DISP_BOX[0]) & (log_cv2 < LOG_DISP_BOX[1]), axis=1))
    lp = _gamma_loglik(a + 2.0 * b * x[None, :], log_cv2, cells)    # log CV^2 clipped where not ok
    return np.where(ok, lp, -np.inf)


def _cells(n: np.ndarray, m: np.ndarray, floor: float) -> dict:
    """Per-sample-count sufficient statistics of the (scaled) per-run MSEs; values <= floor censored."""
    ladder = np.unique(n)
    cen = m <= floor
    by = [n == v for v in ladder]
    mu = np.where(cen, 1.0, m)
    return {
        "n": ladder, "x": np.log(ladder),
        "runs": np.array([s.sum() for s in by], dtype=np.float64),
        "uncensored": np.array([(s & ~cen).sum() for s in by], dtype=np.float64),
        "censored": np.array([(s & cen).sum() for s in by], dtype=np.float64),
        "sum": np.array([m[s & ~cen].sum() for s in by]),
        "sum_log": np.array([np.log(mu[s & ~cen]).sum() for s in by]),
        "mean": np.array([m[s].mean() for s in by]),
        "var": np.array([m[s].var(ddof=1) if s.sum() > 1 else np.nan for s in by]),
        "ss": np.array([np.sum((m[s] - m[s].mean()) ** 2) for s in by]),
        "any_censored": bool(cen.any()), "log_floor": math.log(floor),
    }


def _saturated_cells(c: dict) -> list[float]:
    """Sample counts whose runs' coefficient of variation is near the largest R runs can show
    (sqrt(R), one run carrying everything): that cell's mean rests on one rare event, its true spread
    may be any larger, and so neither its mean nor the slope is measured by these runs."""
    cv = np.sqrt(np.maximum(c["var"], 0.0)) / np.maximum(np.abs(c["mean"]), 1e-300)
    full = SATURATION * np.sqrt(c["runs"])
    return [float(v) for v, s, f, r in zip(c["n"], cv, full, c["runs"]) if r >= 3 and s >= f]


def _above_floor(n: np.ndarray, m: np.ndarray, floor: float) -> np.ndarray:
    """Runs of the cells whose median corrected MSE lies above `floor`. A cell at the floor
    measures the reference's noise, not the estimator, and says nothing about the slope: fitting its
    near-zero values would drag the line (or force the CV law to grow with N). Kept when dropping
    such cells would leave fewer than two sample counts."""
    at = [v for v in np.unique(n) if np.median(m[n == v]) <= floor]
    keep = ~np.isin(n, at)
    if np.unique(n[keep & (m > 0)]).size < 2 or (keep & (m > 0)).sum() < 3:
        return np.ones_like(keep)
    return keep


def _rmse_start(c: dict, x: np.ndarray, floor: float, nwalkers: int, rng) -> np.ndarray:
    """Walkers around a moment estimate: OLS of log cell-mean MSE, and of log cell CV^2, on log N."""
    mean = np.maximum(c["mean"], floor)
    w = np.sqrt(c["runs"])
    b2, a0 = np.polyfit(x, np.log(mean), 1, w=w)
    cv2 = c["var"] / mean ** 2
    good = np.isfinite(cv2) & (cv2 > 0)
    cv2 = np.clip(cv2[good], math.exp(LOG_DISP_BOX[0] + 1), math.exp(LOG_DISP_BOX[1] - 1))
    if good.sum() >= 2 and np.unique(x[good]).size >= 2:
        d1, d0 = np.polyfit(x[good], np.log(cv2), 1)
        d1 = float(np.clip(d1, -0.9 * DISP_SLOPE_BOX, -0.02))
    else:
        d1, d0 = -0.02, float(np.log(cv2).mean()) if good.any() else 0.0
    theta = np.array([a0, b2 / 2.0, d0, d1])
    p0 = theta + 1e-2 * rng.standard_normal((nwalkers, 4))
    p0[:, 3] = -np.abs(p0[:, 3])            # inside the prior (d1 <= 0)
    return p0


def _lack_of_fit(c: dict, x: np.ndarray, theta: np.ndarray) -> tuple[float, float]:
    """Between- against within-cell scatter (an F test, as in a one-way analysis of variance): the
    cell means' squared relative deviations from the fitted power law, and the runs' from their cell
    means, each weighted by the fitted CV^2 law's shape (its scale cancels). Returns (F, p-value on
    (cells - 2, runs - cells) degrees of freedom); a small p means no single slope fits the means."""
    C, n = x.size, float(c["runs"].sum())
    if C < 3 or n <= C:
        return float("nan"), float("nan")
    mu = np.exp(theta[0] + 2.0 * theta[1] * x)
    w = np.exp(-theta[3] * x)
    between = float(np.sum(c["runs"] * w * (c["mean"] / mu - 1.0) ** 2)) / (C - 2)
    within = float(np.sum(w * c["ss"] / mu ** 2)) / (n - C)
    if not within > 0:
        return float("inf"), 0.0
    f = between / within
    return f, float(stats.f.sf(f, C - 2, n - C))


def _cell_means_interval(c: dict, floor: float, level: float) -> tuple[float, float, float] | None:
    """(slope, lo, hi) of ordinary least squares of log sqrt(cell-mean MSE) on log N, with the
    Student-t interval on C - 2 degrees of freedom: no law of a run assumed, only that the cells'
    log means scatter alike about the line. Under heavy tails a cell mean falls short of E[MSE] by a
    random factor; with equal samples per cell (`samples_per_cell`) that factor has the same law in
    every cell, so it shifts the line and widens the scatter but does not tilt it. None below
    CELL_MEANS_MIN_CELLS cells."""
    x = c["x"]
    if x.size < CELL_MEANS_MIN_CELLS:
        return None
    y = 0.5 * np.log(np.maximum(c["mean"], floor))
    _, b, s = ols(x, y)
    h = float(stats.t.ppf(0.5 + level / 2, x.size - 2)) * s / math.sqrt(float(np.sum((x - x.mean()) ** 2)))
    return b, b - h, b + h


def fit_rmse_slope(n, mse, *, seed: int = 0, nwalkers: int = 32, nsteps: int = 2500,
                   burn: int = 500, level: float = CI_LEVEL, line_points: int = 24,
                   floor: float | None = None) -> dict:
    """RMSE slope: fit mean MSE(N) = A N^(2b) to per-run MSEs; b is the slope of RMSE = sqrt(mean MSE).

    `n` and `mse` are per-run values (repetitions included; MSE with the noise floor removed, so it
    may be slightly negative). Non-finite values are dropped (`dropped`); values at or below `floor`
    are left-censored there (`censored`); cells whose median is at or below it are left out of the
    fit (`at_floor`, see `_above_floor`). `floor` defaults to 1% of the smallest cell's median
    positive MSE; pass the ground truth's variance (the correction's scale) when known.
    Returns `fit_typical_slope`'s keys (`intercept`: log RMSE at N = 1; `sigma`: the model's sd of a
    run's log RMSE at the ladder's geometric centre, comparable to the typical fit's; `ols_slope`:
    least squares on log sqrt(cell-mean MSE); `autocorr_time`: 4 parameters) and `cells` (per N: runs,
    mean MSE, RMSE, fitted RMSE, the fitted CV of a run's MSE), `cv_slope` (d log CV / d log N),
    `lack_of_fit_f` / `lack_of_fit_p`, `resolved`, `saturated_cells`, `floor`, `censored`, `model`, `estimand` ("rmse"),
    and `draws`: up to 2000 posterior draws of (intercept, slope) as an array.
    """
    n = np.asarray(n, dtype=np.float64)
    m = np.asarray(mse, dtype=np.float64)
    keep = np.isfinite(m) & np.isfinite(n) & (n > 0)
    n, m = n[keep], m[keep]
    out: dict = {"n_points": int(keep.sum()), "dropped": int((~keep).sum()), "level": level,
                 "estimand": "rmse", "model": "gamma, mean-parameterized, log-linear CV^2 non-increasing in N; "
                          "interval: union with the cell means' least-squares t-interval"}
    pos = m > 0
    if pos.sum() < 3 or np.unique(n[pos]).size < 2:
        out.update({"ok": False, "reason": "fewer than 3 usable points on at least 2 sample counts"})
        return out
    if floor is None or not floor > 0:
        floor = 0.01 * min(float(np.median(m[(n == v) & pos])) for v in np.unique(n[pos]))
    scale = math.exp(float(np.mean(np.log(m[pos]))))
    c = _cells(n, m / scale, floor / scale)
    xm = float(np.mean(np.log(n)))
    x = c["x"] - xm
    fit_n = _above_floor(n, m, floor)
    cf = _cells(n[fit_n], m[fit_n] / scale, floor / scale)
    xf = cf["x"] - xm
    rng = np.random.default_rng(seed)
    p0 = _rmse_start(cf, xf, floor / scale, nwalkers, rng)
    run = _sample(_gamma_log_prob, p0, (xf, cf), nsteps=nsteps, burn=burn, seed=seed)
    chain = run.pop("chain")
    med = np.median(chain, axis=0)
    b = chain[:, 1]
    a = 0.5 * (chain[:, 0] + math.log(scale)) - b * xm        # log RMSE at N = 1
    q = _quantiles(level)
    b_lo, b_med, b_hi = np.percentile(b, q)
    a_lo, a_med, a_hi = np.percentile(a, q)
    grid = np.linspace(c["x"].min(), c["x"].max(), line_points)
    sub = rng.choice(len(chain), size=min(len(chain), 2000), replace=False)
    lines = a[sub, None] + b[sub, None] * grid[None, :]
    f_fit, p_fit = _lack_of_fit(cf, xf, med)
    saturated = _saturated_cells(c)
    means = _cell_means_interval(cf, floor / scale, level)
    lo, hi, agree = float(b_lo), float(b_hi), True
    sigma = 0.5 * math.sqrt(float(special.polygamma(1, math.exp(-med[2]))))
    if means is not None:
        agree = bool(means[1] <= b_hi and b_lo <= means[2])        # the intervals overlap
        # The Gamma likelihood is trusted alone where its own assumptions show no strain: light
        # scatter, no cell carried by one run, no lack of fit, both estimates agreeing. There the
        # union covered 0.98-0.995 on simulated ladders (the cell means' t has C - 2 degrees of
        # freedom) and the model alone 0.93-0.96 (`drtlab audit-intervals`).
        light = not tail_shape([m[n == v] for v in np.unique(n)])["heavy"]
        if not (agree and light and sigma <= LIGHT_SIGMA and not saturated and p_fit >= 0.01):
            lo, hi = min(lo, means[1]), max(hi, means[2])
    cv = np.sqrt(np.exp(med[2] + med[3] * x))
    fitted = np.exp(float(a_med) + float(b_med) * c["x"])
    out.update({
        "ok": True,
        "slope": float(b_med), "slope_lo": lo, "slope_hi": hi,
        "model_slope_lo": float(b_lo), "model_slope_hi": float(b_hi),
        "cell_means_slope": means[0] if means else float("nan"),
        "cell_means_lo": means[1] if means else float("nan"),
        "cell_means_hi": means[2] if means else float("nan"),
        "estimates_agree": agree,
        "resolved": bool(hi - lo <= RESOLVED_WIDTH) and not saturated and agree,
        "saturated_cells": saturated,
        "intercept": float(a_med), "intercept_lo": float(a_lo), "intercept_hi": float(a_hi),
        "sigma": sigma,
        "ols_slope": float(ols(c["x"], 0.5 * np.log(np.maximum(c["mean"], floor / scale)))[1]),
        **run,
        "cv_slope": float(med[3]) / 2.0,
        "lack_of_fit_f": f_fit, "lack_of_fit_p": p_fit,
        "floor": float(floor), "censored": int(c["censored"].sum()),
        "at_floor": [float(v) for v in c["n"] if v not in cf["n"]],
        "cells": [{"n": float(v), "runs": int(r), "mse_mean": float(mm * scale),
                   "rmse": math.sqrt(max(mm * scale, 0.0)), "fitted_rmse": float(f), "cv": float(s)}
                  for v, r, mm, f, s in zip(c["n"], c["runs"], c["mean"], fitted, cv)],
        "line": _band(lines, grid, level),
        # Posterior draws of (log RMSE at N = 1, slope): what speed-ups propagate (not JSON).
        "draws": np.stack([a[sub], b[sub]], axis=1),
    })
    return out
