"""What each point set's draws cost inside a render (`profile_kernels pointsets`): per sample and
bounce one get2d and one get1d at the tracer's dimensions, the count word once per pixel, in CPU
ns per draw pair and against `independent`; --write stores them for `drtlab samplers`
(estimators/draw_costs.py)."""

import os
import sys
import time

import numpy as np


def _draw_kernel(pointset):
    import warp as wp
    from drtlab.estimators import dimensions as D
    get1d, get2d = pointset.get1d, pointset.get2d
    pixel_key, count_word = pointset.pixel_key, pointset.count_word
    bounce_base = D.warp_functions().bounce_base

    @wp.kernel(enable_backward=False, module="unique")
    def draws(seed: wp.uint32, width: int, spp: int, bounces: int, out: wp.array(dtype=float)):
        p = wp.tid()
        pix = pixel_key(p % width, p / width, width)
        word = count_word(wp.uint32(spp))
        acc = float(0.0)
        for i in range(spp):
            idx = wp.uint32(i)
            for b in range(bounces):
                base = bounce_base(b)
                u = get2d(seed, pix, idx, base + wp.uint32(wp.static(D.DIRECTION)), word)
                acc += u[0] + u[1] + get1d(seed, pix, idx, base + wp.uint32(wp.static(D.ROULETTE)),
                                           word)
        out[p] = acc

    return draws


def draw_costs(names, spp: int = 64, pixels: int = 4096, bounces: int = 4,
               repeats: int = 5) -> dict:
    """{name: best ns per draw pair}: the sets take turns in every round (load falls on all)."""
    from drtlab.warp_runtime import warp as _wp
    wp = _wp()
    from drtlab.estimators.registry import POINTSETS
    kernels = {n: _draw_kernel(POINTSETS[n]) for n in names}
    out = wp.zeros(pixels, dtype=float, device="cpu")
    width = max(1, int(np.sqrt(pixels)))
    args = lambda: [wp.uint32(1), width, spp, bounces, out]
    for k in kernels.values():
        wp.launch(k, dim=pixels, inputs=args(), device="cpu")
    best = {n: float("inf") for n in names}
    pairs = pixels * spp * bounces
    for _ in range(repeats):
        for n, k in kernels.items():
            # The launch runs on this thread: its CPU time leaves out the time other jobs hold the
            # core (wall time on this shared machine varied by 30% between runs).
            t0 = time.thread_time()
            wp.launch(k, dim=pixels, inputs=args(), device="cpu")
            best[n] = min(best[n], (time.thread_time() - t0) * 1e9 / pairs)
    return best


def _cpu_name() -> str:
    import platform
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cmd_pointsets(args) -> int:
    from drtlab.estimators.registry import POINTSETS
    names = args.sets or [n for n in POINTSETS]
    if "independent" not in names:
        names = ["independent", *names]
    best = draw_costs(names, spp=args.spp, pixels=args.pixels, repeats=args.repeats)
    base = best["independent"]
    for n in names:
        print(f"{n:20s} {best[n]:7.1f} ns per draw pair  {best[n] / base:5.2f}x independent",
              flush=True)
    if args.write:
        from drtlab.estimators import draw_costs as DC
        if set(names) != set(POINTSETS):
            print("--write needs every point set (no --sets)", file=sys.stderr)
            return 2
        DC.write(best, args.spp, f"{_cpu_name()}, {os.cpu_count()} cores")
        print(f"wrote {DC.PATH}")
    return 0
