"""`make bench-compare`: drtlab against Mitsuba 3 on Mitsuba's own Cornell box -> results/bench/compare.json.

One run renders `mi.cornell_box()` with Mitsuba 3 (`llvm_ad_rgb`, and `scalar_rgb`) and drtlab's
built-in `cornell-box` (its translation, verified number for number first) at equal resolution, spp,
path depth (Mitsuba's max_depth convention, which drtlab shares), box pixel filter and thread count.

* Speed: samples per second after a warm-up render (Mitsuba's JIT compile and drtlab's kernel compile
  are reported apart), best and median of --repeats timed renders, interleaved across renderers so
  that a noisy neighbour on the machine hits all of them alike; samples per CPU-second too.
* Time to equal RMSE: one shared reference, Mitsuba llvm_ad_rgb at --ref-spp (rendered as
  ref-spp / spp independent batches, which also give its per-pixel standard error). Each renderer's
  RMSE at --spp is measured against it (the reference's own noise subtracted), and the time it needs
  to reach Mitsuba-LLVM's RMSE is extrapolated with RMSE ~ spp^-1/2 (time * (rmse / target)^2); the
  extrapolation is checked by measuring each renderer's RMSE again at a higher spp. Both over the
  whole image and without the pixels at and around the light: their partial coverage of the bright
  emitter carries most of the whole image's MSE, so that RMSE rests on few pixels and is noisy.
* Agreement: drtlab's mean of --seeds independent renders against the reference: per-channel image
  means with standard errors from the independent renders, and per-pixel z-scores (mean, sd,
  fraction |z| > 3, with what finite-sample standard errors make of them under agreement).

Mitsuba is the optional extra `[compare]`; its LLVM backend needs LLVM 19 (DRJIT_LIBLLVM_PATH). When
either is missing the run says why in one line, writes a JSON that says skipped and why, and exits 0.

This module is the command line and the order of the run; the renders are in `render`, the
statistics in `stats`, the printed table in `report`, the matched sampler pairs in `samplers`, and
Mitsuba's side (LLVM, its scene dict, the translation check) in `scene` (all in this folder).
"""
from __future__ import annotations

import importlib.util
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from drtlab import fields
from drtlab.cli_args import Help, Parser, int_flag, resolution_flag, run_main
from drtlab.errors import InputError
from drtlab.experiments.bench.mitsuba import stats as cs
from drtlab.experiments.bench.mitsuba.render import (DRTLAB, LLVM, REF_SEED0, RENDERERS, SAMPLER, SCENE, Rig,
                                               independent_renders, log, reference_batches,
                                               timed_renders, warm_up)
from drtlab.experiments.bench.mitsuba.report import markdown
from drtlab.experiments.files import atomic_savez, atomic_write_text
from drtlab.experiments.paths import results_root
from drtlab.experiments.provenance import cpu_model, package_versions, peak_rss_mib

VERSIONED = ("drtlab", "warp-lang", "mitsuba", "drjit", "numpy")


# ---------------------------------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------------------------------

MITSUBA_RR_DEPTH = 5        # Mitsuba 3's path integrator default


def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.bench.mitsuba.compare", formatter_class=Help,
               description="drtlab vs Mitsuba 3 (llvm_ad_rgb, scalar_rgb) on mi.cornell_box(): "
                           "samples/s, time to equal RMSE against one shared reference, and agreement "
                           "of the high-spp images within their standard errors.")
    p.add_argument("--res", type=resolution_flag, default="128x128", metavar="WxH",
                   help="resolution of every render: WxH, or N for N x N")
    p.add_argument("--spp", type=int_flag(1, 1 << 20), default=256,
                   help="samples per pixel of each timed render (and of each independent render)")
    p.add_argument("--ref-spp", type=int_flag(2, 1 << 24), default=4096,
                   help="spp of the shared reference (Mitsuba llvm_ad_rgb), a multiple of --spp: "
                        "rendered as ref-spp/spp independent batches")
    p.add_argument("--repeats", type=int_flag(1, 100), default=3,
                   help="timed renders per renderer (best and median are reported)")
    p.add_argument("--seeds", type=int_flag(2, 1000), default=8,
                   help="independent drtlab renders at --spp for the agreement check and its "
                        "standard errors (at least --repeats; the timed renders are among them)")
    p.add_argument("--max-depth", type=int_flag(1, 1000), default=8,
                   help="path depth, Mitsuba's convention (1: emitters seen directly, 2: direct light)")
    p.add_argument("--threads", type=int_flag(1, 1024), default=os.cpu_count() or 1,
                   help="CPU threads of both renderers")
    p.add_argument("--no-roulette", action="store_true",
                   help="render drtlab without Russian roulette (Mitsuba keeps its default rr_depth "
                        "5): more work per drtlab sample, less variance")
    p.add_argument("--no-scalar", action="store_true", help="leave out Mitsuba's scalar_rgb variant")
    p.add_argument("--no-sampler-pairs", action="store_true",
                   help="leave out the matched sampler pairs (drtlab stratified / cmj / sobol against "
                        "Mitsuba stratified / multijitter / ldsampler, --seeds renders each)")
    p.add_argument("--warm-caches", action="store_true",
                   help="use Warp's and Dr.Jit's on-disk kernel caches as found (WARP_CACHE_PATH, "
                        "DRJIT_CACHE_DIR or ~/.drjit); by default both start empty, so the compile "
                        "times reported are cold")
    p.add_argument("--save-images", type=Path, default=None, metavar="FILE.npz",
                   help="also save every image (drtlab renders, Mitsuba timed renders, reference "
                        "batches) to this .npz, to look into a disagreement")
    p.add_argument("--out", type=Path, default=results_root() / "bench" / "compare.json",
                   help="JSON written")
    p.set_defaults(func=_command)
    return p


