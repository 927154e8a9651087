"""The sweep's progress: a bar (tqdm, on stderr) for a person watching, else a line every
LINE_SECONDS for a log (cells done, samples per second, time left)."""
from __future__ import annotations

import sys
import time

LINE_SECONDS = 10.0


class Progress:
    """One bar for the whole sweep, in samples (spp x pixels, ground truth included), with an ETA;
    without the bar (stderr not a terminal, --no-progress) and with `log`, a progress line every
    LINE_SECONDS of `clock`."""

    def __init__(self, total: int, runs: int, enabled: bool, log=None, clock=time.monotonic):
        self.bar = None
        self.runs_total, self.runs_done = runs, 0
        self.total, self.done = total, 0
        self.log, self.clock = (None if enabled else log), clock
        self.start = self.last = clock()
        if enabled and total > 0:
            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="sample", unit_scale=True, file=sys.stderr,
                            desc="sweep", dynamic_ncols=True, smoothing=0.05)

    def add_work(self, samples: int, runs: int) -> None:
        """Repetitions a precision target added to the sweep."""
        self.runs_total += runs
        self.total += samples
        if self.bar is not None:
            self.bar.total += samples
            self.bar.refresh()

    def update(self, n: int, what: str | None = None, runs_done: int = 0) -> None:
        self.runs_done += runs_done
        self.done += n
        if self.log is not None and n:
            now = self.clock()
            if now - self.last >= LINE_SECONDS:
                self.last = now
                rate = self.done / max(now - self.start, 1e-9)
                left = (self.total - self.done) / rate if rate > 0 else float("inf")
                self.log(f"sweep: {self.runs_done}/{self.runs_total} runs, {self.done / max(self.total, 1):.0%} "
                         f"of the samples, {rate / 1e6:.2f} M samples/s, about {left:.0f} s left")
        if self.bar is not None:
            if what:
                self.bar.set_postfix_str(f"{what} | runs {self.runs_done}/{self.runs_total}", refresh=not n)
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
