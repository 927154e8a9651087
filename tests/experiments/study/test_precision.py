"""Precision-targeted cells: with `target_rel_ci` the runner doubles a cell's repetitions until the
95% interval of its mean MSE is within the target or its `max_samples_per_cell` budget is spent;
`result.cells` says which cells met it and what the rest would need. Deterministic (the decisions
read only committed values), so a rerun renders nothing and a resumed sweep ends with the same
table. Negative control: a target no budget can meet reports target_met = False and the samples it
would need, beyond the budget."""
import math
import textwrap

import pytest

from drtlab.errors import InputError
from drtlab.experiments.study.config import load_experiment
from drtlab.experiments.study.run_store import TIMING_COLUMNS, load_records
from drtlab.experiments.study.runner import run_experiment
from fakes import fake_backend

TEXT = textwrap.dedent("""
    [experiment]
    description = "precision targets on the fake renderer"
    seed = 9
    spp = [1, 4, 16]
    repetitions = 2
    resolution = [16, 12]
    gt_spp = 4096
    gt_batch_spp = 1024
    target_rel_ci = TARGET
    max_samples_per_cell = BUDGET

    [[study]]
    name = "p"
    scenes = ["aa-edges"]
    samplers = ["uniform", "stratified"]
""")


def experiment(tmp_path, target, budget):
    p = tmp_path / "p.toml"
    p.write_text(TEXT.replace("TARGET", str(target)).replace("BUDGET", str(budget)))
    _, fake = fake_backend()
    return load_experiment(str(p), scene_loader=fake.load_scene)


def sweep(exp, out, gt, **fake_kw):
    backend, fake = fake_backend(**fake_kw)
    result = run_experiment(exp, out_dir=out, gt_root=gt, backend=backend, progress=False,
                            log=lambda m: None)
    return result, fake


def test_cells_grow_until_their_target_is_met(tmp_path):
    # The fake's per-run MSE over 16 x 12 x 3 values has a coefficient of variation of about
    # sqrt(2 / 576) = 6%: two runs give a 95% half-width of 12.7 x 6% / sqrt(2) ~ 50%, so every cell
    # must grow; the doubling 2 -> 4 -> 8 ... stops at the first count whose interval is within 10%.
    exp = experiment(tmp_path, 0.1, 4096)
    result, fake = sweep(exp, tmp_path / "out", tmp_path / "gt")
    cells = result.cells
    assert len(cells) == 6 and cells["target_met"].all()
    assert (cells["mse_rel_ci"] <= 0.1).all()
    for n in cells["repetitions"]:
        assert n > 2 and math.log2(n).is_integer()             # doubled from the planned 2
    assert result.stats["runs_added_for_precision"] == int(cells["repetitions"].sum()) - 12
    # the table holds every repetition, once
    recs = load_records(tmp_path / "out")
    assert len(recs) == int(cells["repetitions"].sum()) == len(result.runs)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "Precision target" in report and "6 of 6 cells" in report

    # A rerun renders nothing and keeps the table; so does a sweep resumed after an interruption.
    before = (tmp_path / "out" / "runs.csv").read_bytes()
    again, fake2 = sweep(exp, tmp_path / "out", tmp_path / "gt")
    assert fake2.calls == 0 and (tmp_path / "out" / "runs.csv").read_bytes() == before
    with pytest.raises(KeyboardInterrupt):
        sweep(exp, tmp_path / "cut", tmp_path / "gt", fail_after=25)
    sweep(exp, tmp_path / "cut", tmp_path / "gt")
    assert without_timing(tmp_path / "cut") == without_timing(tmp_path / "out")


def without_timing(out) -> list:
    import csv
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS}
            for r in csv.DictReader(open(out / "runs.csv"))]


def test_negative_control_an_unreachable_target_reports_what_it_would_need(tmp_path):
    # 0.1% on a 6% coefficient of variation needs ~ (1.96 x 6 / 0.1)^2 ~ 14,000 runs; the budget
    # of 64 samples per pixel allows 64 runs at 1 spp and 4 at 16 spp.
    exp = experiment(tmp_path, 0.001, 64)
    result, _ = sweep(exp, tmp_path / "out", tmp_path / "gt")
    cells = result.cells
    assert not cells["target_met"].any()
    assert (cells["mse_rel_ci"] > 0.001).all()
    for _, c in cells.iterrows():
        assert c["repetitions"] == max(64 // c["spp"], 2)       # the budget, spent
        assert c["samples_needed"] > 64 * 100                   # far beyond it
    report = (tmp_path / "out" / "report.md").read_text()
    assert "0 of 6 cells" in report


@pytest.mark.parametrize("key, value", [("target_rel_ci", "0"), ("target_rel_ci", "1.5"),
                                        ("target_rel_ci", "true"), ("max_samples_per_cell", "1"),
                                        ("max_seconds", "0"), ("max_seconds", "-3"), ("max_seconds", "1e9"),
                                        ("max_seconds", '"20"'),
                                        ("keep_images", "1"), ("colour_difference_runs", "1"),
                                        ("colour_difference_runs", "2.5"), ("flip_runs", "-1"),
                                        ("flip_runs", "1.5")])
def test_bad_precision_settings_are_named(tmp_path, key, value):
    p = tmp_path / "bad.toml"
    p.write_text(_with(TEXT.replace("TARGET", "0.1").replace("BUDGET", "64"), key, value))
    _, fake = fake_backend()
    with pytest.raises(InputError) as e:
        load_experiment(str(p), scene_loader=fake.load_scene)
    assert e.value.field == f"experiment.{key}"


def _with(text: str, key: str, value: str) -> str:
    """The experiment text with `key = value` in [experiment] (replacing the key if present)."""
    lines = [ln for ln in text.splitlines() if not ln.startswith(f"{key} =")]
    i = lines.index("[experiment]")
    return "\n".join(lines[:i + 1] + [f"{key} = {value}"] + lines[i + 1:]) + "\n"


def test_a_seconds_budget_grows_the_cells_that_are_not_resolved(tmp_path):
    # Two runs are fewer than resolution.MIN_RUNS: with `max_seconds` each cell doubles to 4 runs
    # (then resolved: light Gaussian errors), without it, or with a budget below one doubling's
    # cost (the fake's runs cost ~1e-4 s), nothing grows. The comparisons then claim only where
    # both cells are resolved.
    text = "\n".join(ln for ln in TEXT.splitlines() if not ln.startswith(("target_rel_ci", "max_samples")))
    runs = {}
    for budget in (None, 1e-7, 10):
        p = tmp_path / f"b{budget}.toml"
        p.write_text(text if budget is None else _with(text, "max_seconds", str(budget)))
        _, fake = fake_backend()
        exp = load_experiment(str(p), scene_loader=fake.load_scene)
        result, _ = sweep(exp, tmp_path / f"out{budget}", tmp_path / "gt")
        runs[budget] = sorted(set(result.cells["repetitions"]))
        claims = dict(zip(result.comparisons["spp"], result.comparisons["claim"]))
        # the fake's stratified set converges as N^-0.75 against N^-0.5: equal at N = 1
        want = {1: "no difference", 4: "better", 16: "better"} if budget == 10 else \
            dict.fromkeys((1, 4, 16), "not resolved")
        assert claims == want, (budget, claims)
        assert result.stats["runs_added_for_resolution"] == (6 * 2 if budget == 10 else 0)
    assert runs == {None: [2], 1e-7: [2], 10: [4]}
