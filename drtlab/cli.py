"""The `drtlab` command. Bad input of any kind ends in one line naming the field, and exit code 2."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from drtlab import fields
from drtlab.cli_args import (Given, Help, Parser, add_cache_and_threads, add_progress_flag, flag,
                             given_flags, int_flag, parse_overrides, path_flag, resolution_flag,
                             run_main, show_progress)
from drtlab.errors import InputError
from drtlab.estimators.defaults import DEFAULT_SAMPLER, POINTSET_STRATEGY


# ---------------------------------------------------------------------------------------------------
# Scenes, samplers, render
# ---------------------------------------------------------------------------------------------------

def cmd_scenes(args) -> int:
    from drtlab.kernels.scene_model.scene_file import builtin_names, scene_settings
    scenes = [(name, scene_settings(name)) for name in builtin_names()]
    rows = [(name, f"{s['width']}x{s['height']}", f"{s['spp']} spp", s["integrator"],
             s["description"]) for name, s in scenes]
    _print_columns(rows)
    return 0


def _print_columns(rows: list[tuple], indent: str = "") -> None:
    """Rows of text cells, every column but the last as wide as its longest cell."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    for r in rows:
        print(indent + " ".join(c.ljust(w) for c, w in zip(r, widths)) + " " + r[-1])


def cmd_samplers(args) -> int:
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS, PRESETS
    from drtlab.estimators.strategies import STRATEGIES
    from drtlab.estimators import draw_costs
    costs = draw_costs.load()
    sections = [
        (f"point sets: a name alone means POINTS+{POINTSET_STRATEGY}; a draw's cost against an "
         f"independent draw's ({costs['machine']}, spp {costs['spp']}: profile_kernels pointsets)",
         [(p.name, "; ".join(filter(None, (p.description,
                                             draw_costs.ratio_note(p.name, costs, p.cost_note)))))
          for p in POINTSETS.values()]),
        ("strategies:", [(s.name, s.description) for s in STRATEGIES.values()]),
        (f"presets: any POINTS+STRATEGY is accepted too; the default is {DEFAULT_SAMPLER}",
         [(name, f"{p}+{s}") for name, (p, s) in PRESETS.items()]),
        ("pixel-filter estimators: a suffix of any sampler name ([camera] filter; the box is the "
         "same image under both)",
         [("+fis", "filter importance sampling (the default): unbiased, each pixel independent"),
          ("+splat", "splatting, sum f L / sum f over the samples within the radius: consistent, "
                     "biased at low spp")]),
        ("integrators:", [(i.name, "biased" if i.biased else "unbiased", i.description)
                          for i in INTEGRATORS.values()])]
    # One name column for all sections, so that the lists read as one table.
    width = max(len(row[0]) for _, rows in sections for row in rows)
    for title, rows in sections:
        print(title)
        _print_columns([(row[0].ljust(width), *row[1:]) for row in rows], indent="  ")
    return 0


def _warn(lines: list[str]) -> None:
    for line in lines:
        print(f"drtlab: warning: {line}", file=sys.stderr)


def _render_size(scene, args) -> tuple[int, int]:
    """(width, height) the render will have: --res, or the scene's."""
    if args.res is None:
        return scene.width, scene.height
    return fields.resolution(args.res, "--res", aspect=scene.height / scene.width)


def _default_out(scene, args) -> Path:
    """results/renders/NAME.exr, NAME made of everything that changes the image: scene (and a hash of
    its --set overrides or its file), integrator, sampler, resolution, spp, seed; renders that
    differ never overwrite each other. Whitted reads neither sampler nor seed."""
    from drtlab.estimators.registry import parse_integrator, parse_sampler
    from drtlab.experiments.paths import results_root
    from drtlab.kernels.scene_model.scene_file import output_stem
    integ = parse_integrator(args.integrator or scene.integrator).name
    width, height = _render_size(scene, args)
    parts = [output_stem(scene, args.scene, bool(args.set)), integ]
    if integ != "whitted":
        parts.append(parse_sampler(args.sampler).name.replace("+", "_"))
    parts += [f"{width}x{height}",
              f"{args.seconds:g}s" if args.seconds is not None else f"{args.spp or scene.spp}spp"]
    if integ != "whitted":
        parts.append(f"s{args.seed}")
    return results_root() / "renders" / ("-".join(parts) + ".exr")


