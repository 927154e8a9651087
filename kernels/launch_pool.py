"""The process's thread pools for CPU launches: a Warp CPU launch runs on one thread and releases the
GIL, so launches on a pool's threads use every core. Kept for the process: starting threads for every
call costs milliseconds, which a low-spp study pays per batch (renders and their error sums alike)."""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

_lock = threading.Lock()
_pools: dict = {}


def launch_pool(threads: int) -> ThreadPoolExecutor:
    """The pool of `threads` workers (one per thread count, made on first use)."""
    with _lock:
        pool = _pools.get(threads)
        if pool is None:
            pool = _pools[threads] = ThreadPoolExecutor(max_workers=threads,
                                                        thread_name_prefix="drtlab-launch")
        return pool


def cpu_threads() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                       # no affinity call (macOS, Windows)
        return os.cpu_count() or 1


def _after_fork_in_child() -> None:
    # A forked child inherits the pools but not their worker threads (and maybe a held lock).
    global _lock
    _lock = threading.Lock()
    _pools.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork_in_child)
