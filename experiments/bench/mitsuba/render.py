"""The renders of `make bench-compare`: drtlab's and Mitsuba's, each timed the same way (wall and CPU
seconds around one render call), in the order the benchmark needs them: warm-up, timed renders
interleaved across renderers, drtlab's further independent renders, the shared reference.

Nothing here imports Warp, Dr.Jit or Mitsuba at module level: the caller points their kernel caches
first, and hands the imported `mitsuba` and `drjit` modules in (`Rig`)."""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

SCENE = "cornell-box"
# The estimator matched to Mitsuba's `path`: BSDF and light sampling with MIS, the light's point
# sampled by area (Mitsuba 3 samples a rectangle emitter by area: its direction pdf is
# d^2 / (cos A), checked against mi 3.9.1), independent points.
STRATEGY = "importance-area"
SAMPLER = f"independent+{STRATEGY}"
WARMUP_SPP = 4
WARMUP_SEED = 4242
REF_SEED0 = 100_000             # reference batches: seeds disjoint from every benchmark render
SCALAR_SEED0 = 200              # scalar_rgb's timed renders: seeds apart from llvm_ad_rgb's
LLVM = "mitsuba_llvm_ad_rgb"
SCALAR = "mitsuba_scalar_rgb"
DRTLAB = "drtlab"
RENDERERS = (DRTLAB, LLVM, SCALAR)


def log(msg: str) -> None:
    print(f"bench-compare: {msg}", file=sys.stderr, flush=True)


@dataclass
class Rig:
    """What every render needs: both renderers' modules and scenes, and the shared settings."""
    mi: Any
    dr: Any
    ms: Any                     # drtlab.experiments.bench.mitsuba.scene
    variants: list[str]
    scene: Any                  # drtlab's translation of mi.cornell_box()
    width: int
    height: int
    spp: int
    max_depth: int
    threads: int
    mscenes: dict = field(default_factory=dict)      # variant -> loaded Mitsuba scene (by warm_up)

    def key(self, variant: str) -> str:
        return LLVM if variant == self.ms.LLVM_VARIANT else SCALAR


