"""The statistics of `make bench-compare`: timing summaries, RMSE against the shared reference, time
to equal RMSE, drtlab / Mitsuba ratios, and agreement of two stacks of independent renders within
their standard errors. Pure numpy / scipy on finished images and timings: nothing here renders."""
from __future__ import annotations

import math

import numpy as np

from drtlab.experiments.bench.mitsuba.render import DRTLAB, LLVM, RENDERERS, SCALAR
from drtlab.experiments.stats.hypothesis_tests import welch_dof

REGION_TAG = {"full": "", "excl_light": "_excl_light"}     # region -> its infix in the ratio keys


# ---------------------------------------------------------------------------------------------------
# Timings
# ---------------------------------------------------------------------------------------------------

def timing_summary(runs: list[dict], samples: int) -> dict:
    secs = sorted(r["seconds"] for r in runs)
    best, med = secs[0], float(np.median(secs))
    best_run = min(runs, key=lambda r: r["seconds"])
    return {"best_seconds": round(best, 4), "median_seconds": round(med, 4),
            "msamples_per_second_best": round(samples / best / 1e6, 4),
            "msamples_per_second_median": round(samples / med / 1e6, 4),
            "msamples_per_cpu_second_best": round(samples / max(min(r["cpu_seconds"] for r in runs),
                                                                1e-12) / 1e6, 4),
            "cpu_utilisation_of_best": round(best_run["cpu_seconds"] / max(best_run["seconds"], 1e-12), 2)}


def add_timings(renderers: dict[str, dict], runs: dict[str, list[dict]], samples: int) -> None:
    """Each renderer's timed runs (rounded; drtlab's per-render facts are in its warm-up entry) and
    their summary; Mitsuba-LLVM's JIT work during them, which should be none after the warm-up."""
    for name, rs in runs.items():
        if rs:
            renderers[name]["runs"] = [{k: (round(v, 4) if isinstance(v, float) else v)
                                        for k, v in x.items() if k not in ("variant", "compile_seconds")}
                                       for x in rs]
            renderers[name].update(timing_summary(rs, samples))
    if runs[LLVM]:
        renderers[LLVM]["jit_seconds_during_timed_renders"] = round(
            sum(x["jit_seconds"] for x in runs[LLVM]), 4)
        renderers[LLVM]["kernels_compiled_during_timed_renders"] = sum(
            x["kernels_compiled"] for x in runs[LLVM])


# ---------------------------------------------------------------------------------------------------
# RMSE and time to equal RMSE
# ---------------------------------------------------------------------------------------------------

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


def add_rmse(renderers: dict[str, dict], images: dict[str, list], ref_stack: np.ndarray,
             spp: int) -> np.ndarray:
    """Each renderer's RMSE at the benchmark spp against the mean of `ref_stack`, over the whole image
    and without the light's pixels (which carry most of the whole image's MSE); returns the light's
    pixel mask."""
    n_ref = len(ref_stack)
    ref = ref_stack.mean(axis=0)
    ref_var = ref_stack.var(axis=0, ddof=1)                     # per pixel-channel, one batch
    ref_noise = ref_var / n_ref                                 # of the reference
    light = emitter_mask(ref)
    regions = {"full": np.ones(light.shape, dtype=bool), "excl_light": ~light}
    loo = [(ref_stack[i], (ref_stack.sum(axis=0) - ref_stack[i]) / (n_ref - 1), ref_var / (n_ref - 1))
           for i in range(n_ref)]
    sources = {name: ([(i, ref, ref_noise) for i in images[name]], images[name]) for name in RENDERERS}
    # Mitsuba-LLVM also has its reference batches, each against the mean of the others.
    sources[LLVM] = (sources[LLVM][0] + loo, images[LLVM] + list(ref_stack))
    for name, (pairs, spread) in sources.items():
        if not images[name]:
            continue
        renderers[name]["rmse"] = {
            reg: rmse_report(pairs, np.stack(spread), np.mean(images[name], axis=0), len(images[name]),
                             ref, ref_noise, mask, spp)
            for reg, mask in regions.items()}
    return light


def add_time_to_equal_rmse(renderers: dict[str, dict], spp: int) -> None:
    """Time each renderer needs to reach Mitsuba-LLVM's RMSE, extrapolated with RMSE ~ spp^-1/2."""
    for reg in REGION_TAG:
        target_mse = renderers[LLVM]["rmse"][reg]["rmse_vs_reference"] ** 2
        for name in RENDERERS:
            e = renderers.get(name)
            if e is None or "rmse" not in e:
                continue
            f = e["rmse"][reg]["rmse_vs_reference"] ** 2 / target_mse
            e.setdefault("time_to_equal_rmse", {})[reg] = {
                "target_rmse": math.sqrt(target_mse), "seconds_best": e["best_seconds"] * f,
                "seconds_median": e["median_seconds"] * f, "spp": spp * f}


