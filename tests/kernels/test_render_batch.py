"""render_batch: repetition r of a batch is bit-identical to a render of seeds[r] alone, whatever the
batch size, thread count and tile size; over point sets, integrators and scenes with a thin lens,
motion blur, triangle meshes, many spheres, Whitted's grid and pixel filters (both estimators). Bad seeds are one InputError."""
import numpy as np
import pytest

import drtlab
from drtlab.errors import InputError
from drtlab.kernels.render import render_batch_with_stats
from drtlab.kernels.scene_model.scene_file import load_scene

CASES = [  # scene, sampler, integrator
    ("dof", "sobol+importance", None),                    # thin lens
    ("motion-blur", "stratified", None),                  # shutter time
    ("displaced-sphere", "zsobol+importance", "path"),    # triangle mesh, pixel-keyed point set
    ("sphere-grid", "pmj02+importance", None),            # sphere BVH
    ("cornell-box", "cmj+light", "path"),                 # transformed boxes, light sampling only
    ("veach-mis", "halton+bsdf", None),
    ("cornell-box", "uniform", "whitted"),                # no sampler: the sub-pixel grid
    # Pixel filters: importance-sampled (each pixel alone) and splatted (a pass's samples of the
    # grown image, gathered after the pass).
    (load_scene("aa-edges", {"camera.filter": "gaussian"}), "stratified", None),
    (load_scene("aa-edges", {"camera.filter": "mitchell"}), "sobol+splat", None),
]
SEEDS = [0, 7, 2**32 - 1, 12345, 7]                      # a repeated seed repeats its image


@pytest.mark.parametrize("scene, sampler, integrator", CASES)
def test_each_repetition_equals_its_own_render(scene, sampler, integrator):
    alone = [drtlab.render(scene, spp=5, sampler=sampler, integrator=integrator, seed=s,
                           res=(21, 13), threads=1, tile=16) for s in SEEDS]
    for threads, tile, seeds in ((2, 5, SEEDS), (1, 64, SEEDS), (2, 16, SEEDS[1:3])):
        batch = drtlab.render_batch(scene, seeds=seeds, spp=5, sampler=sampler,
                                    integrator=integrator, res=(21, 13), threads=threads, tile=tile)
        assert batch.shape == (len(seeds), 13, 21, 3) and batch.dtype == np.float64
        for r, s in enumerate(seeds):
            assert np.array_equal(batch[r], alone[SEEDS.index(s)]), (threads, tile, r)
    # The seeds matter at all, except to Whitted's deterministic sub-pixel grid.
    assert np.array_equal(alone[0], alone[1]) == (integrator == "whitted")


def test_more_than_one_pass_and_variances():
    # spp above the 64-sample pass: the per-pass float64 sums must accumulate per repetition.
    seeds = [3, 4]
    b = render_batch_with_stats("soft-shadows", seeds, spp=70, sampler="stratified+importance",
                                res=(9, 7), threads=2, variance=True)
    for r, s in enumerate(seeds):
        one = drtlab.render("soft-shadows", spp=70, sampler="stratified+importance", seed=s,
                            res=(9, 7), threads=1, stats=True)
        assert np.array_equal(b.images[r], one.image)
    assert b.variances.shape == b.images.shape and np.all(b.variances >= 0)
    assert b.cpu_seconds >= 0 and b.render_seconds > 0


@pytest.mark.parametrize("seeds", [[], [-1], [2**32], "12", [1.5]])
def test_bad_seeds_are_one_input_error(seeds):
    with pytest.raises(InputError) as e:
        drtlab.render_batch("aa-edges", seeds=seeds, spp=1, res=(8, 6))
    assert e.value.field == "seeds"
