"""The reference's noise floor: what the ground truth's own noise does to a study's MSEs once it is
subtracted, and the warning when that could move a cell's interval."""
from __future__ import annotations

import math
from typing import Callable

from drtlab.experiments.stats.hypothesis_tests import Z_CI
from drtlab.experiments.study.ground_truth import GroundTruth
from drtlab.experiments.study.results import NoiseFloor

NAN = float("nan")

# The reference's own noise adds its variance Var_GT to every measured MSE; the analysis subtracts it,
# so what the noise leaves is the subtraction's error D (`GroundTruth.correction_sd`), one offset
# shared by every cell of the scene. The limit is on D, not on Var_GT: a warning when Z_CI sd(D)
# exceeds NOISE_FLOOR_SHARE of the narrowest cell's 95% MSE half-width: at the limit that cell's
# interval covers 94.9% on average over the reference's noise (94.6% with D at its own 95% bound),
# and every wider one more. A fixed Var_GT <= 1% of the smallest MSE said nothing about that: on the default study's quick references (4096 spp, 8 batches of 512)
# Var_GT is 0.6-1.3% of the smallest MSE, yet sd(D) is 0.04-0.38% of it against cell intervals of
# +-2.8% to +-46%, so Z_CI sd(D) is 1.6-3.9% of the narrowest half-width (aa-edges 1.6, glossy 2.1,
# drt-showcase 2.8, dof 3.2, soft-shadows 3.4, motion-blur 3.9); sd(D) scales as 1/gt_spp, so the
# rule warns from about 1600 reference spp down (and 4 batches of 1024 or 2 of 2048 give 1.1-5.2%
# and 1.7-8.1%: fewer batches estimate v worse).
# On the heavy-tailed scenes (glossy, drt-showcase: 19-26 effective pixels) V-hat itself is uncertain:
# three independent layouts of drt-showcase's 4096 spp gave Var_GT 4.3, 6.4 and 5.4e-6, a spread
# sd(D) covers. Var_GT / smallest MSE stays in the report: the metrics not corrected for it (MAE,
# CIEDE2000) carry about half that fraction as a bias.
NOISE_FLOOR_SHARE = 0.1


def noise_floor(cells: dict, gt: GroundTruth, gt_dir) -> NoiseFloor:
    """The reference against the scene's cells: Var_GT, sd(D) and the warning of the rule above."""
    mses = [c.mse.mean for c in cells.values() if math.isfinite(c.mse.mean)]
    min_mse = min(mses) if mses else NAN
    halves = [(c.mse.hi - c.mse.lo) / 2 for c in cells.values()
              if math.isfinite(c.mse.hi) and math.isfinite(c.mse.lo) and c.mse.hi > c.mse.lo]
    half = min(halves) if halves else NAN
    sd = gt.correction_sd
    share = Z_CI * sd / half if half > 0 and math.isfinite(sd) else NAN
    return NoiseFloor(gt_dir=str(gt_dir), gt_spp=gt.spp, gt_variance=gt.variance, smallest_mse=min_mse,
                      fraction_of_smallest_mse=gt.variance / min_mse if min_mse > 0 else NAN,
                      warning=bool(math.isfinite(share) and share > NOISE_FLOOR_SHARE),
                      correction_sd=sd, narrowest_half_width=half, share_of_half_width=share)


def floor_remedy(exp) -> str:
    """What lowers the reference's noise floor: a larger-reference profile when the file has one."""
    if "full" in exp.profiles and exp.profile != "full":
        return "a larger gt_spp (e.g. --profile full) lowers the floor"
    return "a larger gt_spp in the experiment file lowers the floor"


def noise_floor_warnings(group_results: dict, log: Callable[[str], None], remedy: str,
                         group_name: Callable) -> list[str]:
    """The flagged groups, logged in one line and returned one line each (summary.json, report)."""
    flagged = [(g, v.noise_floor) for g, v in group_results.items() if v.noise_floor.warning]
    if flagged:
        fr = [100 * nf.share_of_half_width for _, nf in flagged]
        log(f"warning: in {len(flagged)} of {len(group_results)} scenes "
            f"({', '.join(g[0].label for g, _ in flagged)}) the reference's own noise, subtracted from "
            f"every MSE, leaves an error whose 95% range is {_span(fr)}% of the narrowest cell "
            f"interval (limit {100 * NOISE_FLOOR_SHARE:.0f}%): {remedy}")
    return [f"{group_name(g)}: ground-truth variance is {100 * nf.fraction_of_smallest_mse:.1f}% of the "
            f"smallest MSE; after its subtraction the reference leaves ±{fmt_share(nf.share_of_half_width)} "
            f"of the narrowest cell's 95% half-width (> {100 * NOISE_FLOOR_SHARE:.0f}%)" for g, nf in flagged]


def fmt_share(x: float) -> str:
    return f"{100 * x:.1f}%" if math.isfinite(x) else "–"


def _span(values) -> str:
    lo, hi = f"{min(values):.1f}", f"{max(values):.1f}"
    return lo if lo == hi else f"{lo}-{hi}"
