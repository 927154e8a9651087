"""The variance decomposition in the renderer (experiments/sources/): the pickfreeze set's group map,
single-effect scenes whose indices are known, a negative control with a wrong group map, and the
decomposition's variance against the renderer's own.

Significance: the known indices must lie in intervals at an overall level of 1% (Sidak over the
indices checked in a test); fixed seeds."""
import math

import numpy as np
import pytest
import warp as wp
from scipy.special import ndtri

from drtlab.estimators.dimensions import GROUPS, group_of
from drtlab.estimators.pointsets.pickfreeze import CODE_B, dimension_group, make_pick_freeze, pick_freeze_seed
from drtlab.estimators.pointsets.pickfreeze import POINTSET as PICKFREEZE
from drtlab.estimators.points import points
from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.experiments.sources.decompose import variance_sources
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from scene_pieces import camera_dict, quad, scene_dict

DIMS = 45                      # the camera's five and five bounces


def test_each_code_redraws_exactly_its_group_s_dimensions():
    a = points(PICKFREEZE, 8, DIMS, seed=pick_freeze_seed(77, 0))
    assert np.array_equal(a, points("independent", 8, DIMS, seed=77))     # A is `independent`
    b = points(PICKFREEZE, 8, DIMS, seed=pick_freeze_seed(77, CODE_B))
    assert np.all(a != b)
    for g in range(len(GROUPS)):
        ab = points(PICKFREEZE, 8, DIMS, seed=pick_freeze_seed(77, g + 1))
        from_b = [d for d in range(DIMS) if np.array_equal(ab[:, d], b[:, d])]
        from_a = [d for d in range(DIMS) if np.array_equal(ab[:, d], a[:, d])]
        assert from_b == [d for d in range(DIMS) if group_of(d) == g]
        assert sorted(from_a + from_b) == list(range(DIMS))


def _edges_scene(aperture=0.0, res=(32, 24)):
    """Glowing bars on black, seen directly: a pinhole camera's only distributed effect is the
    pixel area; with a lens far out of focus, inside the bars the lens blur is."""
    cam = camera_dict((0.0, 0.0, 5.0), (0.0, 0.0, 0.0), 40.0, aperture=aperture, focus=1.5)
    shapes = [quad((-1.5 + 0.9 * i, -1.0, 0.0), (0.45, 0.1 * i, 0.0), (0.05 * i, 2.0, 0.0), "glow")
              for i in range(4)]
    return scene_from_dict(scene_dict("edges", cam, {"glow": {"kind": "emitter", "emission": [1.0, 1.0, 1.0]}},
                                      shapes, res=res, integrator="drt", max_depth=2))


def _level(checks: int) -> float:
    return 1 - sidak(0.01, checks)


@pytest.mark.parametrize("metric", ["mse", "relmse"])
def test_pixel_area_alone_holds_all_the_variance_of_a_pinhole_edge_scene(metric):
    s = variance_sources(_edges_scene(), spp=64, seed=11, metric=metric)
    ind = s.indices_at(_level(4))           # two indices, two metrics
    pixel = ind["groups"][GROUPS.index("pixel")]
    assert pixel["first_order_lo"] <= 1.0 <= pixel["first_order_hi"]
    assert pixel["total"] == pytest.approx(1.0, abs=1e-12)            # f(A_B^pixel) = f(B) exactly
    for row in ind["groups"]:
        if row["group"] != "pixel":
            assert row["first_order"] == 0.0 and row["total"] == 0.0   # never read: exactly A's


@wp.func
def _pixel_as_lens(dim: wp.uint32) -> int:
    # The wrong map: the pixel dimensions labelled as the lens group and the lens ones as the pixel
    # group; every other dimension as in dimensions.group_of.
    g = dimension_group(dim)
    if g == 0:
        return 1
    if g == 1:
        return 0
    return g


def test_a_wrong_group_map_is_rejected_by_the_single_effect_scene():
    wrong = make_pick_freeze(_pixel_as_lens, "pickfreeze-wrongmap", "negative control: pixel and lens swapped")
    s = variance_sources(_edges_scene(), spp=64, seed=11, pointset=wrong)
    pixel = s.indices_at(_level(2))["groups"][GROUPS.index("pixel")]
    assert not (pixel["first_order_lo"] <= 1.0 <= pixel["first_order_hi"])


def test_the_lens_holds_the_variance_inside_a_defocused_flat_region():
    # Pixels whose pinhole footprint is entirely inside a bar (no variance at all through a pinhole)
    # but near enough to an edge that the out-of-focus lens blurs it in: there the lens group must
    # hold nearly all of the variance; the pixel area moves a ray by under a pixel against a blur of
    # several, so its total share there stays small.
    # Aperture 0.3 focused at 1.5 blurs the bars at 5 over a disc of ~9 pixels' radius at 48x36.
    flat = variance_sources(_edges_scene(res=(48, 36)), spp=16, seed=3).pixel_variance == 0
    s = variance_sources(_edges_scene(aperture=0.3, res=(48, 36)), spp=128, seed=5)
    region = flat & (s.pixel_variance > 0)
    assert region.sum() >= 500
    lens, pixel = GROUPS.index("lens"), GROUPS.index("pixel")
    v = s.pixel_variance[region]
    t_lens = float(np.sum(s.pixel_total[lens][region] * v) / np.sum(v))
    t_pixel = float(np.sum(s.pixel_total[pixel][region] * v) / np.sum(v))
    assert t_lens > 0.95 and t_pixel < 0.25, (t_lens, t_pixel)      # measured 0.997 and 0.144


def test_cornell_box_decomposition_brackets_and_matches_the_renderer_s_variance():
    # sum S <= 1 <= sum T holds for the true indices; and the decomposition's variance of one sample
    # is the renderer's own per-pixel sample variance (independent points, same estimator), each
    # within its interval (Sidak over the three checks).
    from drtlab.kernels.render import render_with_stats
    level = _level(3)
    s = variance_sources("cornell-box", spp=96, res=(32, 24), seed=21)
    ind = s.indices_at(level)
    z = float(ndtri(0.5 + level / 2))
    assert ind["interaction"][2] >= 0.0                       # sum S <= 1 within its interval
    tot = ind["groups"]
    assert sum(r["total_hi"] for r in tot) >= 1.0
    # The renderer's image-level variance from 8 independent renders (their spread is its error).
    sampler = s.sampler.replace("pickfreeze", "independent")
    ref = [float(np.mean(render_with_stats("cornell-box", spp=128, sampler=sampler, res=(32, 24),
                                            seed=99 + k, variance=True).variance)) for k in range(8)]
    ref_mean = float(np.mean(ref))
    ref_se = float(np.std(ref, ddof=1)) / math.sqrt(len(ref))
    v, lo, hi = ind["variance"]
    se = (hi - lo) / (2 * z)
    assert abs(v - ref_mean) <= z * math.hypot(se, ref_se), (v, ref_mean, se, ref_se)
