"""`drtlab ground-truth`: render (or reuse) the high-spp references of a scene or of an experiment."""
from __future__ import annotations

import sys

from drtlab import fields
from drtlab.cli_args import Help, add_cache_and_threads, add_progress_flag, int_flag, resolution_flag, show_progress
from drtlab.errors import InputError

DEFAULT_GT_SPP = 16384


def _ground_truth_jobs(args) -> list[tuple]:
    """(scene ref, integrator, resolution, spp, batch) of every reference the command asks for."""
    from drtlab.estimators.registry import parse_integrator
    from drtlab.experiments.study.backend import default_backend
    from drtlab.experiments.study.config import load_experiment, scene_ref
    from drtlab.experiments.study.plan import gt_requirements, plan_runs
    if (args.scene is None) == (args.experiment is None):
        raise InputError("ground-truth", "give either a SCENE or --experiment NAME (one of the two)")
    if args.profile is not None and args.experiment is None:
        raise InputError("--profile", "is a profile of --experiment's file; a SCENE has none: give "
                                      "--experiment NAME or drop --profile")
    if args.integrator is not None:
        parse_integrator(args.integrator, "--integrator", unbiased=True)
    backend = default_backend()
    if args.experiment is not None:
        exp = load_experiment(args.experiment, args.profile or "quick")
        jobs = []
        for (ref, integ, res), (spp, batch) in gt_requirements(exp, plan_runs(exp, backend)).items():
            if args.integrator and args.integrator != integ:
                continue
            if args.res is not None:
                scene = backend.load_scene(ref.name, ref.overrides_dict or None)
                res = fields.resolution(args.res, "--res", aspect=scene.height / scene.width)
            jobs.append((ref, integ, res, args.spp or spp, args.batch_spp or batch))
        return jobs
    scene = backend.load_scene(args.scene, None)                    # raises InputError
    integ = parse_integrator(args.integrator or scene.integrator, "--integrator", unbiased=True).name
    res = None if args.res is None else fields.resolution(args.res, "--res",
                                                          aspect=scene.height / scene.width)
    spp = args.spp or DEFAULT_GT_SPP
    batch = args.batch_spp or max(1, min(512, spp // 8))
    return [(scene_ref(args.scene, "SCENE"), integ, res, spp, batch)]


def cmd_ground_truth(args) -> int:
    from drtlab.experiments.study import ground_truth as groundtruth
    from drtlab.experiments.study.backend import default_backend
    from drtlab.experiments.paths import default_gt_root
    jobs = _ground_truth_jobs(args)
    backend = default_backend()
    root = fields.writable_location(args.gt_dir or default_gt_root(), "--gt-dir", folder=True)
    from drtlab.experiments.study.estimate import check_references
    check_references(jobs, backend, root, args.threads, args.yes,       # said first, refused past limits
                     log=lambda line: print(line, file=sys.stderr))
    for ref, integ, res, spp, batch in jobs:
        gt = groundtruth.ensure_ground_truth(ref, integ, res, spp, batch, backend, root,
                                             threads=args.threads, progress=show_progress(args))
        how = "reused" if gt.reused else f"rendered in {gt.manifest.get('wall_seconds', 0):.1f} s"
        print(f"{gt.directory}: {gt.spp} spp, Var_GT {gt.variance:.3e} ({how})")
    return 0


def add_ground_truth_command(sub) -> None:
    g = sub.add_parser(
        "ground-truth", help="render (or reuse) high-spp references with their standard error",
        formatter_class=Help,
        description="Render the reference of one scene, or of every scene of an experiment.")
    g.add_argument("scene", nargs="?", metavar="SCENE", help="built-in scene name or path")
    g.add_argument("--spp", type=int_flag(1), default=None,
                   help=f"reference samples per pixel (default: the experiment's gt_spp, or "
                        f"{DEFAULT_GT_SPP}), rounded up to whole batches of --batch-spp and at least "
                        "2 batches (the standard error needs them); the line printed says the spp "
                        "rendered")
    g.add_argument("--batch-spp", type=int_flag(1, fields.MAX_COUNT), default=None,
                   help="samples per independent batch (default: the experiment's, or spp / 8 up to 512)")
    g.add_argument("--integrator", default=None,
                   help="drt | path (default: the scene's, or the experiment's)")
    g.add_argument("--res", type=resolution_flag, default=None,
                   help="N (width, scene aspect) or WxH (default: the scene's own)")
    g.add_argument("--experiment", default=None, metavar="NAME_OR_PATH",
                   help="render the references every scene of this experiment needs")
    g.add_argument("--profile", default=None,
                   help="profile of --experiment to use (default: quick; only with --experiment)")
    g.add_argument("--yes", action="store_true",
                   help="render even when the up-front estimate passes its limits (24 h of rendering, "
                        "90%% of this machine's memory); without it such a reference is refused before "
                        "anything is rendered")
    add_cache_and_threads(g)
    add_progress_flag(g)
    g.set_defaults(func=cmd_ground_truth)
