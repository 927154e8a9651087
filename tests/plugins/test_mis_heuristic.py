"""The MIS heuristic is a strategy's choice (kernels/mis.py): the balance heuristic, registered as a
composition (`drtlab.register_strategy(..., heuristic="balance")`), renders two closed-form scenes
where both techniques reach the light (a sphere light over a diffuse plane; an emitting furnace
box, path depth 2) to their exact values, as the built-in power heuristic does; weights that sum to
1.1 instead of 1 (a negative control) must be rejected. Significance: ALPHA (stats_util) with Sidak
over the module's tests."""
import numpy as np
import pytest
import warp as wp

import drtlab
from drtlab.errors import InputError
from drtlab.estimators import strategies
from drtlab.experiments.stats.chi2 import sidak
from drtlab.kernels import mis

import scene_util as su
from stats_util import ALPHA, compare, render_estimate

BLOCK, RES, RUNS, SPP = 4, (16, 12), 8, 64
CASES = [("power", "plane"), ("balance", "plane"), ("balance", "furnace"), ("skewed", "plane")]
ALPHA_TEST = sidak(ALPHA, len(CASES))


@wp.func
def skewed_heuristic(a: float, b: float) -> float:
    return a / (a + b) + 0.05                  # both techniques' weights sum to 1.1


def _scene(which: str):
    if which == "plane":
        return su.light_over_plane("sphere", res=RES, integrator="path", max_depth=2)
    return su.furnace_box(rho=0.6, le=1.0, depth=2, integrator="path", res=RES, **su.EDGE_FREE_VIEW)


@pytest.mark.parametrize("heuristic, which", CASES)
def test_each_heuristic_renders_the_closed_form(clean_registry, monkeypatch, heuristic, which):
    if heuristic == "skewed":
        monkeypatch.setattr(strategies, "MIS_HEURISTICS", strategies.MIS_HEURISTICS + ("skewed",))
        monkeypatch.setitem(mis.HEURISTICS, "skewed", skewed_heuristic)
    name = "importance" if heuristic == "power" else f"importance-{heuristic}"
    if heuristic != "power":
        drtlab.register_strategy(name, f"importance, {heuristic} heuristic", heuristic=heuristic)
    cf = _scene(which)
    est = render_estimate(cf.load(), f"independent+{name}", "path", SPP, RUNS,
                          ("mis-heuristic", heuristic, which), block=BLOCK)
    c = compare(est, cf.region_truth(BLOCK), ALPHA_TEST)
    assert est.nonfinite == 0 and est.negative == 0
    if heuristic == "skewed":
        assert c.rejected, f"weights summing to 1.1 passed: {c.summary()}"
    else:
        assert not c.rejected, f"{heuristic} on {which}: {c.summary()}"


def _weights(fn, a, b):
    @wp.kernel(enable_backward=False, module="unique")
    def k(a: wp.array(dtype=float), b: wp.array(dtype=float), out: wp.array(dtype=float)):
        i = wp.tid()
        out[i] = fn(a[i], b[i]) + fn(b[i], a[i])
    out = wp.zeros(len(a), dtype=float, device="cpu")
    wp.launch(k, dim=len(a), inputs=[wp.array(a, dtype=float, device="cpu"),
                                     wp.array(b, dtype=float, device="cpu"), out], device="cpu")
    return out.numpy()


def test_the_heuristics_are_named_once_and_weigh_to_one():
    assert set(mis.HEURISTICS) == set(strategies.MIS_HEURISTICS)
    rng = np.random.default_rng(1)
    a, b = 10.0 ** rng.uniform(-6, 6, 1000), 10.0 ** rng.uniform(-6, 6, 1000)
    for name, fn in mis.HEURISTICS.items():
        assert np.allclose(_weights(fn, a, b), 1.0, rtol=0, atol=1e-6), name
    assert np.allclose(_weights(skewed_heuristic, a, b), 1.1, atol=1e-6)
    assert {s.light.heuristic for s in strategies.STRATEGIES.values() if s.light} == {"power"}
    with pytest.raises(InputError) as e:
        drtlab.register_strategy("bad", "x", like="light", heuristic="balance")   # no MIS to weigh
    assert e.value.field == "heuristic" and "power, balance" in e.value.message