def time_to_equal(e: dict, region: str, which: str) -> float:
    return e["time_to_equal_rmse"][region][f"seconds_{which}"]


def _rmse(e: dict, region: str) -> float:
    return e["rmse"][region]["rmse_vs_reference"]


def _speed(e: dict, which: str) -> float:
    return e[f"msamples_per_second_{which}"]


def ratios(renderers: dict[str, dict]) -> dict:
    """drtlab over Mitsuba-LLVM (and over scalar_rgb, where it ran): speed, time to equal RMSE, RMSE."""
    d, m = renderers[DRTLAB], renderers[LLVM]
    out = {f"samples_per_second_drtlab_over_mitsuba_llvm_{w}": _speed(d, w) / _speed(m, w)
           for w in ("best", "median")}
    out["samples_per_cpu_second_drtlab_over_mitsuba_llvm"] = \
        d["msamples_per_cpu_second_best"] / m["msamples_per_cpu_second_best"]
    out |= {f"time_to_equal_rmse{tag}_drtlab_over_mitsuba_llvm_{w}":
            time_to_equal(d, reg, w) / time_to_equal(m, reg, w)
            for reg, tag in REGION_TAG.items() for w in ("best", "median")}
    out |= {f"rmse_at_equal_spp{tag}_drtlab_over_mitsuba_llvm": _rmse(d, reg) / _rmse(m, reg)
            for reg, tag in REGION_TAG.items()}
    if SCALAR in renderers:
        s = renderers[SCALAR]
        out["samples_per_second_drtlab_over_mitsuba_scalar_best"] = _speed(d, "best") / _speed(s, "best")
        out |= {f"time_to_equal_rmse{tag}_drtlab_over_mitsuba_scalar_best":
                time_to_equal(d, reg, "best") / time_to_equal(s, reg, "best")
                for reg, tag in REGION_TAG.items()}
    return {k: round(v, 4) for k, v in out.items()}


# ---------------------------------------------------------------------------------------------------
# Agreement
# ---------------------------------------------------------------------------------------------------

