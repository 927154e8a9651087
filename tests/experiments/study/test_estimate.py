"""The up-front cost of a study (experiments/study/estimate.py): said before anything is written,
refused past its limits unless the caller says yes (the refusal alone, no plan before it), and its
numbers follow from the plan."""
import pytest

from drtlab.errors import InputError
from drtlab.experiments.study import estimate as E

from test_runner import tiny_experiment

HUGE = """
[experiment]
description = "a study that would render for days"
seed = 1
spp = [1, 65536]
repetitions = 4096
resolution = [640, 480]
gt_spp = 4096
gt_batch_spp = 512

[[study]]
name = "huge"
scenes = ["aa-edges"]
samplers = ["uniform", "stratified"]
"""


def test_a_study_past_the_time_limit_is_refused_before_anything_is_written(tmp_path, capsys):
    from drtlab.cli import main
    (tmp_path / "huge.toml").write_text(HUGE)
    out, gt = tmp_path / "out", tmp_path / "gt"
    rc = main(["experiment", str(tmp_path / "huge.toml"), "--out", str(out), "--gt-dir", str(gt)])
    err = capsys.readouterr().err.splitlines()
    assert rc == 2
    # One line: the refusal says the estimate; the plan and the estimate are not printed first.
    assert len(err) == 1, err
    assert err[0].startswith("drtlab: --yes: this study would render for about ") and "h" in err[0]
    assert not out.exists() and not (gt.exists() and any(gt.iterdir()))


def test_the_limits_and_yes():
    have = E.machine_memory_mib()
    over_time = E.Estimate(E.MAX_HOURS * 3600 * 1.01, 0.0, 10**12, 900.0)
    with pytest.raises(InputError, match="limit 24 h"):
        E.check_budget(over_time, yes=False)
    E.check_budget(over_time, yes=True)
    E.check_budget(E.Estimate(E.MAX_HOURS * 3600 * 0.99, 0.0, 10**12, 900.0), yes=False)
    if have is not None:
        with pytest.raises(InputError, match="of memory"):
            E.check_budget(E.Estimate(1.0, 0.0, 1, have), yes=False)
        E.check_budget(E.Estimate(1.0, 0.0, 1, have), yes=True)


def test_the_estimate_follows_from_the_plan(tmp_path):
    """Samples: every planned run's plus the references'; time: those over the probed speed;
    memory: the base plus the largest batch's and reference's float64 images."""
    from dataclasses import replace
    from drtlab.experiments.study.plan import gt_requirements, plan_runs
    from fakes import fake_backend
    exp = tiny_experiment(tmp_path)
    backend, _ = fake_backend()
    backend = replace(backend, speed=lambda scene, sampler, integrator, res, threads=None: 1e6)
    plan = plan_runs(exp, backend)
    gt_req = gt_requirements(exp, plan)
    pending = {g: 1000 for g in gt_req}
    e = E.estimate(plan, gt_req, pending, backend)
    runs = sum(r.spp * r.resolution[0] * r.resolution[1] for r in plan)
    assert e.samples == runs + 1000 * len(gt_req)
    assert e.seconds == pytest.approx(e.samples / 1e6) and e.reference_seconds == pytest.approx(
        1000 * len(gt_req) / 1e6)
    assert E.BASE_MIB < e.memory_mib < E.BASE_MIB + 1          # 16 x 12 images: next to nothing
    assert E.estimate(plan, gt_req, pending, replace(backend, speed=None)).seconds is None
    assert "time unknown" in E.estimate(plan, gt_req, pending, replace(backend, speed=None)).line()


def test_a_resumed_sweep_estimates_only_what_is_left(tmp_path):
    logs = []
    exp = tiny_experiment(tmp_path)
    from dataclasses import replace
    from fakes import fake_backend
    from drtlab.experiments.study.runner import run_experiment
    backend, _ = fake_backend()
    backend = replace(backend, speed=lambda *a, **k: 1e6)
    kw = dict(out_dir=tmp_path / "out", gt_root=tmp_path / "gt", backend=backend, progress=False,
              log=logs.append, analyze=False)
    run_experiment(exp, **kw)
    assert any(line.startswith("estimate: about") for line in logs)
    logs.clear()
    run_experiment(exp, **kw)                  # everything stored: nothing to estimate or probe
    assert not any(line.startswith("estimate:") for line in logs)


def test_without_a_bar_the_sweep_logs_a_line_every_ten_seconds():
    from drtlab.experiments.study.progress import LINE_SECONDS, Progress
    now, lines = [0.0], []
    p = Progress(1000, 10, enabled=False, log=lines.append, clock=lambda: now[0])
    for k in range(10):                        # a run of 100 samples every 3 s
        now[0] += 3.0
        p.update(100, runs_done=1)
    assert LINE_SECONDS == 10.0 and len(lines) == 2    # at 12 s and 24 s: each 10 s or more after the last
    assert lines[0] == "sweep: 4/10 runs, 40% of the samples, 0.00 M samples/s, about 18 s left"
    quiet = []
    Progress(1000, 10, enabled=True, log=quiet.append, clock=lambda: now[0]).close()
    assert quiet == []                         # a bar for a person watching: no lines
