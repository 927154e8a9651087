"""The Markdown table of `make crosscheck` (crosscheck.json -> text): one row per scene."""
from __future__ import annotations

from drtlab.experiments.bench.mitsuba.crosscheck_stats import BLOCK, L1_RATIO_TOL, REL_TOL, Z_TOL

HEADER = ("| scene | drtlab R / G / B | Mitsuba R / G / B | max rel. diff (z) | L1 ratio "
          "| pixel z beyond ±3 (expected) | pass |")


def _means(channels: list[dict], who: str) -> str:
    return " / ".join(f"{c[who + '_mean']:.4f}±{c[who + '_se']:.4f}" for c in channels)


def row(name: str, r: dict) -> str:
    if "error" in r:
        return f"| {name} | {r['error']} | | | | | **no** |"
    ch, l1, z = r["channels"], r["block_l1"], r["per_pixel_z"]
    worst = max(ch, key=lambda c: c["relative_difference"])
    return (f"| {name} | {_means(ch, 'drtlab')} | {_means(ch, 'mitsuba')} | "
            f"{worst['relative_difference']:.2%} ({worst['z']:+.1f}) | "
            f"{l1['ratio_to_mitsuba_own']:.2f} ({l1['ratio_to_drtlab_own']:.2f}) | "
            f"{z['frac_abs_gt_3']:.2%} ({z['frac_abs_gt_3_expected_if_agreeing']:.2%}) | "
            f"{'yes' if r['pass'] else '**no**'} |")


def markdown(result: dict) -> str:
    s = result["settings"]
    variant = next((r["mitsuba"]["variant"] for r in result["scenes"].values()), "")
    intro = (f"drtlab vs Mitsuba 3 {variant}, {s['seeds']} seeds x {s['spp']} spp per renderer and "
             f"scene. Image means ± standard error across seeds; the channel furthest apart, with its "
             f"z; the L1 between the mean images in {BLOCK}x{BLOCK}-pixel blocks over Mitsuba's own "
             f"seed-to-seed L1 (over drtlab's in brackets); the share of pixel-channels whose z is "
             f"beyond ±3. Pass: every channel within {REL_TOL:.0%} or {Z_TOL:g} combined standard "
             f"errors, and L1 ratio <= {L1_RATIO_TOL:g}.")
    rows = [row(name, r) for name, r in result["scenes"].items()]
    return "\n".join([intro, "", HEADER, "|---|---|---|---|---|---|---|", *rows])