def _check_args(args) -> None:
    """The checks argparse cannot make, before anything is imported or rendered."""
    args.width, args.height = fields.resolution(args.res, "--res", aspect=1.0)   # Mitsuba's box is square
    if args.ref_spp % args.spp or args.ref_spp < 2 * args.spp:
        raise InputError("--ref-spp", f"must be a multiple of --spp ({args.spp}) and at least twice it, "
                                      f"got {args.ref_spp}")
    if args.out.suffix.lower() != ".json":
        raise InputError("--out", f"must be a path ending in .json, got {str(args.out)!r}")
    fields.writable_location(args.out, "--out")
    if args.save_images is not None:
        if args.save_images.suffix.lower() != ".npz":
            raise InputError("--save-images", f"must be a path ending in .npz, got {str(args.save_images)!r}")
        fields.writable_location(args.save_images, "--save-images")


def _command(args) -> int:
    _check_args(args)
    return run(args)


# ---------------------------------------------------------------------------------------------------
# Result file
# ---------------------------------------------------------------------------------------------------

def _base(args) -> dict:
    """What every result says, a skipped one too: the machine, the versions and the settings."""
    machine = {"cpus": os.cpu_count(), "cpu_model": cpu_model(), "platform": platform.platform(),
               "load_average_1_5_15_at_start": [round(x, 2) for x in os.getloadavg()]}
    return {"benchmark": "drtlab vs Mitsuba 3, mi.cornell_box()", "machine": machine,
            "versions": {"python": sys.version.split()[0], **package_versions(VERSIONED)},
            "settings": {"scene": SCENE, "resolution": f"{args.width}x{args.height}", "spp": args.spp,
                         "ref_spp": args.ref_spp, "repeats": args.repeats,
                         "drtlab_independent_renders": max(args.seeds, args.repeats),
                         "max_depth": args.max_depth, "threads": args.threads, "pixel_filter": "box"}}


def _write(out: Path, result: dict) -> None:
    # NaN stays NaN (not null): a statistic of one render, e.g. rmse_from_spread at --repeats 1.
    out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out, json.dumps(result, indent=2, allow_nan=True) + "\n")


def _skip(out: Path, reason: str, base: dict) -> int:
    _write(out, {**base, "skipped": True, "reason": reason})
    print(f"bench-compare: skipped: {reason} (wrote {out})")
    return 0


def _reference_facts(ref_stack: np.ndarray, ref_seconds: float, spp: int, ms) -> dict:
    n_ref = len(ref_stack)
    return {"renderer": f"mitsuba {ms.LLVM_VARIANT}", "spp": n_ref * spp, "batches": n_ref,
            "batch_spp": spp, "seeds": [REF_SEED0, REF_SEED0 + n_ref - 1],
            "render_seconds": round(ref_seconds, 2),
            "noise_mse": float(np.mean(ref_stack.var(axis=0, ddof=1) / n_ref)),
            "why": "the fastest of the renderers; drtlab's mean of independent renders is "
                   "the agreement check against it"}


