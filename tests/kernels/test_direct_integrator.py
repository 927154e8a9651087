"""Mitsuba 3's `direct` integrator (kernels/integrators/direct.py): with one light and one BSDF
sample it draws path tracing's first-vertex numbers and weighs them alike, so it renders path
tracing at max_depth = 2 to float rounding; with other counts (MIS over the techniques' fractions)
its mean agrees with that image (per-seed image means paired by seed, t per channel, Sidak over the counts'
tests), and f|cos| without its cosine (features.DROP_COSINE, applied to the API's BSDF functions)
is rejected by the same test. The [scene] keys are validated."""
import numpy as np
import pytest
from scipy import stats

import drtlab
from drtlab.errors import InputError
from drtlab.experiments.stats.hypothesis_tests import sidak
from drtlab.kernels.features import DROP_COSINE
from drtlab.kernels.render import render_batch_with_stats

SCENE, RES, SPP, SEEDS, ALPHA = "cornell-box", [16, 12], 32, range(24), 0.01
COUNTS = ((4, 1), (0, 2), (2, 0))


def _scene(**scene):
    return drtlab.load_scene(SCENE, {"scene.resolution": RES, **{f"scene.{k}": v for k, v in scene.items()}})


def _means(scene, **kw):
    return render_batch_with_stats(scene, seeds=SEEDS, spp=SPP, **kw).images.mean(axis=(1, 2))  # (R, 3)


def _p_min(a, b) -> float:
    # Paired by seed: both read the same pixel, lens and time numbers (the same dimensions), so the
    # camera's share of the noise (the light's edges seen directly) cancels in the differences.
    return min(stats.ttest_rel(a[:, c], b[:, c]).pvalue for c in range(3))


def test_one_sample_each_is_path_tracing_at_depth_two():
    direct = drtlab.render(_scene(integrator="direct"), spp=SPP, seed=4)
    path = drtlab.render(_scene(integrator="path", max_depth=2), spp=SPP, seed=4)
    assert direct.max() > 0.0
    np.testing.assert_allclose(direct, path, rtol=1e-5, atol=1e-7)


def test_other_counts_agree_with_path_and_a_dropped_cosine_does_not():
    path = _means(_scene(integrator="path", max_depth=2))
    level = sidak(ALPHA, len(COUNTS) * 3)
    for e, b in COUNTS:
        p = _p_min(_means(_scene(integrator="direct", emitter_samples=e, bsdf_samples=b)), path)
        assert p > level, ((e, b), p, level)
    wrong = _means(_scene(integrator="direct", emitter_samples=4, bsdf_samples=1), faults=(DROP_COSINE,))
    assert _p_min(wrong, path) < level


@pytest.mark.parametrize("scene, field", [
    ({"integrator": "path", "emitter_samples": 2}, "scene.emitter_samples"),
    ({"integrator": "direct", "emitter_samples": 0, "bsdf_samples": 0}, "scene.emitter_samples"),
    ({"integrator": "direct", "bsdf_samples": 65}, "scene.bsdf_samples"),
    ({"integrator": "direct", "bsdf_samples": 1.5}, "scene.bsdf_samples"),
])
def test_bad_sample_counts_are_refused(scene, field):
    with pytest.raises(InputError) as e:
        _scene(**scene)
    assert e.value.field == field and "\n" not in e.value.message
