"""A sweep stopped by any catchable signal (SIGTERM, SIGHUP, SIGINT) at random points keeps every
batch its progress reported finished, ends by that signal, and a resume renders only what is
missing: its tables equal an uninterrupted run's."""
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

from drtlab.experiments.study.run_store import TIMING_COLUMNS, load_records
from repo_paths import SUPPORT
from test_runner import TINY, run, tiny_experiment

SWEEP = TINY.replace("repetitions = 3", "repetitions = 6")        # 96 runs in 16 batches

# The sweep in a process of its own, on the fake renderer slowed down; after each batch's commit
# (the progress bar's update is its last step) it prints the batch's run ids.
SCRIPT = textwrap.dedent("""
    import sys, time
    sys.path.insert(0, sys.argv[4])
    from drtlab.experiments.study import runner
    from drtlab.experiments.study.config import load_experiment
    from fakes import fake_backend
    backend, fake = fake_backend()
    slow = fake.render
    def render(*a, **k):
        time.sleep(0.03)
        return slow(*a, **k)
    backend.render = render
    commit = runner._Sweep._commit
    def reported(self, b, *a, **k):
        commit(self, b, *a, **k)
        print(" ".join(r.run_id for r in b.runs), flush=True)
    runner._Sweep._commit = reported
    class Clock:
        t = 0.0
        def __call__(self):
            self.t += 0.5
            return self.t
    exp = load_experiment(sys.argv[1], scene_loader=fake.load_scene)
    runner.run_experiment(exp, out_dir=sys.argv[2], gt_root=sys.argv[3], backend=backend,
                          progress=False, clock=Clock(), log=lambda m: None, analyze=False)
""")


def test_a_signal_at_random_points_of_a_sweep_keeps_every_finished_batch(tmp_path):
    exp_path = tmp_path / "sweep.toml"
    exp_path.write_text(SWEEP)
    exp = tiny_experiment(tmp_path, SWEEP)
    ref, gt, out = tmp_path / "ref", tmp_path / "gt", tmp_path / "out"
    run(exp, ref, gt)                              # the uninterrupted run, and the references
    script = tmp_path / "sweep.py"
    script.write_text(SCRIPT)
    rng = np.random.default_rng(42)
    batches_left = 16
    stopped = 0
    for signum in (signal.SIGTERM, signal.SIGTERM, signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
        if batches_left < 3 or len(load_records(out)) == 96:
            break
        wait_for = int(rng.integers(1, batches_left - 1))   # batches reported before the signal
        proc = subprocess.Popen([sys.executable, str(script), str(exp_path), str(out), str(gt), str(SUPPORT)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        reported = []
        while len(reported) < wait_for:
            line = proc.stdout.readline()
            if not line:                           # it finished first (the signal then changes nothing)
                break
            reported.append(line.split())
        proc.send_signal(signum)
        rest, err = proc.communicate(timeout=120)
        reported += [line.split() for line in rest.splitlines()]
        done = load_records(out)
        missing = [rid for batch in reported for rid in batch if rid not in done]
        assert not missing, (signal.Signals(signum).name, wait_for, len(missing))
        if proc.returncode == -signum:             # stopped mid-sweep: it ended by the signal
            stopped += 1
        else:
            assert proc.returncode == 0 and len(done) == 96, err
        batches_left -= len(reported)
    assert stopped >= 3
    _, fake = run(exp, out, gt)
    assert fake.calls == 96 - len(done)            # only what was missing renders again
    assert (out / "runs.csv").read_bytes() == (ref / "runs.csv").read_bytes()
    a, b = pd.read_parquet(out / "runs.parquet"), pd.read_parquet(ref / "runs.parquet")
    assert a.drop(columns=list(TIMING_COLUMNS)).equals(b.drop(columns=list(TIMING_COLUMNS)))


def test_a_commit_holds_a_signal_until_it_is_done():
    from drtlab.experiments.study.interrupts import Stopped, signals_held, stop_on_signals
    steps = []
    with pytest.raises(KeyboardInterrupt):
        with signals_held():
            signal.raise_signal(signal.SIGINT)
            steps.append("finished")
    assert steps == ["finished"]
    old = signal.getsignal(signal.SIGTERM)
    signal.signal(signal.SIGTERM, lambda *a: steps.append("user's handler"))
    try:
        with stop_on_signals():                    # a handler of the caller's own is left alone
            signal.raise_signal(signal.SIGTERM)
        assert steps[-1] == "user's handler"
    finally:
        signal.signal(signal.SIGTERM, old)
    assert issubclass(Stopped, KeyboardInterrupt)
