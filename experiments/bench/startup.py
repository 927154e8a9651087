"""Start-up of the `drtlab` program (`make bench`'s `startup` entry): the whole process of a tiny
render with a warm kernel cache against the render the command itself records (its EXR's
drtlab:wall_seconds: the kernel's load and the launches), and the whole process of the listings and
the image tool. Each command runs in a fresh process, the commands take turns `repeats` times and
the best of each is kept (other jobs on the machine only slow a run down)."""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENE, RES, SPP = "aa-edges", "16x12", 1
# The other commands timed, {exr} the tiny render's image.
COMMANDS = {"scenes": ["scenes"], "samplers": ["samplers"], "info": ["info", "{exr}"],
            "help": ["--help"]}


def _run(argv: list[str]) -> float:
    """Whole-process seconds of `drtlab ARGV` (the program's own entry, `drtlab.cli.run`)."""
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "drtlab.cli", *argv], capture_output=True,
                          text=True, env=os.environ.copy())
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"drtlab {' '.join(argv)} failed ({proc.returncode}): {proc.stderr}")
    return seconds


def startup(repeats: int) -> dict:
    from drtlab.kernels.imageio import read_exr
    with tempfile.TemporaryDirectory(prefix="drtlab-startup-") as tmp:
        exr = Path(tmp) / "tiny.exr"
        render = ["render", SCENE, "--spp", str(SPP), "--res", RES, "--out", str(exr)]
        _run(render)                              # fills the kernel cache; not timed
        runs, others = [], {name: [] for name in COMMANDS}
        for _ in range(repeats):
            whole = _run(render)
            meta = read_exr(exr)[1]
            runs.append((whole, float(meta["wall_seconds"]), float(meta["compile_seconds"]),
                         float(meta["render_seconds"])))
            for name, argv in COMMANDS.items():
                others[name].append(_run([a.format(exr=exr) for a in argv]))
    best = min(runs)
    return {
        "command": f"drtlab render {SCENE} --spp {SPP} --res {RES}", "repeats": repeats,
        "render_whole_process_seconds": round(best[0], 3),
        "render_in_process_seconds": round(min(r[1] for r in runs), 3),
        "render_compile_seconds": round(min(r[2] for r in runs), 3),
        "render_launch_seconds": round(min(r[3] for r in runs), 4),
        # Per run, the whole process less what the command records as its render; best run.
        "beyond_render_seconds": round(min(r[0] - r[1] for r in runs), 3),
        "whole_process_seconds": {name: round(min(t), 3) for name, t in others.items()},
    }


def print_startup(s: dict) -> None:
    print(f"\nstart-up, best of {s['repeats']} (warm kernel cache): {s['command']}: whole process "
          f"{s['render_whole_process_seconds']:.3f} s, of which the render "
          f"{s['render_in_process_seconds']:.3f} s (kernel load {s['render_compile_seconds']:.3f} s, "
          f"launches {s['render_launch_seconds']:.4f} s): {s['beyond_render_seconds']:.3f} s beyond it")
    print("  whole process: " + ", ".join(f"drtlab {'--help' if n == 'help' else n} {t:.3f} s"
                                          for n, t in s["whole_process_seconds"].items()))
