"""The analytic integrand testbed: convergence rates of every point set on 2D integrands with exact
integrals (experiments/integrands/functions.py), against the rates theory predicts.

    python -m drtlab.experiments.integrands.study [--profile quick|full] [--out DIR]

For every point set (estimators/registry.py POINTSETS but DIRECTION_ONLY_POINTSETS, or the list in
integrands.toml), sample count N (powers of 4) and repetition r, the points are `points(name, N, 2, seed=s)` - the pixel slot's
dimensions 0 and 1, exactly the values a render reads - with s = blake2b(root, point set, N, r).
Every integrand is evaluated on the same points (vectorised over the repetitions); the estimate is
the mean of f over the N points and its error the difference to the exact integral. A randomised
family draws a new member per repetition, from a Generator seeded by (root, integrand, N): the same
members for every point set, so point sets are compared on equal terms.

The slope b of RMSE(N) ∝ N^b is fitted to the per-run squared errors by `slopes.fit_rmse_slope`
(the gamma-model emcee fit of the experiments; the floor is the squared resolution of the points,
(2^-24)^2) and compared with the expected rate of integrands.toml: "as expected" when
the rate lies in the 95% interval widened by the stated tolerance, else "differs: finding", which
the report lists. Each cell's mean error is also tested against zero (a biased point set shows).

Outputs (default results/integrands/): summary.json, report.md, one log-log plot per integrand kind
(experiments/integrands/report.py), manifest.json.
"""
from __future__ import annotations

import math
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats

from drtlab import fields
from drtlab.cli_args import Help, Parser, run_main
from drtlab.errors import InputError
from drtlab.experiments.integrands.functions import INTEGRANDS, KINDS, describe
from drtlab.experiments.stats.intervals import rmse_ci
from drtlab.experiments.study.metrics import mean_ci
from drtlab.experiments.parallel import pmap
from drtlab.experiments.paths import default_out_dir
from drtlab.experiments.seeds import short_hash
from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.experiments.stats.slopes import STUDY_CHAIN, fit_rmse_slope

STUDY_FILE = Path(__file__).with_name("integrands.toml")
DEFAULT_PROFILE = "quick"
GRID = 2.0 ** -24            # points are k * 2^-24 (hashing.unit_float keeps a hash's top 24 bits)
FLOOR = GRID ** 2            # squared errors below the points' own resolution are not resolved
BIAS_ALPHA = 0.01            # family-wise level of the mean-error checks (Sidak over all of them)


@dataclass(frozen=True)
class Expected:
    rates: dict          # kind -> expected RMSE slope
    tolerance: float
    basis: str
    note: str = ""       # what a past run found where the data differ from `basis` (report only)


@dataclass(frozen=True)
class Study:
    description: str
    seed: int
    pointsets: tuple
    integrands: tuple
    n: tuple
    repetitions: int
    profile: str
    expected: dict       # point set -> Expected
    path: str
    file_hash: str


# ---------------------------------------------------------------------------------------------------
# The study file
# ---------------------------------------------------------------------------------------------------

def _names(value, field: str, allowed: list) -> tuple:
    if value == "all":
        return tuple(allowed)
    if not isinstance(value, list) or not value:
        raise InputError(field, f"must be \"all\" or a non-empty list of names from "
                                f"{', '.join(allowed)}")
    for i, v in enumerate(value):
        fields.string(v, f"{field}[{i}]", allowed)
    if len(set(value)) != len(value):
        raise InputError(field, f"lists a name twice: {value}")
    return tuple(value)


def _ladder(value, field: str) -> tuple:
    """Powers of 4, increasing: the counts every point set stratifies fully (module docstring)."""
    if not isinstance(value, list) or len(value) < 3:
        raise InputError(field, f"must be a list of at least 3 sample counts, got {fields.show(value)}")
    for i, v in enumerate(value):
        fields.integer(v, f"{field}[{i}]", "that is a power of 4 >= 4 (4, 16, 64, ...)",
                       lambda n: n >= 4 and n & (n - 1) == 0 and (n.bit_length() - 1) % 2 == 0)
        if i and v <= value[i - 1]:
            raise InputError(f"{field}[{i}]", f"the ladder must be strictly increasing, got {value}")
    return tuple(int(v) for v in value)


def _expected(table, pointsets) -> dict:
    fields.check_keys(table, list(pointsets), "expected", "expected rates by point set")
    out = {}
    for name, entry in table.items():
        t = fields.Table(entry, f"expected.{name}", "expected RMSE slopes")
        t.check_keys([*KINDS, "tolerance", "basis", "note"])
        rates = {k: fields.number(t.get(k, fields.REQUIRED, "the RMSE slope on " + k), t.field(k),
                                  "< 0", lambda b: b < 0) for k in KINDS}
        tol = fields.number(t.get("tolerance", 0.0, ""), t.field("tolerance"), ">= 0", lambda x: x >= 0)
        out[name] = Expected(rates, tol, fields.string(t.get("basis", "", ""), t.field("basis")),
                             fields.string(t.get("note", "", ""), t.field("note")))
    return out