def _sampler_notes(sampler: str, spp: int) -> list[str]:
    """What a user should know of a sampler at this spp before the render."""
    from drtlab.estimators.registry import parse_sampler
    if parse_sampler(sampler).pointset.name == "zsobol" and spp & (spp - 1):
        net = 1 << (spp - 1).bit_length()
        return [f"zsobol at {spp} spp takes {spp} of each pixel's {net}-point net: unbiased, but "
                f"not stratified into {spp} strata; a power of 2 spp stratifies"]
    return []


# A render that will take more than LONG_RENDER_SECONDS says so once its first launches have run
# for NOTE_AFTER_SECONDS (or done NOTE_AFTER_FRACTION of the work): measured on the render itself,
# not by a probe before it, which cost a 4-second render a second.
LONG_RENDER_SECONDS = 120.0
NOTE_AFTER_SECONDS = 2.0
NOTE_AFTER_FRACTION = 0.05


def _duration(seconds: float) -> str:
    if seconds < 3600:
        return f"{seconds / 60:.0f} min"
    if seconds < 86400 * 3:
        return f"{seconds // 3600:.0f} h {seconds % 3600 / 60:.0f} min"
    return f"{seconds / 86400:.0f} days"


def _time_watch(scene, args):
    """A render's `watch`: once enough of it has run, one note of how long the whole will take, if
    that is more than LONG_RENDER_SECONDS (None for a time-budget render, which knows its length)."""
    if args.seconds is not None:
        return None
    width, height = _render_size(scene, args)
    spp = args.spp or scene.spp
    samples = width * height * spp
    said = []

    def watch(fraction: float, seconds: float) -> None:
        if said or (seconds < NOTE_AFTER_SECONDS and fraction < NOTE_AFTER_FRACTION):
            return
        said.append(True)
        total = seconds / fraction
        if total > LONG_RENDER_SECONDS:
            _note([f"this render takes about {_duration(total)}: {width}x{height} x {spp} spp = "
                   f"{samples:.3g} samples at {samples / total / 1e6:.2f} M samples/s (measured on "
                   "its first launches); Ctrl-C stops it, --seconds T renders as many passes as fit "
                   "in T seconds"])
    return watch


def _note(lines: list[str]) -> None:
    from tqdm import tqdm         # a progress bar on the terminal is cleared for the line and redrawn
    for line in lines:
        tqdm.write(f"drtlab: note: {line}", file=sys.stderr)


def _refuse_what_whitted_ignores(scene, args) -> None:
    """The whitted integrator is deterministic (a fixed sub-pixel grid, no random samples): a flag
    that only chooses or seeds random samples would change nothing, so it is refused, not ignored."""
    from drtlab.estimators.registry import parse_integrator
    whitted = parse_integrator(args.integrator or scene.integrator).name == "whitted"
    if whitted:
        for flag, given in (("--variance", args.variance), ("--seed", "seed" in given_flags(args)),
                            ("--sampler", "sampler" in given_flags(args))):
            if given:
                what = "it has no standard error" if flag == "--variance" else "it would change nothing"
                raise InputError(flag, "the whitted integrator is deterministic (a fixed sub-pixel "
                                       f"grid, no random samples): {what}; use drt or path")


def _rescue(result, out: Path, exc: OSError):
    """A write that failed after the render (its names were checked before it: a full disk, a
    folder gone) does not lose the work: the image goes to a fresh folder under the system's
    temporary folder, and the one line says where."""
    import tempfile
    reason = exc.strerror or str(exc)
    try:
        rescued = result.write_exr(Path(tempfile.mkdtemp(prefix="drtlab-rescue-")) / out.name)
    except OSError:
        raise InputError("--out", f"cannot write {out}: {reason}; nor a copy in the temporary "
                                  "folder: the render is lost") from None
    raise InputError("--out", f"cannot write {out}: {reason}; the render is kept in "
                              f"{', '.join(str(p) for p in rescued)}") from None


