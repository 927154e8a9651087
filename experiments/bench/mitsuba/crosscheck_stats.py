"""The statistics of `make crosscheck`: does drtlab's image of a scene equal Mitsuba 3's, within what
each renderer's own seed-to-seed noise allows? Pure numpy on finished stacks of independent renders
(n, H, W, 3), one stack per renderer at matched settings: nothing here renders.

The pass rule: every channel's image mean within 1% of Mitsuba's (or within 3 combined standard
errors, for a dim channel whose noise is larger than 1% of it), and the block L1 between the two
renderers' mean images within 1.5 times the block L1 Mitsuba's mean image shows against an
independent repetition of itself. The per-pixel z summary (shared with `make bench-compare`) is
reported beside it, to locate a difference, not judged.
"""
from __future__ import annotations

import math

import numpy as np

from drtlab.experiments.bench.mitsuba.stats import agreement

REL_TOL = 0.01          # channel means: relative difference allowed
Z_TOL = 3.0             # ... or this many combined standard errors
L1_RATIO_TOL = 1.5      # block L1 between renderers over Mitsuba's own seed-to-seed block L1
BLOCK = 8               # block side in pixels
SPLITS = 32             # random half-splits averaged for a renderer's own seed-to-seed L1
SPLIT_SEED = 20240      # fixed: the same stacks always give the same numbers


def block_means(img: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """(ceil(H/b), ceil(W/b), C) means of `img`'s b x b blocks (edge blocks hold what is left)."""
    h, w = img.shape[:2]
    rows, cols = np.arange(0, h, block), np.arange(0, w, block)
    sums = np.add.reduceat(np.add.reduceat(img, rows, axis=0), cols, axis=1)
    counts = np.outer(np.diff(np.append(rows, h)), np.diff(np.append(cols, w)))
    return sums / counts[..., None]


def block_l1(a: np.ndarray, b: np.ndarray, block: int = BLOCK) -> float:
    """Mean absolute difference of the two images' block means, over blocks and channels."""
    return float(np.mean(np.abs(block_means(a, block) - block_means(b, block))))


def self_block_l1(stack: np.ndarray, block: int = BLOCK, splits: int = SPLITS,
                  seed: int = SPLIT_SEED) -> float:
    """The block L1 between the mean of `stack`'s n renders and an independent mean of n more, from
    the renders alone: random half-splits, each half's mean against the other's. A difference of
    means of a and b renders has variance v (1/a + 1/b) where two means of n have 2 v / n; the L1 of
    a zero-mean Gaussian is proportional to its sd, so each split's L1 is scaled by the square root
    of that ratio."""
    n = len(stack)
    if n < 2:
        raise ValueError("a renderer's own seed-to-seed L1 needs at least 2 renders")
    a = n // 2
    scale = math.sqrt((2.0 / n) / (1.0 / a + 1.0 / (n - a)))
    rng = np.random.default_rng(seed)
    blocks = np.stack([block_means(img, block) for img in stack])
    vals = []
    for _ in range(splits):
        order = rng.permutation(n)
        vals.append(np.mean(np.abs(blocks[order[:a]].mean(axis=0) - blocks[order[a:]].mean(axis=0))))
    return float(np.mean(vals) * scale)


def expected_cross_l1(d_stack: np.ndarray, m_stack: np.ndarray, block: int = BLOCK) -> float:
    """The block L1 of the two mean images if they had the same expectation: each block difference
    zero-mean Gaussian with the variance the renders' spread gives, E|X| = sd sqrt(2 / pi)."""
    var = sum(np.stack([block_means(img, block) for img in s]).var(axis=0, ddof=1) / len(s)
              for s in (d_stack, m_stack))
    return float(np.mean(np.sqrt(var)) * math.sqrt(2.0 / math.pi))


def channel_checks(channels: list[dict], rel_tol: float = REL_TOL, z_tol: float = Z_TOL) -> list[dict]:
    """Per channel of `agreement`'s channel means: within rel_tol of Mitsuba's, or within z_tol
    combined standard errors."""
    out = []
    for c in channels:
        d, m = c["drtlab_mean"], c["mitsuba_mean"]
        se = math.hypot(c["drtlab_se"], c["mitsuba_se"])
        rel = abs(d - m) / abs(m) if m else (0.0 if d == m else math.inf)
        out.append({"channel": c["channel"], "drtlab_mean": d, "drtlab_se": c["drtlab_se"],
                    "mitsuba_mean": m, "mitsuba_se": c["mitsuba_se"], "relative_difference": rel,
                    "z": c["z"], "ok": bool(rel <= rel_tol or abs(d - m) <= z_tol * se)})
    return out


def crosscheck(d_stack: np.ndarray, m_stack: np.ndarray, block: int = BLOCK) -> dict:
    """drtlab's renders against Mitsuba's (each (n, H, W, 3), independent seeds): channel means,
    block L1s, per-pixel z, and the verdict of the pass rule."""
    if d_stack.shape[1:] != m_stack.shape[1:]:
        raise ValueError(f"image shapes differ: drtlab {d_stack.shape[1:]}, mitsuba {m_stack.shape[1:]}")
    agree = agreement(d_stack, m_stack, "drtlab", "mitsuba")
    channels = channel_checks(agree["channel_means"])
    cross = block_l1(d_stack.mean(axis=0), m_stack.mean(axis=0), block)
    own = {"drtlab": self_block_l1(d_stack, block), "mitsuba": self_block_l1(m_stack, block)}
    ratio = cross / own["mitsuba"] if own["mitsuba"] > 0 else (1.0 if cross == 0 else math.inf)
    z = agree["per_pixel_z"]
    checks = {"channel_means": all(c["ok"] for c in channels),
              "block_l1": bool(ratio <= L1_RATIO_TOL)}
    return {"renders": {"drtlab": len(d_stack), "mitsuba": len(m_stack)},
            "channels": channels,
            "block_l1": {"block": block, "between": cross, "drtlab_own": own["drtlab"],
                         "mitsuba_own": own["mitsuba"], "ratio_to_mitsuba_own": ratio,
                         "ratio_to_drtlab_own": cross / own["drtlab"] if own["drtlab"] > 0 else math.inf,
                         "expected_if_agreeing": expected_cross_l1(d_stack, m_stack, block)},
            "per_pixel_z": {k: z[k] for k in ("n", "mean", "mean_se", "sd", "sd_expected_if_agreeing",
                                              "frac_abs_gt_3", "frac_abs_gt_3_expected_if_agreeing",
                                              "largest")},
            "rule": f"every channel mean within {REL_TOL:.0%} of Mitsuba's or within {Z_TOL:g} combined "
                    f"standard errors; block L1 ({block}x{block}) between the mean images at most "
                    f"{L1_RATIO_TOL:g} x Mitsuba's own seed-to-seed block L1",
            "checks": checks, "pass": all(checks.values())}