def drtlab_render(scene, spp: int, seed: int, threads: int,
                  sampler: str = SAMPLER) -> tuple[np.ndarray, dict]:
    from drtlab.kernels.render import render_with_stats
    c0, t0 = time.process_time(), time.perf_counter()
    st = render_with_stats(scene, spp=spp, sampler=sampler, integrator="path", seed=seed,
                           threads=threads, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return st.image, {"seed": seed, "seconds": st.render_seconds, "cpu_seconds": cpu,
                      "call_seconds": wall, "compile_seconds": st.compile_seconds, "variant": st.variant}


def _jit_counts(history: list[dict]) -> dict:
    """Compile time and kernel counts of one render from Dr.Jit's kernel history (launches only)."""
    hist = [k for k in history if k.get("cache_hit") is not None]
    return {"jit_seconds": sum((k.get("codegen_time") or 0.0) + (k.get("backend_time") or 0.0)
                               for k in hist) / 1000.0,
            "kernels_compiled": sum(1 for k in hist if not k.get("cache_hit")),
            "kernels_from_disk_cache": sum(1 for k in hist if k.get("cache_hit") and k.get("cache_disk")),
            "kernels_from_memory_cache": sum(1 for k in hist if k.get("cache_hit")
                                             and not k.get("cache_disk")),
            "kernel_launches": len(hist)}


def mitsuba_render(mi, dr, variant: str, scene, spp: int, seed: int) -> tuple[np.ndarray, dict]:
    mi.set_variant(variant)
    jit = variant.startswith("llvm")
    if jit:
        dr.kernel_history()                                     # clears the history
    c0, t0 = time.process_time(), time.perf_counter()
    img = np.array(mi.render(scene, spp=spp, seed=seed), dtype=np.float64)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    info = {"seed": seed, "seconds": wall, "cpu_seconds": cpu}
    if jit:
        info.update(_jit_counts(dr.kernel_history()))
    return img, info


def _warm_up_mitsuba(rig: Rig, variant: str) -> dict:
    rig.mi.set_variant(variant)
    t0 = time.perf_counter()
    rig.mscenes[variant] = rig.mi.load_dict(rig.ms.scene_dict(rig.mi, rig.width, rig.height, rig.spp,
                                                              rig.max_depth))
    load_s = time.perf_counter() - t0
    log(f"warm-up: mitsuba {variant}")
    _, info = mitsuba_render(rig.mi, rig.dr, variant, rig.mscenes[variant], WARMUP_SPP, WARMUP_SEED)
    entry = {"scene_load_seconds": round(load_s, 3), "first_render_seconds": round(info["seconds"], 3)}
    if variant != rig.ms.LLVM_VARIANT:
        entry["compile_note"] = "scalar_rgb is precompiled C++: no JIT"
        return entry
    entry.update({"jit_compile_seconds": round(info["jit_seconds"], 3),
                  "kernels_compiled": info["kernels_compiled"],
                  "kernels_from_disk_cache": info["kernels_from_disk_cache"],
                  "compile_note": "Dr.Jit codegen + LLVM backend time of the warm-up render "
                                  "(kernel history); cold unless --warm-caches, when kernels "
                                  "in Dr.Jit's disk cache are loaded instead"})
    return entry


def warm_up(rig: Rig) -> dict[str, dict]:
    """Renderer name -> its compile facts. drtlab compiles its kernel variant, Mitsuba JIT-compiles its
    megakernel (both at the benchmark resolution, tiny spp); scalar_rgb is precompiled C++. Loads
    Mitsuba's scenes into `rig.mscenes`."""
    log("warm-up: drtlab kernel compile")
    t0 = time.perf_counter()
    _, info = drtlab_render(rig.scene, WARMUP_SPP, WARMUP_SEED, rig.threads)
    import warp as wp               # read only now: Warp fills in its default cache folder at init
    renderers = {DRTLAB: {"compile_seconds": round(info["compile_seconds"], 3),
                          "first_call_seconds": round(time.perf_counter() - t0, 3),
                          "variant": info["variant"], "warp_kernel_cache": str(wp.config.kernel_cache_dir),
                          "compile_note": "Warp kernel build (cold unless --warm-caches, when a kernel "
                                          "in Warp's cache is loaded instead), excluded from render "
                                          "seconds"}}
    for v in rig.variants:
        renderers[rig.key(v)] = _warm_up_mitsuba(rig, v)
    return renderers


def _mitsuba_timed(rig: Rig, variant: str, seed: int) -> tuple[np.ndarray, dict]:
    img, info = mitsuba_render(rig.mi, rig.dr, variant, rig.mscenes[variant], rig.spp, seed)
    if img.shape != (rig.height, rig.width, 3):
        raise RuntimeError(f"mitsuba {variant} returned an image of shape {img.shape}, "
                           f"expected {(rig.height, rig.width, 3)}")
    return img, info


def timed_renders(rig: Rig, repeats: int, images: dict[str, list]) -> dict[str, list[dict]]:
    """Renderer name -> its timed runs, interleaved across renderers so that a noisy neighbour on the
    machine hits all of them alike; each image goes to `images[name]`."""
    runs: dict[str, list[dict]] = {name: [] for name in RENDERERS}
    for r in range(repeats):
        img, info = drtlab_render(rig.scene, rig.spp, r, rig.threads)
        images[DRTLAB].append(img)
        runs[DRTLAB].append(info)
        line = f"timed {r + 1}/{repeats}: drtlab {info['seconds']:.2f} s"
        for v in rig.variants:
            name = rig.key(v)
            img, info = _mitsuba_timed(rig, v, r if name == LLVM else SCALAR_SEED0 + r)
            images[name].append(img)
            runs[name].append(info)
            line += f", {v} {info['seconds']:.2f} s"
        log(line)
    return runs


def independent_renders(rig: Rig, start: int, count: int, images: list) -> None:
    """drtlab's renders with seeds start..count-1, after the timed ones (seeds 0..start-1)."""
    for k in range(start, count):
        img, info = drtlab_render(rig.scene, rig.spp, k, rig.threads)
        images.append(img)
        log(f"drtlab independent render {k + 1}/{count}: {info['seconds']:.2f} s")


def reference_batches(rig: Rig, n_ref: int) -> tuple[np.ndarray, float]:
    """(n_ref, H, W, 3) independent llvm_ad_rgb batches at the benchmark spp, and their render seconds."""
    llvm = rig.ms.LLVM_VARIANT
    stack, seconds = [], 0.0
    for i in range(n_ref):
        img, info = mitsuba_render(rig.mi, rig.dr, llvm, rig.mscenes[llvm], rig.spp, REF_SEED0 + i)
        stack.append(img)
        seconds += info["seconds"]
        if (i + 1) % 4 == 0 or i + 1 == n_ref:
            log(f"reference batch {i + 1}/{n_ref} ({llvm}, {rig.spp} spp each)")
    return np.stack(stack), seconds