def _channel_means(stack: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean image value per channel and its standard error from the independent renders in `stack`."""
    per = stack.mean(axis=(1, 2))                              # (n, 3)
    return per.mean(axis=0), per.std(axis=0, ddof=1) / math.sqrt(len(per))


def _channel_agreement(a_stack, b_stack, a_name: str, b_name: str) -> tuple[list[dict], np.ndarray]:
    """Per channel: the image means' difference over its standard error; and those z values."""
    from scipy import stats as sst
    ma, sa = _channel_means(a_stack)
    mb, sb = _channel_means(b_stack)
    se = np.sqrt(sa ** 2 + sb ** 2)
    cz = (ma - mb) / np.where(se > 0, se, np.inf)
    cdof = welch_dof(sa ** 2, len(a_stack), sb ** 2, len(b_stack))
    channels = []
    for c, name in enumerate("RGB"):
        channels.append({"channel": name, f"{a_name}_mean": float(ma[c]), f"{a_name}_se": float(sa[c]),
                         f"{b_name}_mean": float(mb[c]), f"{b_name}_se": float(sb[c]),
                         "difference": float(ma[c] - mb[c]),
                         "relative_difference": float((ma[c] - mb[c]) / mb[c]) if mb[c] else None,
                         "z": float(cz[c]), "welch_dof": float(cdof[c]),
                         "p_two_sided": float(2 * sst.t.sf(abs(cz[c]), cdof[c]))})
    return channels, cz


def _largest(z, valid, a_mean, b_mean, a_name: str, b_name: str, count: int = 5) -> list[dict]:
    order = np.argsort(-np.abs(np.where(valid, z, 0)).ravel())[:count]
    worst = []
    for flat in order:
        y, x, c = np.unravel_index(flat, z.shape)
        worst.append({"y": int(y), "x": int(x), "channel": "RGB"[c], "z": float(z[y, x, c]),
                      a_name: float(a_mean[y, x, c]), b_name: float(b_mean[y, x, c])})
    return worst


def _pixel_agreement(a_stack, b_stack, a_name: str, b_name: str) -> dict:
    """Per pixel and channel: z = (mean_a - mean_b) / sqrt(se_a^2 + se_b^2), with what Student's t at
    the Welch degrees of freedom makes of its sd and |z| > 3 fraction under agreement."""
    from scipy import stats as sst
    na, nb = len(a_stack), len(b_stack)
    a_mean, b_mean = a_stack.mean(axis=0), b_stack.mean(axis=0)
    a2 = a_stack.var(axis=0, ddof=1) / na
    b2 = b_stack.var(axis=0, ddof=1) / nb
    d2 = a2 + b2
    valid = d2 > 1e-30
    z = np.zeros_like(d2)
    z[valid] = (a_mean - b_mean)[valid] / np.sqrt(d2[valid])
    zv = z[valid]
    dof = welch_dof(a2[valid], na, b2[valid], nb)
    dof_sd = dof[dof > 2.05]
    n = int(valid.sum())
    nan = float("nan")
    exp_frac3 = float(np.mean(2 * sst.t.sf(3.0, dof))) if n else nan
    sd = float(zv.std()) if n else nan
    exp_sd = float(math.sqrt(np.mean(dof_sd / (dof_sd - 2)))) if len(dof_sd) else nan
    per_channel_z = [{"channel": name, "mean": float(z[..., c][valid[..., c]].mean()),
                      "sd": float(z[..., c][valid[..., c]].std()),
                      "frac_abs_gt_3": float(np.mean(np.abs(z[..., c][valid[..., c]]) > 3))}
                     for c, name in enumerate("RGB") if valid[..., c].any()]
    return {"n": n, "excluded_zero_variance": int((~valid).sum()),
            "mean": float(zv.mean()) if n else nan,
            # Pixels are independent in both renderers, so the mean z has standard error sd / sqrt(n).
            "mean_se": sd / math.sqrt(n) if n else nan, "sd": sd,
            "sd_expected_if_agreeing": exp_sd,
            "frac_abs_gt_3": float(np.mean(np.abs(zv) > 3)) if n else nan,
            "frac_abs_gt_3_expected_if_agreeing": exp_frac3,
            "welch_dof_median": float(np.median(dof)) if n else None,
            "per_channel": per_channel_z, "largest": _largest(z, valid, a_mean, b_mean, a_name, b_name)}


def agreement(a_stack: np.ndarray, b_stack: np.ndarray, a_name: str, b_name: str) -> dict:
    """Does the mean of the renders in `a_stack` agree with that of `b_stack` within standard errors?

    Both are stacks of independent renders (n, H, W, 3), the standard errors come from their spread.
    Agreement: every channel mean within 3 se, the mean per-pixel z within 3 of its se, and the sd
    and |z| > 3 fraction of z no larger than Student's t predicts."""
    channels, cz = _channel_agreement(a_stack, b_stack, a_name, b_name)
    z = _pixel_agreement(a_stack, b_stack, a_name, b_name)
    n, exp_frac3 = z["n"], z["frac_abs_gt_3_expected_if_agreeing"]
    frac3_se = math.sqrt(max(exp_frac3 * (1 - exp_frac3), 1e-12) / n) if n else float("nan")
    checks = {"channel_means_within_3_se": bool(np.all(np.abs(cz) < 3)),
              "mean_z_within_3_se": bool(abs(z["mean"]) < 3 * z["mean_se"]) if n else False,
              "frac_abs_z_gt_3_as_expected":
                  bool(z["frac_abs_gt_3"] <= exp_frac3 + 3 * frac3_se + 0.002) if n else False,
              "z_sd_as_expected": bool(z["sd"] <= 1.1 * z["sd_expected_if_agreeing"]) if n else False}
    return {"a": a_name, "b": b_name, "a_renders": len(a_stack), "b_renders": len(b_stack),
            "channel_means": channels, "per_pixel_z": z, "checks": checks, "agree": all(checks.values())}


def all_agreements(images: dict[str, list], ref_stack: np.ndarray) -> tuple[dict, dict]:
    """drtlab's renders against the reference (the verdict), and the side checks that help locate a
    disagreement: scalar_rgb against the reference, drtlab against Mitsuba-LLVM's timed renders."""
    drtlab = np.stack(images[DRTLAB])
    agree = agreement(drtlab, ref_stack, "drtlab", "mitsuba_llvm")
    extra = {}
    if len(images[SCALAR]) >= 2:
        extra["mitsuba_scalar_vs_reference_channel_means"] = agreement(
            np.stack(images[SCALAR]), ref_stack, "mitsuba_scalar", "mitsuba_llvm")["channel_means"]
    if len(images[LLVM]) >= 2:
        extra["drtlab_vs_mitsuba_llvm_timed_channel_means"] = agreement(
            drtlab, np.stack(images[LLVM]), "drtlab", "mitsuba_llvm_timed")["channel_means"]
    return agree, extra
