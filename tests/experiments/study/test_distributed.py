"""Sweeps on a Dask cluster (`experiments/study/cluster.py`): a two-worker LocalCluster gives the same
table of runs, cell files and ground truth as the in-process sweep (apart from timings and the
worker column), a partial distributed sweep resumes without redoing or duplicating runs, and bad
--scheduler / --workers input is one line and exit 2. One cluster serves the whole module: starting
one costs seconds."""
import contextlib
import csv
import os

import numpy as np
import pytest

pytest.importorskip("distributed")

from cli_util import assert_one_line_error, run_bad            # noqa: E402
from drtlab.cli import main                                     # noqa: E402
from drtlab.experiments.study import cluster as dist  # noqa: E402
from drtlab.experiments.study.backend import default_backend          # noqa: E402
from drtlab.experiments.study.config import load_experiment           # noqa: E402
from drtlab.experiments.study.runner import run_experiment            # noqa: E402
from fakes import tiny_real_experiment                          # noqa: E402
from drtlab.experiments.study.run_store import TIMING_COLUMNS, load_cell, load_records  # noqa: E402

# Two groups (two ground truths), 16 runs, 8 ground-truth batches: tiny but every path.
TINY = tiny_real_experiment("distributed sweep, tiny", ["soft-shadows", "aa-edges"])
N_RUNS = 16
TIMING = set(TIMING_COLUMNS)


@pytest.fixture(scope="module")
def cluster():
    with dist.DaskExecutor.local(2) as ex:
        yield ex


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    d = tmp_path_factory.mktemp("tiny")
    (d / "tiny.toml").write_text(TINY)
    return load_experiment(str(d / "tiny.toml"))


@pytest.fixture(scope="module")
def reference(tiny, tmp_path_factory):
    """The in-process sweep (two threads per render; the workers use one)."""
    d = tmp_path_factory.mktemp("ref")
    sweep(tiny, d / "out", d / "gt", threads=2)
    return d


def sweep(exp, out, gt, **kw):
    return run_experiment(exp, out_dir=out, gt_root=gt, backend=default_backend(), progress=False,
                          log=lambda m: None, analyze=False, **kw)


def rows(path):
    return list(csv.DictReader(open(path)))


def without_timing(table):
    return [{k: v for k, v in r.items() if k not in TIMING} for r in table]


def test_local_cluster_matches_the_in_process_sweep(tiny, reference, cluster, tmp_path):
    assert len(cluster.workers()) == 2
    # Workers share this checkout's kernel cache (else each recompiles every variant).
    assert set(cluster.client.run(os.getenv, "WARP_CACHE_PATH").values()) == {os.environ["WARP_CACHE_PATH"]}
    s = sweep(tiny, tmp_path / "out", tmp_path / "gt", executor=cluster)
    assert s.stats["runs_new"] == N_RUNS and cluster.submitted >= s.stats["batches"] + 8
    ref, got = rows(reference / "out" / "runs.csv"), rows(tmp_path / "out" / "runs.csv")
    assert len(got) == N_RUNS and without_timing(got) == without_timing(ref)
    assert {r["worker"] for r in ref} == {"local"}
    assert {r["worker"] for r in got} == set(cluster.workers())          # both workers took runs
    assert sum(s.stats["workers"].values()) == N_RUNS
    for cell in {rec["cell"] for rec in load_records(reference / "out").values()}:
        a, b = load_cell(reference / "out", cell), load_cell(tmp_path / "out", cell)
        # Batches finish in any order on a cluster; they are merged in order: bit-identical files.
        assert a.batches == b.batches and a.moments.n == b.moments.n
        assert np.array_equal(a.moments.mean, b.moments.mean) and a.moments.m2 == b.moments.m2
        assert np.array_equal(a.first, b.first)
    for d in (reference / "gt").iterdir():                               # and ground truths
        with np.load(d / "gt.npz") as a, np.load(tmp_path / "gt" / d.name / "gt.npz") as b:
            assert all(np.array_equal(a[k], b[k]) for k in ("mean", "m2", "seeds", "batches"))


class StopAfter:
    """The cluster executor, but the sweep is interrupted after `k` finished batches (as Ctrl-C or
    a killed client would stop it)."""

    def __init__(self, ex, k):
        self.ex, self.k = ex, k

    def ground_truth_backend(self, *a):
        return self.ex.ground_truth_backend(*a)

    def render_batches(self, *a):
        with contextlib.closing(self.ex.render_batches(*a)) as it:  # cancels what is in flight
            for item in it:
                if self.k == 0:
                    raise KeyboardInterrupt("stop")
                self.k -= 1
                yield item