def load_study(profile: str = DEFAULT_PROFILE, path: Path = STUDY_FILE) -> Study:
    """Parse and validate the study file for `profile`; raises InputError, writes nothing."""
    from drtlab.estimators.registry import DIRECTION_ONLY_POINTSETS, POINTSETS
    text = Path(path).read_text()
    try:
        data = fields.check_nesting(tomllib.loads(text), Path(path).name)
    except tomllib.TOMLDecodeError as e:
        raise InputError(Path(path).name, f"not valid TOML: {e}") from None
    except RecursionError:
        raise fields.too_deep(Path(path).name) from None
    fields.check_keys(data, ["study", "profile", "expected"], "", "the study file")
    st = fields.Table(data.get("study"), "study", "the study's settings")
    st.check_keys(["description", "seed", "pointsets", "integrands"])
    profiles = data.get("profile", {})
    fields.check_keys(profiles, list(profiles), "profile")
    if profile not in profiles:
        raise InputError("--profile", f"must be one of {', '.join(profiles)}; "
                                      f"got {fields.show(profile)}")
    pr = fields.Table(profiles[profile], f"profile.{profile}", "run sizes")
    pr.check_keys(["n", "repetitions"])
    pointsets = _names(st.get("pointsets", "all", ""), st.field("pointsets"),
                       [p for p in POINTSETS if p not in DIRECTION_ONLY_POINTSETS])
    return Study(
        description=fields.nonempty_string(st.get("description", fields.REQUIRED, "one line"),
                                           st.field("description")),
        seed=fields.integer_in(st.get("seed", fields.REQUIRED, "the root seed"), st.field("seed"), 0,
                               2 ** 63 - 1),
        pointsets=pointsets,
        integrands=_names(st.get("integrands", "all", ""), st.field("integrands"), list(INTEGRANDS)),
        n=_ladder(pr.get("n", fields.REQUIRED, "the sample counts"), pr.field("n")),
        repetitions=fields.integer_in(pr.get("repetitions", fields.REQUIRED, "runs per cell"),
                                      pr.field("repetitions"), 3, 100000),
        profile=profile, expected=_expected(data.get("expected", {}), list(POINTSETS)),
        path=str(path), file_hash=short_hash(text, 16))


# ---------------------------------------------------------------------------------------------------
# Errors of the estimates
# ---------------------------------------------------------------------------------------------------

def point_seed(root: int, pointset: str, n: int, rep: int) -> int:
    return int(short_hash(["integrands", root, pointset, n, rep], 8), 16)


def fit_seed(root: int, pointset: str, integrand: str) -> int:
    return int(short_hash(["fit", root, pointset, integrand], 8), 16) & 0x7FFFFFFF


def member_rng(root: int, integrand: str, n: int) -> np.random.Generator:
    """The Generator of a cell's family members: the same for every point set."""
    return np.random.default_rng(int(short_hash(["integrand-members", root, integrand, n], 8), 16))


def sample_mean(values: np.ndarray) -> np.ndarray:
    """The estimator: the mean of f over a run's points (values: (runs, N))."""
    return values.mean(axis=1)


def signed_errors(pointset: str, integrands, ns, repetitions: int, root: int,
                  estimator=sample_mean) -> dict:
    """{integrand: (len(ns), repetitions) array of estimate - exact integral} for one point set.
    `estimator` maps f's values on each run's points, (repetitions, N), to the estimates (the
    tests swap in deliberately biased ones)."""
    from drtlab.estimators.points import points
    out = {name: np.empty((len(ns), repetitions)) for name in integrands}
    for i, n in enumerate(ns):
        pts = np.stack([points(pointset, n, 2, seed=point_seed(root, pointset, n, r))
                        for r in range(repetitions)])               # (repetitions, n, 2)
        x, y = pts[..., 0], pts[..., 1]
        for name in integrands:
            batch = INTEGRANDS[name].members(member_rng(root, name, n), repetitions)
            values = np.broadcast_to(batch.f(x, y), x.shape)      # a constant f stays a full array
            out[name][i] = estimator(values) - batch.exact()
    return out