def _equal_rmse_facts(renderers: dict, light: np.ndarray, spp: int, ms) -> dict:
    return {
        "target_rmse": {reg: renderers[LLVM]["rmse"][reg]["rmse_vs_reference"] for reg in cs.REGION_TAG},
        "target": f"Mitsuba {ms.LLVM_VARIANT}'s RMSE at {spp} spp against the reference",
        "method": "MSE of each renderer's independent renders at the benchmark spp against the shared "
                  "reference, minus the reference's own noise (its mean per-pixel variance); Mitsuba "
                  "LLVM's reference batches count too, each against the mean of the others. Time to "
                  "the target extrapolated as time * (rmse / target)^2 (RMSE ~ spp^-1/2, exact in "
                  "expectation for independent samples); at_higher_spp measures each renderer's "
                  "mean of its independent renders against that law",
        "regions": {"full": "every pixel",
                    "excl_light": f"without the {int(light.sum())} pixels that see the light or "
                                  "touch one that does (reference brighter than 1 in a channel, "
                                  "dilated by one pixel): partial coverage of the radiance-18 "
                                  "emitter makes them carry most of the full image's MSE, so the "
                                  "full-image RMSE rests on few pixels (effective_pixels)"}}


# ---------------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------------

def run(args) -> int:
    t_start = time.perf_counter()
    base = _base(args)
    # Mitsuba and its LLVM, each checked before anything is imported or timed.
    if importlib.util.find_spec("mitsuba") is None:
        return _skip(args.out, "mitsuba is not installed (pip install -e '.[compare]')", base)
    from drtlab.experiments.bench.mitsuba import scene as ms
    libllvm, how = ms.find_libllvm()
    if libllvm is None:
        return _skip(args.out, f"Mitsuba's {ms.LLVM_VARIANT} needs LLVM 19: {how}", base)
    os.environ["DRJIT_LIBLLVM_PATH"] = libllvm
    base["settings"]["drjit_libllvm_path"] = libllvm
    cold_dir = None if args.warm_caches else Path(tempfile.mkdtemp(prefix="drtlab-bench-compare-"))
    try:
        log(f"probing {ms.LLVM_VARIANT} with {libllvm} ({how})")
        probe_env = {} if cold_dir is None else {"DRJIT_CACHE_DIR": str(cold_dir / "probe")}
        ok, why = ms.probe_variant(ms.LLVM_VARIANT, env=probe_env)
        if not ok:
            return _skip(args.out, f"{why} (DRJIT_LIBLLVM_PATH={libllvm})", base)
        return _run_compare(args, ms, base, cold_dir, t_start)
    finally:
        if cold_dir is not None:
            shutil.rmtree(cold_dir, ignore_errors=True)


def _point_kernel_caches(cold_dir: Path | None, settings: dict) -> None:
    """Without --warm-caches both kernel caches start empty, so the warm-up's compile times are cold
    ones; Dr.Jit's must be set before drjit is imported."""
    if cold_dir is not None:
        os.environ["DRJIT_CACHE_DIR"] = str(cold_dir / "drjit")
    import warp as wp
    if cold_dir is not None:
        wp.config.kernel_cache_dir = str(cold_dir / "warp")
    settings["kernel_caches"] = "as found (--warm-caches)" if cold_dir is None else \
        "empty temporary caches: compile times are cold"


def _mitsuba_variants(args, ms):
    """(mitsuba, drjit, the variants to time); variants is None when llvm_ad_rgb is missing."""
    import drjit as dr
    import mitsuba as mi
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    variants = [ms.LLVM_VARIANT] + ([] if args.no_scalar else [ms.SCALAR_VARIANT])
    missing = [v for v in variants if v not in mi.variants()]
    if ms.LLVM_VARIANT in missing:
        return mi, dr, None
    if missing:
        log(f"leaving out {missing}: not in this mitsuba build")
        variants = [v for v in variants if v not in missing]
    dr.set_thread_count(args.threads)
    return mi, dr, variants


