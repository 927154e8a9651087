"""The plan of an experiment: every run (scene, sampler, integrator, resolution, spp, repetition, seed)
in sweep order, the references its groups need, how a cell's repetitions are cut into batches
(`Batch`) and the row each run leaves in the table of runs (`run_record`)."""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from functools import cached_property

from drtlab.experiments.seeds import run_seed, short_hash
from drtlab.experiments.study.config import Experiment, SceneRef

# Samples (pixels x spp x repetitions) a batch aims at: on this 2-core machine 0.2-1 s of CPU, long
# enough for the process clock to time it to a few percent, short enough for a kill to lose little.
BATCH_SAMPLES = 1 << 20
MIN_BATCHES = 4                  # batches a cell is cut into at least (where it has the runs)
MAX_BATCH_PIXELS = 1 << 24       # pixels x repetitions of one batch: bounds its buffers (~1 GiB)

@dataclass(frozen=True)
class RunSpec:
    scene: SceneRef
    sampler: str
    integrator: str
    resolution: tuple[int, int]          # actual (W, H)
    spp: int
    rep: int
    seed: int
    studies: tuple[str, ...]

    @cached_property                     # read for every run at every commit
    def run_id(self) -> str:
        w, h = self.resolution
        return (f"{self.scene.key}__{self.sampler}__{self.integrator}__{w}x{h}"
                f"__spp{self.spp:05d}__rep{self.rep:02d}__{self.seed:08x}")

    @property
    def cell(self) -> str:
        """The cell it is a repetition of (what `run_store` names its cell file by)."""
        w, h = self.resolution
        return f"{self.scene.key}__{self.sampler}__{self.integrator}__{w}x{h}__spp{self.spp:05d}"

    @property
    def group(self) -> tuple:
        return (self.scene, self.integrator, self.resolution)


def plan_runs(exp: Experiment, backend) -> list[RunSpec]:
    """Every run of the experiment in sweep order (scene-major), each listed once."""
    res_cache: dict = {}
    plan: dict[str, RunSpec] = {}
    for study in exp.studies:
        settings = study.settings
        for scene_ref in study.scenes:
            if (scene_ref, settings.resolution) not in res_cache:
                if settings.resolution:
                    res_cache[(scene_ref, settings.resolution)] = tuple(settings.resolution)
                else:
                    scene = backend.load_scene(scene_ref.name, scene_ref.overrides_dict or None)
                    res_cache[(scene_ref, settings.resolution)] = (int(scene.width), int(scene.height))
            res = res_cache[(scene_ref, settings.resolution)]
            for sampler in study.samplers:
                for spp in settings.spp:
                    for rep in range(settings.runs_at(spp)):
                        seed = run_seed(study.seed, scene_ref.key, sampler, study.integrator, res, spp, rep)
                        r = RunSpec(scene_ref, sampler, study.integrator, res, spp, rep, seed, (study.name,))
                        old = plan.get(r.run_id)
                        if old is None:
                            plan[r.run_id] = r
                        elif study.name not in old.studies:
                            plan[r.run_id] = replace(old, studies=old.studies + (study.name,))
    # Group by scene so that one ground truth is in memory at a time.
    runs = list(plan.values())
    order = {}
    for r in runs:
        order.setdefault(r.group, len(order))
    return sorted(runs, key=lambda r: order[r.group])     # stable: keeps study/sampler/spp order


def integrator_notes(exp: Experiment, backend) -> list[str]:
    """One line per (study, scene) whose scene file names another integrator than the study's: the
    study's `integrator` (default drt) is what renders its runs and ground truth, whatever a scene
    file (a TOML [scene] integrator, a Mitsuba XML <integrator>) says."""
    notes, seen = [], set()
    for study in exp.studies:
        for ref in study.scenes:
            if (study.name, ref) in seen:
                continue
            seen.add((study.name, ref))
            own = backend.load_scene(ref.name, ref.overrides_dict or None).integrator
            if own != study.integrator:
                notes.append(f"drtlab: note: study {study.name} renders {ref.name} with integrator "
                             f"{study.integrator} (the study's `integrator`), not the scene file's "
                             f"own {own}")
    return notes


