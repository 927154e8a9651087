"""Ground truth: float64 batches with a per-pixel standard error; reused when the key matches,
recomputed when the scene or the estimator code changes, resumable by batch."""
import json
from dataclasses import replace

import numpy as np
import pytest

from drtlab.experiments.study.config import SceneRef
from fakes import FakeRenderer
from drtlab.experiments.study.ground_truth import GT_SAMPLER, ensure_ground_truth, load_ground_truth
from drtlab.experiments.seeds import GT_BIT
from drtlab.errors import InputError

SCENE = SceneRef("aa-edges", "aa-edges")
RES = (16, 12)


def make(tmp_path, fake=None, spp=2048, batch=256, **kw):
    fake = fake or FakeRenderer()
    gt = ensure_ground_truth(SCENE, "drt", RES, spp, batch, fake.backend(), tmp_path / "gt",
                             progress=False, log=lambda m: None, **kw)
    return gt, fake


def test_mean_stderr_files_and_manifest(tmp_path):
    gt, fake = make(tmp_path)
    assert gt.spp == 2048 and gt.batches == 8 and not gt.reused
    assert fake.calls == 8 and all(s == GT_SAMPLER for _, s, _, _ in fake.log)
    assert all(seed >= GT_BIT for *_, seed in fake.log)
    truth = FakeRenderer.truth("aa-edges", *RES)
    # The fake's error sd of a stratified 256-spp batch is 0.2 * 256^-0.75, so the standard error of
    # the mean of 8 batches is that over sqrt(8); the batch-means estimate (7 degrees of freedom per
    # pixel) averages to it over 576 values.
    assert GT_SAMPLER.startswith("stratified")
    expect = 0.2 * 256 ** -0.75 / np.sqrt(8)
    assert abs(np.sqrt(np.mean(gt.stderr ** 2)) / expect - 1) < 0.1
    z = (gt.mean - truth) / gt.stderr
    assert abs(np.mean(z)) < 0.15 and 0.8 < np.std(z) < 1.35
    d = gt.directory
    for name in ("gt.npz", "mean.exr", "stderr.exr", "manifest.json"):
        assert (d / name).is_file()
    m = json.loads((d / "manifest.json").read_text())
    assert m["spp"] == 2048 and m["code_version"] == "fake-1" and m["estimator"]["sampler"] == GT_SAMPLER
    assert len(m["seeds"]) == 8 and m["scene_hash"] and m["wall_seconds"] >= 0
    again = load_ground_truth(d)
    assert np.array_equal(again.mean, gt.mean) and gt.mean.dtype == np.float64


def test_reused_when_key_matches(tmp_path):
    gt, _ = make(tmp_path)
    gt2, fake2 = make(tmp_path)
    assert gt2.reused and fake2.calls == 0 and np.array_equal(gt2.mean, gt.mean)
    gt3, fake3 = make(tmp_path, spp=1024)                  # fewer spp asked: the better one is kept
    assert gt3.reused and fake3.calls == 0 and gt3.spp == 2048


def test_more_spp_extends_the_same_reference(tmp_path):
    make(tmp_path, spp=1024)
    gt, fake = make(tmp_path, spp=2048)
    assert fake.calls == 4 and gt.spp == 2048
    ref, _ = make(tmp_path / "other", spp=2048)
    assert np.array_equal(gt.mean, ref.mean)


def test_recomputed_when_scene_or_code_changes(tmp_path):
    make(tmp_path)
    fake = FakeRenderer(versions={"aa-edges": "v2"})          # the scene text changed
    msgs = []
    gt = ensure_ground_truth(SCENE, "drt", RES, 2048, 256, fake.backend(), tmp_path / "gt",
                             progress=False, log=msgs.append)
    assert fake.calls == 8 and not gt.reused and "scene_hash" in msgs[0]
    fake2 = FakeRenderer(versions={"aa-edges": "v2"})
    backend = replace(fake2.backend(), code_version="fake-2")   # the estimator code changed
    msgs = []
    ensure_ground_truth(SCENE, "drt", RES, 2048, 256, backend, tmp_path / "gt", progress=False,
                        log=msgs.append)
    assert fake2.calls == 8 and "code_version" in msgs[0]


def test_resumable_by_batch_and_identical_to_uninterrupted(tmp_path):
    with pytest.raises(KeyboardInterrupt):
        make(tmp_path, fake=FakeRenderer(fail_after=3))
    d = next((tmp_path / "gt").iterdir())
    assert not (d / "manifest.json").exists()               # not complete, but 3 batches are kept
    gt, fake = make(tmp_path)
    assert fake.calls == 5
    ref, _ = make(tmp_path / "ref")
    assert np.array_equal(gt.mean, ref.mean) and np.array_equal(gt.stderr, ref.stderr)


def test_biased_integrator_refused(tmp_path):
    with pytest.raises(InputError) as e:
        ensure_ground_truth(SCENE, "whitted", RES, 2048, 256, FakeRenderer().backend(), tmp_path,
                            progress=False)
    assert e.value.field == "integrator"


def test_each_pixel_filter_has_its_own_reference(tmp_path):
    # A filter defines the pixel: the same scene under two filters must never share a reference
    # (the filter is in the scene's overrides, its content hash and its directory), and the reference
    # is rendered with filter importance sampling (unbiased), never the splatting estimator.
    from drtlab.experiments.study.config import scene_ref
    from drtlab.experiments.study.ground_truth import gt_directory, scene_key_info
    from drtlab.estimators.registry import parse_sampler
    backend = FakeRenderer().backend()
    refs = [scene_ref(e, "scenes[0]") for e in
            ("aa-edges", {"name": "aa-edges", "overrides": {"camera.filter": "gaussian"}},
             {"name": "aa-edges", "overrides": {"camera.filter": "mitchell"}})]
    keys = [scene_key_info(r, "drt", RES, backend)[0] for r in refs]
    assert len({k["scene_hash"] for k in keys}) == 3
    assert len({gt_directory(tmp_path, r, "drt", RES) for r in refs}) == 3
    assert not parse_sampler(GT_SAMPLER).splat


def test_a_stale_reference_is_recomputed_without_touching_other_files_in_its_folder(tmp_path):
    gt, _ = make(tmp_path)
    (gt.directory / "notes.txt").write_text("the user's")
    (gt.directory / "old").mkdir()
    (gt.directory / "old" / "mean.exr").write_bytes(b"kept")
    fake = FakeRenderer(versions={"aa-edges": "v2"})
    gt2, fake = make(tmp_path, fake)
    assert fake.calls == 8 and not gt2.reused and gt2.directory == gt.directory
    assert (gt.directory / "notes.txt").read_text() == "the user's"
    assert (gt.directory / "old" / "mean.exr").read_bytes() == b"kept"
