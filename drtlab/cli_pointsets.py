"""`drtlab pointset` (one point set's projection: scatter, spectrum, discrepancy, min distance) and
`drtlab validate` (the statistical battery on a registered point set). Bad input is one line naming
the flag and exit 2, checked before any work (the point sets, scipy and matplotlib load after)."""
from __future__ import annotations

import sys

from drtlab import fields
from drtlab.cli_args import Given, Help, flag, given_flags, int_flag, path_flag
from drtlab.errors import InputError
from drtlab.experiments.pointsets import analysis as A
from drtlab.experiments.pointsets import validate as V
from drtlab.experiments.study.output_dir import checked_folder


def _pointset_name(text: str, field: str) -> str:
    V.check_pointset(text, field)
    return text


def _checkable_name(text: str, field: str) -> str:
    """A registered point set, light selection, lobe sampler or integrator (what `drtlab check`
    scores)."""
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS
    from drtlab.kernels.light_selection import LIGHT_SELECTIONS
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
    if text in POINTSETS or text in LIGHT_SELECTIONS or text in LOBE_SAMPLERS or text in INTEGRATORS:
        return text
    from drtlab.experiments.error_metrics.base import METRICS
    if text in METRICS:
        raise InputError(field, f"{text!r} is an error metric, and metrics have no check: a check "
                                "scores a sampling routine against its own density and an exact "
                                "render, and a metric samples nothing; a study that names it "
                                "(metric = ...) ranks its samplers by it")
    raise InputError(field, f"unknown point set, light selection, lobe sampler or integrator {text!r}; "
                            f"point sets: {', '.join(POINTSETS)}; light selections: {', '.join(LIGHT_SELECTIONS)}; "
                            f"lobe samplers: {', '.join(LOBE_SAMPLERS) or 'none (yours: --plugin)'}; "
                            f"integrators: {', '.join(INTEGRATORS)}")


def _level_text(text: str, field: str) -> float:
    rule = "in (0, 0.5], e.g. 0.01"
    try:
        value = float(text)
    except ValueError:
        raise InputError(field, f"must be a number {rule}, got {fields.show(text)}") from None
    return fields.number(value, field, rule, lambda v: 0.0 < v <= 0.5)


def _dims_text(text: str, field: str) -> tuple[int, int]:
    return A.parse_dims(text, field)


def cmd_pointset(args) -> int:
    A.check_request(args.name, args.n, args.realisations, args.seed)
    out = args.out if args.out is not None else A.default_out_dir(args.name, args.n, args.dims)
    out = fields.writable_location(out, "--out", folder=True)
    fields.output_files([out / name for name in A.FILES], "--out")     # none of them a folder
    record = checked_folder(out, A.FILES)
    result = A.analyse(args.name, args.n, args.dims, args.realisations, args.seed)
    record.claim(A.FILES)
    A.write_analysis(result, out, argv=sys.argv)
    s = result.summary
    print(f"wrote {out}/: {', '.join(A.FILES)}")
    seeds = f"1 realisation (seed {args.seed})" if args.realisations == 1 else \
        f"{args.realisations} realisations (seeds {s['seeds'][0]}-{s['seeds'][1]})"
    print(f"{args.name}, N = {args.n}, dims {args.dims[0]},{args.dims[1]} "
          f"({', '.join(s['dim_labels'])}), {seeds}; mean +- standard error:")
    rows = [(f"discrepancy {m}{'^2' if m in A.SQUARED_DISCREPANCIES else ''}", s["discrepancy"][m])
            for m in A.DISCREPANCY_METHODS]
    rows += [("min toroidal distance", s["min_distance"]),
             ("  / hexagonal maximum", s["min_distance_relative"]),
             ("mean nearest-neighbour", s["mean_nn_distance"]),
             ("periodogram, k != 0", s["periodogram"]["mean_nonzero"]),
             ("  low |k| < sqrt(N)/2", s["periodogram"]["low_frequency_power"])]
    for label, v in rows:
        se = "" if v["se"] is None else f" +- {v['se']:.3g}"
        print(f"  {label:24s} {v['mean']:.5g}{se}")
    return 0


def _battery_arguments(p, name_help: str, level_help: str, name_type=_pointset_name) -> None:
    p.add_argument("name", metavar="NAME", type=flag(name_type), help=name_help)
    p.add_argument("--seed", type=int_flag(0, fields.MAX_SEED), default=0, metavar="S",
                   help="the seed of the points and samples")
    p.add_argument("--level", type=flag(_level_text), default=V.DEFAULT_LEVEL, metavar="ALPHA",
                   help=level_help)
    p.add_argument("--pixels", type=int_flag(V.MIN_PIXELS, V.MAX_PIXELS), default=V.PIXELS,
                   metavar="P", action=Given,
                   help="pixels of the battery (more: more power, longer; a point set's only)")


def cmd_check(args) -> int:
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS
    from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
    if args.out is not None:
        args.out = fields.writable_location(args.out, "--out")
        fields.output_files([args.out], "--out")
    if "pixels" in given_flags(args) and args.name not in POINTSETS:
        raise InputError("--pixels", f"sizes a point set's battery; {args.name} is not a point set "
                                     "and its card has no battery: drop --pixels")
    if args.name in POINTSETS:
        from drtlab.experiments.checks.pointset import check
        card = check(args.name, seed=args.seed, level=args.level, pixels=args.pixels)
    elif args.name in LOBE_SAMPLERS:
        from drtlab.experiments.checks import lobe_sampler
        card = lobe_sampler.check(args.name, seed=args.seed, level=args.level)
    elif args.name in INTEGRATORS:
        from drtlab.experiments.checks import integrator
        card = integrator.check(args.name, seed=args.seed, level=args.level)
    else:
        from drtlab.experiments.checks import light_selection
        card = light_selection.check(args.name, seed=args.seed, level=args.level)
    print("\n".join(card.text()))
    if args.out is not None:
        from drtlab.experiments.files import atomic_write_json
        args.out.parent.mkdir(parents=True, exist_ok=True)      # checked writable before the work
        atomic_write_json(args.out, card.to_json())
        print(f"wrote {args.out}")
    return 0 if card.passed else 1


