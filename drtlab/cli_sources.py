"""`drtlab sources SCENE`: where the scene's variance comes from, as Sobol' indices of the sample
dimension groups (experiments/sources/). Bad input is one line naming the flag and exit 2, checked
before any work (Warp and matplotlib load after)."""
from __future__ import annotations

import sys

from drtlab import fields
from drtlab.cli_args import Help, flag, int_flag, path_flag, resolution_flag
from drtlab.errors import InputError
from drtlab.estimators.dimensions import GROUPS
from drtlab.estimators.strategies import STRATEGIES
from drtlab.experiments.study.output_dir import checked_folder


def _groups(text: str, field: str) -> tuple:
    from drtlab.experiments.sources.decompose import check_groups
    return check_groups(text, field)


def cmd_sources(args) -> int:
    from drtlab.experiments.paths import results_root
    from drtlab.experiments.sources import report
    from drtlab.experiments.sources.decompose import max_seed, variance_sources
    from drtlab.kernels.render import check_image_size
    from drtlab.kernels.scene_model.scene_file import load_scene, output_stem
    scene = load_scene(args.scene)
    from drtlab.estimators.strategies import environment_only
    if scene.environment is None and environment_only(args.strategy):
        raise InputError("--strategy", f"{args.strategy} changes only how an environment light is sampled, "
                                       f"and {scene.name} has none: it would decompose the same estimator")
    if args.seed > max_seed(args.spp):
        raise InputError("--seed", f"must be an integer in [0, {max_seed(args.spp)}] with --spp "
                                   f"{args.spp} (the pick-freeze seeds carry the group in their "
                                   f"top byte), got {args.seed}")
    if args.res is not None:
        width, height = fields.resolution(args.res, "--res", aspect=scene.height / scene.width)
        check_image_size(width, height, field="--res")
    out = args.out if args.out is not None else results_root() / "sources" / output_stem(scene, args.scene)
    out = fields.writable_location(out, "--out", folder=True)
    fields.output_files([out / name for name in report.FILES], "--out")    # none of them a folder
    record = checked_folder(out, report.FILES)
    _check_cost(scene, args)
    s = variance_sources(scene, spp=args.spp, res=args.res, groups=args.groups, strategy=args.strategy,
                         integrator=args.integrator, seed=args.seed, threads=args.threads,
                         metric=args.metric)
    record.claim(report.FILES)
    report.write_sources(s, out, argv=sys.argv)
    print("\n".join(report.table_lines(s)))
    print(f"wrote {out}/: {', '.join(report.FILES)} ({s.seconds:.1f} s, rendering {s.render_seconds:.1f} s)")
    return 0


def _check_cost(scene, args) -> None:
    """The decomposition's samples (each base sample renders len(groups) + 2, and the pilot), said
    first and refused past the study limits unless --yes (study/estimate.py)."""
    from drtlab.estimators.defaults import DEFAULT_SAMPLER
    from drtlab.experiments.sources.decompose import PILOT_SPP, check_groups
    from drtlab.experiments.study.backend import PROBE_SECONDS
    from drtlab.experiments.study.estimate import check_render
    from drtlab.kernels.render import measured_speed
    width, height = (scene.width, scene.height) if args.res is None else \
        fields.resolution(args.res, "--res", aspect=scene.height / scene.width)
    samples = (args.spp * (len(check_groups(args.groups)) + 2) + PILOT_SPP) * width * height
    sampler = f"independent+{args.strategy}" if args.strategy else DEFAULT_SAMPLER
    check_render(samples, lambda: measured_speed(scene, sampler, args.integrator, res=(width, height),
                                                 threads=args.threads, probe_seconds=PROBE_SECONDS,
                                                 full_size=True),
                 args.yes, "this decomposition", log=lambda line: print(line, file=sys.stderr))


def add_sources_command(sub) -> None:
    """The `sources` subcommand on the parser's subparsers `sub`."""
    from drtlab.experiments.sources.decompose import DEFAULT_SAMPLES, MAX_SAMPLES
    p = sub.add_parser(
        "sources", formatter_class=Help,
        help="where a scene's variance comes from: Sobol' indices of its sample dimension groups",
        description="Renders the scene with the pickfreeze point set: per base sample, f(A), f(B) "
                    "and f(A_B^g) for each group g (group g's dimensions from B's seed), one sample "
                    "per pixel each, and estimates each group's first-order index S (Saltelli 2010) "
                    "and total index T (Jansen 1999) of one sample's variance, pooled over pixels "
                    "and channels, with 95% delta-method intervals; 1 - sum S is the interactions' "
                    "share. Groups: " + "; ".join(GROUPS) + " (estimators/dimensions.py says which "
                    "dimensions each holds). Writes sources.json, sources.png (image, the map of the "
                    "group that dominates each pixel's variance, bars of S and T) and manifest.json.")
    p.add_argument("scene", help="built-in scene name or path to a .toml or Mitsuba 3 .xml scene")
    p.add_argument("--spp", type=int_flag(2, MAX_SAMPLES), default=DEFAULT_SAMPLES, metavar="N",
                   help="base samples per pixel (each renders len(groups) + 2 samples)")
    p.add_argument("--res", type=resolution_flag, default=None,
                   help="N (width N, height from the scene's aspect) or WxH (default: the scene's)")
    p.add_argument("--groups", type=flag(_groups), default=None, metavar="G,G,...",
                   help=f"groups to decompose, from {','.join(GROUPS)} (default: all)")
    p.add_argument("--strategy", choices=list(STRATEGIES), default=None,
                   help="the estimator whose variance is decomposed (default: the default sampler's)")
    p.add_argument("--integrator", default=None,
                   help="whitted, drt, path, direct or a plugin's (default: the scene's)")
    p.add_argument("--metric", choices=("mse", "relmse"), default="mse",
                   help="what the image-level indices split: the mean per-pixel variance (mse), or "
                        "with each pixel weighted by 1/(mean^2 + 0.01) as the studies' relMSE "
                        "(relmse: a few very bright pixels, such as a light's edge, no longer "
                        "decide it alone)")
    p.add_argument("--seed", type=int_flag(0), default=0,
                   help="first base seed, in [0, 2^24 - N - 2] (the pick-freeze seeds carry the "
                        "group in their top byte)")
    p.add_argument("--threads", type=int_flag(1, 1024), default=None,
                   help="CPU threads (default: all cores)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the up-front estimate passes 24 h of rendering (said first; "
                        "without it such a decomposition is refused before it starts)")
    p.add_argument("--out", type=path_flag, default=None, metavar="DIR",
                   help="output folder (default: results/sources/SCENE)")
    p.set_defaults(func=cmd_sources)
