"""Ground truth: a high-spp reference from an unbiased estimator, with its per-pixel standard error.

The reference uses `GT_SAMPLER` (jittered strata with the MIS `importance` strategy) and the study's
own integrator (whitted is refused: biased). It is accumulated in float64 over independent batches of
`batch_spp` samples: the per-pixel mean is the mean of the batch means, and the per-pixel standard
error is their standard deviation over sqrt(batches) (Welford updates, no cancellation).

Layout, under the ground-truth root (default `results/ground-truth/`):

    <scene key>__<integrator>__<W>x<H>/
        gt.npz          mean, stderr, m2, batches, batch_spp (rewritten atomically after each batch)
        mean.exr        per-pixel mean (written when the requested spp is reached)
        stderr.exr      per-pixel standard error
        manifest.json   scene hash, code version, estimator, spp, seeds, wall time, status

Reuse: a stored reference is used when its key (scene content hash + overrides, resolution,
integrator, estimator, code version) matches and it holds at least the requested spp; with fewer spp
it resumes from the last finished batch; with a different key it is discarded and recomputed.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study.config import SceneRef
from drtlab.experiments.paths import default_gt_root
from drtlab.experiments.files import atomic_savez, atomic_write_json
from drtlab.experiments.stats.running_moments import RunningMoments
from drtlab.kernels.imageio import write_exr
from drtlab.experiments.seeds import gt_seed, short_hash

# Unbiased, MIS, and the lowest-variance estimator the default study compares: at 1024 spp its
# variance is 1.6x (drt-showcase) to 32x (aa-edges) below independent+importance's at equal spp, so
# half the samples give a lower noise floor on five of the six default scenes; its batches are
# independent (disjoint seeds), so their spread is still an honest standard error.
GT_SAMPLER = "stratified+importance"
GT_FORMAT = 2                            # bump when the storage, seeding or estimator changes
GT_FILES = ("gt.npz", "mean.exr", "stderr.exr", "manifest.json")     # what a reference's folder holds


@dataclass
class GroundTruth:
    mean: np.ndarray                     # (H, W, 3) float64
    stderr: np.ndarray                   # (H, W, 3) float64, standard error of `mean`
    spp: int
    batches: int
    directory: Path
    manifest: dict
    reused: bool = False

    @property
    def variance(self) -> float:
        """Mean per-pixel variance of the reference: its additive contribution to every MSE."""
        return float(np.mean(np.square(self.stderr)))

    @property
    def correction_sd(self) -> float:
        """Standard deviation of the error that subtracting `variance` leaves in a measured MSE.
        Against this reference a run's MSE holds mean(e^2), e the reference's own error, where the
        analysis subtracts mean(stderr^2); per pixel e^2 has variance 2 v^2 and the estimate
        v-hat (from B batches) 2 v^2 / (B - 1), so the sd is sqrt(2B / (B - 1) * sum v^2) over the
        pixels' count, with a pixel's three channels taken as one (fully correlated: an upper bound)."""
        b = self.batches
        if b < 2:
            return float("nan")
        v = np.square(self.stderr).sum(axis=2)
        return float(math.sqrt(2.0 * b / (b - 1) * np.square(v).sum()) / self.stderr.size)


def pending_samples(scene_ref: SceneRef, integrator: str, resolution, spp: int, batch_spp: int,
                    backend, root: Path | None = None) -> int:
    """Samples (spp x pixels) still to render for this reference: 0 when it can be reused."""
    root = Path(root) if root is not None else default_gt_root()
    key, res, _ = scene_key_info(scene_ref, integrator, resolution, backend)
    state = _load_state(gt_directory(root, scene_ref, integrator, res), key)
    have = 0
    if isinstance(state, dict):
        batch_spp = int(state["batch_spp"])
        have = int(state["batches"])
    need = max(math.ceil(spp / batch_spp), 2)
    return max(need - have, 0) * batch_spp * res[0] * res[1]


def gt_directory(root: Path, scene: SceneRef, integrator: str, resolution) -> Path:
    res = f"{resolution[0]}x{resolution[1]}"
    return Path(root) / f"{scene.key}__{integrator}__{res}"


def scene_key_info(scene_ref: SceneRef, integrator: str, resolution, backend):
    """(invalidation key of a reference, the resolution it is rendered at, the loaded scene)."""
    scene = backend.load_scene(scene_ref.name, scene_ref.overrides_dict or None)
    res = tuple(resolution) if resolution else (int(scene.width), int(scene.height))
    key = {
        "format": GT_FORMAT,
        "scene": scene_ref.key,
        "scene_hash": scene.content_hash(),
        "overrides": scene_ref.overrides_dict,
        "resolution": list(res),
        "integrator": integrator,
        "sampler": GT_SAMPLER,
        "code_version": backend.code_version,
    }
    return key, res, scene


def _load_state(d: Path, key: dict):
    f = d / "gt.npz"
    if not f.is_file():
        return None
    try:
        with np.load(f, allow_pickle=False) as z:
            if str(z["key"]) != short_hash(key, 32):
                try:
                    old = json.loads(str(z["key_json"]))
                    changed = [k for k in key if old.get(k) != key[k]]
                except Exception:                        # noqa: BLE001
                    changed = []
                return ("stale", ", ".join(changed) or "key")
            return {k: z[k] for k in ("mean", "m2", "batches", "batch_spp", "seeds", "render_seconds",
                                      "compile_seconds", "wall_seconds")}
    except Exception:                                   # noqa: BLE001 - unreadable = recompute
        return ("stale", "unreadable gt.npz")


def _stderr(m2: np.ndarray, batches: int) -> np.ndarray:
    return RunningMoments(batches, m2=m2).standard_error()


def ensure_ground_truth(scene_ref: SceneRef, integrator: str, resolution, spp: int, batch_spp: int,
                        backend, root: Path | None = None, threads: int | None = None,
                        progress: bool = True, log: Callable[[str], None] | None = None,
                        on_batch: Callable[[int], None] | None = None) -> GroundTruth:
    """Return a reference with at least `spp` samples per pixel, computing what is missing.

    `on_batch(samples)` is called after each batch with the samples it rendered (spp x pixels), for
    a caller's own progress bar; without it (and with `progress`) the batches get a bar of their own.
    """
    log = log or (lambda s: print(s, file=sys.stderr))
    from drtlab.estimators.registry import parse_integrator
    parse_integrator(integrator, "integrator", unbiased=True)
    root = Path(root) if root is not None else default_gt_root()
    key, res, scene = scene_key_info(scene_ref, integrator, resolution, backend)
    d = gt_directory(root, scene_ref, integrator, res)
    state = _load_state(d, key)
    if isinstance(state, tuple):
        log(f"ground truth {d.name}: {state[1]} changed since it was made; recomputing")
        for name in GT_FILES:                     # the reference's own files, nothing else of the folder
            (d / name).unlink(missing_ok=True)
        state = None
    if state is not None:
        batch_spp = int(state["batch_spp"])            # a stored reference keeps its batch size
        have = int(state["batches"])
    else:
        have = 0
    need = max(math.ceil(spp / batch_spp), 2)
    if state is not None and have >= need:
        return _reuse(d, key, scene_ref, integrator, res, state, have, batch_spp, backend)
    if state is not None:
        log(f"ground truth {d.name}: resuming at batch {have} of {need}")
    d.mkdir(parents=True, exist_ok=True)
    acc = _Accumulation() if state is None else _Accumulation.resume(state, have)
    bar = None
    if progress and on_batch is None:
        from tqdm import tqdm
        bar = tqdm(total=need, initial=have, desc=f"ground truth {scene_ref.label}", unit="batch",
                   file=sys.stderr, leave=False, dynamic_ncols=True)
    try:
        for b in range(have, need):
            seed = gt_seed(scene_ref.key, integrator, res, b)
            t0 = time.perf_counter()
            r = backend.render(scene, spp=batch_spp, sampler=GT_SAMPLER, integrator=integrator,
                               seed=seed, res=res, threads=threads)
            img = np.asarray(r.image, dtype=np.float64)
            if img.shape != (res[1], res[0], 3):
                raise RuntimeError(f"renderer returned shape {img.shape}, expected {(res[1], res[0], 3)}")
            acc.add(img, seed, r, t0)
            acc.save(d / "gt.npz", key, batch_spp)
            if bar is not None:
                bar.update(1)
            if on_batch is not None:
                on_batch(batch_spp * res[0] * res[1])
    finally:
        if bar is not None:
            bar.close()
    return _finalize(d, key, scene_ref, integrator, res, acc.moments.mean, acc.moments.m2, need,
                     batch_spp, acc.seeds, acc.wall_seconds, acc.render_seconds, acc.compile_seconds,
                     backend, reused=False)


@dataclass
class _Accumulation:
    """A reference being accumulated: float64 Welford moments over batch means, seeds, timings."""
    moments: RunningMoments = field(default_factory=RunningMoments)
    seeds: list = field(default_factory=list)
    render_seconds: float = 0.0
    compile_seconds: float = 0.0
    wall_seconds: float = 0.0

    @classmethod
    def resume(cls, state: dict, batches: int) -> "_Accumulation":
        return cls(RunningMoments(batches, state["mean"].astype(np.float64), state["m2"].astype(np.float64)),
                   [int(s) for s in state["seeds"]], float(state["render_seconds"]),
                   float(state["compile_seconds"]), float(state["wall_seconds"]))

    def add(self, img: np.ndarray, seed: int, result, t0: float) -> None:
        """One batch's image (the render `result`, started at perf_counter() == t0)."""
        self.moments.add(img)
        self.seeds.append(seed)
        self.render_seconds += float(result.render_seconds)
        self.compile_seconds += float(getattr(result, "compile_seconds", 0.0))
        self.wall_seconds += time.perf_counter() - t0

    def save(self, path: Path, key: dict, batch_spp: int) -> None:
        """The state after each batch, written atomically: a kill resumes at the next batch."""
        m, n = self.moments, self.moments.n
        atomic_savez(path, key=np.array(short_hash(key, 32)),
                     key_json=np.array(json.dumps(key, sort_keys=True)), mean=m.mean, m2=m.m2,
                     stderr=m.standard_error(), batches=np.array(n), batch_spp=np.array(batch_spp),
                     spp=np.array(n * batch_spp), seeds=np.array(self.seeds, dtype=np.uint32),
                     render_seconds=np.array(self.render_seconds),
                     compile_seconds=np.array(self.compile_seconds),
                     wall_seconds=np.array(self.wall_seconds))