def cmd_validate(args) -> int:
    result = V.validate(args.name, seed=args.seed, level=args.level, pixels=args.pixels)
    print("\n".join(result.lines()))
    return 0 if result.passed else 1


def add_pointset_commands(sub) -> None:
    """The `pointset` and `validate` subcommands on the parser's subparsers `sub`."""
    name_help = "a registered point set (`drtlab samplers` lists them)"
    p = sub.add_parser(
        "pointset", help="scatter, periodogram, radial spectrum, discrepancy and min distance of "
                         "one point set's 2D projection", formatter_class=Help,
        description="Analyse N points of a point set in dimensions i,j over R realisations "
                    "(seeds S ... S+R-1, pixel 0, spp = N: the values the render kernels use). "
                    "Writes scatter.png, periodogram.png, radial_spectrum.png, analysis.json "
                    "(means and standard errors over realisations), periodogram.npz and "
                    "manifest.json.")
    p.add_argument("name", metavar="NAME", type=flag(_pointset_name), help=name_help)
    p.add_argument("--n", type=int_flag(A.MIN_N, A.MAX_N), required=True,
                   help="points per realisation (the samples of one pixel, spp = N)")
    p.add_argument("--dims", type=flag(_dims_text), default="0,1", metavar="I,J",
                   help="the two dimensions to project onto (tracer layout: 0-1 pixel, 2-3 lens, "
                        "4 time, 5 + 8b + {0 light choice, 1-2 light position, 3 lobe, "
                        "4-5 direction, 6 roulette} for bounce b)")
    p.add_argument("--realisations", type=int_flag(1, A.MAX_REALISATIONS),
                   default=A.DEFAULT_REALISATIONS, metavar="R",
                   help="independent realisations (seeds) the numbers are averaged over")
    p.add_argument("--seed", type=int_flag(0, fields.MAX_SEED), default=0, metavar="S",
                   help="first seed")
    p.add_argument("--out", type=path_flag, default=None, metavar="DIR",
                   help="output folder (default: results/pointsets/NAME_nN_dI-J)")
    p.set_defaults(func=cmd_pointset)

    v = sub.add_parser(
        "validate", help="uniformity, stratification, independence and unbiasedness tests of a "
                         "point set: p-values and verdicts", formatter_class=Help,
        description=f"Run the statistical battery of experiments/pointsets/validate.py on a "
                    f"registered point set (P pixels x {V.SPP} samples in the dimensions a "
                    f"{V.BOUNCES}-bounce path reads). Prints each test's Sidak-adjusted p-value "
                    "and verdict at the level, Sidak-corrected over the tests. Exit 0 when every "
                    "test passes, 1 when any fails. Tests: "
                    + "; ".join(f"{k}: {w}" for k, w in V.TESTS.items()) + ".")
    _battery_arguments(v, name_help, "false-alarm probability of the whole battery")
    v.set_defaults(func=cmd_validate)

    c = sub.add_parser(
        "check", formatter_class=Help,
        help="the scorecard a built-in point set, light selection, lobe sampling or integrator "
             "gets, for any registered one (yours: --plugin)",
        description="Every check drtlab runs on its own point sets, light selections, lobe "
                    "samplers or integrators, as one "
                    "scorecard. A point set: purity (same key, same value), bit-identical renders "
                    "across threads and tiles, the range [0, 1), the statistical battery of `drtlab "
                    "validate`, unbiasedness in the renderer (a white furnace with an exact answer), "
                    "convergence on a smooth and a discontinuous integrand beside the built-ins' "
                    "rates, and the render cost against independent points (about 30 s). A light "
                    "selection: its pmf sums to 1, pick frequencies against that pmf at three "
                    "points, light-sample directions against the density MIS evaluates "
                    "(chi-square), that density against the samples', finite values at a tiny, a "
                    "huge and a grazing light, the white furnace with importance sampling composed "
                    "with it, and its render cost against the power pick (about 30 s). A lobe sampler: "
                    "its directions against its pdf (chi-square) at three angles, its directional "
                    "albedo against the built-in sampler's, finite values at grazing angles and "
                    "extreme lobe shapes, the furnace for a diffuse sampler, and its sampling cost "
                    "(about 10 s). An integrator: unbiasedness against path on a small scene per "
                    "effect it claims to handle, the white furnace against its exact value, "
                    "bit-identical renders across threads and tiles, finite non-negative pixels in "
                    "hard cases, its convergence rate and its cost beside path's (about 5 s after "
                    "its kernels compile). Exit 0 when "
                    "every judged line passes, 1 when any fails.")
    _battery_arguments(c, "a registered point set, light selection, lobe sampler or integrator (`drtlab "
                          "samplers` lists the point sets; a plugin's with --plugin)",
                       "false-alarm probability of the scorecard's tests together", _checkable_name)
    c.add_argument("--out", type=path_flag, default=None, metavar="FILE.json",
                   help="also write the scorecard as JSON")
    c.set_defaults(func=cmd_check)
