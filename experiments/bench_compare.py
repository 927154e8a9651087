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
"""
from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import json
import math
import os
import platform
import re
import resource
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from drtlab import fields
from drtlab.errors import InputError

EXIT_BAD_INPUT = 2
SCENE = "cornell-box"
SAMPLER = "importance"          # independent points, BSDF + light sampling with MIS: Mitsuba's `path`
WARMUP_SPP = 4
REF_SEED0 = 100_000             # reference batches: seeds disjoint from every benchmark render
SCALAR_SEED0 = 200
LLVM = "mitsuba_llvm_ad_rgb"
SCALAR = "mitsuba_scalar_rgb"
DRTLAB = "drtlab"


def _log(msg: str) -> None:
    print(f"bench-compare: {msg}", file=sys.stderr, flush=True)


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# ---------------------------------------------------------------------------------------------------
# Command line (drtlab's convention: a bad flag is one line `drtlab: --flag: message`, exit code 2)
# ---------------------------------------------------------------------------------------------------

class _Parser(argparse.ArgumentParser):
    def error(self, message: str):
        m = re.match(r"argument ([^:]+): (.*)", message)
        if m:
            raise InputError(m.group(1).split("/")[-1], m.group(2))
        m = re.match(r"unrecognized arguments: (.*)", message)
        if m:
            raise InputError(m.group(1).split()[0], f"unknown option; see `{self.prog} --help`")
        raise InputError("arguments", message)


def _int_flag(low: int, high: int | None = None):
    def parse(text: str) -> int:
        try:
            return fields.int_text(text, "", low, high)
        except InputError as e:
            raise argparse.ArgumentTypeError(e.message) from None
    return parse


def _res_flag(text: str) -> tuple[int, int]:
    try:
        return fields.resolution(text, "", aspect=1.0)      # Mitsuba's box is square: N means N x N
    except InputError as e:
        raise argparse.ArgumentTypeError(e.message) from None


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """Shows a flag's default, except for on/off switches."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False:
            return action.help
        return super()._get_help_string(action)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="python -m drtlab.experiments.bench_compare", formatter_class=_Help,
                description="drtlab vs Mitsuba 3 (llvm_ad_rgb, scalar_rgb) on mi.cornell_box(): "
                            "samples/s, time to equal RMSE against one shared reference, and agreement "
                            "of the high-spp images within their standard errors.")
    p.add_argument("--res", type=_res_flag, default="128x128", metavar="WxH",
                   help="resolution of every render: WxH, or N for N x N")
    p.add_argument("--spp", type=_int_flag(1, 1 << 20), default=256,
                   help="samples per pixel of each timed render (and of each independent render)")
    p.add_argument("--ref-spp", type=_int_flag(2, 1 << 24), default=4096,
                   help="spp of the shared reference (Mitsuba llvm_ad_rgb), a multiple of --spp: "
                        "rendered as ref-spp/spp independent batches")
    p.add_argument("--repeats", type=_int_flag(1, 100), default=3,
                   help="timed renders per renderer (best and median are reported)")
    p.add_argument("--seeds", type=_int_flag(2, 1000), default=8,
                   help="independent drtlab renders at --spp for the agreement check and its "
                        "standard errors (at least --repeats; the timed renders are among them)")
    p.add_argument("--max-depth", type=_int_flag(1, 1000), default=8,
                   help="path depth, Mitsuba's convention (1: emitters seen directly, 2: direct light)")
    p.add_argument("--threads", type=_int_flag(1, 1024), default=os.cpu_count() or 1,
                   help="CPU threads of both renderers")
    p.add_argument("--no-scalar", action="store_true", help="leave out Mitsuba's scalar_rgb variant")
    p.add_argument("--warm-caches", action="store_true",
                   help="use Warp's and Dr.Jit's on-disk kernel caches as found (WARP_CACHE_PATH, "
                        "DRJIT_CACHE_DIR or ~/.drjit); by default both start empty, so the compile "
                        "times reported are cold")
    p.add_argument("--save-images", type=Path, default=None, metavar="FILE.npz",
                   help="also save every image (drtlab renders, Mitsuba timed renders, reference "
                        "batches) to this .npz, to look into a disagreement")
    p.add_argument("--out", type=Path, default=Path("results/bench/compare.json"), help="JSON written")
    return p


def parse_args(argv: list[str] | None):
    args = build_parser().parse_args(argv)
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
    return args


# ---------------------------------------------------------------------------------------------------
# Renders
# ---------------------------------------------------------------------------------------------------

