"""`drtlab experiment` and `drtlab ground-truth`: subcommands hooked into the main CLI.

The main CLI calls `add_subcommands(subparsers)`; each subcommand's `func(args)` returns an exit code
and raises `InputError` for bad input, which the main CLI prints as one line and turns into exit 2.
Everything is validated before the first file or directory is written.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drtlab.kernels.errors import InputError


def _positive_int(name):
    def parse(v):
        try:
            x = int(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be an integer >= 1, got {v!r}") from None
        if x < 1:
            raise argparse.ArgumentTypeError(f"{name} must be an integer >= 1, got {v}")
        return x
    return parse


def _resolution(v):
    try:
        w, h = (int(x) for x in v.lower().split("x"))
        if w < 1 or h < 1:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(f"--res must look like 64x48, got {v!r}") from None
    return (w, h)


def add_subcommands(subparsers) -> None:
    p = subparsers.add_parser(
        "experiment", help="run (or resume) an experiment: ground truth, runs, plots, report",
        description="Run an experiment file (a built-in name such as stratified, importance, uniform, "
                    "all, or a path). Finished runs are kept and skipped on a rerun.")
    p.add_argument("experiment", metavar="NAME_OR_PATH")
    p.add_argument("--profile", default="quick", help="profile section to use (quick | full | ...)")
    p.add_argument("--out", type=Path, default=None, help="output folder (default results/NAME)")
    p.add_argument("--gt-dir", type=Path, default=None,
                   help="ground-truth cache (default results/ground-truth)")
    p.add_argument("--threads", type=_positive_int("--threads"), default=None)
    p.add_argument("--fresh", action="store_true", help="discard this experiment's earlier runs first")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_experiment)

    g = subparsers.add_parser(
        "ground-truth", help="render (or reuse) high-spp references with their standard error",
        description="Render the reference of one scene, or of every scene of an experiment.")
    g.add_argument("scene", nargs="?", metavar="SCENE", help="built-in scene name or path")
    g.add_argument("--spp", type=_positive_int("--spp"), default=None,
                   help="reference samples per pixel (default: the experiment's gt_spp, or 16384)")
    g.add_argument("--batch-spp", type=_positive_int("--batch-spp"), default=None)
    g.add_argument("--integrator", default=None, help="drt | path (default: the scene's, or the experiment's)")
    g.add_argument("--res", type=_resolution, default=None, help="WxH (default: the scene's own)")
    g.add_argument("--experiment", default=None, metavar="NAME_OR_PATH",
                   help="render the references every scene of this experiment needs")
    g.add_argument("--profile", default="quick")
    g.add_argument("--gt-dir", type=Path, default=None)
    g.add_argument("--threads", type=_positive_int("--threads"), default=None)
    g.add_argument("--no-progress", action="store_true")
    g.set_defaults(func=cmd_ground_truth)


def cmd_experiment(args) -> int:
    from drtlab.experiments.backend import default_backend
    from drtlab.experiments.config import load_experiment
    from drtlab.experiments.runner import run_experiment
    exp = load_experiment(args.experiment, args.profile)          # raises InputError, writes nothing
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise InputError("--out", f"{args.out} exists and is not a folder")
    backend = default_backend()
    summary = run_experiment(exp, out_dir=args.out, gt_root=args.gt_dir, backend=backend,
                             threads=args.threads, fresh=args.fresh, progress=not args.no_progress,
                             argv=sys.argv)
    from drtlab.experiments.runner import default_out_dir
    out = args.out if args.out is not None else default_out_dir(exp)
    st = summary.get("_stats", {})
    print(f"{exp.name} ({exp.profile}): {st.get('runs_new', 0)} new runs, {st.get('runs_reused', 0)} reused, "
          f"{summary.get('_wall_seconds', 0):.1f} s")
    for sd in summary.get("studies", []):
        for sc in sd["scenes"]:
            parts = []
            for s in sd["samplers"]:
                f = sc["slopes"].get(s, {})
                if f.get("ok"):
                    parts.append(f"{s} b={f['slope']:.2f} [{f['slope_lo']:.2f},{f['slope_hi']:.2f}]")
            sp = [f"{s} {v:.2f}x" for s, v in sc["speed"]["speedup_vs_baseline"].items()
                  if s != sd["baseline"] and v == v]
            print(f"  {sd['name']:>18} {sc['scene']:<14} " + "; ".join(parts)
                  + (f"; speed-up vs {sd['baseline']}: " + ", ".join(sp) if sp else ""))
    print(f"report: {out / 'report.md'}")
    return 0


def cmd_ground_truth(args) -> int:
    from drtlab.experiments import groundtruth as gtmod
    from drtlab.experiments.backend import default_backend, default_scene_loader
    from drtlab.experiments.config import _scene_ref, load_experiment
    from drtlab.experiments.runner import default_gt_root, gt_requirements, plan_runs
    if (args.scene is None) == (args.experiment is None):
        raise InputError("ground-truth", "give either a SCENE or --experiment NAME (one of the two)")
    jobs = []                     # (scene ref, integrator, resolution, spp, batch)
    if args.experiment is not None:
        exp = load_experiment(args.experiment, args.profile)
        backend = default_backend()
        plan = plan_runs(exp, backend)
        for (sc, integ, res), (spp, batch) in gt_requirements(exp, plan).items():
            if args.integrator and args.integrator != integ:
                continue
            jobs.append((sc, integ, args.res or res, args.spp or spp, args.batch_spp or batch))
    else:
        loader = default_scene_loader()
        scene = loader(args.scene, None)                            # raises InputError
        integ = args.integrator or scene.integrator
        from drtlab.estimators.registry import parse_integrator
        if parse_integrator(integ, "--integrator").biased:
            raise InputError("--integrator", f"'{integ}' is biased and cannot make a ground truth; "
                             f"use drt or path")
        spp = args.spp or 16384
        batch = args.batch_spp or max(1, min(512, spp // 8))
        jobs.append((_scene_ref(args.scene, "SCENE"), integ, args.res, spp, batch))
        backend = default_backend()
    root = args.gt_dir or default_gt_root()
    for sc, integ, res, spp, batch in jobs:
        gt = gtmod.ensure_ground_truth(sc, integ, res, spp, batch, backend, root, threads=args.threads,
                                       progress=not args.no_progress)
        how = "reused" if gt.reused else f"rendered in {gt.manifest.get('wall_seconds', 0):.1f} s"
        print(f"{gt.directory}: {gt.spp} spp, Var_GT {gt.variance:.3e} ({how})")
    return 0


def main(argv=None) -> int:
    """Stand-alone entry for these two subcommands (the project CLI normally hosts them)."""
    parser = argparse.ArgumentParser(prog="drtlab")
    sub = parser.add_subparsers(dest="command", required=True)
    add_subcommands(sub)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
