"""`drtlab audit-intervals`: how often every interval the study report prints covers the truth, on
simulated studies with a known truth run through the study's own analysis
(experiments/audit/coverage.py). Bad input is one line naming the flag and exit 2, checked before
any work."""
from __future__ import annotations

from pathlib import Path

from drtlab.cli_args import Help, flag, int_flag, path_flag
from drtlab.errors import InputError


def _settings(text: str, field: str) -> list[str]:
    from drtlab.experiments.audit.simulate import SETTINGS
    names = [t.strip() for t in text.split(",")] if isinstance(text, str) else []
    if not names or any(n not in SETTINGS for n in names) or len(set(names)) != len(names):
        raise InputError(field, f"must be distinct names from {','.join(SETTINGS)}, comma separated; "
                                f"got {text!r}")
    return names


def cmd_audit_intervals(args) -> int:
    from drtlab import fields
    from drtlab.experiments.audit.coverage import AUDIT_FILES, run_audit, write_audit
    from drtlab.experiments.study.output_dir import checked_folder
    from drtlab.experiments.audit.simulate import SETTINGS
    from drtlab.experiments.paths import results_root
    out = args.out if args.out is not None else results_root() / "audit"
    out = fields.writable_location(out, "--out", folder=True)
    record = checked_folder(out, AUDIT_FILES)
    result = run_audit(args.settings or list(SETTINGS), args.studies, args.seed, args.jobs)
    ok = bool(result["pass"])
    if args.renderer:
        # The same cell interval on the renderer's own errors (a white furnace, exact reference).
        from drtlab.experiments.audit.renderer import renderer_audit, summary_lines
        r = renderer_audit(200, spp=(4, 16), samplers=("uniform", "stratified"))
        result["renderer"] = {f"{s}@{n}": v for (s, n), v in r.items()}
        ok = ok and all(v["in_band"] for v in r.values())
        renderer_lines = ["", "## The cell MSE interval on the renderer (white furnace, 200 cells of 5 "
                          "runs, 32x24, exact reference)", ""] + [f"    {ln}" for ln in summary_lines(r)]
    result["pass"] = ok
    record.claim(AUDIT_FILES)
    lines = write_audit(result, Path(out), renderer_lines if args.renderer else [])
    print("\n".join(lines))
    print(f"wrote {out}/: intervals.json, intervals.md")
    return 0 if ok else 1


def add_audit_command(sub) -> None:
    """The `audit-intervals` subcommand on the parser's subparsers `sub` (imports nothing of the
    layers: every `drtlab` command builds this parser, and a render must not load scipy)."""
    p = sub.add_parser(
        "audit-intervals", formatter_class=Help,
        help="coverage of the study report's intervals and false findings of its claims, on "
             "simulated studies with a known truth",
        description="Simulates studies (one scene, a baseline sampler of RMSE slope -0.5 against "
                    "another; N = 1, 4, 16, 64 with 320/80/20/5 runs; batches timed and "
                    "interleaved as the runner does), runs each through the study's analysis "
                    "(compare_scene, finish_claims) and tabulates, per setting and interval kind "
                    "(cell mean MSE, MSE ratio, slope, cost, efficiency, speed-up), the coverage "
                    "of the truth, the resolved fraction and the coverage among resolved ones; "
                    "the false findings of claims where the samplers are equal; the load-step "
                    "test's detection; and a negative control (the method before: normal "
                    "delta-method ratios, faster-half costs, uncorrected claims), which must fail. "
                    "Settings: gamma errors of CV 0.05 (light, as real renders) and 0.3, log-normal "
                    "(sigma 1) and Pareto (alpha 2.5) errors, each with equal samplers and with a "
                    "slope of -0.75 (light also -1), and a load step; a bad --settings value lists "
                    "their names. Writes intervals.json and intervals.md. Exit 0 when every criterion "
                    "passes, 1 otherwise. About 2 CPU seconds per study.")
    p.add_argument("--studies", type=int_flag(1, 100_000), default=500, metavar="N",
                   help="simulated studies per setting")
    p.add_argument("--settings", type=flag(_settings), default=None, metavar="NAME,...",
                   help="settings to run (default: all)")
    p.add_argument("--seed", type=int_flag(0, 2 ** 32 - 1), default=0,
                   help="seed of the simulations: the same seed gives the same tables")
    p.add_argument("--jobs", type=int_flag(1, 1024), default=None, metavar="J",
                   help="processes (default: the cores, at most 8; DRTLAB_JOBS)")
    p.add_argument("--out", type=path_flag, default=None, metavar="DIR",
                   help="output folder (default: results/audit)")
    p.add_argument("--no-renderer", dest="renderer", action="store_false",
                   help="leave out the audit on the renderer (a white furnace at 200 x 5 seeds, "
                        "uniform and stratified at 4 and 16 spp: about 10 s)")
    p.set_defaults(func=cmd_audit_intervals)
