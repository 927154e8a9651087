"""The interval audit: many simulated studies (`simulate.py`) through the study's own analysis
(`study.compare.compare_scene` and `finish_claims`, unchanged, with the study's chain), and for every
interval kind the report prints, how often it covers the truth.

Kinds: the cell mean MSE (the RMSE interval is its square root: same coverage), the MSE ratio, the
RMSE slope, the cost of one repetition, the efficiency ratio at N and the speed-up at the row's own
stated target RMSE (true times of both samplers to reach that target with the true laws and costs).
Each is tabulated per setting over all its intervals, over the resolved ones (the ones a claim may
rest on: cell / row resolved, fit resolved, speed-up resolved; a cost has no such flag) and by its
mean width (hi / lo; the slope's hi - lo). Claims: in equal settings the share of studies with any
better / worse claim (claim or MSE claim); otherwise the share of claims whose direction is wrong
(a claim where the truth is a tie counts as wrong) and the power (resolved rows with a non-tie
truth claimed in the right direction).

Uncertainty of a rate: a Wilson interval on the effective count. Intervals of one study share its
cost models and fits, so they are not independent: the count is the number of intervals divided
by the design effect measured between studies (cluster variance of the rate); with no variation at
all it is the number of studies (the conservative end).

Pass criteria (`judge`), at the confidence `level` (95% in the CLI): a coverage passes when its
interval meets the band [0.92, 0.98]; light-tailed settings judge every kind over all its
intervals; heavy-tailed ones judge a kind with a resolution flag over its resolved intervals, or
pass it when under 5% of them are resolved (then no claim rests on it). A false-finding or wrong-
claim rate passes unless its interval lies above 5%. Load steps: `load_shift` must detect the step
(rate not below 0.9) and not fire without one (rate not above 5%). The analysis levels a detected
step (`compare.level_load`: later batches scaled back to the earlier load), so under a load step
the cost of a repetition is judged against the unloaded truth like the ratios.

Negative control: the method before the interval core ("today's"): the MSE ratio by a delta-method
normal interval (z = 1.96, sd / mean / sqrt(n) per side), a cell's cost as the mean of the faster
half of its batches' seconds per repetition with a t interval and a 5% systematic term, the
efficiency ratio by the delta method over both, every row resolved and claims wherever an interval
excludes 1, uncorrected. It must fail (a coverage interval outside the band, or false findings
above 5%) in the equal settings, where it is bound to: eight uncorrected tests of a study make a
false claim far more often than 5% whatever the law. Elsewhere its failure is reported, not
required: its delta-method MSE ratio covers 0.91-0.92 under log-normal and Pareto errors, too close
to the band for a hundred studies to tell.
"""
from __future__ import annotations

import math
import zlib
from pathlib import Path

import numpy as np
from scipy import stats

from drtlab.experiments.audit.simulate import (
    BASELINE, LADDER, OTHER, PIXELS, SETTINGS, Setting, Study, simulate_study,
)
from drtlab.experiments.stats.hypothesis_tests import CI_LEVEL, Z_CI

BAND = (0.92, 0.98)
MAX_FALSE = 0.05            # false findings / wrong claims
UNRESOLVED_ENOUGH = 0.05    # heavy tails: below this resolved fraction no claim rests on a kind
DETECT_MIN = 0.9            # load-step detection rate
SYSTEMATIC = 0.05           # today's cost interval carried this fraction of the mean besides its t
NAN = float("nan")
# kind -> (title, has a resolution flag, width as hi / lo (else hi - lo))
KINDS = {
    "cell_mse": ("cell mean MSE (RMSE: its square root, same coverage)", True, True),
    "mse_ratio": ("MSE ratio", True, True),
    "slope": ("RMSE slope", True, False),
    "cost": ("cost of one repetition", False, True),
    "efficiency": ("efficiency ratio at N", True, True),
    "speedup": ("speed-up at the row's target RMSE", True, True),
}
CONTROL_KINDS = ("mse_ratio", "cost", "efficiency")
DIRECTION = {"better": 1, "worse": -1}


def _sign(ratio: float) -> int:
    return 0 if not math.isfinite(ratio) or abs(math.log(ratio)) < 1e-9 else (1 if ratio > 1 else -1)


def _seeds(seed: int, name: str, index: int) -> tuple[np.random.Generator, int]:
    """The study's generator and the analysis seed, fixed by (seed, setting, index) alone."""
    ss = np.random.SeedSequence([seed, zlib.crc32(name.encode()), index])
    return np.random.default_rng(ss), int(ss.generate_state(1)[0] & 0x7FFFFFFF)


