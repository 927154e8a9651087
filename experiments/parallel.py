"""A tiny process map for the analysis phase (slope fits, figures): the sweep is over by then, so the
cores are free. Uses fork where available (cheap: the parent's imports are inherited); serial when
DRTLAB_JOBS=1, on one core, or where fork is unavailable."""
from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import ProcessPoolExecutor


def jobs() -> int:
    env = os.environ.get("DRTLAB_JOBS")
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            pass
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:
        n = os.cpu_count() or 1
    return max(1, min(n, 8))


def _call(job):
    fn, args, kwargs = job
    return fn(*args, **kwargs)


def pmap(calls: list[tuple], n_jobs: int | None = None) -> list:
    """[(fn, args, kwargs), ...] -> [fn(*args, **kwargs), ...] in order."""
    n = min(n_jobs or jobs(), len(calls))
    if n <= 1 or "fork" not in mp.get_all_start_methods():
        return [_call(c) for c in calls]
    with ProcessPoolExecutor(max_workers=n, mp_context=mp.get_context("fork")) as ex:
        return list(ex.map(_call, calls, chunksize=1))