def cmd_render(args) -> int:
    from drtlab.kernels.imageio import nonfinite_note, write_png
    from drtlab.kernels import render as R
    from drtlab.kernels.render import check_image_size
    from drtlab.kernels.scene_model.scene_checks import image_warnings, scene_warnings
    from drtlab.kernels.scene_model.scene_file import load_scene
    from drtlab.render_result import result_of

    scene = load_scene(args.scene, parse_overrides(args.set))
    _refuse_what_whitted_ignores(scene, args)
    out = Path(args.out) if args.out is not None else _default_out(scene, args)
    if out.suffix.lower() != ".exr":
        raise InputError("--out", f"must be a path ending in .exr, got {str(out)!r}")
    out = fields.writable_location(out, "--out")          # ~ expanded: where the check looked
    from drtlab.render_result import stderr_path
    # Every file the render writes, checked before it starts: a sibling that is a folder or a name
    # too long would otherwise fail after the work, with some files written.
    fields.output_files([out, out.with_suffix(".png"), *([stderr_path(out)] if args.variance else [])],
                        "--out")
    if args.res is not None:
        width, height = fields.resolution(args.res, "--res", aspect=scene.height / scene.width)
        check_image_size(width, height, moments=args.variance, field="--res")
    notes = [] if args.seconds is not None else _sampler_notes(args.sampler, args.spp or scene.spp)
    _warn(scene_warnings(scene) + notes)
    t0 = time.perf_counter()
    common = dict(sampler=args.sampler, integrator=args.integrator, seed=args.seed, res=args.res,
                  threads=args.threads, tile=args.tile, device=args.device,
                  progress=show_progress(args), variance=args.variance)
    if args.seconds is not None:
        stats = R.render_for_seconds(scene, args.seconds, **common)
    else:
        stats = R.render_with_stats(scene, spp=args.spp, watch=_time_watch(scene, args), **common)
    result = result_of(scene, stats, time.perf_counter() - t0, seconds_budget=args.seconds)
    try:
        exr, *stderr = result.write_exr(out)
        png = out.with_suffix(".png")
        write_png(png, result.image, result.metadata)
    except OSError as exc:
        _rescue(result, out, exc)
    files = [str(p) for p in (exr, png, *stderr)]
    meta = result.metadata
    estimator = (meta["integrator"] if meta["sampler"] == "none"
                 else f"{meta['sampler']}, {meta['integrator']}")
    print(f"wrote {', '.join(files[:-1])} and {files[-1]}: {meta['resolution']}, {stats.spp} spp, "
          f"{estimator}, render {stats.render_seconds:.3f} s, compile {stats.compile_seconds:.2f} s, "
          f"{result.samples_per_second / 1e6:.2f} M samples/s")
    _warn(image_warnings(scene, stats.image))
    bad = nonfinite_note(stats.image)
    if bad:
        print(f"drtlab: image: {bad} (a value overflowed float32 in the render); the files are kept "
              "to show where", file=sys.stderr)
        return 1
    return 0


# ---------------------------------------------------------------------------------------------------
# Experiments and ground truth
# ---------------------------------------------------------------------------------------------------

def cmd_experiment(args) -> int:
    from drtlab.experiments.study.backend import default_backend
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.cluster import open_executor
    from drtlab.experiments.paths import default_out_dir
    from drtlab.experiments.study.runner import run_experiment
    exp = load_experiment(args.experiment, args.profile)          # raises InputError, writes nothing
    fields.writable_location(args.out if args.out is not None else default_out_dir(exp.name), "--out",
                             folder=True)
    if args.gt_dir is not None:
        fields.writable_location(args.gt_dir, "--gt-dir", folder=True)
    backend = default_backend()
    # The cluster is reached (or started) before any rendering: an unreachable scheduler is one line.
    with open_executor(args.scheduler, args.workers, backend) as executor:
        try:
            summary = run_experiment(exp, out_dir=args.out, gt_root=args.gt_dir, backend=backend,
                                     threads=args.threads, fresh=args.fresh, progress=show_progress(args),
                                     argv=sys.argv, executor=executor,
                                     keep_images=True if args.keep_images else None, yes=args.yes,
                                     allow_other_files=args.allow_other_files)
        except InputError as e:
            if e.field != "out_dir":
                raise
            raise InputError("--out", e.message) from None      # the API's argument is this flag
    out = summary.out_dir
    _print_summary(exp, summary)
    print(f"report: {out / 'report.md'} (interactive: {out / 'report.html'})")
    return 0


