"""The interval audit (experiments/audit/): its simulated studies have the truth they claim, its
judgement fails a bad method, and a fast run of the audit itself on two settings: every interval
the study report prints covers in light-tailed equal samplers, no false claims there or with
Pareto errors, and the method before it (normal delta-method ratios, uncorrected claims) is shown
to fail.

Statistics: every check of a rate is a Wilson interval (on the effective count, intervals of one
study being correlated) at level 1 - ALPHA / CHECKS, Bonferroni over the checks of the two audit
runs (9 criteria each), so a correct method fails this module with probability below ALPHA = 0.01
however the draws fall; a check that the control FAILS uses the same level, so its failure is
significant. The audit runs take about 2 CPU seconds per study (two emcee fits).
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from drtlab.cli_args import Parser, run_main
from drtlab.cli_audit import add_audit_command
from drtlab.experiments.audit import coverage as cov
from drtlab.experiments.audit import simulate as sim

ALPHA = 0.01
CHECKS = 18
LEVEL = 1 - ALPHA / CHECKS
Z = 3.5          # mean-of-law checks: |mean - 1| below Z standard errors (Bonferroni over 4 laws)


def _run(argv: list[str]) -> int:
    def build():
        p = Parser(prog="drtlab")
        add_audit_command(p.add_subparsers(dest="command", required=True, parser_class=Parser))
        return p
    return run_main(build, ["audit-intervals", *argv])


# ---------------------------------------------------------------------------------------------------
# The simulation
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("law", list(sim.LAWS))
def test_every_law_has_mean_one(law):
    x = sim.LAWS[law][0](np.random.default_rng(1), 400_000)
    se = x.std() / math.sqrt(x.size)
    assert abs(x.mean() - 1) < Z * se, (law, x.mean(), se)


def test_a_study_is_cut_and_interleaved_as_the_runner_does():
    study = sim.simulate_study(sim.SETTINGS["load-step-equal"], np.random.default_rng(3))
    runs, b = study.runs, study.batches
    for s in (sim.BASELINE, sim.OTHER):
        for n, k in sim.RUNS.items():
            assert sum(1 for x, m in zip(runs["sampler"], runs["spp"]) if (x, m) == (s, n)) == k
            assert sum(r for x, m, r in zip(b["sampler"], b["spp"], b["reps"]) if (x, m) == (s, n)) == k
    cells = len(sim.RUNS) * 2
    first = list(zip(b["sampler"], b["spp"]))[:cells]          # the first turn: every cell once
    assert first == [(s, n) for s in (sim.BASELINE, sim.OTHER) for n in sim.LADDER]
    assert b["time"] == list(range(1, len(b["time"]) + 1))
    # Seconds over the true batch cost: the noise (mean 1) and, after the middle, the load step.
    T = study.truth
    ratio = np.array([sec / (sim.CALL + r * T.of(s).seconds(n))
                      for s, n, sec, r in zip(b["sampler"], b["spp"], b["seconds"], b["reps"])])
    late = np.array(b["time"]) > study.step_after
    assert study.step_after == len(ratio) // 2
    assert np.median(ratio[late]) / np.median(ratio[~late]) == pytest.approx(sim.LOAD_STEP, rel=0.1)


def test_truth_of_the_ratios():
    T = sim.truth_of(sim.SETTINGS["light-s1"])
    n = 16
    assert T.mse_ratio(n) == pytest.approx(n)                 # slopes -0.5 and -1, same A: N^1
    assert T.efficiency(n) == pytest.approx(n * T.base.seconds(n) / T.other.seconds(n))
    # At the baseline's RMSE at N the other sampler needs sqrt(N) samples.
    target = math.sqrt(T.base.mse(n))
    assert T.speedup(target) == pytest.approx(T.base.seconds(n) / T.other.seconds(math.sqrt(n)))
    equal = sim.truth_of(sim.SETTINGS["light-equal"])
    assert equal.speedup(0.03) == pytest.approx(1.0) and equal.efficiency(4) == pytest.approx(1.0)
    assert math.isnan(T.speedup(float("nan")))


def test_noise_has_mean_one_so_the_true_cost_is_the_model_cost():
    rng = np.random.default_rng(5)
    r = []
    for _ in range(200):
        study = sim.simulate_study(sim.SETTINGS["light-equal"], rng)
        b, T = study.batches, study.truth
        r += [sec / (sim.CALL + k * T.of(s).work_seconds(n))
              for s, n, sec, k in zip(b["sampler"], b["spp"], b["seconds"], b["reps"])]
    r = np.array(r)
    assert abs(r.mean() - 1) < Z * r.std() / math.sqrt(r.size)


def test_load_shift_detects_the_step_and_stays_quiet_without_one():
    from drtlab.experiments.study.compare import level_load

    def shifted(name: str, k: int) -> list[bool]:
        rng = np.random.default_rng(11)
        out = []
        for _ in range(k):
            study = sim.simulate_study(sim.SETTINGS[name], rng)
            out.append(level_load([study.batches], [sim.PIXELS])[1]["shifted"])
        return out

    step, none = shifted("load-step-equal", 40), shifted("light-equal", 40)
    assert cov.rate(step, [1] * len(step), LEVEL)["hi"] >= cov.DETECT_MIN, np.mean(step)
    assert cov.rate(none, [1] * len(none), LEVEL)["lo"] <= cov.MAX_FALSE, np.mean(none)


# ---------------------------------------------------------------------------------------------------
# The judgement
# ---------------------------------------------------------------------------------------------------

def _intervals(rng, coverage: float, studies: int, per: int) -> list:
    """Fake intervals of a method covering with probability `coverage`, as (lo, hi, truth, resolved,
    label) per study."""
    out = []
    for _ in range(studies):
        hit = rng.random(per) < coverage
        out.append([(0.9, 1.1, 1.0 if h else 2.0, True, f"N={i}") for i, h in enumerate(hit)])
    return out


def test_rate_interval_covers_a_known_rate():
    rng = np.random.default_rng(2)
    p, inside = 0.9, 0
    for _ in range(400):
        hits = rng.random((30, 4)) < p
        r = cov.rate(hits.sum(axis=1), [4] * 30)
        inside += r["lo"] <= p <= r["hi"]
    # 95% Wilson intervals: 400 trials, a correct one covers in at least 0.9 of them (4 se below).
    assert inside / 400 > 0.9


def test_judgement_fails_an_undercovering_method_and_passes_a_calibrated_one():
    rng = np.random.default_rng(4)
    bad = cov._kind_table(_intervals(rng, 0.85, 300, 4), True, LEVEL)
    good = cov._kind_table(_intervals(rng, 0.95, 300, 4), True, LEVEL)
    assert not cov.meets(bad["coverage"]) and cov.meets(good["coverage"])
    assert set(good["by"]) == {"N=0", "N=1", "N=2", "N=3"}
    # Claims: 10% of equal-sampler studies with a false claim is a failure, 1% is not.
    for share, ok in ((0.10, False), (0.01, True)):
        said = rng.random(1000) < share
        claims = [[{"claim": cov._claim("better" if s else "no difference", 0),
                    "mse": cov._claim("no difference", 0)}] for s in said]
        r = cov._claim_table(claims, True, LEVEL)["false_findings"]
        assert (r["lo"] <= cov.MAX_FALSE) == ok, r


# ---------------------------------------------------------------------------------------------------
# The audit itself, fast
# ---------------------------------------------------------------------------------------------------

def _audit(setting: str, studies: int) -> dict:
    return cov.run_audit([setting], studies, seed=20240, jobs=1, level=LEVEL)["settings"][setting]


def _failed(table: dict) -> list[str]:
    return [f"{c['criterion']}: {c['detail']}" for c in table["criteria"] if c["judged"] and not c["pass"]]


def test_audit_light_tailed_equal_samplers():
    """Every interval kind covers, no false claims, and today's uncorrected claims are caught."""
    t = _audit("light-equal", 20)
    assert t["pass"], _failed(t)
    for kind in cov.KINDS:
        assert t["kinds"][kind]["missing"] == 0, kind
    for kind in ("cell_mse", "mse_ratio", "efficiency"):             # light tails: claims are made
        assert t["kinds"][kind]["resolved"] >= 0.9, kind
    control = next(c for c in t["criteria"] if c["criterion"] == "control fails")
    assert control["judged"] and control["pass"], control