def gt_requirements(exp: Experiment, plan: list[RunSpec]) -> dict:
    """(scene, integrator, resolution) -> (gt_spp, gt_batch_spp): the most any study asks for."""
    by_name = {study.name: study for study in exp.studies}
    req: dict = {}
    for r in plan:
        for name in r.studies:
            settings = by_name[name].settings
            prev = req.get(r.group)
            if prev is None or settings.gt_spp > prev[0]:
                req[r.group] = (settings.gt_spp, settings.gt_batch_spp)
    return req


def run_fingerprint(r: RunSpec, gt, code_version: str) -> str:
    return short_hash({"run": r.run_id, "gt_key": gt.manifest.get("key"), "code": code_version}, 16)


def batch_ranges(reps: int, pixels: int, spp: int, start: int = 0) -> list[tuple[int, int]]:
    """[a, b) repetition ranges of a cell's batches from `start` to `reps`: about BATCH_SAMPLES each,
    at least MIN_BATCHES where the repetitions allow (every batch is a point of its sampler's cost
    model: ten batches a sampler left a 1.6x efficiency interval at N = 1 from cost alone, fifteen
    narrow it), and within MAX_BATCH_PIXELS. A function of the work alone, so every machine cuts
    the same batches."""
    per = max(1, min(-(-BATCH_SAMPLES // (pixels * spp)), MAX_BATCH_PIXELS // pixels))
    per = min(per, max(1, -(-(reps - start) // MIN_BATCHES)))
    return [(a, min(a + per, reps)) for a in range(start, reps, per)]


def check_image_sizes(exp, gt_req: dict) -> None:
    """Every group's image (its reference's, with per-pixel moments, the largest) fits this
    machine, else the one line of `check_image_size` naming the resolution's field."""
    from drtlab.kernels.render import check_image_size
    for scene_ref, _, (w, h) in gt_req:
        study = next(st for st in exp.studies if scene_ref in st.scenes)
        field = f"resolution (study {study.name}, scene {scene_ref.label})"
        check_image_size(w, h, moments=True, field=field)


@dataclass
class Batch:
    """Repetitions [a, b) of one cell, to render together."""
    cell: str
    runs: list                    # RunSpec, in repetition order
    fingerprints: list

    @property
    def batch_id(self) -> str:
        return f"r{self.runs[0].rep:05d}-{self.runs[-1].rep + 1:05d}"


# A run's row of the table of runs (run_store): its plan entry, its metrics and its batch's timings.
def run_record(r: RunSpec, fingerprint: str, batch: Batch, result, wall: float, gt,
               metrics: dict, code_version: str, worker: str = "local") -> dict:
    n = len(batch.runs)
    render_s = float(result.render_seconds) / n
    return {
        "run_id": r.run_id, "fingerprint": fingerprint, "cell": r.cell,
        "scene": r.scene.label, "scene_key": r.scene.key, "sampler": r.sampler,
        "integrator": r.integrator, "width": r.resolution[0], "height": r.resolution[1],
        "spp": r.spp, "rep": r.rep, "seed": r.seed, "studies": ";".join(r.studies),
        **metrics,
        # A batch's timings, shared out over its repetitions (each row carries its share).
        "render_seconds": render_s,
        "cpu_seconds": float(getattr(result, "cpu_seconds", result.render_seconds)) / n,
        "compile_seconds": float(getattr(result, "compile_seconds", 0.0)) / n,
        "wall_seconds": float(wall) / n,
        "samples_per_second": r.spp * r.resolution[0] * r.resolution[1] / max(render_s, 1e-12),
        "gt_spp": gt.spp, "gt_key": gt.manifest.get("key"),
        "code_version": code_version,
        "worker": worker,                     # where it rendered: a Dask worker's address, or local
        "batch": batch.batch_id, "batch_reps": n,
        "batch_time": time.time(),            # when it was committed: load steps show against it
    }