def _reuse(d, key, scene_ref, integrator, res, state, have, batch_spp, backend) -> GroundTruth:
    """A stored reference with enough batches: read as is, or its final files finished first."""
    mean, m2 = state["mean"].astype(np.float64), state["m2"].astype(np.float64)
    try:
        manifest = json.loads((d / "manifest.json").read_text())
        complete = (manifest.get("key") == short_hash(key, 32) and manifest.get("batches") == have
                    and (d / "mean.exr").is_file() and (d / "stderr.exr").is_file())
    except (OSError, ValueError):
        complete = False
    if not complete:        # killed between the last batch and the final files: finish them now
        return _finalize(d, key, scene_ref, integrator, res, mean, m2, have, batch_spp,
                         [int(x) for x in state["seeds"]], float(state["wall_seconds"]),
                         float(state["render_seconds"]), float(state["compile_seconds"]), backend,
                         reused=True)
    return GroundTruth(mean=mean, stderr=_stderr(m2, have), spp=have * batch_spp, batches=have,
                       directory=d, manifest=manifest, reused=True)


def _finalize(d, key, scene_ref, integrator, res, mean, m2, batches, batch_spp, seeds, t_wall,
              t_render, t_compile, backend, reused) -> GroundTruth:
    stderr = _stderr(m2, batches)
    manifest = {
        "status": "complete",
        "scene": {"name": scene_ref.name, "label": scene_ref.label,
                  "overrides": scene_ref.overrides_dict},
        "scene_hash": key["scene_hash"],
        "code_version": key["code_version"],
        "key": short_hash(key, 32),
        "estimator": {"integrator": integrator, "sampler": GT_SAMPLER,
                      "accumulation": "float64 Welford over independent batch means"},
        "resolution": list(res),
        "spp": batches * batch_spp, "batches": batches, "batch_spp": batch_spp,
        "seeds": seeds,
        "seed_scheme": "blake2b('ground-truth', scene, integrator, resolution, batch) with the top "
                       "bit set; study runs use seeds with the top bit clear",
        "wall_seconds": t_wall, "render_seconds": t_render, "compile_seconds": t_compile,
        "gt_variance": float(np.mean(np.square(stderr))),
        "backend": backend.name,
        "updated": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
    }
    meta = {k: manifest[k] for k in ("scene_hash", "code_version", "spp", "batches")}
    meta.update(scene=scene_ref.key, integrator=integrator, sampler=GT_SAMPLER)
    write_exr(d / "mean.exr", mean, meta)
    write_exr(d / "stderr.exr", stderr, meta)
    atomic_write_json(d / "manifest.json", manifest)
    return GroundTruth(mean=mean, stderr=stderr, spp=batches * batch_spp, batches=batches,
                       directory=d, manifest=manifest, reused=reused)


def load_ground_truth(directory) -> GroundTruth:
    """Read a stored reference (as written by `ensure_ground_truth`)."""
    d = Path(directory)
    with np.load(d / "gt.npz", allow_pickle=False) as z:
        mean = z["mean"].astype(np.float64)
        m2 = z["m2"].astype(np.float64)
        batches = int(z["batches"])
        batch_spp = int(z["batch_spp"])
    try:
        manifest = json.loads((d / "manifest.json").read_text())
    except (OSError, ValueError):
        manifest = {}
    return GroundTruth(mean=mean, stderr=_stderr(m2, batches), spp=batches * batch_spp,
                       batches=batches, directory=d, manifest=manifest, reused=True)


def reference_info(gt) -> dict:
    """What the summary and the manifest record of a group's ground truth."""
    return {"dir": str(gt.directory), "spp": gt.spp, "batches": gt.batches, "variance": gt.variance,
            "reused": gt.reused, "key": gt.manifest.get("key"),
            "wall_seconds": gt.manifest.get("wall_seconds"),
            "compile_seconds": gt.manifest.get("compile_seconds"), "seeds": gt.manifest.get("seeds")}