def _drtlab_render(scene, spp: int, seed: int, threads: int) -> tuple[np.ndarray, dict]:
    from drtlab.kernels.render import render_with_stats
    c0, t0 = time.process_time(), time.perf_counter()
    st = render_with_stats(scene, spp=spp, sampler=SAMPLER, integrator="path", seed=seed,
                           threads=threads, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return st.image, {"seed": seed, "seconds": st.render_seconds, "cpu_seconds": cpu,
                      "call_seconds": wall, "compile_seconds": st.compile_seconds, "variant": st.variant}


def _mitsuba_render(mi, dr, variant: str, scene, spp: int, seed: int) -> tuple[np.ndarray, dict]:
    mi.set_variant(variant)
    jit = variant.startswith("llvm")
    if jit:
        dr.kernel_history()                                     # clears the history
    c0, t0 = time.process_time(), time.perf_counter()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    info = {"seed": seed, "seconds": wall, "cpu_seconds": cpu}
    if jit:
        hist = [k for k in dr.kernel_history() if k.get("cache_hit") is not None]
        info["jit_seconds"] = sum((k.get("codegen_time") or 0.0) + (k.get("backend_time") or 0.0)
                                  for k in hist) / 1000.0
        info["kernels_compiled"] = sum(1 for k in hist if not k.get("cache_hit"))
        info["kernels_from_disk_cache"] = sum(1 for k in hist if k.get("cache_hit") and k.get("cache_disk"))
        info["kernels_from_memory_cache"] = sum(1 for k in hist if k.get("cache_hit")
                                                and not k.get("cache_disk"))
        info["kernel_launches"] = len(hist)
    return img, info


def _timing_summary(runs: list[dict], samples: int) -> dict:
    secs = sorted(r["seconds"] for r in runs)
    best, med = secs[0], float(np.median(secs))
    best_run = min(runs, key=lambda r: r["seconds"])
    return {"best_seconds": round(best, 4), "median_seconds": round(med, 4),
            "msamples_per_second_best": round(samples / best / 1e6, 4),
            "msamples_per_second_median": round(samples / med / 1e6, 4),
            "msamples_per_cpu_second_best": round(samples / max(min(r["cpu_seconds"] for r in runs),
                                                                1e-12) / 1e6, 4),
            "cpu_utilisation_of_best": round(best_run["cpu_seconds"] / max(best_run["seconds"], 1e-12), 2)}


# ---------------------------------------------------------------------------------------------------
# Statistics
# ---------------------------------------------------------------------------------------------------

def _mse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean((a - b) ** 2))