# ---------------------------------------------------------------------------------------------------
# One study
# ---------------------------------------------------------------------------------------------------

def _claim(claim: str, truth: int) -> dict:
    return {"claim": claim, "truth": truth}


def _naive_log_mean(v) -> tuple[float, float]:
    v = np.asarray(v, dtype=np.float64)
    m = float(v.mean())
    return m, float(v.std(ddof=1)) / m / math.sqrt(v.size)


def _naive_cost(seconds_per_rep: list) -> tuple[float, float]:
    """(mean, log-scale sd) of a cell's cost as today's analysis had it: the faster half of its
    batches (at least 2), a t half-width over them and a systematic term, sd = half-width / z."""
    v = sorted(seconds_per_rep)
    v = np.asarray(v[:max(2, (len(v) + 1) // 2)] if len(v) > 2 else v)
    m = float(v.mean())
    h = SYSTEMATIC * m
    if v.size > 1:
        h = math.hypot(float(stats.t.ppf(0.5 + CI_LEVEL / 2, v.size - 1)) * float(v.std(ddof=1))
                       / math.sqrt(v.size), h)
    return m, h / Z_CI / m


def naive_control(study: Study) -> dict:
    """Today's intervals and uncorrected claims on the same study (see the module docstring)."""
    runs, b, T = study.runs, study.batches, study.truth
    vals, per_rep = {}, {}
    for s, n, v in zip(runs["sampler"], runs["spp"], runs["value"]):
        vals.setdefault((s, n), []).append(v)
    for s, n, sec, r in zip(b["sampler"], b["spp"], b["seconds"], b["reps"]):
        per_rep.setdefault((s, n), []).append(sec / r)
    cost = {k: _naive_cost(v) for k, v in per_rep.items()}
    out = {"intervals": {k: [] for k in CONTROL_KINDS}, "claims": []}
    for (s, n), (m, sd) in cost.items():
        out["intervals"]["cost"].append((m * math.exp(-Z_CI * sd), m * math.exp(Z_CI * sd),
                                         T.of(s).seconds(n), True, f"{s} N={n}"))
    for n in LADDER:
        (mb, sb), (ms, ss) = _naive_log_mean(vals[(BASELINE, n)]), _naive_log_mean(vals[(OTHER, n)])
        (cb, cbs), (cs, css) = cost[(BASELINE, n)], cost[(OTHER, n)]
        eff_sd = math.sqrt(sb ** 2 + ss ** 2 + cbs ** 2 + css ** 2)
        row = {"spp": n, "resolved": True}
        for kind, key, r, sd, truth in (
                ("mse_ratio", "mse", mb / ms, math.hypot(sb, ss), T.mse_ratio(n)),
                ("efficiency", "claim", mb * cb / (ms * cs), eff_sd, T.efficiency(n))):
            lo, hi = r * math.exp(-Z_CI * sd), r * math.exp(Z_CI * sd)
            out["intervals"][kind].append((lo, hi, truth, True, f"N={n}"))
            row[key] = _claim("better" if lo > 1 else "worse" if hi < 1 else "no difference", _sign(truth))
        out["claims"].append(row)
    return out


def audit_study(name: str, index: int, seed: int) -> dict:
    """Study `index` of setting `name`: every interval with its truth and resolution, every claim
    with the truth's direction, today's control on the same data and the load-shift test."""
    from drtlab.experiments.study.compare import compare_scene, finish_claims, level_load
    setting = SETTINGS[name]
    rng, analysis_seed = _seeds(seed, name, index)
    study = simulate_study(setting, rng)
    T = study.truth
    (batches,), load = level_load([study.batches], [PIXELS])
    sc = compare_scene(study.runs, batches, [BASELINE, OTHER], BASELINE, list(LADDER), PIXELS,
                       seed=analysis_seed)
    iv = {k: [] for k in KINDS}
    for (s, n), c in sc.cells.items():
        iv["cell_mse"].append((c.lo, c.hi, T.of(s).mse(n), c.resolved, f"{s} N={n}"))
        iv["cost"].append((c.seconds_lo, c.seconds_hi, T.of(s).seconds(n), True, f"{s} N={n}"))
    for s, f in sc.fits.items():
        iv["slope"].append((f.get("slope_lo", NAN), f.get("slope_hi", NAN), T.of(s).slope,
                            bool(f.get("ok") and f.get("resolved")), s))
    claims = []
    for r in finish_claims(sc.rows):
        sp = T.speedup(r.target_rmse)
        at = f"N={r.spp}"
        iv["mse_ratio"].append((r.mse_ratio_lo, r.mse_ratio_hi, T.mse_ratio(r.spp), r.resolved, at))
        iv["efficiency"].append((r.efficiency_lo, r.efficiency_hi, T.efficiency(r.spp), r.resolved, at))
        iv["speedup"].append((r.speedup_lo, r.speedup_hi, sp, r.speedup_resolved, at))
        on = sp if r.claim_on == "speedup" else T.efficiency(r.spp)
        claims.append({"spp": r.spp, "resolved": r.resolved, "on": r.claim_on,
                       "claim": _claim(r.claim, _sign(on)),
                       "mse": _claim(r.mse_claim, _sign(T.mse_ratio(r.spp)))})
    return {"setting": name, "index": index, "intervals": iv, "claims": claims,
            "control": naive_control(study), "load_shifted": load["shifted"],
            "noise_sd": study.noise_sd}


# ---------------------------------------------------------------------------------------------------
# Rates and tables
# ---------------------------------------------------------------------------------------------------

def rate(hits, totals, level: float = CI_LEVEL) -> dict:
    """Pooled rate sum(hits) / sum(totals) over studies (clusters) with a Wilson interval on the
    effective count (see the module docstring)."""
    h, n = np.asarray(hits, dtype=np.float64), np.asarray(totals, dtype=np.float64)
    k, N = int(np.sum(n > 0)), float(n.sum())
    if N == 0:
        return {"rate": NAN, "lo": NAN, "hi": NAN, "count": 0, "n_eff": 0.0}
    p = float(h.sum() / N)
    var = float(np.sum((h - p * n) ** 2)) / N ** 2 * k / max(k - 1, 1)
    n_eff = min(N, p * (1 - p) / var) if var > 0 and 0 < p < 1 else float(k)
    z = float(stats.norm.ppf(0.5 + level / 2))
    c = 1 + z * z / n_eff
    mid = (p + z * z / (2 * n_eff)) / c
    half = z / c * math.sqrt(p * (1 - p) / n_eff + z * z / (4 * n_eff ** 2))
    return {"rate": p, "lo": max(0.0, mid - half), "hi": min(1.0, mid + half), "count": int(N),
            "n_eff": round(n_eff, 1)}


def _kind_table(per_study: list, width_ratio: bool, level: float) -> dict:
    """Coverage, resolved fraction, coverage among resolved and mean width of one kind's intervals,
    and the coverage of each cell or row (`by`, for diagnosis); `per_study` is each study's list of
    (lo, hi, truth, resolved, label)."""
    cov, fin, res, cov_r, fin_r, widths, by = [], [], [], [], [], [], {}
    for ivs in per_study:
        a = np.asarray([iv[:4] for iv in ivs], dtype=np.float64).reshape(-1, 4)
        ok = np.isfinite(a[:, 0]) & np.isfinite(a[:, 1]) & np.isfinite(a[:, 2])
        hit = ok & (a[:, 0] <= a[:, 2]) & (a[:, 2] <= a[:, 1])
        r = a[:, 3] > 0
        cov.append(hit.sum()), fin.append(ok.sum()), res.append(r.sum())
        cov_r.append((hit & r).sum()), fin_r.append((ok & r).sum())
        if ok.any():
            widths += list(a[ok, 1] / a[ok, 0] if width_ratio else a[ok, 1] - a[ok, 0])
        for iv, h, o in zip(ivs, hit, ok):
            by.setdefault(iv[4], []).append((int(h), int(o)))
    total = sum(len(ivs) for ivs in per_study)
    return {"intervals": total, "missing": int(total - sum(fin)),
            "coverage": rate(cov, fin, level), "resolved": sum(res) / total if total else NAN,
            "coverage_resolved": rate(cov_r, fin_r, level),
            "mean_width": float(np.mean(widths)) if widths else NAN,
            "width": "hi/lo" if width_ratio else "hi-lo",
            "by": {k: rate(*zip(*v), level=level) for k, v in by.items()}}


def _claim_table(claims: list, equal: bool, level: float) -> dict:
    """`claims`: per study, its rows' claims (dicts of `claim` and `mse`, each claim and truth)."""
    any_claim, wrong, made, right, chances = [], [], [], [], []
    for rows in claims:
        said = [(row[k], row.get("resolved", True)) for row in rows for k in ("claim", "mse")]
        directed = [(DIRECTION[c["claim"]], c["truth"]) for c, _ in said if c["claim"] in DIRECTION]
        any_claim.append(int(bool(directed)))
        wrong.append(sum(d != t for d, t in directed))
        made.append(len(directed))
        right.append(sum(DIRECTION.get(c["claim"]) == c["truth"] for c, r in said if r and c["truth"]))
        chances.append(sum(1 for c, r in said if r and c["truth"]))
    out = {"studies": len(claims), "claims": int(sum(made)),
           "wrong_claims": rate(wrong, made, level), "power": rate(right, chances, level)}
    if equal:
        out["false_findings"] = rate(any_claim, [1] * len(claims), level)
    return out


def meets(r: dict, band=BAND) -> bool:
    """A rate whose interval meets the band (not shown to lie outside it)."""
    return r["count"] > 0 and r["lo"] <= band[1] and r["hi"] >= band[0]


def _criterion(name: str, ok: bool, detail: str, judged: bool = True) -> dict:
    return {"criterion": name, "pass": bool(ok), "judged": judged, "detail": detail}


def _false(claims: dict, equal: bool) -> tuple[str, dict]:
    return ("false findings", claims["false_findings"]) if equal else ("wrong claims", claims["wrong_claims"])


def _fmt(r: dict) -> str:
    return "-" if not r["count"] else f"{r['rate']:.3f} [{r['lo']:.3f}, {r['hi']:.3f}]"


def judge(setting: Setting, table: dict) -> list[dict]:
    """The pass criteria of one setting's tables (see the module docstring)."""
    out = []
    for kind, (_, has_flag, _) in KINDS.items():
        t = table["kinds"][kind]
        if setting.heavy and has_flag:
            few = t["resolved"] < UNRESOLVED_ENOUGH
            ok = few or not t["coverage_resolved"]["count"] or meets(t["coverage_resolved"])
            out.append(_criterion(kind, ok, f"resolved {t['resolved']:.3f}; among resolved "
                                            f"{_fmt(t['coverage_resolved'])}"))
        else:
            out.append(_criterion(kind, meets(t["coverage"]), _fmt(t["coverage"])))
    what, r = _false(table["claims"], setting.equal)
    out.append(_criterion(what, not r["count"] or r["lo"] <= MAX_FALSE, _fmt(r)))
    load = table["load_shifted"]
    out.append(_criterion("load step detected", load["hi"] >= DETECT_MIN, _fmt(load)) if setting.load_step
               else _criterion("no false load step", load["lo"] <= MAX_FALSE, _fmt(load)))
    c = table["control"]
    what, r = _false(c["claims"], setting.equal)
    fails = [k for k in CONTROL_KINDS if not meets(c["kinds"][k]["coverage"])]
    fails += [what] if r["count"] and r["lo"] > MAX_FALSE else []
    expected = setting.equal
    out.append(_criterion("control fails", bool(fails) or not expected,
                          f"fails on {', '.join(fails) or 'nothing'}", judged=expected))
    return out


def tabulate(setting: Setting, records: list, level: float = CI_LEVEL) -> dict:
    """Tables and criteria of one setting from its studies' `audit_study` records."""
    kinds = {k: _kind_table([r["intervals"][k] for r in records], KINDS[k][2], level) for k in KINDS}
    control = {k: _kind_table([r["control"]["intervals"][k] for r in records], True, level)
               for k in CONTROL_KINDS}
    table = {"description": setting.description, "studies": len(records), "kinds": kinds,
             "claims": _claim_table([r["claims"] for r in records], setting.equal, level),
             "load_shifted": rate([r["load_shifted"] for r in records], [1] * len(records), level),
             "control": {"kinds": control, "claims": _claim_table([r["control"]["claims"] for r in records],
                                                                  setting.equal, level)}}
    table["criteria"] = judge(setting, table)
    table["pass"] = all(c["pass"] for c in table["criteria"] if c["judged"])
    return table


def run_audit(settings: list[str], studies: int, seed: int = 0, jobs: int | None = None,
              level: float = CI_LEVEL) -> dict:
    """Every setting's tables from `studies` simulated studies each (processes: `parallel.pmap`)."""
    from drtlab.experiments.parallel import pmap
    calls = [(audit_study, (name, i, seed), {}) for name in settings for i in range(studies)]
    records = pmap(calls, jobs)
    tables = {name: tabulate(SETTINGS[name], [r for r in records if r["setting"] == name], level)
              for name in settings}
    return {"studies": studies, "seed": seed, "level": level, "band": list(BAND),
            "settings": tables, "pass": all(t["pass"] for t in tables.values())}


# ---------------------------------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------------------------------

def _verdict(table: dict, name: str) -> str:
    c = next(c for c in table["criteria"] if c["criterion"] == name)
    return ("pass" if c["pass"] else "FAIL") if c["judged"] else "(not judged)"


def markdown(result: dict) -> list[str]:
    """The report's tables: one per interval kind, then claims and load, then the control."""
    S = result["settings"]
    lines = [f"# Interval audit: {result['studies']} studies per setting, seed {result['seed']}", "",
             f"Coverage band {result['band'][0]:g}-{result['band'][1]:g}; rates with a "
             f"{result['level']:.0%} Wilson interval on the effective count.", "",
             "| setting | description |", "|---|---|"]
    lines += [f"| {n} | {t['description']} |" for n, t in S.items()]
    for kind, (title, _, _) in KINDS.items():
        w = next(iter(S.values()))["kinds"][kind]["width"]
        lines += ["", f"## {title}", "",
                  f"| setting | coverage | resolved | coverage among resolved | mean {w} | intervals "
                  f"(missing) | pass |", "|---|---|---|---|---|---|---|"]
        for n, t in S.items():
            k = t["kinds"][kind]
            lines.append(f"| {n} | {_fmt(k['coverage'])} | {k['resolved']:.3f} | "
                         f"{_fmt(k['coverage_resolved'])} | {k['mean_width']:.4g} | {k['intervals']} "
                         f"({k['missing']}) | {_verdict(t, kind)} |")
    lines += ["", "## Claims and load", "",
              "| setting | claims | false findings (studies) | wrong claims | power | load step "
              "flagged | pass |", "|---|---|---|---|---|---|---|"]
    for n, t in S.items():
        c = t["claims"]
        ff = _fmt(c["false_findings"]) if "false_findings" in c else "-"
        crit = [x for x in t["criteria"] if x["criterion"] in ("false findings", "wrong claims",
                                                                "load step detected", "no false load step")]
        lines.append(f"| {n} | {c['claims']} | {ff} | {_fmt(c['wrong_claims'])} | {_fmt(c['power'])} | "
                     f"{_fmt(t['load_shifted'])} | {'pass' if all(x['pass'] for x in crit) else 'FAIL'} |")
    lines += ["", "## Negative control (today's method: normal delta-method ratios, faster-half "
                  "costs, uncorrected claims)", "",
              "| setting | MSE ratio coverage | cost coverage | efficiency coverage | false findings "
              "| wrong claims | expected to fail | result |", "|---|---|---|---|---|---|---|---|"]
    for n, t in S.items():
        c, crit = t["control"], next(x for x in t["criteria"] if x["criterion"] == "control fails")
        ff = _fmt(c["claims"]["false_findings"]) if "false_findings" in c["claims"] else "-"
        lines.append(f"| {n} | {' | '.join(_fmt(c['kinds'][k]['coverage']) for k in CONTROL_KINDS)} | "
                     f"{ff} | {_fmt(c['claims']['wrong_claims'])} | {'yes' if crit['judged'] else 'no'} | "
                     f"{crit['detail']}{'' if crit['pass'] else ' (FAIL: the audit cannot tell)'} |")
    lines += ["", "## Verdict", ""]
    for n, t in S.items():
        bad = [c["criterion"] for c in t["criteria"] if c["judged"] and not c["pass"]]
        lines.append(f"- {n}: {'pass' if t['pass'] else 'FAIL (' + ', '.join(bad) + ')'}")
    lines.append(f"\n**{'PASS' if result['pass'] else 'FAIL'}**")
    return lines


AUDIT_FILES = ("intervals.json", "intervals.md")


def write_audit(result: dict, out: Path, extra: list[str] = ()) -> list[str]:
    """intervals.json and intervals.md in `out` (each written whole or not at all), the Markdown
    with `extra` lines at its end; returns the Markdown lines."""
    from drtlab.experiments.files import atomic_write_json, atomic_write_text
    out.mkdir(parents=True, exist_ok=True)
    lines = markdown(result) + list(extra)
    json_file, md_file = AUDIT_FILES
    atomic_write_json(out / json_file, result)
    atomic_write_text(out / md_file, "\n".join(lines) + "\n")
    return lines
