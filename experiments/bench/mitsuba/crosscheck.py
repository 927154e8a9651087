"""`make crosscheck`: drtlab against Mitsuba 3 on every scene both renderers read.

The scenes: each built-in drtlab can export (`drtlab export`: drtlab renders the built-in, Mitsuba
the exported file) and each Mitsuba 3 XML file of --scene-dir (both render the same file, drtlab
through its importer). Both render at the file's resolution, path depth and roulette depth, at one
--spp, --seeds times with independent seeds; the statistics and the pass rule are in
`crosscheck_stats`, Mitsuba's LLVM and its probe in `scene` (both in this folder).

Writes results/crosscheck/crosscheck.json (every number), crosscheck.md (the table, also printed) and
images.npz (every render, to look into a difference). Without Mitsuba or LLVM 19 it says why, writes
a JSON that says skipped, and exits 0. Exit 0 also when a scene fails: the table says which.
"""
from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from drtlab import fields
from drtlab.cli_args import Help, Parser, int_flag, run_main
from drtlab.errors import InputError
from drtlab.experiments.files import atomic_savez, atomic_write_text
from drtlab.experiments.paths import results_root

SCENE_DIR = Path(__file__).resolve().parents[3] / "tests" / "data" / "mitsuba"
VERSIONED = ("drtlab", "warp-lang", "mitsuba", "drjit", "numpy")
MITSUBA_SEED0 = 1000        # Mitsuba's seeds, apart from drtlab's (0..n-1) for the reader's sake


def log(msg: str) -> None:
    print(f"crosscheck: {msg}", file=sys.stderr, flush=True)


def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.bench.mitsuba.crosscheck", formatter_class=Help,
               description="drtlab vs Mitsuba 3 (llvm_ad_rgb) on every scene both read: the exportable "
                           "built-ins and the Mitsuba XML files of --scene-dir. Per scene: channel "
                           "means with standard errors across seeds, block L1 between the renderers "
                           "against each one's own seed-to-seed L1, per-pixel z.")
    p.add_argument("--seeds", type=int_flag(2, 1000), default=32,
                   help="independent renders per renderer and scene (the standard errors rest on their spread: "
                        "with few, a caustic's rare bright paths make them unreliable)")
    p.add_argument("--spp", type=int_flag(1, 1 << 20), default=32, help="samples per pixel of each render")
    p.add_argument("--threads", type=int_flag(1, 1024), default=os.cpu_count() or 1,
                   help="CPU threads of both renderers")
    p.add_argument("--scene-dir", type=Path, default=SCENE_DIR,
                   help="folder of Mitsuba 3 XML scenes (*.xml) rendered by both")
    p.add_argument("--only", action="append", default=None, metavar="NAME",
                   help="render only this scene (a built-in name or an XML file's stem; repeatable)")
    p.add_argument("--builtin-res", default="48x48", metavar="WxH",
                   help="resolution the built-ins are exported and rendered at")
    p.add_argument("--out-dir", type=Path, default=results_root() / "crosscheck", help="folder written")
    p.set_defaults(func=_command)
    return p


def _command(args) -> int:
    args.builtin_res = fields.resolution(args.builtin_res, "--builtin-res", aspect=1.0)
    if not args.scene_dir.is_dir():
        raise InputError("--scene-dir", f"must be a folder of .xml scenes, got {str(args.scene_dir)!r}")
    fields.writable_location(args.out_dir, "--out-dir", folder=True)
    jobs = _scenes(args)
    return run(args, jobs)