def _print_summary(exp, result) -> None:
    """One line of run counts, then per study and scene its slopes and speed-ups (an
    `experiments.study.experiment_result.ExperimentResult`)."""
    stats = result.stats
    print(f"{exp.name} ({exp.profile}): {stats.get('runs_new', 0)} new runs, "
          f"{stats.get('runs_reused', 0)} reused, {result.wall_seconds:.1f} s")
    for study in result.summary.studies if result.summary is not None else []:
        for scene in study.scenes:
            parts = []
            for s in study.samplers:
                f = scene.fit(s)
                if f is not None:
                    parts.append(f"{s} {f.slope_text()}")
            top = [scene.row(s, study.spp[-1]) for s in study.samplers if s != study.baseline]
            sp = [f"{r.sampler} {r.speedup:.2f}x [{r.speedup_lo:.2f}, {r.speedup_hi:.2f}] {r.claim}"
                  if r.speedup_resolved else f"{r.sampler} not resolved" for r in top if r is not None]
            print(f"  {study.name:>18} {scene.scene:<14} " + "; ".join(parts)
                  + (f"; speed-up vs {study.baseline}: " + ", ".join(sp) if sp else ""))


# ---------------------------------------------------------------------------------------------------
# The parser
# ---------------------------------------------------------------------------------------------------

def _add_render(sub) -> None:
    r = sub.add_parser("render", help="render a scene to EXR + sRGB PNG",
                       formatter_class=Help)
    r.add_argument("scene", help="built-in scene name or path to a .toml or Mitsuba 3 .xml scene")
    count = r.add_mutually_exclusive_group()
    count.add_argument("--spp", type=int_flag(1, fields.MAX_COUNT), default=None,
                       help="samples per pixel (default: the scene's)")
    count.add_argument("--seconds", type=flag(fields.budget_seconds), default=None, metavar="T",
                       help="a time budget instead of --spp: as many whole passes of 64 spp as fit "
                            "in T seconds of rendering (at least one; the compile and a speed probe "
                            "at the full resolution come first, not counted); the EXR's drtlab:spp "
                            "says how many, and the image is that spp's, bit for bit")
    r.add_argument("--sampler", default=DEFAULT_SAMPLER, action=Given,
                   help=f"preset (uniform, stratified, importance), POINTS+STRATEGY, or POINTS alone "
                        f"(= POINTS+{POINTSET_STRATEGY}); `drtlab samplers` lists them (not with the "
                        "whitted integrator, which samples nothing)")
    r.add_argument("--integrator", default=None,
                   help="whitted, drt, path, direct or a plugin's (default: the scene's)")
    r.add_argument("--seed", type=int_flag(0, fields.MAX_SEED), default=0, action=Given,
                   help="root seed (not with the whitted integrator, which samples nothing)")
    r.add_argument("--res", type=resolution_flag, default=None,
                   help="N (width N, height from the scene's aspect) or WxH (default: the scene's)")
    r.add_argument("--set", action="append", metavar="KEY=VALUE", default=None,
                   help="override a scene value, e.g. --set camera.fov=30 (any scene), --set "
                        "materials.gloss100.exponent=50 (glossy) (repeatable; values are TOML)")
    r.add_argument("--threads", type=int_flag(1, 1024), default=None,
                   help="CPU threads (default: all cores)")
    r.add_argument("--tile", type=int_flag(1, 1 << 16), default=None,
                   help="tile edge in pixels (default: 16)")
    r.add_argument("--device", default="cpu", help="cpu or cuda")
    r.add_argument("--out", type=path_flag, default=None,
                   help="output .exr; a .png preview is written beside it (default: "
                        "results/renders/SCENE[-HASH]-INTEGRATOR-SAMPLER-WxH-SPPspp-sSEED.exr, HASH "
                        "of the --set overrides or a scene file, no sampler and seed for whitted)")
    r.add_argument("--variance", action="store_true",
                   help="also write OUT.stderr.exr: each pixel's standard error, sqrt(sample "
                        "variance / spp) of the same samples (exact for independent point sets, an "
                        "upper bound for stratified ones)")
    add_progress_flag(r)
    r.set_defaults(func=cmd_render)


