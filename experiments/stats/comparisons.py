"""Two samplers compared: ratios of mean errors, of efficiencies and of times to an equal error, each
with a 95% interval and a p-value, and the claims a report may make from them.

* MSE ratio (baseline's mean MSE over the sampler's): Welch's t on the log scale, log(m_b / m_s) with
  standard error sqrt(cv_b^2 / n_b + cv_s^2 / n_s) and Welch-Satterthwaite degrees of freedom (the
  log-t interval of each mean, `intervals.positive_mean_ci`, combined).
* Efficiency ratio at equal N, (m_b T_b) / (m_s T_s): draws of the log MSE ratio from that t law
  times draws of the cost ratio from both cost models (`cost_model.CostModel.draw_seconds`).
* Speed-up at a target error: each sampler's time to reach it, T(N*) with log RMSE = a + b log N*
  from draws of its fitted convergence law (the emcee posterior of `slopes.fit_rmse_slope`) and of
  its cost model; the ratio of the baseline's time to the sampler's, draw by draw.

Draws give the interval (2.5 and 97.5 percentiles) and a two-sided p-value from the normal law of
the log ratio's draws. `assign_claims` turns p-values into claims with the Benjamini-Hochberg
correction (scipy's `false_discovery_control`) over every test a report states: better / worse
where the adjusted p is below `ALPHA`, no difference where it is not, and not resolved where a
cell or fit behind the comparison is not (no test is made there).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL, welch_dof

ALPHA = 1.0 - CI_LEVEL          # the false-discovery rate of a report's claims
DRAWS = 4000                    # draws behind each efficiency and speed-up interval
LOG_CLIP = 50.0                 # log ratios of draws that never reach the target are clipped here


def _log_mean(values) -> tuple[float, float, int]:
    """(log mean, its standard error by the delta method, n) of positive-mean values."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    n = int(v.size)
    m = float(v.mean()) if n else float("nan")
    if n < 2 or not m > 0:
        return float("nan"), float("nan"), n
    return math.log(m), float(v.std(ddof=1)) / m / math.sqrt(n), n


def mean_ratio(base_values, values, level: float = CI_LEVEL) -> dict:
    """Ratio of the baseline's mean to the sampler's (>1: the sampler's error is lower) with its
    Welch log-t interval and p-value; `log`, `se` and `dof` let callers draw from its law."""
    la, sa, na = _log_mean(base_values)
    lb, sb, nb = _log_mean(values)
    out = {"ratio": float("nan"), "lo": float("nan"), "hi": float("nan"), "p": float("nan"),
           "log": float("nan"), "se": float("nan"), "dof": float("nan")}
    if not (math.isfinite(la) and math.isfinite(lb)):
        return out
    d, se = la - lb, math.hypot(sa, sb)
    if se == 0:
        out.update(ratio=math.exp(d), lo=math.exp(d), hi=math.exp(d), p=0.0 if d else 1.0, log=d, se=0.0,
                   dof=float("inf"))
        return out
    dof = float(welch_dof(sa ** 2, na, sb ** 2, nb))
    t = float(stats.t.ppf(0.5 + level / 2, dof))
    out.update(ratio=math.exp(d), lo=math.exp(d - t * se), hi=math.exp(d + t * se),
               p=float(2 * stats.t.sf(abs(d) / se, dof)), log=d, se=se, dof=dof)
    return out


def draw_log_ratio(r: dict, rng, size: int = DRAWS) -> np.ndarray:
    """Draws of log(ratio) from `mean_ratio`'s t law."""
    if not math.isfinite(r["se"]):
        return np.full(size, np.nan)
    if r["se"] == 0:
        return np.full(size, r["log"])
    return r["log"] + r["se"] * rng.standard_t(r["dof"], size=size)


def interval_of_draws(log_draws, point: float, level: float = CI_LEVEL) -> dict:
    """`point` with the percentile interval of exp(draws) and the two-sided p-value of log ratio 0
    under the draws' normal law. An end at the clip (draws that never reach the target) is no bound:
    0 below, inf above."""
    d = np.asarray(log_draws, dtype=np.float64)
    d = d[np.isfinite(d)]
    if d.size < 0.5 * DRAWS or not math.isfinite(point):
        return {"ratio": point, "lo": float("nan"), "hi": float("nan"), "p": float("nan")}
    q = 100 * (1 - level) / 2
    lo, hi = np.percentile(d, [q, 100 - q])
    sd = float(np.std(d, ddof=1))
    p = float(2 * stats.norm.sf(abs(float(np.mean(d))) / sd)) if sd > 0 else float(np.mean(d) == 0)
    return {"ratio": point, "lo": 0.0 if lo <= -LOG_CLIP else float(math.exp(lo)),
            "hi": math.inf if hi >= LOG_CLIP else float(math.exp(hi)), "p": p}


def samples_to_reach(line, target: float) -> np.ndarray:
    """N at which log RMSE = a + b log N reaches `target`, per (a, b) row of `line`; inf where the
    line does not fall (b >= 0)."""
    line = np.atleast_2d(np.asarray(line, dtype=np.float64))
    a, b = line[:, 0], line[:, 1]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x = (math.log(target) - a) / b
        return np.where(b < 0, np.exp(np.clip(x, -LOG_CLIP, LOG_CLIP)), np.inf)


def log_time_ratio(t_base, t) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.log(np.asarray(t_base, dtype=np.float64)) - np.log(np.asarray(t, dtype=np.float64))
    return np.clip(np.where(np.isnan(r), 0.0, r), -LOG_CLIP, LOG_CLIP)


def assign_claims(tests: list[dict], alpha: float = ALPHA) -> list[dict]:
    """Benjamini-Hochberg over `tests` (dicts with `p`, `resolved` and `direction` = the sign of log
    ratio): each gets `p_adjusted` and `claim` (better / worse / no difference / not resolved).
    Unresolved tests are not part of the family."""
    fam = [i for i, t in enumerate(tests) if t["resolved"] and math.isfinite(t["p"])]
    adj = stats.false_discovery_control([tests[i]["p"] for i in fam], method="bh") if fam else []
    out = [dict(t, p_adjusted=float("nan"), claim="not resolved") for t in tests]
    for i, a in zip(fam, adj):
        sig = bool(a < alpha)
        out[i]["p_adjusted"] = float(a)
        out[i]["claim"] = ("better" if tests[i]["direction"] > 0 else "worse") if sig else "no difference"
    return out