def _scenes(args) -> list[dict]:
    """The scene list: {name, kind, drtlab (what drtlab loads), xml (what Mitsuba loads)}; checked
    before any render, so a bad --only is one line."""
    from drtlab.kernels.scene_model.mitsuba_export import check_exportable
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
    overrides = {"scene.resolution": list(args.builtin_res)}
    jobs = []
    for name in builtin_names():
        if args.only and name not in args.only:
            continue
        try:
            check_exportable(load_scene(name, overrides))
        except InputError:
            continue                        # uses something Mitsuba lacks (the drt integrator, ...)
        jobs.append({"name": name, "kind": "built-in, exported", "drtlab": name, "overrides": overrides,
                     "xml": args.out_dir / "scenes" / f"{name}.xml"})
    for path in sorted(args.scene_dir.glob("*.xml")):
        if args.only and path.stem not in args.only:
            continue
        jobs.append({"name": path.stem, "kind": "Mitsuba XML", "drtlab": path, "overrides": None,
                     "xml": path})
    known = {j["name"] for j in jobs}
    missing = [n for n in (args.only or []) if n not in known]
    if missing:
        raise InputError("--only", f"{missing[0]!r} is neither an exportable built-in nor an .xml file in "
                                   f"{args.scene_dir} (scenes: {', '.join(sorted(known)) or 'none'})")
    return jobs


def _base(args, jobs) -> dict:
    from drtlab.experiments.provenance import cpu_model, package_versions
    return {"benchmark": "drtlab vs Mitsuba 3 on every scene both read",
            "machine": {"cpus": os.cpu_count(), "cpu_model": cpu_model()},
            "versions": {"python": sys.version.split()[0], **package_versions(VERSIONED)},
            "settings": {"seeds": args.seeds, "spp": args.spp, "threads": args.threads,
                         "drtlab_seeds": [0, args.seeds - 1],
                         "mitsuba_seeds": [MITSUBA_SEED0, MITSUBA_SEED0 + args.seeds - 1],
                         "scenes": [{"name": j["name"], "kind": j["kind"], "xml": str(j["xml"])}
                                    for j in jobs]}}


def _write_json(path: Path, obj: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, json.dumps(obj, indent=2, allow_nan=True, default=str) + "\n")


def _skip(args, reason: str, base: dict) -> int:
    out = args.out_dir / "crosscheck.json"
    _write_json(out, {**base, "skipped": True, "reason": reason})
    print(f"crosscheck: skipped: {reason} (wrote {out})")
    return 0


def run(args, jobs: list[dict]) -> int:
    base = _base(args, jobs)
    if importlib.util.find_spec("mitsuba") is None:
        return _skip(args, "mitsuba is not installed (pip install -e '.[compare]'; make crosscheck does)", base)
    from drtlab.experiments.bench.mitsuba import scene as ms
    libllvm, how = ms.find_libllvm()
    if libllvm is None:
        return _skip(args, f"Mitsuba's {ms.LLVM_VARIANT} needs LLVM 19: {how}", base)
    os.environ["DRJIT_LIBLLVM_PATH"] = libllvm
    log(f"probing {ms.LLVM_VARIANT} with {libllvm} ({how})")
    ok, why = ms.probe_variant(ms.LLVM_VARIANT)
    if not ok:
        return _skip(args, f"{why} (DRJIT_LIBLLVM_PATH={libllvm})", base)
    base["settings"]["drjit_libllvm_path"] = libllvm
    return _run_all(args, jobs, base, ms)


def _export(job: dict) -> None:
    from drtlab.kernels.scene_model.mitsuba_export import export_mitsuba
    from drtlab.kernels.scene_model.scene_file import load_scene, scene_data
    job["xml"].parent.mkdir(parents=True, exist_ok=True)
    export_mitsuba(load_scene(job["drtlab"], job["overrides"]), job["xml"],
                   scene_data(job["drtlab"], job["overrides"]))


