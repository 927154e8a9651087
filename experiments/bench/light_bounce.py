"""Calibration of kernels/lights.py's SPHERICAL_MAX_BOUNCE: from which path vertices does
solid-angle (spherical rectangle) sampling of a rectangle light still pay per unit time?

For each value of the rule (0: the camera ray's hit only, 1, and every vertex), `importance` against
`importance-area` on the `lights` study's two scenes (experiments/studies/lights.toml: a large light
over the Cornell box under path tracing, over soft-shadows under drt) and three built-ins: ns per
sample (one thread, best of --reps, the two samplers interleaved) and the mean over pixels of the
per-pixel sample variance (one render at --spp). Efficiency of importance over area:
(var_area t_area) / (var t); above 1 solid angle pays. Each value runs in its own process: the
kernel reads SPHERICAL_MAX_BOUNCE when it is built, and its value is part of the kernel's hash.

    python -m drtlab.experiments.bench.light_bounce [--spp 1024] [--time-spp 64] [--reps 5]
"""
from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tomllib

from drtlab.experiments.study.config import EXPERIMENT_DIR
from drtlab.kernels import lights
from drtlab.kernels.integrators.api import DEPTH_CAP

RES = (96, 72)
SAMPLERS = ("independent+importance-area", "importance")
BUILTINS = ("cornell-box", "soft-shadows", "veach-mis")
RULES = (0, 1, DEPTH_CAP)       # DEPTH_CAP: every vertex (the rule off)


def scenes() -> list[tuple[str, str, str | None, dict | None]]:
    """(label, scene, integrator, overrides): the lights study's scenes, then the built-ins."""
    with open(EXPERIMENT_DIR / "lights.toml", "rb") as fh:
        spec = tomllib.load(fh)
    out = [(sc["label"], sc["name"], st.get("integrator"), sc.get("overrides"))
           for st in spec["study"] for sc in st["scenes"]]
    return out + [(name, name, None, None) for name in BUILTINS]


def child(rule: int, spp: int, time_spp: int, reps: int) -> None:
    lights.SPHERICAL_MAX_BOUNCE = rule      # before any kernel is built
    from drtlab.kernels.render import render_with_stats
    from drtlab.kernels.scene_model.scene_file import load_scene
    for label, name, integ, ov in scenes():
        sc = load_scene(name, ov)
        best = {smp: math.inf for smp in SAMPLERS}
        for _ in range(reps):
            for smp in SAMPLERS:
                s = render_with_stats(sc, spp=time_spp, sampler=smp, integrator=integ, seed=1,
                                      threads=1, res=RES, progress=False)
                best[smp] = min(best[smp], s.render_seconds)
        ns, var = {}, {}
        for smp in SAMPLERS:
            ns[smp] = best[smp] / (RES[0] * RES[1] * time_spp) * 1e9
            st = render_with_stats(sc, spp=spp, sampler=smp, integrator=integ, seed=7, res=RES,
                                   variance=True, progress=False)
            var[smp] = float(st.variance.sum(axis=2).mean())
        a, s = SAMPLERS
        eff = var[a] * ns[a] / (var[s] * ns[s])
        print(f"{rule:>5} {label:26s} {ns[a]:7.0f} {ns[s]:7.0f} {ns[s] / ns[a]:6.2f} "
              f"{var[a] / var[s]:8.3f} {eff:6.2f}", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--time-spp", type=int, default=64)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        child(args.child, args.spp, args.time_spp, args.reps)
        return
    print(f"{'rule':>5} {'scene':26s} {'ns area':>7} {'ns sa':>7} {'cost':>6} {'var a/sa':>8} "
          f"{'eff':>6}  (rule {DEPTH_CAP}: every vertex)", flush=True)
    for rule in RULES:
        subprocess.run([sys.executable, "-m", "drtlab.experiments.bench.light_bounce", "--child",
                        str(rule), "--spp", str(args.spp), "--time-spp", str(args.time_spp),
                        "--reps", str(args.reps)], check=True)


if __name__ == "__main__":
    main()
