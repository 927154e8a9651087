"""Signals during a sweep. SIGTERM and SIGHUP end a process at once by default, losing the batches
rendered since the last commit; during a sweep they raise `Stopped` (a KeyboardInterrupt, as Ctrl-C
does) in the main thread, so the sweep's `finally` commits every finished batch, and once that is
done the process ends by the same signal, as it would have. A commit (and the bookkeeping that
reports a batch finished) holds every catchable signal until it is done, so a second signal cannot
cut it short."""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

CATCHABLE = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n))
STOPPING = tuple(s for s in CATCHABLE if s != getattr(signal, "SIGINT", None))


class Stopped(KeyboardInterrupt):
    """A sweep stopped by a signal (`signum`) whose default would have ended the process."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


def _raise(signum, frame):
    raise Stopped(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextmanager
def stop_on_signals(log=None):
    """Inside: SIGTERM and SIGHUP, where their handler is the default, raise `Stopped`. Leaving by
    one, the handlers are restored and the signal raised again: the process ends by it."""
    if not _main_thread():                   # signal handlers belong to the main thread
        yield
        return
    old = {s: signal.getsignal(s) for s in STOPPING}
    installed = [s for s, h in old.items() if h == signal.SIG_DFL]
    for s in installed:
        signal.signal(s, _raise)
    try:
        yield
    except Stopped as e:
        for s in installed:
            signal.signal(s, old[s])
        if log is not None:
            log(f"stopped by {signal.Signals(e.signum).name}: every finished batch is saved; the same "
                "command resumes")
        signal.raise_signal(e.signum)
        raise
    finally:
        for s in installed:
            signal.signal(s, old[s])


@contextmanager
def signals_held():
    """Inside: every catchable signal with a Python-level handler waits; the first one that came is
    raised again on leaving (its own handler then runs: KeyboardInterrupt, `Stopped`, ...)."""
    if not _main_thread():
        yield
        return
    pending: list = []
    old = {s: signal.getsignal(s) for s in CATCHABLE}
    held = [s for s, h in old.items() if h is not None and h != signal.SIG_IGN]
    for s in held:
        signal.signal(s, lambda signum, frame: pending.append(signum))
    try:
        yield
    finally:
        for s in held:
            signal.signal(s, old[s])
        if pending:
            signal.raise_signal(pending[0])