def _drtlab_stack(job: dict, spp: int, seeds: list[int], threads: int) -> tuple[np.ndarray, dict]:
    from drtlab.estimators.defaults import DEFAULT_SAMPLER
    from drtlab.kernels.render import render_batch_with_stats
    from drtlab.kernels.scene_model.scene_file import load_scene
    scene = load_scene(job["drtlab"], job["overrides"])
    # Mitsuba splats a wide filter's samples into every pixel it covers: drtlab's +splat estimator
    # forms the same ratio, its 1/spp bias included. Filter importance sampling converges to the same
    # image (unbiased), but at 32 spp it rarely reaches a bright detail in the filter's far tail, so its
    # pixels there are heavy-tailed and their seed-to-seed standard errors too small.
    sampler = DEFAULT_SAMPLER + ("" if scene.camera.filter == "box" else "+splat")
    b = render_batch_with_stats(scene, seeds, spp=spp, sampler=sampler, threads=threads, progress=False)
    return b.images, {"sampler": sampler, "integrator": b.integrator, "max_depth": scene.max_depth,
                      "russian_roulette": bool(scene.russian_roulette), "rr_depth": scene.rr_depth,
                      "resolution": [b.width, b.height], "render_seconds": round(b.render_seconds, 2),
                      "compile_seconds": round(b.compile_seconds, 2), "variant": b.variant}


def _mitsuba_stack(mi, job: dict, spp: int, seeds: list[int]) -> tuple[np.ndarray, dict]:
    t0 = time.perf_counter()
    mscene = mi.load_file(str(job["xml"]))
    images = [np.array(mi.render(mscene, spp=spp, seed=s), dtype=np.float64) for s in seeds]
    integrator = " ".join(str(mscene.integrator()).split())     # e.g. PathIntegrator[ max_depth = 8, ... ]
    return np.stack(images), {"variant": mi.variant(), "integrator": integrator,
                              "seconds": round(time.perf_counter() - t0, 2)}


def _run_all(args, jobs: list[dict], base: dict, ms) -> int:
    from drtlab.experiments.bench.mitsuba.crosscheck_report import markdown
    from drtlab.experiments.bench.mitsuba.crosscheck_stats import crosscheck
    import drjit as dr
    import mitsuba as mi
    mi.set_variant(ms.LLVM_VARIANT)
    dr.set_thread_count(args.threads)
    t_start = time.perf_counter()
    scenes, arrays = {}, {}
    d_seeds = list(range(args.seeds))
    m_seeds = [MITSUBA_SEED0 + i for i in d_seeds]
    for job in jobs:
        if job["overrides"] is not None:
            _export(job)
        log(f"{job['name']}: drtlab, {args.seeds} x {args.spp} spp")
        d_stack, d_info = _drtlab_stack(job, args.spp, d_seeds, args.threads)
        log(f"{job['name']}: mitsuba, {args.seeds} x {args.spp} spp")
        m_stack, m_info = _mitsuba_stack(mi, job, args.spp, m_seeds)
        if d_stack.shape != m_stack.shape:      # a film the two read differently: no statistics
            result = {"pass": False, "error": f"image stacks differ: drtlab {list(d_stack.shape)}, "
                                              f"mitsuba {list(m_stack.shape)}"}
            log(f"{job['name']}: {result['error']}")
        else:
            result = crosscheck(d_stack, m_stack)
        scenes[job["name"]] = {"kind": job["kind"], "xml": str(job["xml"]), "drtlab": d_info,
                               "mitsuba": m_info, **result}
        arrays[f"{job['name']}__drtlab"], arrays[f"{job['name']}__mitsuba"] = d_stack, m_stack
        log(f"{job['name']}: {'pass' if result['pass'] else 'FAIL'}")
    out = {**base, "skipped": False, "scenes": scenes,
           "passed": sorted(n for n, s in scenes.items() if s["pass"]),
           "failed": sorted(n for n, s in scenes.items() if not s["pass"]),
           "total_seconds": round(time.perf_counter() - t_start, 1)}
    _write_json(args.out_dir / "crosscheck.json", out)
    table = markdown(out)
    atomic_write_text(args.out_dir / "crosscheck.md", table + "\n")
    atomic_savez(args.out_dir / "images.npz", **arrays)
    print(table)
    log(f"wrote {args.out_dir}/crosscheck.json, crosscheck.md, images.npz ({out['total_seconds']:.0f} s)")
    return 0


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
