"""`make bench`: render speed and compile time of every built-in scene, the `drtlab` program's
start-up (experiments/bench/startup.py), and how speed scales with resolution, spp, path depth,
threads and primitive count -> results/bench/render.json (and the primitive-count figure
results/bench/primitives.png, experiments/bench/primitives.py).

Compile times are cold: Warp's kernel cache is pointed at an empty temporary folder, so each scene's
variant is built from source (the first one also builds Warp's precompiled header, reported apart);
a scene whose variant an earlier scene already built (they differ only in runtime switches,
`Features.code_key`) reports which one (`kernel_shared_with`) instead of a compile time.
Speed is samples per second after compilation (the launches alone), best of `--repeats`, on 1 thread
and on all cores. The scaling tables (one scene, `--scaling-scene`) also give each render's whole
call time, upload and image readback included: at low spp and small images that per-run overhead,
not the tracing, bounds a convergence study's speed. Peak RSS of this process is reported, and of the
default experiment if its manifest records it.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from drtlab import fields
from drtlab.cli_args import Help, Parser, int_flag, run_main
from drtlab.estimators.defaults import DEFAULT_SAMPLER
from drtlab.experiments.bench.primitives import plot_primitives, primitives
from drtlab.experiments.bench.startup import print_startup, startup
from drtlab.experiments.paths import default_out_dir, results_root
from drtlab.experiments.provenance import peak_rss_mib as _peak_rss_mib

# The scaling sweeps: each varies one setting of --scaling-scene, the others at their defaults.
RESOLUTIONS = (32, 64, 128, 256, 512)           # square images, SCALING_SPP samples per pixel
SPPS = (1, 4, 16, 64, 256, 1024, 4096)          # at SCALING_RES^2 pixels
DEPTHS = (1, 2, 4, 8, 16)                       # max_depth at SCALING_RES^2, SCALING_SPP
SCALING_RES = 32
SCALING_SPP = 16
THREADS_RES, THREADS_SPP = 128, 64              # the thread sweep's image


def _best(render, repeats: int):
    """(best RenderStats by render seconds, best whole-call seconds) over `repeats` renders."""
    best, best_call = None, float("inf")
    for rep in range(repeats):
        t0 = time.perf_counter()
        st = render(seed=rep)
        best_call = min(best_call, time.perf_counter() - t0)
        best = st if best is None or st.render_seconds < best.render_seconds else best
    return best, best_call


def _row(setting: str, value, st, call_s: float) -> dict:
    return {setting: value, "resolution": f"{st.width}x{st.height}", "spp": st.spp,
            "threads": st.threads, "render_seconds": round(st.render_seconds, 5),
            "call_seconds": round(call_s, 5),
            "msamples_per_second": round(st.samples_per_second / 1e6, 4),
            "msamples_per_second_whole_call":
                round(st.width * st.height * st.spp / max(call_s, 1e-12) / 1e6, 4)}


def scaling(scene_name: str, sampler: str, repeats: int, threads_all: int) -> dict:
    """Samples/s of `scene_name` against resolution, spp, max depth and thread count."""
    from drtlab.kernels.render import render_with_stats
    from drtlab.kernels.scene_model.scene_file import load_scene
    base = load_scene(scene_name)

    def measure(setting, value, scene=base, res=SCALING_RES, spp=SCALING_SPP, threads=1):
        render_with_stats(scene, spp=1, sampler=sampler, res=8, threads=1, progress=False)
        st, call_s = _best(lambda seed: render_with_stats(
            scene, spp=spp, sampler=sampler, res=res, threads=threads, seed=seed,
            progress=False), repeats)
        return _row(setting, value, st, call_s)

    return {
        "scene": scene_name, "sampler": sampler, "repeats": repeats,
        "resolution": [measure("width", r, res=r) for r in RESOLUTIONS],
        "spp": [measure("spp", s, spp=s) for s in SPPS],
        "max_depth": [measure("max_depth", d, scene=load_scene(scene_name, {"scene.max_depth": d}))
                      for d in DEPTHS],
        "threads": [measure("threads", t, res=THREADS_RES, spp=THREADS_SPP, threads=t)
                    for t in sorted({1, 2, threads_all})],
    }


def scene_rows(spp: int, sampler: str, repeats: int, threads_all: int) -> list[dict]:
    """Per built-in scene: cold compile seconds and samples/s on 1 thread and on all cores."""
    from drtlab.estimators.registry import parse_sampler
    from drtlab.kernels.render import features_of, get_kernel, render_with_stats
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
    rows = []
    spec = parse_sampler(sampler)
    first_of = {}       # kernel variant (code_key) -> the scene that compiled it
    for name in builtin_names():
        scene = load_scene(name)
        features = features_of(scene, scene.integrator)
        _, compile_s = get_kernel(features, spec, "cpu")
        shared = first_of.setdefault(features.code_key(), name)
        speeds = {}
        for threads in sorted({1, threads_all}):
            speeds[threads], _ = _best(lambda seed: render_with_stats(
                scene, spp=spp, sampler=sampler, seed=seed, threads=threads, progress=False),
                repeats)
        one, many = speeds[1], speeds[threads_all]
        rows.append({
            "scene": name, "integrator": scene.integrator, "sampler": one.sampler,
            "resolution": f"{scene.width}x{scene.height}", "spp": spp,
            "variant": one.variant, "compile_seconds_cold": round(compile_s, 3),
            "kernel_shared_with": shared if shared != name else None,
            "render_seconds_1_thread": round(one.render_seconds, 4),
            f"render_seconds_{threads_all}_threads": round(many.render_seconds, 4),
            "msamples_per_second_1_thread": round(one.samples_per_second / 1e6, 3),
            f"msamples_per_second_{threads_all}_threads": round(many.samples_per_second / 1e6, 3),
            "thread_speedup": round(one.render_seconds / max(many.render_seconds, 1e-12), 2),
        })
        compiled = f"{compile_s:5.2f} s" if shared == name else f"shared with {shared}"
        print(f"{name:14s} compile {compiled:24s} 1 thread {rows[-1]['msamples_per_second_1_thread']:6.2f}"
              f"   {threads_all} threads {rows[-1][f'msamples_per_second_{threads_all}_threads']:6.2f}"
              f" M samples/s   x{rows[-1]['thread_speedup']:.2f}", flush=True)
    return rows


def print_scaling(sc: dict) -> None:
    print(f"\nscaling: {sc['scene']}, sampler {sc['sampler']}, best of {sc['repeats']}, 1 thread unless "
          f"the table varies threads; M samples/s of the launches and of the whole call")
    for key, label in (("resolution", "width"), ("spp", "spp"), ("max_depth", "max_depth"),
                       ("threads", "threads")):
        print(f"  {'by ' + label:14s} {'image':>9s} {'spp':>5s} {'thr':>3s} {'render s':>9s} "
              f"{'call s':>8s} {'M/s':>7s} {'M/s call':>9s}")
        for r in sc[key]:
            print(f"  {str(r[label]):14s} {r['resolution']:>9s} {r['spp']:5d} {r['threads']:3d} "
                  f"{r['render_seconds']:9.4f} {r['call_seconds']:8.4f} "
                  f"{r['msamples_per_second']:7.3f} {r['msamples_per_second_whole_call']:9.3f}")


def build_parser() -> Parser:
    ap = Parser(prog="python -m drtlab.experiments.bench", formatter_class=Help,
                description="Render speed and compile time of every built-in scene, and how speed "
                            "scales with resolution, spp, path depth, threads and primitive count.")
    ap.add_argument("--spp", type=int_flag(1, 1 << 20), default=64,
                    help="samples per pixel of the scene table")
    ap.add_argument("--repeats", type=int_flag(1, 1000), default=3,
                    help="renders per scene (the best is kept)")
    ap.add_argument("--sampler", default=DEFAULT_SAMPLER)
    ap.add_argument("--scaling-scene", default="cornell-box")
    ap.add_argument("--scaling-repeats", type=int_flag(1, 1000), default=2,
                    help="renders per point of the scaling sweeps")
    ap.add_argument("--startup-repeats", type=int_flag(1, 1000), default=5,
                    help="runs of each command timed for the start-up entry (the best is kept)")
    ap.add_argument("--no-scaling", action="store_true",
                    help="only the per-scene table and the start-up entry")
    ap.add_argument("--scaling-primitives", action="store_true",
                    help="only the primitive-count sweep (spheres: loop vs BVH; triangles), merged "
                         "into --out; the default run includes it")
    ap.add_argument("--out", type=Path, default=results_root() / "bench" / "render.json",
                    help="JSON written (the primitive-count figure goes beside it)")
    ap.set_defaults(func=_command)
    return ap


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


def _command(args) -> int:
    fields.writable_location(args.out, "--out")
    cache = tempfile.mkdtemp(prefix="drtlab-bench-cache-")
    import warp as wp
    wp.config.kernel_cache_dir = cache
    from drtlab.version import __version__
    from drtlab.kernels import CODE_VERSION
    from drtlab.warp_runtime import warp as _wp

    t0 = time.perf_counter()
    _wp()
    init_s = time.perf_counter() - t0
    threads_all = os.cpu_count() or 1
    if args.scaling_primitives:
        return _primitives_only(args, wp)
    rows = scene_rows(args.spp, args.sampler, args.repeats, threads_all)
    # The start-up commands run in processes of their own, with the caller's kernel cache (warm
    # after their first render), not this process's cold one.
    start = startup(args.startup_repeats)
    print_startup(start)
    sc = None
    if not args.no_scaling:
        sc = scaling(args.scaling_scene, args.sampler, args.scaling_repeats, threads_all)
        print_scaling(sc)

    experiment_rss = None
    manifest = default_out_dir("stratified") / "manifest.json"
    if manifest.exists():
        try:
            experiment_rss = json.loads(manifest.read_text()).get("peak_rss_mib")
        except (OSError, ValueError):
            experiment_rss = None
    result = {
        "drtlab_version": __version__, "code_version": CODE_VERSION,
        "warp_version": wp.config.version, "python": sys.version.split()[0],
        "machine": {"cpus": threads_all, "platform": platform.platform(),
                    "processor": platform.processor() or platform.machine(),
                    "load_average_1_5_15_at_end": list(os.getloadavg())},
        "warp_init_seconds": round(init_s, 3),
        "note": "compile_seconds_cold of the first scene includes building Warp's precompiled header",
        "scenes": rows,
        "startup": start,
        "scaling": sc,
        "primitives": None if args.no_scaling else _primitives(args),
        "peak_rss_mib_bench": _peak_rss_mib(),
        "peak_rss_mib_default_experiment": experiment_rss,
        "mitsuba_comparison": _mitsuba_comparison(Path(args.out)),
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2) + "\n")
    os.replace(tmp, out)
    print(f"peak RSS (bench): {result['peak_rss_mib_bench']} MiB; default experiment: "
          f"{experiment_rss if experiment_rss is not None else 'not measured yet (make experiment-stratified)'}")
    cmp = result["mitsuba_comparison"]
    if cmp is None:
        print("Mitsuba 3 comparison: not measured yet (make bench-compare)")
    else:
        print(f"Mitsuba 3 comparison ({cmp['file']}): drtlab / llvm_ad_rgb samples/s "
              f"{cmp['samples_per_second_drtlab_over_mitsuba_llvm_best']}x, time to equal RMSE "
              f"{cmp['time_to_equal_rmse_drtlab_over_mitsuba_llvm_best']}x")
        pairs = cmp["time_to_equal_rmse_drtlab_over_mitsuba_by_sampler_pair"]
        if pairs:
            print("  time to equal RMSE by sampler pair: " +
                  ", ".join(f"{k} {v}x" for k, v in pairs.items()))
    print(f"wrote {out}")
    return 0


def _mitsuba_comparison(out: Path) -> dict | None:
    """The headline ratios of `make bench-compare`'s compare.json beside --out, when it exists (the
    comparison needs the [compare] extra and LLVM 19, so it is its own target)."""
    path = out.with_name("compare.json")
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    r = d.get("ratios") or {}
    keys = ("samples_per_second_drtlab_over_mitsuba_llvm_best",
            "samples_per_cpu_second_drtlab_over_mitsuba_llvm",
            "time_to_equal_rmse_drtlab_over_mitsuba_llvm_best",
            "rmse_at_equal_spp_drtlab_over_mitsuba_llvm")
    pairs = {f"{p['drtlab_sampler']} / {p['mitsuba_sampler']}":
             p["time_to_equal_rmse_drtlab_over_mitsuba"]["full"]["time_ratio"]
             for p in (d.get("sampler_pairs") or {}).get("pairs", [])}
    return {"file": str(path), "resolution": d.get("settings", {}).get("resolution"),
            "spp": d.get("settings", {}).get("spp"), **{k: r.get(k) for k in keys},
            "time_to_equal_rmse_drtlab_over_mitsuba_by_sampler_pair": pairs}


def _primitives(args) -> dict:
    print("\nprimitive count: M samples/s on 1 thread (spheres: loop / BVH), BVH build seconds")
    result = primitives(args.sampler, args.scaling_repeats)
    figure = Path(args.out).with_name("primitives.png")
    plot_primitives(result, figure)
    print(f"sphere BVH crossover: {result['sphere_bvh_crossover']} spheres "
          f"({result['seconds']} s); wrote {figure}")
    return result


def _primitives_only(args, wp) -> int:
    """--scaling-primitives: the sweep alone, merged into an existing --out (other keys kept)."""
    out = Path(args.out)
    try:
        result = json.loads(out.read_text()) if out.exists() else {}
    except (OSError, ValueError):
        result = {}
    result["primitives"] = _primitives(args)
    result["warp_version"] = wp.config.version
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2) + "\n")
    os.replace(tmp, out)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
