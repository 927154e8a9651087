"""The statistics of `make crosscheck` on synthetic stacks of renders (pure numpy, no renderer): the
pass rule holds when two renderers share an expected image, and fails on a 5% brightness error
(the negative control); a renderer's own seed-to-seed block L1 is what two independent means of n
renders show. Fixed generator seeds; each stack is (n, H, W, 3) of Gaussian pixel noise."""
import math

import numpy as np
import pytest

from drtlab.experiments.bench.mitsuba.crosscheck_stats import (block_l1, block_means, crosscheck,
                                                                self_block_l1)

H, W, N, SD = 48, 64, 8, 0.2
BASE = np.linspace(0.2, 0.8, H * W * 3).reshape(H, W, 3)


def stacks(seed: int, scale: float = 1.0, sd_a: float = SD):
    rng = np.random.default_rng(seed)
    return (scale * BASE + rng.normal(0.0, sd_a, (N, H, W, 3)),
            BASE + rng.normal(0.0, SD, (N, H, W, 3)))


def test_block_means_cover_partial_edge_blocks_exactly():
    img = np.arange(5 * 3 * 1, dtype=float).reshape(5, 3, 1)
    b = block_means(img, 2)
    assert b.shape == (3, 2, 1)
    assert b[0, 0, 0] == np.mean(img[:2, :2]) and b[2, 1, 0] == img[4, 2, 0]
    assert b[2, 0, 0] == np.mean(img[4, :2]) and b[0, 1, 0] == np.mean(img[:2, 2])
    assert block_l1(img, img + 0.5, 2) == 0.5


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_equal_expectations_pass(seed):
    # Under agreement the L1 ratio is ~1 (sd about 0.06 over 144 block-channels) and each channel's
    # relative difference about 0.2%: the 1.5 and 1% bounds are several sd away.
    r = crosscheck(*stacks(seed))
    assert r["pass"], r["checks"]
    assert 0.8 < r["block_l1"]["ratio_to_mitsuba_own"] < 1.25


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_five_percent_brightness_error_fails_both_checks(seed):
    r = crosscheck(*stacks(seed, scale=1.05))
    assert not r["pass"]
    assert r["checks"] == {"channel_means": False, "block_l1": False}
    assert all(0.04 < c["relative_difference"] < 0.06 for c in r["channels"])


def test_the_block_rule_also_bounds_drtlab_noise_against_mitsuba():
    # drtlab with 9x Mitsuba's variance, same expectation: the cross L1 is sqrt(10/2) ~ 2.24 times
    # Mitsuba's own and sqrt(10/18) ~ 0.75 times drtlab's, so the block rule fails without any bias
    # (it passes up to about 3.5x the variance); the L1 expected under agreement, reported beside
    # it, tells the two cases apart.
    r = crosscheck(*stacks(4, sd_a=3 * SD))
    assert r["checks"] == {"channel_means": True, "block_l1": False}
    assert 1.9 < r["block_l1"]["ratio_to_mitsuba_own"] < 2.6
    assert 0.6 < r["block_l1"]["ratio_to_drtlab_own"] < 0.9
    assert r["block_l1"]["between"] == pytest.approx(r["block_l1"]["expected_if_agreeing"], rel=0.1)


def test_own_block_l1_is_that_of_two_independent_means():
    # An 8 x 8 block of N renders with pixel sd SD: each block mean's sd is SD / 8 per render; two
    # independent means of N differ with sd SD / 8 * sqrt(2 / N), and E|X| = sd sqrt(2 / pi).
    stack, _ = stacks(5)
    want = SD / 8 * math.sqrt(2 / N) * math.sqrt(2 / math.pi)
    assert self_block_l1(stack) == pytest.approx(want, rel=0.08)
    r = crosscheck(*stacks(5))
    assert r["block_l1"]["expected_if_agreeing"] == pytest.approx(want, rel=0.08)


def test_the_table_has_a_row_per_scene_and_marks_a_failure():
    from drtlab.experiments.bench.mitsuba.crosscheck_report import markdown
    scenes = {"same": crosscheck(*stacks(1)), "brighter": crosscheck(*stacks(1, scale=1.05)),
              "film": {"pass": False, "error": "image stacks differ"}}
    for r in scenes.values():
        r["mitsuba"] = {"variant": "llvm_ad_rgb"}
    text = markdown({"settings": {"seeds": N, "spp": 4}, "scenes": scenes})
    rows = [line for line in text.splitlines() if line.startswith("| ") and "scene" not in line]
    assert len(rows) == 3
    assert rows[0].startswith("| same |") and rows[0].endswith("| yes |")
    assert rows[1].startswith("| brighter |") and rows[1].endswith("| **no** |")
    assert rows[2].startswith("| film | image stacks differ |") and rows[2].endswith("| **no** |")
    assert all(line.count("|") == 8 for line in text.splitlines() if line.startswith("|"))
