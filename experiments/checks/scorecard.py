"""A scorecard: one line per check with its verdict (pass / FAIL, or reported only) and the figure
behind it; its p-valued lines share a level, Sidak-corrected over them."""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class Line:
    name: str
    passed: bool | None          # None: reported, not judged
    figure: str
    p: float = float("nan")


def per_test(level: float, tests: int) -> float:
    from drtlab.experiments.stats.hypothesis_tests import sidak
    return sidak(level, tests)


@dataclass
class Scorecard:
    name: str
    level: float
    tests: int                   # the p-valued lines the level is shared over
    lines: list[Line] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def passed(self) -> bool:
        return all(x.passed is not False for x in self.lines)

    def text(self) -> list[str]:
        out = [f"drtlab check {self.name}: level {self.level:g} over its {self.tests} tests "
               f"({per_test(self.level, self.tests):.3g} each, Sidak)"]
        for x in self.lines:
            verdict = "info" if x.passed is None else ("pass" if x.passed else "FAIL")
            out.append(f"  {x.name:24s} {verdict:5s} {x.figure}")
        bad = [x.name for x in self.lines if x.passed is False]
        out.append(f"{self.name}: " + (f"every check passes ({self.seconds:.0f} s)" if not bad else
                                       f"{len(bad)} check(s) FAIL: {', '.join(bad)}"))
        return out

    def to_json(self) -> dict:
        return {"name": self.name, "level": self.level, "passed": self.passed, "seconds": self.seconds,
                "lines": [{"name": x.name, "passed": x.passed, "figure": x.figure,
                           "p": None if math.isnan(x.p) else x.p} for x in self.lines]}
