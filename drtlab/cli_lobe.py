"""`drtlab lobe KIND`: a material's BSDF lobe in the plane of incidence for a few incident angles,
beside the sampling density the chi-square test compares it with (experiments/tools/lobes.py). Bad
input is one line naming the flag and exit 2, checked before any work (Warp and matplotlib load
after)."""
from __future__ import annotations

import sys

from drtlab import fields
from drtlab.cli_args import Help, flag, int_flag, path_flag
from drtlab.errors import InputError
from drtlab.experiments.tools import lobes as L
from drtlab.experiments.study.output_dir import checked_folder


# Each lobe parameter, the kinds it applies to and its default: a flag a kind does not read is
# refused rather than ignored (and written into the output's name).
_PARAMETERS = (("--exponent", "exponent", L.USES_EXPONENT, 20.0), ("--roughness", "roughness", L.USES_ROUGHNESS, 0.2),
               ("--ior", "ior", L.USES_IOR, 1.5))


def _check_flags_apply(args) -> None:
    for flag_name, attr, kinds, default in _PARAMETERS:
        if getattr(args, attr) is None:
            setattr(args, attr, default)
        elif args.kind not in kinds:
            raise InputError(flag_name, f"{args.kind} does not read it; it applies to {', '.join(kinds)}")
    if args.strategy == "importance-ggxd" and args.kind not in L.USES_ROUGHNESS:
        raise InputError("--strategy", f"importance-ggxd draws GGX normals; {args.kind} has none (it "
                                       f"applies to {', '.join(L.USES_ROUGHNESS)})")


def cmd_lobe(args) -> int:
    _check_flags_apply(args)
    out = args.out if args.out is not None else L.default_out_dir(args.kind, args.exponent,
                                                                  args.ior, args.strategy,
                                                                  args.roughness)
    out = fields.writable_location(out, "--out", folder=True)
    fields.output_files([out / name for name in L.FILES], "--out")     # none of them a folder
    record = checked_folder(out, L.FILES)
    result = L.analyse(args.kind, exponent=args.exponent, ior=args.ior, albedo=args.albedo,
                       incident=args.incident, strategy=args.strategy, samples=args.samples,
                       seed=args.seed, roughness=args.roughness)
    record.claim(L.FILES)
    L.write_lobe(result, out, argv=sys.argv)
    S = result.summary
    print(f"wrote {out}/: {', '.join(L.FILES)}")
    print(f"{S['kind']}, {S['strategy']} sampling, N = {S['samples']}; chi-square level "
          f"{S['sidak_level']:.3g} (Sidak, family alpha {S['family_alpha']:g}):")
    for r in S["incident"]:
        c, h = r["chi2"], r["histogram"]
        dev = "-" if h["max_rel_dev"] is None else f"{h['max_rel_dev']:.3f}"
        print(f"  theta_i {r['theta_deg']:5.1f} deg: albedo {sum(r['albedo_estimate']['mean']) / 3:.4f}"
              f"  chi2 {c['statistic']:.1f} (dof {c['dof']}) p {c['p_value']:.3g} "
              f"{'pass' if c['passed'] else 'REJECTED'}  max|hist-pdf|/pdf {dev}")
    return 0 if S["passed"] else 1


def add_lobe_command(sub) -> None:
    """The `lobe` subcommand on the parser's subparsers `sub`."""
    p = sub.add_parser(
        "lobe", help="plot a material's BSDF lobe in the plane of incidence beside its sampling "
                     "density and chi-square p-value", formatter_class=Help,
        description="For each incident angle: a polar plot of f·cos in the plane of incidence "
                    "(eval_bsdf), and beside it a histogram of sample_bsdf's directions within "
                    f"{L.BAND_DEG:g} degrees of that plane, as a density, with the claimed pdf; "
                    "plus the chi-square test of the samples (Sidak-corrected over the angles) "
                    "and the directional albedo. Writes lobe.png, lobe.json and manifest.json. "
                    "Exit 0 when every chi-square test passes, 1 when any is rejected.")
    p.add_argument("kind", metavar="KIND", type=flag(L.check_kind),
                   help=f"material kind with a lobe: {', '.join(L.LOBE_KINDS)}")
    p.add_argument("--exponent", type=flag(L.check_exponent), default=None, metavar="E",
                   help=f"Phong exponent of {', '.join(L.USES_EXPONENT)}, in [0, "
                        f"{L.MAX_EXPONENT:g}] (default: 20)")
    p.add_argument("--roughness", type=flag(L.check_roughness), default=None, metavar="A",
                   help=f"GGX alpha of {', '.join(L.USES_ROUGHNESS)}, in [0.001, 1] (default: 0.2)")
    p.add_argument("--ior", type=flag(L.check_ior), default=None, metavar="I",
                   help=f"index of refraction of {', '.join(L.USES_IOR)}, in [0.1, 10], not 1 (default: 1.5)")
    p.add_argument("--albedo", type=flag(L.check_albedo), default="0.8,0.8,0.8",
                   metavar="R,G,B", help="albedo, three numbers in [0, 1]")
    p.add_argument("--incident", type=flag(L.check_incident),
                   default=",".join(f"{a:g}" for a in L.DEFAULT_INCIDENT), metavar="A,B,...",
                   help=f"incident angles from the normal in degrees, 1 to {L.MAX_ANGLES} in "
                        f"[0, {L.MAX_INCIDENT:g}]")
    p.add_argument("--strategy", choices=L.STRATEGIES, default="importance",
                   help="sample_bsdf's strategy: importance (cosine / Phong lobes / Fresnel; GGX: "
                        "visible normals), importance-ggxd (GGX normals from D cos) or uniform "
                        "(hemisphere, sphere for transmission)")
    p.add_argument("--samples", type=int_flag(L.MIN_SAMPLES, L.MAX_SAMPLES),
                   default=L.DEFAULT_SAMPLES, metavar="N", help="samples per incident angle")
    p.add_argument("--seed", type=int_flag(0, fields.MAX_SEED), default=0, metavar="S",
                   help="root seed (angle i uses S + 7919 i)")
    p.add_argument("--out", type=path_flag, default=None, metavar="DIR",
                   help="output folder (default: results/lobes/KIND[_nE][_aA][_iorI]_STRATEGY)")
    p.set_defaults(func=cmd_lobe)
