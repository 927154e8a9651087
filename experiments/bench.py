"""`make bench`: render speed and compile time of every built-in scene -> results/bench/render.json.

Compile times are cold: Warp's kernel cache is pointed at an empty temporary folder, so each scene's
variant is built from source (the first one also builds Warp's precompiled header, reported apart).
Speed is samples per second after compilation, best of `--repeats`, on 1 thread and on all cores.
Peak RSS of this process is reported, and of the default experiment if its manifest records it.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="drtlab-bench")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sampler", default="stratified")
    ap.add_argument("--out", default="results/bench/render.json")
    args = ap.parse_args(argv)

    cache = tempfile.mkdtemp(prefix="drtlab-bench-cache-")
    import warp as wp
    wp.config.kernel_cache_dir = cache
    from drtlab import __version__
    from drtlab.kernels import CODE_VERSION
    from drtlab.kernels.render import get_kernel, features_of, render_with_stats
    from drtlab.warp_runtime import warp as _wp
    from drtlab.estimators.registry import parse_sampler
    from drtlab.kernels.scene_file import builtin_names, load_scene

    t0 = time.perf_counter()
    _wp()
    init_s = time.perf_counter() - t0
    threads_all = os.cpu_count() or 1
    rows = []
    spec = parse_sampler(args.sampler)
    for name in builtin_names():
        scene = load_scene(name)
        _, compile_s = get_kernel(features_of(scene, scene.integrator), spec, "cpu")
        speeds = {}
        for threads in sorted({1, threads_all}):
            best = None
            for rep in range(args.repeats):
                st = render_with_stats(scene, spp=args.spp, sampler=args.sampler, seed=rep,
                                       threads=threads, progress=False)
                best = st if best is None or st.render_seconds < best.render_seconds else best
            speeds[threads] = best
        one, many = speeds[1], speeds[threads_all]
        rows.append({
            "scene": name, "integrator": scene.integrator, "sampler": one.sampler,
            "resolution": f"{scene.width}x{scene.height}", "spp": args.spp,
            "variant": one.variant, "compile_seconds_cold": round(compile_s, 3),
            "render_seconds_1_thread": round(one.render_seconds, 4),
            f"render_seconds_{threads_all}_threads": round(many.render_seconds, 4),
            "msamples_per_second_1_thread": round(one.samples_per_second / 1e6, 3),
            f"msamples_per_second_{threads_all}_threads": round(many.samples_per_second / 1e6, 3),
            "thread_speedup": round(one.render_seconds / max(many.render_seconds, 1e-12), 2),
        })
        print(f"{name:14s} compile {compile_s:5.2f} s   1 thread {rows[-1]['msamples_per_second_1_thread']:6.2f}"
              f"   {threads_all} threads {rows[-1][f'msamples_per_second_{threads_all}_threads']:6.2f}"
              f" M samples/s   x{rows[-1]['thread_speedup']:.2f}", flush=True)

    experiment_rss = None
    manifest = Path("results/stratified/manifest.json")
    if manifest.exists():
        try:
            experiment_rss = json.loads(manifest.read_text()).get("peak_rss_mib")
        except (OSError, ValueError):
            experiment_rss = None
    result = {
        "drtlab_version": __version__, "code_version": CODE_VERSION,
        "warp_version": wp.config.version, "python": sys.version.split()[0],
        "machine": {"cpus": threads_all, "platform": platform.platform(),
                    "processor": platform.processor() or platform.machine()},
        "warp_init_seconds": round(init_s, 3),
        "note": "compile_seconds_cold of the first scene includes building Warp's precompiled header",
        "scenes": rows,
        "peak_rss_mib_bench": round(_peak_rss_mib(), 1),
        "peak_rss_mib_default_experiment": experiment_rss,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2) + "\n")
    os.replace(tmp, out)
    print(f"peak RSS (bench): {result['peak_rss_mib_bench']} MiB; default experiment: "
          f"{experiment_rss if experiment_rss is not None else 'not measured yet (make experiment-stratified)'}")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
