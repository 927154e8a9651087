"""The Markdown summary `make bench-compare` prints: settings, the speed / RMSE table, how the reference
and time to equal RMSE were made, and the agreement verdict with its per-channel table. It reads
only the result dict written to compare.json, so it can be re-made from that file."""
from __future__ import annotations

from drtlab.experiments.bench.mitsuba.render import DRTLAB, LLVM, RENDERERS, SAMPLER, SCALAR
from drtlab.experiments.bench.mitsuba.samplers import markdown_rows
from drtlab.experiments.bench.mitsuba.stats import time_to_equal

LABELS = {DRTLAB: f"drtlab ({SAMPLER}, Warp CPU)", LLVM: "Mitsuba 3 llvm_ad_rgb",
          SCALAR: "Mitsuba 3 scalar_rgb"}


def _g(x, nd=3):
    return "—" if x is None else f"{x:.{nd}f}"


def _header(r: dict) -> list[str]:
    s, m = r["settings"], r["machine"]
    cold = "empty" in s.get("kernel_caches", "")
    return [
        f"drtlab vs Mitsuba 3 on `mi.cornell_box()`: {s['resolution']}, {s['spp']} spp, path "
        f"max_depth {s['max_depth']}, box filter, {s['threads']} threads; best / median of "
        f"{s['repeats']} timed renders after a warm-up render ({m['cpu_model'] or 'CPU'}, "
        f"{m['cpus']} cores, shared machine: load average "
        f"{m['load_average_1_5_15_at_start'][0]:.1f} at the start). Compile: the warm-up's kernel "
        f"compile ({'cold: empty kernel caches' if cold else 'kernel caches as found'}), not part of the "
        f"render times.",
        "",
    ]


def _renderer_row(name: str, e: dict, llvm: dict) -> str:
    comp = e.get("compile_seconds", e.get("jit_compile_seconds"))
    comp_txt = "none (C++)" if comp is None else _g(comp, 2)
    tt, rm = e["time_to_equal_rmse"], e["rmse"]
    return (f"| {LABELS[name]} | {comp_txt} | {_g(e['best_seconds'], 2)} / {_g(e['median_seconds'], 2)} "
            f"| {_g(e['msamples_per_second_best'], 3)} / {_g(e['msamples_per_second_median'], 3)} "
            f"| {_g(e['msamples_per_cpu_second_best'], 3)} "
            f"| {_g(rm['full']['rmse_vs_reference'], 4)} / {_g(rm['excl_light']['rmse_vs_reference'], 5)} "
            f"| {_g(tt['full']['seconds_best'], 2)} / {_g(tt['excl_light']['seconds_best'], 2)} "
            f"| {time_to_equal(e, 'full', 'best') / time_to_equal(llvm, 'full', 'best'):.2f}x / "
            f"{time_to_equal(e, 'excl_light', 'best') / time_to_equal(llvm, 'excl_light', 'best'):.2f}x "
            f"time |")


def _speed_table(r: dict) -> list[str]:
    rs = r["renderers"]
    lines = [
        "| renderer | compile (s) | render (s) best / median | M samples/s best / median "
        "| M samples/CPU-s | RMSE @ %d spp: all / excl. light | time to equal RMSE (s): all / excl. light "
        "| vs Mitsuba LLVM |" % r["settings"]["spp"],
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name in RENDERERS:
        e = rs.get(name)
        if e and "best_seconds" in e:
            lines.append(_renderer_row(name, e, rs[LLVM]))
    return lines


def _reference_paragraph(r: dict) -> list[str]:
    s, ref, ra = r["settings"], r["reference"], r["ratios"]
    rmse = r["renderers"][DRTLAB]["rmse"]
    target = r["equal_rmse"]["target_rmse"]
    light_px = rmse["full"]["pixels"] - rmse["excl_light"]["pixels"]
    return [
        "",
        f"Reference: Mitsuba llvm_ad_rgb at {ref['spp']} spp ({ref['batches']} independent batches of "
        f"{ref['batch_spp']} spp). RMSE: each renderer's independent {s['spp']}-spp renders against it, "
        f"its own noise subtracted; \"excl. light\" leaves out the {light_px} pixels at and around the "
        f"light, whose partial coverage of the emitter carries most of the full image's MSE. Time to "
        f"equal RMSE = best time x (RMSE / target)^2, extrapolated with RMSE ~ spp^-1/2, target = Mitsuba "
        f"LLVM's RMSE ({target['full']:.4f} / {target['excl_light']:.5f}). drtlab / Mitsuba LLVM: "
        f"{ra['samples_per_second_drtlab_over_mitsuba_llvm_best']:.3f}x samples/s (best; "
        f"{ra['samples_per_cpu_second_drtlab_over_mitsuba_llvm']:.3f}x per CPU-second), "
        f"{ra['rmse_at_equal_spp_drtlab_over_mitsuba_llvm']:.3f}x / "
        f"{ra['rmse_at_equal_spp_excl_light_drtlab_over_mitsuba_llvm']:.3f}x RMSE at equal spp, "
        f"{ra['time_to_equal_rmse_drtlab_over_mitsuba_llvm_best']:.2f}x / "
        f"{ra['time_to_equal_rmse_excl_light_drtlab_over_mitsuba_llvm_best']:.2f}x time to equal RMSE.",
    ]


def _agreement_section(r: dict) -> list[str]:
    a = r["agreement"]
    z = a["per_pixel_z"]
    lines = [
        "",
        f"Agreement at high spp, drtlab ({a['a_renders']} x {r['settings']['spp']} spp) vs the reference: "
        + ("**agree**" if a["agree"] else "**DISAGREE**"),
        "",
        "| channel | drtlab mean ± se | Mitsuba mean ± se | difference | z |",
        "|---|---:|---:|---:|---:|",
    ]
    for c in a["channel_means"]:
        lines.append(f"| {c['channel']} | {c['drtlab_mean']:.5f} ± {c['drtlab_se']:.5f} "
                     f"| {c['mitsuba_llvm_mean']:.5f} ± {c['mitsuba_llvm_se']:.5f} "
                     f"| {100 * c['relative_difference']:+.3f} % | {c['z']:+.2f} |")
    lines += [
        "",
        f"Per-pixel z over {z['n']} pixel-channels: mean {z['mean']:+.4f} (± {z['mean_se']:.4f}), sd "
        f"{z['sd']:.3f} (expected {z['sd_expected_if_agreeing']:.3f} with Welch dof ~"
        f"{z['welch_dof_median']:.0f}), |z| > 3: {100 * z['frac_abs_gt_3']:.3f} % (expected "
        f"{100 * z['frac_abs_gt_3_expected_if_agreeing']:.3f} %).",
    ]
    return lines


def markdown(r: dict) -> str:
    pairs = markdown_rows(r["sampler_pairs"]) if "sampler_pairs" in r else []
    return "\n".join(_header(r) + _speed_table(r) + _reference_paragraph(r) + _agreement_section(r)
                     + pairs)