def bias_p(errors: np.ndarray) -> float:
    """p-value of "every cell's mean error is 0": per cell a t statistic, mapped to the normal
    deviate of equal two-sided p, their squares summed ~ chi-square(cells)."""
    m, sd, r = errors.mean(axis=1), errors.std(axis=1, ddof=1), errors.shape[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(sd > 0, m / (sd / math.sqrt(r)), 0.0)
    z = stats.norm.isf(stats.t.sf(np.abs(t), r - 1))
    return float(stats.chi2.sf(np.sum(z * z), len(m)))


# ---------------------------------------------------------------------------------------------------
# Fits and verdicts
# ---------------------------------------------------------------------------------------------------

def fit_ladder_slope(ns, errors: np.ndarray, seed: int, **kwargs) -> dict:
    """`fit_rmse_slope` of one cell ladder's per-run squared errors (every repetition a point)."""
    n = np.repeat(np.asarray(ns, dtype=np.float64), errors.shape[1])
    return fit_rmse_slope(n, np.ravel(errors) ** 2, seed=seed, floor=FLOOR, **{**STUDY_CHAIN, **kwargs})


def verdict(fit: dict, rate: float | None, tolerance: float) -> str:
    if not fit.get("ok"):
        return f"no fit: {fit.get('reason', 'unknown')}"
    if rate is None:
        return "no stated rate"
    lo, hi = fit["slope_lo"] - tolerance, fit["slope_hi"] + tolerance
    if lo <= rate <= hi:
        return "as expected"
    return f"differs: finding ({'steeper' if fit['slope'] < rate else 'shallower'} than expected)"


def _cells(ns, errors: np.ndarray) -> list:
    out = []
    for n, e in zip(ns, errors):
        r, me = rmse_ci(e * e), mean_ci(e)
        out.append({"n": n, "runs": len(e), "rmse": {k: r[k] for k in ("mean", "lo", "hi")},
                    "mean_error": {k: me[k] for k in ("mean", "lo", "hi")}})
    return out


def _row(study: Study, pointset: str, name: str, errors: np.ndarray, fit: dict, alpha: float) -> dict:
    kind = INTEGRANDS[name].kind
    exp = study.expected.get(pointset)
    rate = exp.rates[kind] if exp else None
    tol = exp.tolerance if exp else 0.0
    keep = ("ok", "reason", "slope", "slope_lo", "slope_hi", "intercept", "lack_of_fit_p", "converged",
            "acceptance_fraction", "autocorr_time", "censored", "seed", "line")
    p = bias_p(errors)
    return {"pointset": pointset, "integrand": name, "kind": kind, "expected": rate,
            "tolerance": tol, "verdict": verdict(fit, rate, tol),
            "fit": {k: fit[k] for k in keep if k in fit}, "cells": _cells(study.n, errors),
            "bias_p": p, "biased": bool(p < alpha)}


def run(study: Study, log=None) -> dict:
    """Simulate every (point set, integrand) cell ladder and fit its slope; returns summary.json."""
    log = log or (lambda msg: None)
    t0 = time.perf_counter()
    errors = {}
    for ps in study.pointsets:
        t = time.perf_counter()
        for name, e in signed_errors(ps, study.integrands, study.n, study.repetitions,
                                     study.seed).items():
            errors[ps, name] = e
        log(f"{ps}: {len(study.n)} sample counts x {study.repetitions} runs "
            f"({time.perf_counter() - t:.1f} s)")
    sim_seconds = time.perf_counter() - t0
    keys = list(errors)
    calls = [(fit_ladder_slope, (study.n, errors[k], fit_seed(study.seed, *k)), {}) for k in keys]
    t1 = time.perf_counter()
    fits = pmap(calls)
    log(f"{len(fits)} slope fits ({time.perf_counter() - t1:.1f} s)")
    alpha = sidak(BIAS_ALPHA, len(keys))          # over every cell ladder
    rows = [_row(study, ps, name, errors[ps, name], fit, alpha) for (ps, name), fit in zip(keys, fits)]
    return {
        "study": "integrands", "description": study.description, "profile": study.profile,
        "n": list(study.n), "repetitions": study.repetitions, "seed": study.seed,
        "dims": [0, 1], "floor": FLOOR, "point_grid": GRID, "bias_alpha_per_ladder": alpha,
        "pointsets": list(study.pointsets),
        "integrands": {name: {"kind": INTEGRANDS[name].kind, "what": describe(name)}
                       for name in study.integrands},
        "expected": {ps: {"rates": e.rates, "tolerance": e.tolerance, "basis": e.basis,
                          "note": e.note} for ps, e in study.expected.items() if ps in study.pointsets},
        "results": rows,
        "wall_seconds": {"simulation": sim_seconds, "fits": time.perf_counter() - t1},
    }


# ---------------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------------

def _profiles() -> list:
    try:
        return list(tomllib.loads(STUDY_FILE.read_text()).get("profile", {})) or [DEFAULT_PROFILE]
    except (OSError, tomllib.TOMLDecodeError):
        return [DEFAULT_PROFILE]          # load_study then says what is wrong with the file


def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.integrands.study", formatter_class=Help,
               description="Convergence slopes of every point set on 2D integrands with exact "
                           "integrals (experiments/integrands/integrands.toml), against the known rates.")
    p.add_argument("--profile", choices=_profiles(), default=DEFAULT_PROFILE,
                   help="run size: quick (N up to 4096) or full (N up to 65536)")
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="output folder (default: results/integrands)")
    p.set_defaults(func=_command)
    return p


def _command(args) -> int:
    from drtlab.experiments.integrands.report import write_outputs
    study = load_study(args.profile)
    out = fields.writable_location(args.out or default_out_dir("integrands"), "--out", folder=True)
    t0 = time.perf_counter()
    summary = run(study, log=lambda m: print(f"integrands: {m}", file=sys.stderr, flush=True))
    out.mkdir(parents=True, exist_ok=True)
    write_outputs(summary, study, out, time.perf_counter() - t0)
    findings = [r for r in summary["results"] if r["verdict"].startswith("differs")]
    print(f"integrands: wrote {out}/report.md ({len(summary['results'])} ladders, "
          f"{len(findings)} findings)", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