def _drtlab_scene(args, ms, mi, variants: list[str], settings: dict):
    """drtlab's scene and its translation check: Mitsuba's dict is the source of truth."""
    from drtlab.kernels.scene_model.scene_file import load_scene
    W, H = args.width, args.height
    mi.set_variant(ms.LLVM_VARIANT)
    d = ms.scene_dict(mi, W, H, args.spp, args.max_depth)
    overrides = {"scene.max_depth": args.max_depth}
    if not args.no_roulette:
        # Mitsuba's path integrator plays roulette from its rr_depth = 5 on, with drtlab's rule
        # (survival min(max throughput, 0.95)). Mitsuba tests after the 5th vertex's light sample,
        # drtlab before the 6th vertex's (drtlab's depth counts from 0): drtlab traces one more
        # closest-hit ray per long path, so the match is conservative for drtlab's speed.
        overrides.update({"scene.russian_roulette": True, "scene.rr_depth": MITSUBA_RR_DEPTH})
    vfov = ms.vfov_for(d, W, H)
    if abs(vfov - load_scene(SCENE).camera.vfov_deg) > 1e-9:
        overrides["camera.fov"] = vfov          # Mitsuba's fov_axis 'smaller' on a non-square film
    scene = replace(load_scene(SCENE, overrides), width=W, height=H)
    check = ms.translation_check(d, scene, W, H)
    settings.update({
        "drtlab": {"scene": SCENE, "overrides": overrides, "sampler": SAMPLER, "integrator": "path",
                   "russian_roulette": bool(scene.russian_roulette), "vfov_deg": scene.camera.vfov_deg},
        "mitsuba": {"scene": "mi.cornell_box()", "integrator": d["integrator"],
                    "rr_depth": f"{MITSUBA_RR_DEPTH} (Mitsuba's default)",
                    "sampler": d["sensor"]["sampler"]["type"], "rfilter": "box",
                    "fov": d["sensor"]["fov"], "fov_axis": d["sensor"].get("fov_axis"),
                    "variants": variants},
        "translation_check": {k: v for k, v in check.items() if k != "checks"} | {"checks": check["checks"]},
    })
    if not check["ok"]:
        log(f"drtlab's {SCENE} is not mi.cornell_box(): " + "; ".join(
            f"{c['what']} off by {c['deviation']:.3g}" for c in check["failed"][:5]))
    else:
        log(f"{SCENE} matches mi.cornell_box(): {check['n_checks']} checks, geometry within "
            f"{check['max_geometry_deviation']:.1e}")
    return scene, check


def _run_compare(args, ms, base: dict, cold_dir: Path | None, t_start: float) -> int:
    _point_kernel_caches(cold_dir, base["settings"])
    mi, dr, variants = _mitsuba_variants(args, ms)
    if variants is None:
        return _skip(args.out, f"this mitsuba build has no {ms.LLVM_VARIANT} variant", base)
    scene, check = _drtlab_scene(args, ms, mi, variants, base["settings"])
    rig = Rig(mi=mi, dr=dr, ms=ms, variants=variants, scene=scene, width=args.width, height=args.height,
              spp=args.spp, max_depth=args.max_depth, threads=args.threads)
    renderers = warm_up(rig)
    images: dict[str, list[np.ndarray]] = {name: [] for name in RENDERERS}
    runs = timed_renders(rig, args.repeats, images)
    cs.add_timings(renderers, runs, args.width * args.height * args.spp)
    independent_renders(rig, args.repeats, max(args.seeds, args.repeats), images[DRTLAB])
    ref_stack, ref_seconds = reference_batches(rig, args.ref_spp // args.spp)
    if args.save_images is not None:
        args.save_images.parent.mkdir(parents=True, exist_ok=True)
        atomic_savez(args.save_images, reference_batches=ref_stack,
                     **{k: np.stack(v) for k, v in images.items() if v})
        log(f"saved images to {args.save_images}")
    light = cs.add_rmse(renderers, images, ref_stack, args.spp)
    cs.add_time_to_equal_rmse(renderers, args.spp)
    agree, extra = cs.all_agreements(images, ref_stack)
    pairs = None
    if not args.no_sampler_pairs:
        from drtlab.experiments.bench.mitsuba.samplers import sampler_pairs
        baseline = {"drtlab": (np.stack(images[DRTLAB]), renderers[DRTLAB]["best_seconds"]),
                    "mitsuba": (ref_stack, renderers[LLVM]["best_seconds"])}
        pairs = sampler_pairs(rig, max(args.seeds, args.repeats), baseline, ref_stack)
    result = {
        **base, "skipped": False, "renderers": renderers, "ratios": cs.ratios(renderers),
        "reference": _reference_facts(ref_stack, ref_seconds, args.spp, ms),
        "equal_rmse": _equal_rmse_facts(renderers, light, args.spp, ms),
        "agreement": agree, "agreement_extra": extra,
        **({"sampler_pairs": pairs} if pairs is not None else {}),
        "load_average_1_5_15_at_end": [round(x, 2) for x in os.getloadavg()],
        "peak_rss_mib": peak_rss_mib(),
        "total_seconds": round(time.perf_counter() - t_start, 1),
    }
    return _finish(args.out, result, check)


def _finish(out: Path, result: dict, check: dict) -> int:
    _write(out, result)
    print(markdown(result))
    if not result["agreement"]["agree"]:
        log("DISAGREEMENT between drtlab and Mitsuba at high spp: see agreement in " + str(out))
    if not check["ok"]:
        log(f"translation check FAILED: drtlab's {SCENE} differs from mi.cornell_box()")
    log(f"wrote {out} ({result['total_seconds']:.0f} s)")
    return 0


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
