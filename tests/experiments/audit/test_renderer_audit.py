"""The study's cell-MSE interval covers on the real renderer (experiments/audit/renderer.py).

200 cells of 5 furnace renders (fixed seed) per sampler and spp, each cell's log-t interval from
`compare_scene`, judged against the leave-cell-out mean MSE of the other 995 runs. If the interval
is calibrated the number of covering cells is Binomial(200, 0.95); the check rejects that when the
count falls outside the two-sided 99.9% acceptance band (`coverage_band`, alpha = 0.001, at most
0.0005 in each tail): 179-198 covered cells of 200.

Measured with 2000 cells (seed 7): 0.949-0.952 at 16 spp, but 0.932 (uniform) and 0.937
(stratified) at 4 spp, 4:1 of the misses above the interval: the 4-spp per-run MSE is more skewed
(skewness 1.15) than a gamma law of its cv 0.19. So at 4 spp a new seed lands outside the band with
probability ~0.01; the fixed seed here is inside.

Negative controls, checked the same way, must be rejected: the naive z-interval (normal quantile
instead of Student's t on the log scale) on 3-run cells (covers ~0.79), and the study's interval
computed against a reference 5% too bright at 16 spp (covers ~0.02).
"""
import numpy as np
import pytest

from drtlab.experiments.audit import renderer as R

import scene_util as su

CELLS = 200
SEED = 20240611
SAMPLERS = ("uniform", "stratified")
SPP = (4, 16)


@pytest.fixture(scope="module")
def audit():
    return R.renderer_audit(CELLS, 5, SPP, SAMPLERS, (32, 24), SEED)


def test_furnace_is_the_closed_form_of_the_tests():
    # The audit's scene must be the furnace whose exact value tests/kernels/test_analytic.py checks.
    cf = su.furnace_box(rho=R.RHO, le=R.LE, depth=R.DEPTH, integrator="path", res=(32, 24),
                        **su.EDGE_FREE_VIEW)
    d, exact = R.furnace_scene((32, 24))
    for key in ("camera", "materials", "shapes"):
        assert d[key] == cf.scene[key], key
    assert d["scene"]["max_depth"] == cf.scene["scene"]["max_depth"]
    np.testing.assert_allclose(cf.truth, 3.0 * exact)
    assert exact == pytest.approx(su.furnace_value(R.RHO, R.LE, R.DEPTH, "path"), rel=1e-12)


def test_coverage_band():
    assert R.coverage_band(200) == (179, 198)
    lo, hi = R.coverage_band(2000)
    assert lo < 1900 < hi


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("spp", SPP)
def test_cell_interval_covers_on_renders(audit, sampler, spp):
    r = audit[(sampler, spp)]
    summary = "; ".join(R.summary_lines({(sampler, spp): r}))
    assert r["cells"] == CELLS and r["runs_per_cell"] == 5
    assert r["band"][0] <= r["covered"] <= r["band"][1], summary
    assert r["in_band"], summary
    # Light-tailed MSEs: the study resolves (nearly) every cell, and its tail check stays quiet.
    assert r["resolved_fraction"] >= 0.95 and not r["tail_heavy"], summary
    lo, hi = R.coverage_band(r["resolved"])
    assert lo <= r["resolved_covered"] <= hi, summary
    # The estimated truth is far more precise than the intervals it judges.
    assert r["truth_rel_se"] < 0.1 * r["median_rel_halfwidth"], summary


def test_audit_is_fast(audit):
    # 200 cells x 5 runs at 32x24, 4 spp: rendering plus 200 compare_scene calls (compile excluded:
    # the kernel is cached by the fixture's first use or by Warp's disk cache).
    again = R.renderer_audit(CELLS, 5, (4,), ("uniform",), (32, 24), SEED)[("uniform", 4)]
    assert again["covered"] == audit[("uniform", 4)]["covered"]       # reproducible
    assert again["seconds"] < 30.0


def test_naive_z_interval_is_rejected():
    r = R.renderer_audit(CELLS, 3, (4,), ("uniform",), (32, 24), SEED, interval="naive-z")[("uniform", 4)]
    assert r["cells"] == CELLS
    assert not r["in_band"] and r["covered"] < r["band"][0], R.summary_lines({("uniform", 4): r})


def test_biased_reference_is_rejected(audit):
    r = R.renderer_audit(CELLS, 5, (16,), ("uniform",), (32, 24), SEED,
                         reference_scale=1.05)[("uniform", 16)]
    assert not r["in_band"] and r["covered"] < r["band"][0], R.summary_lines({("uniform", 16): r})
    # The same renders (same seeds) against the exact image pass: the bias alone made it fail.
    assert audit[("uniform", 16)]["in_band"]
