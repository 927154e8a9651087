"""The sweep's progress bar (tqdm, on stderr)."""
from __future__ import annotations

import sys


class Progress:
    """One bar for the whole sweep, in samples (spp x pixels, ground truth included), with an ETA."""

    def __init__(self, total: int, runs: int, enabled: bool):
        self.bar = None
        self.runs_total, self.runs_done = runs, 0
        if enabled and total > 0:
            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="sample", unit_scale=True, file=sys.stderr,
                            desc="sweep", dynamic_ncols=True, smoothing=0.05)

    def add_work(self, samples: int, runs: int) -> None:
        """Repetitions a precision target added to the sweep."""
        self.runs_total += runs
        if self.bar is not None:
            self.bar.total += samples
            self.bar.refresh()

    def update(self, n: int, what: str | None = None, runs_done: int = 0) -> None:
        self.runs_done += runs_done
        if self.bar is not None:
            if what:
                self.bar.set_postfix_str(f"{what} | runs {self.runs_done}/{self.runs_total}", refresh=not n)
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()
