"""Matched sampler pairs of `make bench-compare`: drtlab's and Mitsuba 3's stratified, multi-jittered and
low-discrepancy samplers on the same Cornell box, each renderer against its own independent sampler.

What a researcher asks of two renderers is not only which traces faster with independent samples (the
main comparison) but what each one's better samplers buy per second. Pairs of the same construction:

    drtlab `stratified+importance`  vs Mitsuba `stratified`    (jittered strata per dimension)
    drtlab `cmj+importance`         vs Mitsuba `multijitter`   (Kensler's correlated multi-jitter)
    drtlab `sobol+importance`       vs Mitsuba `ldsampler`     (scrambled (0,2)-sequence points)

METHOD below says how they are measured.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.stats import norm

from drtlab.experiments.bench.mitsuba.render import (STRATEGY, WARMUP_SEED, WARMUP_SPP, drtlab_render, log,
                                                     mitsuba_render)
from drtlab.experiments.bench.mitsuba.stats import agreement, emitter_mask, timing_summary

PAIRS = (("stratified", "stratified"), ("cmj", "multijitter"), ("sobol", "ldsampler"))
SEED0 = 300                      # the pairs' seeds: apart from the main comparison's and the reference's
Z90 = float(norm.ppf(0.95))      # a two-sided 90% interval
METHOD = ("Every render of a pair uses the main comparison's settings (resolution, spp, depth, box "
          "filter, threads); drtlab and Mitsuba renders alternate seed by seed. MSE is the mean per-pixel "
          "variance of --seeds independent renders (ddof 1): exact for an unbiased renderer, and free "
          "of the reference's own noise, which at these errors is as large as the MSE itself (each "
          "sampler's agreement with the shared reference is reported beside it). The time to equal "
          "RMSE at this spp is the ratio of best seconds x MSE, with a 90% interval from the MSEs' "
          "jackknife variances over the renders (the best time is one number). The independent "
          "baseline is the main comparison's renders at the same spp: drtlab's independent renders "
          "and Mitsuba-LLVM's reference batches.")


def mse_and_variance(stack: np.ndarray, region: np.ndarray) -> tuple[float, float]:
    """The mean per-pixel variance over `region` of a stack of n independent renders, and the
    jackknife estimate of its sampling variance (leave one render out: each pixel's sample variance
    without render i is ((n - 1) s^2 - n / (n - 1) d_i^2) / (n - 2), d_i its deviation from the mean).
    On synthetic 8-render stacks it covers at 93% (Gaussian pixels) and 86% (Student t, 10 dof) for a
    nominal 90%; the per-pixel fourth-moment formula covers at 85% and 76%, a bootstrap over the
    renders at ~100% with intervals several times too wide (resampling duplicates alone spread an
    8-render MSE by ~15%)."""
    x = stack[:, region].reshape(len(stack), -1)
    n = len(x)
    d = x - x.mean(axis=0)
    s2 = (d * d).sum(axis=0) / (n - 1)
    loo = ((((n - 1) * s2)[None, :] - n / (n - 1) * d * d) / (n - 2)).mean(axis=1)
    return float(s2.mean()), float((n - 1) / n * ((loo - loo.mean()) ** 2).sum())


def efficiency_ratio(a: np.ndarray, ta: float, b: np.ndarray, tb: float, region: np.ndarray) -> dict:
    """(ta x MSE_a) / (tb x MSE_b): the time a needs for b's RMSE at this spp, with a 90% interval from
    the two MSEs' jackknife variances (independent stacks; normal on the log scale; the times are
    taken as exact)."""
    (ma, va), (mb, vb) = mse_and_variance(a, region), mse_and_variance(b, region)
    point = ta * ma / (tb * mb)
    half = Z90 * math.sqrt(va / ma ** 2 + vb / mb ** 2)
    return {"time_ratio": round(point, 4),
            "ci90": [round(point * math.exp(-half), 4), round(point * math.exp(half), 4)]}


def _renders(rig, points: str, mitsuba_type: str, seeds: int) -> dict:
    """Warm-up, then `seeds` renders per renderer alternating seed by seed: images and timings."""
    mi, llvm = rig.mi, rig.ms.LLVM_VARIANT
    mi.set_variant(llvm)
    d = rig.ms.scene_dict(mi, rig.width, rig.height, rig.spp, rig.max_depth)
    d["sensor"]["sampler"]["type"] = mitsuba_type
    mscene = mi.load_dict(d)
    sampler = f"{points}+{STRATEGY}"
    drtlab_render(rig.scene, WARMUP_SPP, WARMUP_SEED, rig.threads, sampler=sampler)
    mitsuba_render(mi, rig.dr, llvm, mscene, WARMUP_SPP, WARMUP_SEED)
    out = {"drtlab": ([], []), "mitsuba": ([], [])}
    for s in range(SEED0, SEED0 + seeds):
        img, info = drtlab_render(rig.scene, rig.spp, s, rig.threads, sampler=sampler)
        out["drtlab"][0].append(img)
        out["drtlab"][1].append(info)
        img, info = mitsuba_render(mi, rig.dr, llvm, mscene, rig.spp, s)
        out["mitsuba"][0].append(img)
        out["mitsuba"][1].append(info)
    log(f"sampler pair {sampler} / {mitsuba_type}: drtlab best "
        f"{min(x['seconds'] for x in out['drtlab'][1]):.2f} s, mitsuba best "
        f"{min(x['seconds'] for x in out['mitsuba'][1]):.2f} s")
    return {k: (np.stack(imgs), infos) for k, (imgs, infos) in out.items()}


def sampler_pairs(rig, seeds: int, baseline: dict, ref_stack: np.ndarray) -> dict:
    """The pairs' table. `baseline`: {"drtlab": (independent renders, best seconds), "mitsuba": (the
    same)} from the main comparison."""
    samples = rig.width * rig.height * rig.spp
    light = emitter_mask(ref_stack.mean(axis=0))
    regions = {"full": np.ones(light.shape, dtype=bool), "excl_light": ~light}
    rows = []
    for points, mitsuba_type in PAIRS:
        got = _renders(rig, points, mitsuba_type, seeds)
        row = {"drtlab_sampler": f"{points}+{STRATEGY}", "mitsuba_sampler": mitsuba_type}
        for who, (stack, infos) in got.items():
            t = timing_summary(infos, samples)
            base_stack, base_t = baseline[who]
            row[who] = {
                **{k: t[k] for k in ("best_seconds", "median_seconds", "msamples_per_second_best")},
                "mse_from_spread": {r: mse_and_variance(stack, m)[0] for r, m in regions.items()},
                "time_to_equal_rmse_over_own_independent": {
                    r: efficiency_ratio(stack, t["best_seconds"], base_stack, base_t, m)
                    for r, m in regions.items()},
                "vs_reference_channel_means": agreement(stack, ref_stack, who, "reference")["channel_means"],
            }
        d, m = got["drtlab"], got["mitsuba"]
        row["time_to_equal_rmse_drtlab_over_mitsuba"] = {
            r: efficiency_ratio(d[0], row["drtlab"]["best_seconds"], m[0], row["mitsuba"]["best_seconds"],
                                 mask) for r, mask in regions.items()}
        row["samples_per_second_drtlab_over_mitsuba"] = round(
            row["drtlab"]["msamples_per_second_best"] / row["mitsuba"]["msamples_per_second_best"], 4)
        rows.append(row)
    return {"pairs": rows, "renders_per_sampler": seeds, "method": METHOD}


def markdown_rows(section: dict) -> list[str]:
    """The pairs' table for report.py."""
    lines = ["", f"Matched samplers ({section['renders_per_sampler']} renders each; MSE from their "
                 "spread; time to equal RMSE at this spp with its 90% interval, whole image):", "",
             "| drtlab sampler | Mitsuba sampler | M samples/s drtlab / Mitsuba | time to equal RMSE "
             "vs own independent: drtlab / Mitsuba | drtlab vs Mitsuba: samples/s, time to equal RMSE |",
             "|---|---|---:|---:|---:|"]

    def ratio(x: dict, nd: int) -> str:
        return f"{x['time_ratio']:.{nd}f}x [{x['ci90'][0]:.{nd}f}, {x['ci90'][1]:.{nd}f}]"

    for r in section["pairs"]:
        d, m = r["drtlab"], r["mitsuba"]
        own = [e["time_to_equal_rmse_over_own_independent"]["full"] for e in (d, m)]
        lines.append(
            f"| {r['drtlab_sampler']} | {r['mitsuba_sampler']} | {d['msamples_per_second_best']:.2f} / "
            f"{m['msamples_per_second_best']:.2f} | {ratio(own[0], 3)} / {ratio(own[1], 3)} "
            f"| {r['samples_per_second_drtlab_over_mitsuba']:.2f}x, "
            f"{ratio(r['time_to_equal_rmse_drtlab_over_mitsuba']['full'], 2)} |")
    return lines
