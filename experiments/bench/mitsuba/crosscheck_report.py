"""The Markdown table of `make crosscheck` (crosscheck.json -> text): one row per scene."""
from __future__ import annotations


def _means(ch: list[dict], who: str) -> str:
    return " / ".join(f"{c[who + '_mean']:.4f}±{c[who + '_se']:.4f}" for c in ch)


def markdown(result: dict) -> str:
    s = result["settings"]
    lines = [f"drtlab vs Mitsuba 3 ({result['scenes'] and next(iter(result['scenes'].values()))['mitsuba']['variant']}), "
             f"{s['seeds']} seeds x {s['spp']} spp per renderer and scene; R / G / B image means ± "
             f"standard error across seeds; block L1 of 8x8-pixel blocks between the mean images "
             f"over Mitsuba's own seed-to-seed block L1 (drtlab's own in brackets); pass: every "
             f"channel within 1% or 3 combined se, and L1 ratio <= 1.5.", "",
             "| scene | drtlab R / G / B | Mitsuba R / G / B | max rel. diff | L1 ratio | share of pixel z beyond ±3 (expected) | pass |",
             "|---|---|---|---|---|---|---|"]
    for name, r in result["scenes"].items():
        ch, l1, z = r["channels"], r["block_l1"], r["per_pixel_z"]
        rel = max(c["relative_difference"] for c in ch)
        lines.append(f"| {name} | {_means(ch, 'drtlab')} | {_means(ch, 'mitsuba')} | {rel:.2%} | "
                     f"{l1['ratio_to_mitsuba_own']:.2f} ({l1['ratio_to_drtlab_own']:.2f}) | "
                     f"{z['frac_abs_gt_3']:.2%} ({z['frac_abs_gt_3_expected_if_agreeing']:.2%}) | "
                     f"{'yes' if r['pass'] else '**no**'} |")
    return "\n".join(lines)
