"""What each point set's draws cost against the independent set's, as `profile_kernels pointsets
--write` measured them (`draw_costs.json` beside this module, committed with the code it measured).

A draw pair is one get2d and one get1d at the tracer's dimensions, made as a render makes them (the
count word once per pixel, the sample's hash prefixes once per sample); the ratio is of CPU times in
one job, the sets taking turns. `drtlab samplers` prints it; a set whose draws stay above
`CHEAP` times an independent draw says so there, and why (`PointSet.cost_note`: halton's digit
permutations, zsobol's digit-by-digit index). Warp-free: the file is plain JSON.
"""
from __future__ import annotations

import json
from pathlib import Path

PATH = Path(__file__).with_name("draw_costs.json")
# The most an independent draw's multiple a draw may cost and still be called cheap (issue 21).
CHEAP = 3.0


def load() -> dict:
    """{"spp": ..., "machine": ..., "ns": {name: ns per draw pair}, "ratio": {name: x independent}}."""
    return json.loads(PATH.read_text())


def ratio_note(name: str, costs: dict, why: str | None = None) -> str:
    """'draw 5.2x independent' (' (above 3x)' appended where it is not cheap, and ': ' + why where
    the set says why: PointSet.cost_note), '' if unmeasured."""
    r = costs.get("ratio", {}).get(name)
    if r is None:
        return ""
    if r <= CHEAP:
        return f"draw {r:.1f}x independent"
    return f"draw {r:.1f}x independent (above {CHEAP:g}x)" + (f": {why}" if why else "")


def write(ns: dict[str, float], spp: int, machine: str, path: Path = PATH) -> dict:
    base = ns["independent"]
    data = {"spp": spp, "machine": machine, "ns": {k: round(v, 2) for k, v in ns.items()},
            "ratio": {k: round(v / base, 2) for k, v in ns.items()}}
    path.write_text(json.dumps(data, indent=1) + "\n")
    return data