def _add_experiment(sub) -> None:
    p = sub.add_parser(
        "experiment", help="run (or resume) an experiment: ground truth, runs, plots, report",
        formatter_class=Help,
        description="Run an experiment file (a built-in name such as stratified, importance, uniform, "
                    "all, or a path). Finished runs are kept and skipped on a rerun.")
    p.add_argument("experiment", metavar="NAME_OR_PATH",
                   help="a built-in experiment (experiments/*.toml) or a path to a .toml file")
    p.add_argument("--profile", default="quick",
                   help="profile section of the file to use (e.g. quick, full)")
    p.add_argument("--out", type=path_flag, default=None,
                   help="output folder (default: results/NAME)")
    add_cache_and_threads(p)
    p.add_argument("--fresh", action="store_true",
                   help="discard this experiment's earlier runs first (only the files drtlab wrote)")
    p.add_argument("--allow-other-files", action="store_true",
                   help="write into an --out folder that holds files drtlab did not write (without it "
                        "such a folder is refused); drtlab never removes or overwrites them")
    p.add_argument("--yes", action="store_true",
                   help="run even when the up-front estimate passes its limits (24 h of rendering, "
                        "90%% of this machine's memory); without it such a study is refused before "
                        "anything is written")
    p.add_argument("--keep-images", action="store_true",
                   help="keep every repetition's image in its cell file (default: the file's "
                        "keep_images; otherwise per cell only the first image and per-pixel moments)")
    add_progress_flag(p)
    from drtlab.experiments.study.cluster import scheduler_address
    cluster = p.add_mutually_exclusive_group()
    cluster.add_argument("--scheduler", type=flag(scheduler_address), default=None, metavar="ADDRESS",
                         help="render on the Dask cluster of this scheduler, tcp://HOST:PORT or "
                              "HOST:PORT; this process writes every result (default: none, render "
                              "in this process)")
    cluster.add_argument("--workers", type=int_flag(1, 1024), default=None, metavar="N",
                         help="render on a local Dask cluster of N single-threaded worker "
                              "processes; --threads then sets each render's threads, 1 unless "
                              "given (default: none, render in this process)")
    p.set_defaults(func=cmd_experiment)


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="drtlab", formatter_class=Help,
                description="Monte Carlo estimator studies for distribution ray tracing (Warp kernels).")
    from drtlab.version import __version__
    p.add_argument("--version", action="version", version=f"drtlab {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=Parser)
    sub.add_parser("scenes", help="list built-in scenes").set_defaults(func=cmd_scenes)
    sub.add_parser("samplers", help="list point sets, strategies, presets, integrators") \
        .set_defaults(func=cmd_samplers)
    _add_render(sub)
    _add_experiment(sub)
    from drtlab import cli_audit, cli_export, cli_ground_truth, cli_images, cli_lobe, cli_pointsets, cli_sources
    for add in (cli_ground_truth.add_ground_truth_command, cli_images.add_image_commands, cli_pointsets.add_pointset_commands, cli_lobe.add_lobe_command,
                cli_sources.add_sources_command, cli_audit.add_audit_command,
                cli_export.add_export_command):
        add(sub)
    # Every command takes --plugin; `main` loads the plugins before parsing (a plugin's names must be
    # known to the checks of the other arguments), so here it is only listed and accepted.
    for parser in [p, *sub.choices.values()]:
        parser.add_argument("--plugin", action="append", default=None, metavar="FILE_OR_MODULE",
                            help="load a plugin first: a .py file or an installed module that "
                                 "registers point sets, light selections, lobe samplers, "
                                 "strategies or error metrics (repeatable; docs/plugins.md)")
    return p


def _load_plugins(argv: list[str]) -> None:
    if not any(a.startswith("--plugin") for a in argv):
        return                  # most commands: no plugin machinery imported at start-up
    from drtlab.estimators.plugins import load_plugins, plugin_args
    load_plugins(plugin_args(argv))


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv, prepare=_load_plugins)


def run() -> None:
    """The `drtlab` program: `main` on the process's arguments, then the process ends at once.
    Python's own exit walks every object left alive for a last garbage collection, and Warp's import
    leaves ~150k of them: 0.25-0.4 s of every command, more than the import of anything a render
    needs but Warp (measured on `drtlab render` of a 16x12 image). Every file is written and closed
    by now; what the interpreter's exit does first still runs, in its order: other threads are
    joined (thread pools told to stop), then the exit handlers (logging's flush, Warp's native
    cleanup). Only the teardown of the objects is skipped."""
    import atexit
    import os
    import threading
    code = main()
    threading._shutdown()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):   # a closed pipe: run_main has pointed it away
            pass
    os._exit(code)


if __name__ == "__main__":
    run()