def test_partial_distributed_sweep_resumes_with_only_the_missing_runs(tiny, reference, cluster,
                                                                      tmp_path):
    out, gt = tmp_path / "out", reference / "gt"          # the reference's ground truth: reused
    with pytest.raises(KeyboardInterrupt):
        sweep(tiny, out, gt, executor=StopAfter(cluster, 5))
    done = len(load_records(out))
    assert 0 < done < N_RUNS
    before = cluster.submitted
    s = sweep(tiny, out, gt, executor=cluster)
    assert s.stats["runs_new"] == N_RUNS - done and s.stats["runs_reused"] == done
    assert cluster.submitted - before == s.stats["batches"]   # no ground-truth batch, no done run
    assert without_timing(rows(out / "runs.csv")) == without_timing(rows(reference / "out" / "runs.csv"))

    # Lost cell files (a disk cleanup, a copy gone wrong): their runs render again, nothing else.
    cells = sorted((out / "cells").glob("*.npz"))
    lost = cells[::3]
    for f in lost:
        f.unlink()
    lost_runs = sum(1 for rec in load_records(reference / "out").values()
                    if f"{rec['cell']}.npz" in {f.name for f in lost})
    s = sweep(tiny, out, gt, executor=cluster)
    assert s.stats["runs_new"] == lost_runs and s.stats["runs_reused"] == N_RUNS - lost_runs
    got = rows(out / "runs.csv")
    assert len({r["run_id"] for r in got}) == len(got) == N_RUNS
    assert without_timing(got) == without_timing(rows(reference / "out" / "runs.csv"))


# ---------------------------------------------------------------------------------------------------
# The CLI flags
# ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("flags, field", [
    (["--workers", "0"], "--workers"),
    (["--workers", "two"], "--workers"),
    (["--scheduler", "localhost"], "--scheduler"),
    (["--scheduler", "tcp://host:70000"], "--scheduler"),
    (["--scheduler", "http://host:8786"], "--scheduler"),
    (["--scheduler", "127.0.0.1:8786", "--workers", "2"], "--workers"),
])
def test_bad_cluster_flags_are_one_line(flags, field, tmp_path, capsys):
    run_bad(["experiment", "uniform", "--out", str(tmp_path / "sweep")] + flags, field, tmp_path,
            capsys)


def test_unreachable_scheduler_fails_fast(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(dist, "CONNECT_TIMEOUT", 1.0)
    run_bad(["experiment", "uniform", "--out", str(tmp_path / "sweep"), "--scheduler",
             "127.0.0.1:1"], "--scheduler", tmp_path, capsys)


def test_scheduler_without_workers_is_refused(tmp_path, capsys, monkeypatch):
    from distributed import LocalCluster
    monkeypatch.setattr(dist, "CONNECT_TIMEOUT", 1.0)
    with LocalCluster(n_workers=0, processes=False, protocol="tcp", dashboard_address=":0") as empty:
        rc = main(["experiment", "uniform", "--out", str(tmp_path / "sweep"), "--scheduler",
                   empty.scheduler_address])
    err = capsys.readouterr().err
    assert rc == 2 and not (tmp_path / "sweep").exists()
    assert_one_line_error(err, "--scheduler")
    assert "no workers" in err


def test_cli_passes_the_cluster_to_the_runner(cluster, tmp_path, monkeypatch, capsys):
    """--scheduler reaches the running cluster; --workers N starts N workers; neither: in-process."""
    import drtlab.experiments.study.runner as runner
    from drtlab.experiments.study.experiment_result import ExperimentResult
    seen = []

    def fake_run(exp, executor=None, out_dir=None, **kw):
        seen.append(executor if executor is None else sorted(executor.workers()))
        return ExperimentResult(stats={}, wall_seconds=0.0, out_dir=out_dir)

    monkeypatch.setattr(runner, "run_experiment", fake_run)
    address = cluster.client.scheduler.address
    started = []

    class FakeLocal:
        def workers(self):
            return ["w"] * started[-1]

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            pass

    def fake_local(n):
        started.append(n)
        return FakeLocal()

    monkeypatch.setattr(dist.DaskExecutor, "local", staticmethod(fake_local))
    base = ["experiment", "uniform", "--out", str(tmp_path / "o"), "--gt-dir", str(tmp_path / "g")]
    assert main(base + ["--scheduler", address.removeprefix("tcp://")]) == 0
    assert main(base + ["--workers", "3"]) == 0
    assert main(base) == 0
    assert seen == [cluster.workers(), ["w"] * 3, None] and started == [3]
    capsys.readouterr()


def test_a_plugin_point_set_renders_alike_on_the_workers(cluster, tmp_path, clean_registry):
    # The study's file names its plugin (the example R2 set); the workers have never imported it:
    # each task carries it (estimators.plugins.shipped) and the tables agree with an in-process sweep.
    from repo_paths import REPO
    plugin = REPO / "examples" / "plugins" / "r2.py"
    text = tiny_real_experiment("plugin on a cluster", ["aa-edges"]).replace(
        'samplers = ["uniform", "stratified"]', 'samplers = ["uniform", "r2"]').replace(
        "seed = 5\n", f'seed = 5\nplugins = ["{plugin}"]\n')
    (tmp_path / "p.toml").write_text(text)
    exp = load_experiment(str(tmp_path / "p.toml"))
    sweep(exp, tmp_path / "local", tmp_path / "gt1", threads=2)
    s = sweep(exp, tmp_path / "dist", tmp_path / "gt2", executor=cluster)
    ref, got = rows(tmp_path / "local" / "runs.csv"), rows(tmp_path / "dist" / "runs.csv")
    assert s.stats["runs_new"] == 8 and {r["sampler"] for r in got} == {"uniform", "r2+uniform"}
    assert without_timing(got) == without_timing(ref)