def test_audit_pareto_equal_samplers():
    """Heavy tails: the cells are not resolved so no claim is made, while today's method claims
    differences between equal samplers in many studies."""
    t = _audit("pareto-equal", 16)
    assert t["pass"], _failed(t)
    assert t["claims"]["claims"] == 0 or t["claims"]["false_findings"]["lo"] <= cov.MAX_FALSE
    assert t["kinds"]["mse_ratio"]["resolved"] < cov.UNRESOLVED_ENOUGH
    assert t["control"]["claims"]["false_findings"]["lo"] > cov.MAX_FALSE, t["control"]["claims"]


# ---------------------------------------------------------------------------------------------------
# The command
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, field", [
    (["--studies", "0"], "--studies"),
    (["--studies", "many"], "--studies"),
    (["--settings", "light-equal,nope"], "--settings"),
    (["--settings", "light-equal,light-equal"], "--settings"),
    (["--jobs", "0"], "--jobs"),
    (["--seed", "-1"], "--seed"),
    (["--bogus"], "--bogus"),
])
def test_bad_flags_are_one_line_and_exit_2(argv, field, capsys, tmp_path):
    assert _run([*argv, "--out", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"drtlab: {field}:"), err
    assert not (tmp_path / "a").exists()


def test_command_writes_the_tables_and_the_same_seed_gives_the_same_ones(tmp_path, capsys):
    tables = []
    for out in ("a", "b"):
        code = _run(["--no-renderer", "--studies", "1", "--settings", "light-s1", "--jobs", "1", "--seed", "7",
                     "--out", str(tmp_path / out)])
        assert code in (0, 1)
        printed = capsys.readouterr().out
        assert "## MSE ratio" in printed and "## Negative control" in printed
        data = json.loads((tmp_path / out / "intervals.json").read_text())
        assert (code == 0) == data["pass"]
        assert set(data["settings"]) == {"light-s1"}
        assert (tmp_path / out / "intervals.md").read_text().startswith("# Interval audit")
        tables.append(data)
    assert tables[0] == tables[1]
