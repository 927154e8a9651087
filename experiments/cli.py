"""The `drtlab` command. Bad input of any kind ends in one line naming the field, and exit code 2."""
from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

from drtlab.kernels.errors import InputError

EXIT_BAD_INPUT = 2


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (`drtlab: --spp: ...`) and exit code 2."""

    def error(self, message: str):
        m = re.match(r"argument ([^:]+): (.*)", message)
        if m:
            raise InputError(m.group(1).split("/")[-1], m.group(2))
        m = re.match(r"the following arguments are required: (.*)", message)
        if m:
            raise InputError(m.group(1), "required")
        m = re.match(r"unrecognized arguments: (.*)", message)
        if m:
            raise InputError(m.group(1).split()[0], f"unknown option; see `{self.prog} --help`")
        raise InputError("arguments", message)


def _int_at_least(low: int, high: int | None = None):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {text!r}")
        if value < low or (high is not None and value > high):
            rng = f">= {low}" if high is None else f"in [{low}, {high}]"
            raise argparse.ArgumentTypeError(f"must be an integer {rng}, got {value}")
        return value
    return parse


def cmd_scenes(args) -> int:
    from drtlab.kernels.scene import builtin_descriptions, load_scene
    for name, desc in builtin_descriptions().items():
        sc = load_scene(name)
        print(f"{name:14s} {sc.width}x{sc.height} {sc.spp:3d} spp {sc.integrator:7s} {desc}")
    return 0


def cmd_samplers(args) -> int:
    from drtlab.estimators.integrators import INTEGRATORS
    from drtlab.estimators.registry import POINTSETS, PRESETS
    from drtlab.estimators.strategies import STRATEGIES
    print("point sets:")
    for p in POINTSETS.values():
        print(f"  {p.name:12s} {p.description}")
    print("strategies:")
    for s in STRATEGIES.values():
        print(f"  {s.name:12s} {s.description}")
    print("presets (any POINTS+STRATEGY is accepted too):")
    for name, (p, s) in PRESETS.items():
        print(f"  {name:12s} {p}+{s}")
    print("integrators:")
    for i in INTEGRATORS.values():
        print(f"  {i.name:12s} {'biased  ' if i.biased else 'unbiased'} {i.description}")
    return 0


def cmd_render(args) -> int:
    from drtlab import __version__
    from drtlab.kernels import CODE_VERSION
    from drtlab.kernels.imageio import write_exr, write_png
    from drtlab.kernels.render import render_with_stats
    from drtlab.kernels.scene import load_scene

    scene = load_scene(args.scene)
    out = Path(args.out) if args.out else Path("results/renders") / (
        f"{scene.name}-{args.sampler.replace('+', '_')}-{args.spp or scene.spp}spp-s{args.seed}.exr")
    if out.suffix.lower() != ".exr":
        raise InputError("--out", f"must be a path ending in .exr, got {str(out)!r}")
    t0 = time.perf_counter()
    st = render_with_stats(scene, spp=args.spp, sampler=args.sampler, integrator=args.integrator,
                           seed=args.seed, res=args.res, threads=args.threads, tile=args.tile,
                           device=args.device)
    wall = time.perf_counter() - t0
    meta = {"scene": scene.name, "scene_hash": scene.content_hash(), "spp": st.spp,
            "sampler": st.sampler, "integrator": st.integrator, "seed": st.seed,
            "resolution": f"{st.width}x{st.height}", "version": __version__,
            "code_version": CODE_VERSION, "variant": st.variant, "device": st.device,
            "wall_seconds": round(wall, 4), "render_seconds": round(st.render_seconds, 4),
            "compile_seconds": round(st.compile_seconds, 4)}
    write_exr(out, st.image, meta)
    write_png(out.with_suffix(".png"), st.image, meta)
    print(f"wrote {out} and {out.with_suffix('.png').name}: {st.width}x{st.height}, {st.spp} spp, "
          f"{st.sampler}, {st.integrator}, render {st.render_seconds:.3f} s, compile "
          f"{st.compile_seconds:.2f} s, {st.samples_per_second / 1e6:.2f} M samples/s")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="drtlab", description="Monte Carlo estimator studies for distribution ray "
                "tracing (Warp kernels).")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    sub.add_parser("scenes", help="list built-in scenes").set_defaults(func=cmd_scenes)
    sub.add_parser("samplers", help="list point sets, strategies, presets, integrators") \
        .set_defaults(func=cmd_samplers)
    r = sub.add_parser("render", help="render a scene to EXR + sRGB PNG")
    r.add_argument("scene", help="built-in scene name or path to a .toml scene")
    r.add_argument("--spp", type=_int_at_least(1), default=None,
                   help="samples per pixel (default: the scene's)")
    r.add_argument("--sampler", default="stratified",
                   help="preset (uniform, stratified, importance) or POINTS+STRATEGY")
    r.add_argument("--integrator", default=None, help="whitted, drt or path (default: the scene's)")
    r.add_argument("--seed", type=_int_at_least(0, 2**32 - 1), default=0)
    r.add_argument("--res", default=None, help="N (width, scene aspect) or WxH")
    r.add_argument("--threads", type=_int_at_least(1, 1024), default=None)
    r.add_argument("--tile", type=_int_at_least(1), default=None, help="tile edge in pixels")
    r.add_argument("--device", default="cpu", help="cpu or cuda")
    r.add_argument("--out", default=None, help="output .exr (a .png preview is written beside it)")
    r.set_defaults(func=cmd_render)
    try:
        from drtlab.experiments.cli_experiments import add_subcommands
    except ImportError:  # the experiment runner is optional while it is being built
        add_subcommands = None
    if add_subcommands is not None:
        add_subcommands(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return args.func(args)
    except InputError as e:
        print(f"drtlab: {e.field}: {e.message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("drtlab: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