def _channel_means(stack: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean image value per channel and its standard error from the independent renders in `stack`."""
    per = stack.mean(axis=(1, 2))                              # (n, 3)
    return per.mean(axis=0), per.std(axis=0, ddof=1) / math.sqrt(len(per))


def _welch_dof(a2: np.ndarray, na: int, b2: np.ndarray, nb: int) -> np.ndarray:
    return (a2 + b2) ** 2 / (a2 ** 2 / (na - 1) + b2 ** 2 / (nb - 1))


def agreement(a_stack: np.ndarray, b_stack: np.ndarray, a_name: str, b_name: str) -> dict:
    """Does the mean of the renders in `a_stack` agree with that of `b_stack` within standard errors?

    Both are stacks of independent renders (n, H, W, 3). Per channel: the image mean's difference over
    its standard error. Per pixel and channel: z = (mean_a - mean_b) / sqrt(se_a^2 + se_b^2) with
    standard errors from the spread of the renders, so z follows roughly Student's t with the Welch
    degrees of freedom under agreement: its expected sd and |z| > 3 fraction are given alongside."""
    from scipy import stats as sst
    na, nb = len(a_stack), len(b_stack)
    ma, sa = _channel_means(a_stack)
    mb, sb = _channel_means(b_stack)
    se = np.sqrt(sa ** 2 + sb ** 2)
    cz = (ma - mb) / np.where(se > 0, se, np.inf)
    cdof = _welch_dof(sa ** 2, na, sb ** 2, nb)
    channels = []
    for c, name in enumerate("RGB"):
        channels.append({"channel": name, f"{a_name}_mean": float(ma[c]), f"{a_name}_se": float(sa[c]),
                         f"{b_name}_mean": float(mb[c]), f"{b_name}_se": float(sb[c]),
                         "difference": float(ma[c] - mb[c]),
                         "relative_difference": float((ma[c] - mb[c]) / mb[c]) if mb[c] else None,
                         "z": float(cz[c]), "welch_dof": float(cdof[c]),
                         "p_two_sided": float(2 * sst.t.sf(abs(cz[c]), cdof[c]))})
    a_mean, b_mean = a_stack.mean(axis=0), b_stack.mean(axis=0)
    a2 = a_stack.var(axis=0, ddof=1) / na
    b2 = b_stack.var(axis=0, ddof=1) / nb
    d2 = a2 + b2
    valid = d2 > 1e-30
    z = np.zeros_like(d2)
    z[valid] = (a_mean - b_mean)[valid] / np.sqrt(d2[valid])
    zv = z[valid]
    dof = _welch_dof(a2[valid], na, b2[valid], nb)
    dof_sd = dof[dof > 2.05]
    n = int(valid.sum())
    frac3 = float(np.mean(np.abs(zv) > 3)) if n else float("nan")
    exp_frac3 = float(np.mean(2 * sst.t.sf(3.0, dof))) if n else float("nan")
    exp_sd = float(math.sqrt(np.mean(dof_sd / (dof_sd - 2)))) if len(dof_sd) else float("nan")
    sd = float(zv.std()) if n else float("nan")
    # Pixels are independent in both renderers, so the mean z has standard error sd / sqrt(n).
    mean_z = float(zv.mean()) if n else float("nan")
    mean_z_se = sd / math.sqrt(n) if n else float("nan")
    frac3_se = math.sqrt(max(exp_frac3 * (1 - exp_frac3), 1e-12) / n) if n else float("nan")
    per_channel_z = [{"channel": name, "mean": float(z[..., c][valid[..., c]].mean()),
                      "sd": float(z[..., c][valid[..., c]].std()),
                      "frac_abs_gt_3": float(np.mean(np.abs(z[..., c][valid[..., c]]) > 3))}
                     for c, name in enumerate("RGB") if valid[..., c].any()]
    order = np.argsort(-np.abs(np.where(valid, z, 0)).ravel())[:5]
    worst = []
    for flat in order:
        y, x, c = np.unravel_index(flat, z.shape)
        worst.append({"y": int(y), "x": int(x), "channel": "RGB"[c], "z": float(z[y, x, c]),
                      a_name: float(a_mean[y, x, c]), b_name: float(b_mean[y, x, c])})
    ok_channels = bool(np.all(np.abs(cz) < 3))
    ok_mean_z = bool(abs(mean_z) < 3 * mean_z_se) if n else False
    ok_frac = bool(frac3 <= exp_frac3 + 3 * frac3_se + 0.002) if n else False
    ok_sd = bool(sd <= 1.1 * exp_sd) if n else False
    return {
        "a": a_name, "b": b_name, "a_renders": na, "b_renders": nb,
        "channel_means": channels,
        "per_pixel_z": {"n": n, "excluded_zero_variance": int((~valid).sum()),
                        "mean": mean_z, "mean_se": mean_z_se, "sd": sd,
                        "sd_expected_if_agreeing": exp_sd,
                        "frac_abs_gt_3": frac3, "frac_abs_gt_3_expected_if_agreeing": exp_frac3,
                        "welch_dof_median": float(np.median(dof)) if n else None,
                        "per_channel": per_channel_z, "largest": worst},
        "checks": {"channel_means_within_3_se": ok_channels, "mean_z_within_3_se": ok_mean_z,
                   "frac_abs_z_gt_3_as_expected": ok_frac, "z_sd_as_expected": ok_sd},
        "agree": ok_channels and ok_mean_z and ok_frac and ok_sd,
    }


def emitter_mask(ref: np.ndarray, threshold: float = 1.0) -> np.ndarray:
    """(H, W) bool: pixels whose reference exceeds `threshold` in some channel (in the Cornell box only
    the light does; every reflector stays below 1), and their 8 neighbours."""
    from scipy.ndimage import binary_dilation
    return binary_dilation(ref.max(axis=-1) > threshold, structure=np.ones((3, 3), dtype=bool))


def rmse_report(pairs, spread: np.ndarray, combined: np.ndarray, n_combined: int, ref: np.ndarray,
                ref_noise: np.ndarray, region: np.ndarray, spp: int) -> dict:
    """RMSE at `spp` over `region` ((H, W) bool) from independent (image, reference, noise of that
    reference) pairs, the reference's noise subtracted; the same from the spread of the independent
    renders in `spread` alone; and the measured vs the predicted RMSE of `combined`, the mean of
    `n_combined` renders (n_combined * spp samples)."""
    raw = float(np.mean([np.mean(((img - r) ** 2)[region]) for img, r, _ in pairs]))
    noise = float(np.mean([np.mean(nz[region]) for _, _, nz in pairs]))
    corr = max(raw - noise, 1e-30)
    v = spread.var(axis=0, ddof=1)[region]
    out = {"rmse_vs_reference": math.sqrt(corr), "rmse_vs_reference_raw": math.sqrt(raw),
           "rmse_from_spread": float(math.sqrt(v.mean())), "images": len(pairs),
           "pixels": int(region.sum()),
           "effective_pixels": float(v.sum() ** 2 / max((v ** 2).sum(), 1e-300))}
    if n_combined > 1:
        c = max(float(np.mean(((combined - ref) ** 2)[region])) - float(np.mean(ref_noise[region])), 1e-30)
        out["at_higher_spp"] = {"spp": n_combined * spp, "measured": math.sqrt(c),
                                "predicted": math.sqrt(corr / n_combined),
                                "measured_over_predicted": math.sqrt(c / (corr / n_combined))}
    return out


def _tt(e: dict, region: str, which: str) -> float:
    return e["time_to_equal_rmse"][region][f"seconds_{which}"]


# ---------------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------------

def _versions() -> dict:
    out = {"python": sys.version.split()[0]}
    for dist in ("drtlab", "warp-lang", "mitsuba", "drjit", "numpy"):
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = None
    return out


def _machine() -> dict:
    cpu_model = None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu_model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpus": os.cpu_count(), "cpu_model": cpu_model, "platform": platform.platform(),
            "load_average_1_5_15_at_start": [round(x, 2) for x in os.getloadavg()]}


def _write(out: Path, result: dict) -> None:
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=2, allow_nan=True) + "\n")
    os.replace(tmp, out)


def _skip(out: Path, reason: str, base: dict) -> int:
    _write(out, {**base, "skipped": True, "reason": reason})
    print(f"bench-compare: skipped: {reason} (wrote {out})")
    return 0


def run(args) -> int:
    t_start = time.perf_counter()
    W, H = args.res
    spp, repeats, threads = args.spp, args.repeats, args.threads
    K = max(args.seeds, repeats)
    base = {"benchmark": "drtlab vs Mitsuba 3, mi.cornell_box()", "machine": _machine(),
            "versions": _versions(),
            "settings": {"scene": SCENE, "resolution": f"{W}x{H}", "spp": spp, "ref_spp": args.ref_spp,
                         "repeats": repeats, "drtlab_independent_renders": K, "max_depth": args.max_depth,
                         "threads": threads, "pixel_filter": "box"}}

    # Mitsuba and its LLVM, each checked before anything is imported or timed.
    if importlib.util.find_spec("mitsuba") is None:
        return _skip(args.out, "mitsuba is not installed (pip install -e '.[compare]')", base)
    from drtlab.experiments import mitsuba_scene as ms
    libllvm, how = ms.find_libllvm()
    if libllvm is None:
        return _skip(args.out, f"Mitsuba's {ms.LLVM_VARIANT} needs LLVM 19: {how}", base)
    os.environ["DRJIT_LIBLLVM_PATH"] = libllvm
    base["settings"]["drjit_libllvm_path"] = libllvm
    cold_dir = None if args.warm_caches else Path(tempfile.mkdtemp(prefix="drtlab-bench-compare-"))
    try:
        _log(f"probing {ms.LLVM_VARIANT} with {libllvm} ({how})")
        probe_env = {} if cold_dir is None else {"DRJIT_CACHE_DIR": str(cold_dir / "probe")}
        ok, why = ms.probe_variant(ms.LLVM_VARIANT, env=probe_env)
        if not ok:
            return _skip(args.out, f"{why} (DRJIT_LIBLLVM_PATH={libllvm})", base)
        return _run_compare(args, ms, base, cold_dir, t_start)
    finally:
        if cold_dir is not None:
            shutil.rmtree(cold_dir, ignore_errors=True)


def _run_compare(args, ms, base: dict, cold_dir: Path | None, t_start: float) -> int:
    W, H = args.res
    spp, repeats, threads = args.spp, args.repeats, args.threads
    K = max(args.seeds, repeats)
    n_ref = args.ref_spp // spp
    if cold_dir is not None:
        # Both kernel caches start empty: the warm-up's compile times are cold ones.
        os.environ["DRJIT_CACHE_DIR"] = str(cold_dir / "drjit")
    import warp as wp
    if cold_dir is not None:
        wp.config.kernel_cache_dir = str(cold_dir / "warp")
    base["settings"]["kernel_caches"] = "as found (--warm-caches)" if cold_dir is None else \
        "empty temporary caches: compile times are cold"
    import drjit as dr
    import mitsuba as mi
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    variants = [ms.LLVM_VARIANT] + ([] if args.no_scalar else [ms.SCALAR_VARIANT])
    missing = [v for v in variants if v not in mi.variants()]
    if ms.LLVM_VARIANT in missing:
        return _skip(args.out, f"this mitsuba build has no {ms.LLVM_VARIANT} variant", base)
    if missing:
        _log(f"leaving out {missing}: not in this mitsuba build")
        variants = [v for v in variants if v not in missing]
    dr.set_thread_count(threads)

    # The scenes: Mitsuba's dict is the source of truth; drtlab's translation is checked against it.
    from drtlab.kernels.scene_file import load_scene
    mi.set_variant(ms.LLVM_VARIANT)
    d = ms.scene_dict(mi, W, H, spp, args.max_depth)
    overrides = {"scene.max_depth": args.max_depth}
    vfov = ms.vfov_for(d, W, H)
    default_scene = load_scene(SCENE)
    if abs(vfov - default_scene.camera.vfov_deg) > 1e-9:
        overrides["camera.fov"] = vfov          # Mitsuba's fov_axis 'smaller' on a non-square film
    scene = replace(load_scene(SCENE, overrides), width=W, height=H)
    check = ms.translation_check(d, scene, W, H)
    base["settings"].update({
        "drtlab": {"scene": SCENE, "overrides": overrides, "sampler": SAMPLER, "integrator": "path",
                   "russian_roulette": bool(scene.russian_roulette), "vfov_deg": scene.camera.vfov_deg},
        "mitsuba": {"scene": "mi.cornell_box()", "integrator": d["integrator"],
                    "rr_depth": "5 (Mitsuba's default; drtlab's cornell-box has no Russian roulette)",
                    "sampler": d["sensor"]["sampler"]["type"], "rfilter": "box",
                    "fov": d["sensor"]["fov"], "fov_axis": d["sensor"].get("fov_axis"),
                    "variants": variants},
        "translation_check": {k: v for k, v in check.items() if k != "checks"} | {"checks": check["checks"]},
    })
    if not check["ok"]:
        _log(f"drtlab's {SCENE} is not mi.cornell_box(): " + "; ".join(
            f"{c['what']} off by {c['deviation']:.3g}" for c in check["failed"][:5]))
    else:
        _log(f"{SCENE} matches mi.cornell_box(): {check['n_checks']} checks, geometry within "
             f"{check['max_geometry_deviation']:.1e}")

    samples = W * H * spp
    renderers: dict[str, dict] = {}
    images: dict[str, list[np.ndarray]] = {DRTLAB: [], LLVM: [], SCALAR: []}

    # Warm-up: drtlab compiles its kernel variant, Mitsuba JIT-compiles its megakernel (both at the
    # benchmark resolution, tiny spp); scalar_rgb is precompiled C++.
    _log("warm-up: drtlab kernel compile")
    t0 = time.perf_counter()
    _, info = _drtlab_render(scene, WARMUP_SPP, 4242, threads)
    renderers[DRTLAB] = {"compile_seconds": round(info["compile_seconds"], 3),
                         "first_call_seconds": round(time.perf_counter() - t0, 3),
                         "variant": info["variant"], "warp_kernel_cache": str(wp.config.kernel_cache_dir),
                         "compile_note": "Warp kernel build (cold unless --warm-caches, when a kernel in "
                                         "Warp's cache is loaded instead), excluded from render seconds"}
    mscenes = {}
    for v in variants:
        name = LLVM if v == ms.LLVM_VARIANT else SCALAR
        mi.set_variant(v)
        t0 = time.perf_counter()
        mscenes[v] = mi.load_dict(ms.scene_dict(mi, W, H, spp, args.max_depth))
        load_s = time.perf_counter() - t0
        _log(f"warm-up: mitsuba {v}")
        _, info = _mitsuba_render(mi, dr, v, mscenes[v], WARMUP_SPP, 4242)
        entry = {"scene_load_seconds": round(load_s, 3), "first_render_seconds": round(info["seconds"], 3)}
        if v == ms.LLVM_VARIANT:
            entry.update({"jit_compile_seconds": round(info["jit_seconds"], 3),
                          "kernels_compiled": info["kernels_compiled"],
                          "kernels_from_disk_cache": info["kernels_from_disk_cache"],
                          "compile_note": "Dr.Jit codegen + LLVM backend time of the warm-up render "
                                          "(kernel history); cold unless --warm-caches, when kernels "
                                          "in Dr.Jit's disk cache are loaded instead"})
        else:
            entry["compile_note"] = "scalar_rgb is precompiled C++: no JIT"
        renderers[name] = entry

    # Timed renders, interleaved across renderers.
    runs: dict[str, list[dict]] = {DRTLAB: [], LLVM: [], SCALAR: []}
    for r in range(repeats):
        img, info = _drtlab_render(scene, spp, r, threads)
        images[DRTLAB].append(img)
        runs[DRTLAB].append(info)
        line = f"timed {r + 1}/{repeats}: drtlab {info['seconds']:.2f} s"
        for v in variants:
            name = LLVM if v == ms.LLVM_VARIANT else SCALAR
            seed = r if name == LLVM else SCALAR_SEED0 + r
            img, info = _mitsuba_render(mi, dr, v, mscenes[v], spp, seed)
            if img.shape != (H, W, 3):
                raise RuntimeError(f"mitsuba {v} returned an image of shape {img.shape}, expected {(H, W, 3)}")
            images[name].append(img)
            runs[name].append(info)
            line += f", {v} {info['seconds']:.2f} s"
        _log(line)
    for name in runs:
        if runs[name]:
            renderers[name]["runs"] = [{k: (round(v, 4) if isinstance(v, float) else v)
                                        for k, v in x.items() if k not in ("variant", "compile_seconds")}
                                       for x in runs[name]]
            renderers[name].update(_timing_summary(runs[name], samples))
    if runs[LLVM]:
        renderers[LLVM]["jit_seconds_during_timed_renders"] = round(
            sum(x["jit_seconds"] for x in runs[LLVM]), 4)
        renderers[LLVM]["kernels_compiled_during_timed_renders"] = sum(
            x["kernels_compiled"] for x in runs[LLVM])

    # drtlab's further independent renders (agreement), then the shared reference.
    for k in range(repeats, K):
        img, info = _drtlab_render(scene, spp, k, threads)
        images[DRTLAB].append(img)
        _log(f"drtlab independent render {k + 1}/{K}: {info['seconds']:.2f} s")
    ref_stack, ref_seconds = [], 0.0
    for i in range(n_ref):
        img, info = _mitsuba_render(mi, dr, ms.LLVM_VARIANT, mscenes[ms.LLVM_VARIANT], spp, REF_SEED0 + i)
        ref_stack.append(img)
        ref_seconds += info["seconds"]
        if (i + 1) % 4 == 0 or i + 1 == n_ref:
            _log(f"reference batch {i + 1}/{n_ref} ({ms.LLVM_VARIANT}, {spp} spp each)")
    ref_stack = np.stack(ref_stack)
    if args.save_images is not None:
        args.save_images.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(args.save_images, reference_batches=ref_stack,
                            **{k: np.stack(v) for k, v in images.items() if v})
        _log(f"saved images to {args.save_images}")
    ref = ref_stack.mean(axis=0)
    ref_noise_mse = float(np.mean(ref_stack.var(axis=0, ddof=1) / n_ref))

    # RMSE at the benchmark spp against the shared reference, and the time to Mitsuba-LLVM's RMSE,
    # over the whole image and without the light's pixels (which carry most of the whole image's MSE).
    ref_var = ref_stack.var(axis=0, ddof=1)                     # per pixel-channel, one batch
    ref_noise = ref_var / n_ref                                 # of the reference
    light = emitter_mask(ref)
    regions = {"full": np.ones(light.shape, dtype=bool), "excl_light": ~light}
    loo = [(ref_stack[i], (ref_stack.sum(axis=0) - ref_stack[i]) / (n_ref - 1), ref_var / (n_ref - 1))
           for i in range(n_ref)]
    sources = {
        DRTLAB: ([(i, ref, ref_noise) for i in images[DRTLAB]], images[DRTLAB]),
        # Mitsuba-LLVM also has its reference batches, each against the mean of the others.
        LLVM: ([(i, ref, ref_noise) for i in images[LLVM]] + loo, images[LLVM] + list(ref_stack)),
        SCALAR: ([(i, ref, ref_noise) for i in images[SCALAR]], images[SCALAR]),
    }
    for name, (pairs, spread) in sources.items():
        if not images[name]:
            continue
        renderers[name]["rmse"] = {
            reg: rmse_report(pairs, np.stack(spread), np.mean(images[name], axis=0), len(images[name]),
                             ref, ref_noise, mask, spp)
            for reg, mask in regions.items()}
    for reg in regions:
        target_mse = renderers[LLVM]["rmse"][reg]["rmse_vs_reference"] ** 2
        for name in (DRTLAB, LLVM, SCALAR):
            e = renderers.get(name)
            if e is None or "rmse" not in e:
                continue
            f = e["rmse"][reg]["rmse_vs_reference"] ** 2 / target_mse
            e.setdefault("time_to_equal_rmse", {})[reg] = {
                "target_rmse": math.sqrt(target_mse), "seconds_best": e["best_seconds"] * f,
                "seconds_median": e["median_seconds"] * f, "spp": spp * f}

    # Agreement of the high-spp images.
    agree = agreement(np.stack(images[DRTLAB]), ref_stack, "drtlab", "mitsuba_llvm")
    extra = {}
    if len(images[SCALAR]) >= 2:
        extra["mitsuba_scalar_vs_reference_channel_means"] = agreement(
            np.stack(images[SCALAR]), ref_stack, "mitsuba_scalar", "mitsuba_llvm")["channel_means"]
    if len(images[LLVM]) >= 2:
        extra["drtlab_vs_mitsuba_llvm_timed_channel_means"] = agreement(
            np.stack(images[DRTLAB]), np.stack(images[LLVM]), "drtlab", "mitsuba_llvm_timed")["channel_means"]

    dl, ml = renderers[DRTLAB], renderers[LLVM]
    ratios = {
        "samples_per_second_drtlab_over_mitsuba_llvm_best":
            dl["msamples_per_second_best"] / ml["msamples_per_second_best"],
        "samples_per_second_drtlab_over_mitsuba_llvm_median":
            dl["msamples_per_second_median"] / ml["msamples_per_second_median"],
        "samples_per_cpu_second_drtlab_over_mitsuba_llvm":
            dl["msamples_per_cpu_second_best"] / ml["msamples_per_cpu_second_best"],
        "time_to_equal_rmse_drtlab_over_mitsuba_llvm_best":
            _tt(dl, "full", "best") / _tt(ml, "full", "best"),
        "time_to_equal_rmse_drtlab_over_mitsuba_llvm_median":
            _tt(dl, "full", "median") / _tt(ml, "full", "median"),
        "time_to_equal_rmse_excl_light_drtlab_over_mitsuba_llvm_best":
            _tt(dl, "excl_light", "best") / _tt(ml, "excl_light", "best"),
        "time_to_equal_rmse_excl_light_drtlab_over_mitsuba_llvm_median":
            _tt(dl, "excl_light", "median") / _tt(ml, "excl_light", "median"),
        "rmse_at_equal_spp_drtlab_over_mitsuba_llvm":
            dl["rmse"]["full"]["rmse_vs_reference"] / ml["rmse"]["full"]["rmse_vs_reference"],
        "rmse_at_equal_spp_excl_light_drtlab_over_mitsuba_llvm":
            dl["rmse"]["excl_light"]["rmse_vs_reference"] / ml["rmse"]["excl_light"]["rmse_vs_reference"],
    }
    if SCALAR in renderers:
        sl = renderers[SCALAR]
        ratios["samples_per_second_drtlab_over_mitsuba_scalar_best"] = \
            dl["msamples_per_second_best"] / sl["msamples_per_second_best"]
        ratios["time_to_equal_rmse_drtlab_over_mitsuba_scalar_best"] = \
            _tt(dl, "full", "best") / _tt(sl, "full", "best")
        ratios["time_to_equal_rmse_excl_light_drtlab_over_mitsuba_scalar_best"] = \
            _tt(dl, "excl_light", "best") / _tt(sl, "excl_light", "best")
    ratios = {k: round(v, 4) for k, v in ratios.items()}

    result = {
        **base, "skipped": False,
        "renderers": renderers, "ratios": ratios,
        "reference": {"renderer": f"mitsuba {ms.LLVM_VARIANT}", "spp": args.ref_spp, "batches": n_ref,
                      "batch_spp": spp, "seeds": [REF_SEED0, REF_SEED0 + n_ref - 1],
                      "render_seconds": round(ref_seconds, 2), "noise_mse": ref_noise_mse,
                      "why": "the fastest of the renderers; drtlab's mean of independent renders is "
                             "the agreement check against it"},
        "equal_rmse": {
            "target_rmse": {reg: renderers[LLVM]["rmse"][reg]["rmse_vs_reference"] for reg in regions},
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
                                      "full-image RMSE rests on few pixels (effective_pixels)"}},
        "agreement": agree, "agreement_extra": extra,
        "load_average_1_5_15_at_end": [round(x, 2) for x in os.getloadavg()],
        "peak_rss_mib": round(_peak_rss_mib(), 1),
        "total_seconds": round(time.perf_counter() - t_start, 1),
    }
    _write(args.out, result)
    print(markdown(result))
    if not agree["agree"]:
        _log("DISAGREEMENT between drtlab and Mitsuba at high spp: see agreement in " + str(args.out))
    if not check["ok"]:
        _log(f"translation check FAILED: drtlab's {SCENE} differs from mi.cornell_box()")
    _log(f"wrote {args.out} ({result['total_seconds']:.0f} s)")
    return 0


# ---------------------------------------------------------------------------------------------------
# Markdown
# ---------------------------------------------------------------------------------------------------

def _g(x, nd=3):
    return "—" if x is None else f"{x:.{nd}f}"


def markdown(r: dict) -> str:
    s = r["settings"]
    rs = r["renderers"]
    eq = r["equal_rmse"]
    cold = "empty" in s.get("kernel_caches", "")
    tf, tl = eq["target_rmse"]["full"], eq["target_rmse"]["excl_light"]
    lines = [
        f"drtlab vs Mitsuba 3 on `mi.cornell_box()`: {s['resolution']}, {s['spp']} spp, path "
        f"max_depth {s['max_depth']}, box filter, {s['threads']} threads; best / median of "
        f"{s['repeats']} timed renders after a warm-up render ({r['machine']['cpu_model'] or 'CPU'}, "
        f"{r['machine']['cpus']} cores, shared machine: load average "
        f"{r['machine']['load_average_1_5_15_at_start'][0]:.1f} at the start). Compile: the warm-up's kernel "
        f"compile ({'cold: empty kernel caches' if cold else 'kernel caches as found'}), not part of the "
        f"render times.",
        "",
        "| renderer | compile (s) | render (s) best / median | M samples/s best / median "
        "| M samples/CPU-s | RMSE @ %d spp: all / excl. light | time to equal RMSE (s): all / excl. light "
        "| vs Mitsuba LLVM |" % s["spp"],
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    labels = {DRTLAB: f"drtlab ({SAMPLER}, Warp CPU)", LLVM: "Mitsuba 3 llvm_ad_rgb",
              SCALAR: "Mitsuba 3 scalar_rgb"}
    for name in (DRTLAB, LLVM, SCALAR):
        e = rs.get(name)
        if not e or "best_seconds" not in e:
            continue
        comp = e.get("compile_seconds", e.get("jit_compile_seconds"))
        comp_txt = "none (C++)" if comp is None else _g(comp, 2)
        tt = e["time_to_equal_rmse"]
        lines.append(
            f"| {labels[name]} | {comp_txt} | {_g(e['best_seconds'], 2)} / {_g(e['median_seconds'], 2)} "
            f"| {_g(e['msamples_per_second_best'], 3)} / {_g(e['msamples_per_second_median'], 3)} "
            f"| {_g(e['msamples_per_cpu_second_best'], 3)} "
            f"| {_g(e['rmse']['full']['rmse_vs_reference'], 4)} / {_g(e['rmse']['excl_light']['rmse_vs_reference'], 5)} "
            f"| {_g(tt['full']['seconds_best'], 2)} / {_g(tt['excl_light']['seconds_best'], 2)} "
            f"| {_tt(e, 'full', 'best') / _tt(rs[LLVM], 'full', 'best'):.2f}x / "
            f"{_tt(e, 'excl_light', 'best') / _tt(rs[LLVM], 'excl_light', 'best'):.2f}x time |")
    a = r["agreement"]
    z = a["per_pixel_z"]
    ref = r["reference"]
    ra = r["ratios"]
    light_px = rs[DRTLAB]["rmse"]["full"]["pixels"] - rs[DRTLAB]["rmse"]["excl_light"]["pixels"]
    lines += [
        "",
        f"Reference: Mitsuba llvm_ad_rgb at {ref['spp']} spp ({ref['batches']} independent batches of "
        f"{ref['batch_spp']} spp). RMSE: each renderer's independent {s['spp']}-spp renders against it, "
        f"its own noise subtracted; \"excl. light\" leaves out the {light_px} pixels at and around the "
        f"light, whose partial coverage of the emitter carries most of the full image's MSE. Time to "
        f"equal RMSE = best time x (RMSE / target)^2, extrapolated with RMSE ~ spp^-1/2, target = Mitsuba "
        f"LLVM's RMSE ({tf:.4f} / {tl:.5f}). drtlab / Mitsuba LLVM: "
        f"{ra['samples_per_second_drtlab_over_mitsuba_llvm_best']:.3f}x samples/s (best; "
        f"{ra['samples_per_cpu_second_drtlab_over_mitsuba_llvm']:.3f}x per CPU-second), "
        f"{ra['rmse_at_equal_spp_drtlab_over_mitsuba_llvm']:.3f}x / "
        f"{ra['rmse_at_equal_spp_excl_light_drtlab_over_mitsuba_llvm']:.3f}x RMSE at equal spp, "
        f"{ra['time_to_equal_rmse_drtlab_over_mitsuba_llvm_best']:.2f}x / "
        f"{ra['time_to_equal_rmse_excl_light_drtlab_over_mitsuba_llvm_best']:.2f}x time to equal RMSE.",
        "",
        f"Agreement at high spp, drtlab ({a['a_renders']} x {s['spp']} spp) vs the reference: "
        + ("**agree**" if a["agree"] else "**DISAGREE**"),
        "",
        "| channel | drtlab mean ± se | Mitsuba mean ± se | difference | z |",
        "|---|---:|---:|---:|---:|",
    ]
    for c in a["channel_means"]:
        rel = c["relative_difference"]
        lines.append(f"| {c['channel']} | {c['drtlab_mean']:.5f} ± {c['drtlab_se']:.5f} "
                     f"| {c['mitsuba_llvm_mean']:.5f} ± {c['mitsuba_llvm_se']:.5f} "
                     f"| {100 * rel:+.3f} % | {c['z']:+.2f} |")
    lines += [
        "",
        f"Per-pixel z over {z['n']} pixel-channels: mean {z['mean']:+.4f} (± {z['mean_se']:.4f}), sd "
        f"{z['sd']:.3f} (expected {z['sd_expected_if_agreeing']:.3f} with Welch dof ~"
        f"{z['welch_dof_median']:.0f}), |z| > 3: {100 * z['frac_abs_gt_3']:.3f} % (expected "
        f"{100 * z['frac_abs_gt_3_expected_if_agreeing']:.3f} %).",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    try:
        args = parse_args(argv)
        return run(args)
    except InputError as e:
        print(f"drtlab: {e.field}: {e.message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("drtlab: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
