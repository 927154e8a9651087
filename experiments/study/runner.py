"""The sweep: ground truth, then every (scene, sampler, spp, repetition) run, resumable at run level;
then the analysis, summary.json, the report and the manifest.

Each finished run is two files under `<out>/runs/`, both written atomically (temp file + os.replace;
see `run_store`): `<run id>.npz` (the image, float32) and then `<run id>.json` (its record: seeds,
metrics, timings). The JSON is the commit point: a run is done exactly when its JSON exists and its fingerprint (code
version, ground-truth key, scene hash) matches. `runs.csv` is regenerated from the records after every
run, also atomically, in the plan's order, so a `kill -9` anywhere loses at most the run in flight,
and can never leave a torn file or a duplicate row.
"""
from __future__ import annotations

import math
import shutil
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study import analysis, manifest, report
from drtlab.experiments.study import ground_truth as gtmod
from drtlab.experiments.study.config import Experiment, SceneRef
from drtlab.experiments.files import atomic_write_json
from drtlab.experiments.paths import default_gt_root, default_out_dir
from drtlab.experiments.study.metrics import _lab, image_metrics
from drtlab.experiments.study.results import ExperimentResult
from drtlab.experiments.study.run_store import (calibration_key, load_calibration, load_records,
                                          load_run_image, save_calibration, save_record, save_run,
                                          write_runs_csv)
from drtlab.experiments.seeds import run_seed, short_hash

OUTPUT_NAMES = ("runs", "runs.csv", "summary.json", "report.md", "plots", "images", "manifest.json",
                "calibration.json")
CSV_EVERY = 15.0            # seconds between rewrites of runs.csv during a sweep (and at each scene end)
CAL_SECONDS = 0.15          # target length of one calibration render
CAL_REPEATS = 8             # calibration renders per (scene, sampler) at that length
CAL_LOW_REPEATS = 6         # and at the ladder's smallest spp (overhead)
CAL_BUDGET = 3.0            # most seconds of calibration renders per (scene, sampler)


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

    @property
    def run_id(self) -> str:
        w, h = self.resolution
        return (f"{self.scene.key}__{self.sampler}__{self.integrator}__{w}x{h}"
                f"__spp{self.spp:05d}__rep{self.rep:02d}__{self.seed:08x}")

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


def _fingerprint(r: RunSpec, gt, code_version: str) -> str:
    return short_hash({"run": r.run_id, "gt_key": gt.manifest.get("key"), "code": code_version}, 16)


def _lock(out_dir: Path):
    """An exclusive lock on `<out>/.lock`, released when the returned file is closed (or the process
    dies): a second sweep into the same folder stops with one line instead of racing the first."""
    f = open(out_dir / ".lock", "a+")
    try:
        import fcntl
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except ImportError:                       # no fcntl (Windows): no lock
        pass
    except OSError:
        f.close()
        from drtlab.errors import InputError
        raise InputError("--out", f"another `drtlab experiment` is writing to {out_dir}; wait for it "
                         f"or choose another --out") from None
    return f


def _remove_orphaned_temps(out_dir: Path) -> None:
    """Temp files of writes a kill interrupted (never read: the os.replace never happened)."""
    for d in (out_dir, out_dir / "runs"):
        for p in d.glob(".*"):
            if p.is_file() and p.suffix in (".tmp", ".exr", ".npz", ".json", ".csv"):
                p.unlink(missing_ok=True)


def _clean_outputs(out_dir: Path) -> None:
    for name in OUTPUT_NAMES:
        p = out_dir / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


class _Progress:
    """One bar for the whole sweep, in samples (spp x pixels, ground truth included), with an ETA."""

    def __init__(self, total: int, runs: int, enabled: bool):
        self.bar = None
        self.runs_total, self.runs_done = runs, 0
        if enabled and total > 0:
            from tqdm import tqdm
            self.bar = tqdm(total=total, unit="sample", unit_scale=True, file=sys.stderr,
                            desc="sweep", dynamic_ncols=True, smoothing=0.05)

    def update(self, n: int, what: str | None = None, run_done: bool = False) -> None:
        if run_done:
            self.runs_done += 1
        if self.bar is not None:
            if what:
                self.bar.set_postfix_str(f"{what} | runs {self.runs_done}/{self.runs_total}", refresh=not n)
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def run_experiment(exp: Experiment, out_dir: Path | None = None, gt_root: Path | None = None,
                   backend=None, threads: int | None = None, fresh: bool = False,
                   progress: bool = True, clock: Callable[[], float] = time.perf_counter,
                   log: Callable[[str], None] | None = None, analyze: bool = True,
                   argv: list[str] | None = None, executor=None) -> ExperimentResult:
    """Run (or resume) the sweep, then analyse it and write every output. Returns the run counts,
    the wall time and (with `analyze`) the typed summary; `result["studies"]` reads summary.json's
    content. With an `executor` (`distributed.DaskExecutor`) the renders run on its cluster and this
    process writes their results; the calibration and the analysis stay here."""
    if backend is None:
        from drtlab.experiments.study.backend import default_backend
        backend = default_backend()
    log = log or (lambda s: print(s, file=sys.stderr))
    t_start = time.time()
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir(exp.name)
    gt_root = Path(gt_root) if gt_root is not None else default_gt_root()
    plan = plan_runs(exp, backend)
    gt_req = gt_requirements(exp, plan)

    out_dir.mkdir(parents=True, exist_ok=True)
    lock = _lock(out_dir)                     # one sweep at a time per output folder
    try:
        if fresh:
            _clean_outputs(out_dir)
        (out_dir / "runs").mkdir(exist_ok=True)
        _remove_orphaned_temps(out_dir)
        sweep = _Sweep(plan, out_dir, gt_root, backend, threads, clock, log,
                       records=load_records(out_dir / "runs"), executor=executor)
        sweep.run(gt_req, progress)
        if analyze:
            sweep.calibrate()
        return _analyse_and_report(exp, sweep, analyze, argv, t_start)
    finally:
        lock.close()


def _reference_info(gt) -> dict:
    """What the summary and the manifest record of a group's ground truth."""
    return {"dir": str(gt.directory), "spp": gt.spp, "batches": gt.batches, "variance": gt.variance,
            "reused": gt.reused, "key": gt.manifest.get("key"),
            "wall_seconds": gt.manifest.get("wall_seconds"),
            "compile_seconds": gt.manifest.get("compile_seconds"), "seeds": gt.manifest.get("seeds")}


def _run_record(r: RunSpec, fingerprint: str, img: np.ndarray, result, wall: float, gt,
                metrics: dict, code_version: str, worker: str = "local") -> dict:
    return {
        "run_id": r.run_id, "fingerprint": fingerprint,
        "scene": r.scene.label, "scene_key": r.scene.key, "sampler": r.sampler,
        "integrator": r.integrator, "width": r.resolution[0], "height": r.resolution[1],
        "spp": r.spp, "rep": r.rep, "seed": r.seed,
        **metrics,
        "render_seconds": float(result.render_seconds),
        "compile_seconds": float(getattr(result, "compile_seconds", 0.0)),
        "wall_seconds": float(wall),
        "samples_per_second": float(getattr(result, "samples_per_second", 0.0)
                                    or (r.spp * img.shape[0] * img.shape[1]
                                        / max(float(result.render_seconds), 1e-12))),
        "gt_spp": gt.spp, "gt_key": gt.manifest.get("key"),
        "code_version": code_version,
        "worker": worker,                     # where it rendered: a Dask worker's address, or local
    }


@dataclass
class _Sweep:
    """The runs of a plan, group by group (one ground truth in memory at a time): each run reused,
    refreshed (same render, better reference: new metrics, same timings) or rendered."""
    plan: list[RunSpec]
    out_dir: Path
    gt_root: Path
    backend: object
    threads: int | None
    clock: Callable[[], float]
    log: Callable[[str], None]
    records: dict                             # run id -> record, of the runs on disk
    gts: dict = field(default_factory=dict)   # group -> _reference_info
    stats: dict = field(default_factory=dict)
    bar: _Progress | None = None
    executor: object = None                   # distributed.DaskExecutor, or None: render here

    def run(self, gt_req: dict, progress: bool) -> None:
        # Work estimate for one bar: pending GT samples + pending run samples (done runs checked below).
        gt_pending = {g: gtmod.pending_samples(g[0], g[1], g[2], req[0], req[1], self.backend, self.gt_root)
                      for g, req in gt_req.items()}
        candidates = [r for r in self.plan if r.run_id not in self.records]
        total = sum(gt_pending.values()) + sum(r.spp * r.resolution[0] * r.resolution[1] for r in candidates)
        self.bar = _Progress(total, len(candidates), progress)
        self.stats = {"runs_planned": len(self.plan), "runs_new": 0, "runs_reused": 0, "runs_refreshed": 0}
        self._csv_written = time.monotonic()
        self._precompile()
        try:
            groups: dict = {}
            for r in self.plan:
                groups.setdefault(r.group, []).append(r)
            for g, runs in groups.items():
                self._group(g, runs, *gt_req[g])
        except BaseException:
            # An interrupted sweep's table catches up; a finished one is written by each scene's end
            # and, from the plan's records, by the analysis.
            if self.stats["runs_new"] or self.stats["runs_refreshed"]:
                self._write_csv()
            raise
        finally:
            self.bar.close()

    def _precompile(self) -> None:
        """Every kernel variant the sweep, its ground truths and its calibration render, compiled
        side by side first (a cold kernel cache: ~4 s per variant, one core each); a warm cache
        loads them in milliseconds. Renders on a cluster compile there instead."""
        if self.executor is not None or getattr(self.backend, "precompile", None) is None:
            return
        scenes, jobs = {}, {}
        for r in self.plan:
            if r.scene not in scenes:
                scenes[r.scene] = self.backend.load_scene(r.scene.name, r.scene.overrides_dict or None)
            for sampler in (r.sampler, gtmod.GT_SAMPLER):
                jobs.setdefault((r.scene, sampler, r.integrator),
                                (scenes[r.scene], sampler, r.integrator))
        self.bar.update(0, "compiling kernel variants")
        facts = self.backend.precompile(list(jobs.values()), self.threads)
        self.stats["kernel_precompile"] = {k: round(v, 3) if isinstance(v, float) else v
                                           for k, v in facts.items()}
        if facts["compiled"]:
            self.log(f"compiled {facts['compiled']} kernel variants in {facts['wall_seconds']:.1f} s "
                     f"on {facts['threads']} threads ({facts['compile_seconds']:.1f} s of compiles)")

    def _write_csv(self, every: float = 0.0) -> None:
        """runs.csv from the records, if `every` seconds have passed since the last write. Per run
        it would be quadratic in the runs (60% of a 10,000-run sweep); the records are the commit
        points, and the table catches up at the end of each scene and of an interrupted sweep."""
        now = time.monotonic()
        if now - self._csv_written >= every:
            write_runs_csv(self.out_dir / "runs.csv", self.plan, self.records)
            self._csv_written = now

    def _group(self, g, runs: list[RunSpec], gt_spp: int, gt_batch: int) -> None:
        scene_ref, integrator, res = g
        gt_backend = self.backend if self.executor is None else \
            self.executor.ground_truth_backend(self.backend, scene_ref, gt_spp)
        gt = gtmod.ensure_ground_truth(
            scene_ref, integrator, res, gt_spp, gt_batch, gt_backend, self.gt_root,
            threads=self.threads, progress=False, log=self.log,
            on_batch=lambda n, lab=scene_ref.label: self.bar.update(n, f"ground truth {lab}"))
        self.gts[g] = _reference_info(gt)
        gt_lab = None
        todo = []
        for r in runs:
            fp = _fingerprint(r, gt, self.backend.code_version)
            rec = self.records.get(r.run_id)
            if rec is not None and rec.get("fingerprint") == fp:
                if rec.get("gt_spp") == gt.spp:
                    self.stats["runs_reused"] += 1
                    continue
                # Same render, better reference: recompute the metrics, keep the timings.
                if gt_lab is None:
                    gt_lab = _lab(gt.mean)
                img = load_run_image(self.out_dir, r.run_id)
                rec.update(image_metrics(img, gt.mean, gt.stderr, gt_lab), gt_spp=gt.spp)
                save_record(self.out_dir / "runs", r.run_id, rec)
                self.stats["runs_refreshed"] += 1
                continue
            todo.append((r, fp))
        if not todo:
            return
        scene = self.backend.load_scene(scene_ref.name, scene_ref.overrides_dict or None)
        gt_lab = _lab(gt.mean) if gt_lab is None else gt_lab
        if self.executor is None:
            for r, fp in todo:
                self._render(r, scene, gt, gt_lab, fp)
            self._write_csv()
            return
        fps = {r.run_id: fp for r, fp in todo}
        workers = self.stats.setdefault("workers", {})
        for r, result, wall, worker in self.executor.render_runs(self.backend, scene,
                                                                 [r for r, _ in todo], self.threads):
            self._commit(r, result, wall, gt, gt_lab, fps[r.run_id], worker)
            workers[worker] = workers.get(worker, 0) + 1
        self._write_csv()

    def _render(self, r: RunSpec, scene, gt, gt_lab, fingerprint: str) -> None:
        t0 = self.clock()
        result = self.backend.render(scene, spp=r.spp, sampler=r.sampler, integrator=r.integrator,
                                     seed=r.seed, res=r.resolution, threads=self.threads)
        self._commit(r, result, self.clock() - t0, gt, gt_lab, fingerprint, "local")

    def _commit(self, r: RunSpec, result, wall: float, gt, gt_lab, fingerprint: str,
                worker: str) -> None:
        """A rendered run: its metrics and its files (the record last: the commit point)."""
        img = np.asarray(result.image, dtype=np.float64)
        metrics = image_metrics(img, gt.mean, gt.stderr, gt_lab)
        rec = _run_record(r, fingerprint, img, result, wall, gt, metrics, self.backend.code_version,
                          worker)
        save_run(self.out_dir / "runs", r.run_id, img, rec)          # the record is the commit point
        self.records[r.run_id] = rec
        self._write_csv(every=CSV_EVERY)
        self.stats["runs_new"] += 1
        self.bar.update(r.spp * r.resolution[0] * r.resolution[1],
                        f"{r.scene.label} {r.sampler} {r.spp}spp", run_done=True)

    def calibrate(self) -> None:
        """Cost calibration of every (scene, sampler) of the plan, after the sweep (the kernel variants
        are compiled), stored in calibration.json keyed by backend, code version and threads: a rerun
        reuses it (`--fresh` recalibrates). Per group, the samplers take turns (round robin) so that
        load from other jobs hits them alike: `CAL_REPEATS` renders each of about `CAL_SECONDS` (spp
        from a probe render, itself sized from the sweep's own per-sample time) and `CAL_LOW_REPEATS`
        at the ladder's smallest spp (the overhead)."""
        from drtlab.experiments.study.analysis import group_name
        cal = load_calibration(self.out_dir)
        fp = short_hash({"code": self.backend.code_version, "backend": self.backend.name,
                         "threads": self.threads, "repeats": CAL_REPEATS, "clock": 4}, 16)
        t0 = time.perf_counter()
        todo: dict = {}
        for r in self.plan:
            if r.run_id in self.records:
                todo.setdefault(r.group, {}).setdefault(r.sampler, []).append(self.records[r.run_id])
        for g, by_sampler in todo.items():
            keys = {s: calibration_key(group_name(g), s) for s in by_sampler}
            if all(cal.get(k, {}).get("fingerprint") == fp for k in keys.values()):
                continue
            scene = self.backend.load_scene(g[0].name, g[0].overrides_dict or None)
            for s, entry in self._calibrate_group(scene, g, by_sampler).items():
                cal[keys[s]] = {"fingerprint": fp, **entry}
            save_calibration(self.out_dir, cal)
        self.stats["calibration_seconds"] = time.perf_counter() - t0

    def _calibrate_group(self, scene, g, by_sampler: dict) -> dict:
        res = g[2]
        pixels = res[0] * res[1]

        # CPU backend: cost in CPU seconds of the render call (process_time, all threads: far less
        # moved by other jobs' load, which doubles wall times on a busy 2-core VM, though not blind to
        # it: run_store keeps the faster half); render_seconds otherwise.
        cpu = self.backend.name == "warp-cpu"

        def render(sampler, spp, i):
            c0 = time.process_time()
            result = self.backend.render(
                scene, spp=spp, sampler=sampler, integrator=g[1], res=res, threads=self.threads,
                seed=run_seed(0xCA11B, g[0].key, sampler, g[1], res, spp, 10_000 + i))
            c1 = time.process_time()
            return c1 - c0 if cpu else float(result.render_seconds)

        entries = {}
        for s, recs in by_sampler.items():       # spp of about CAL_SECONDS per render
            top = max(rec["spp"] for rec in recs)
            per = float(np.median([rec["render_seconds"] for rec in recs if rec["spp"] == top])) / (pixels * top)
            spp = max(1, int(math.ceil(CAL_SECONDS / max(per * pixels, 1e-12))))
            for _ in range(3):                   # the sweep's estimate includes overhead: correct it
                t = render(s, spp, 0)
                if t >= 0.6 * CAL_SECONDS:
                    break
                spp = int(math.ceil(spp * min(CAL_SECONDS / max(t, 1e-6), 64.0)))
            repeats = max(3, min(CAL_REPEATS, int(CAL_BUDGET / max(t, 1e-9)) - 1))
            entries[s] = {"spp": spp, "pixels": pixels, "seconds": [], "repeats": repeats,
                          "clock": "cpu" if cpu else "render_seconds",
                          "low_spp": min(rec["spp"] for rec in recs), "low_seconds": []}
        for i in range(max(e["repeats"] for e in entries.values())):     # round robin
            for s, e in entries.items():
                if i < e["repeats"]:
                    e["seconds"].append(render(s, e["spp"], i + 1))
                if i < CAL_LOW_REPEATS:
                    e["low_seconds"].append(render(s, e["low_spp"], 100 + i))
        return entries


def _analyse_and_report(exp, sweep: _Sweep, analyze: bool, argv, t_start: float) -> ExperimentResult:
    out_dir, plan = sweep.out_dir, sweep.plan
    # Only the plan's runs count; stale records (other code version, other plan) stay on disk unused.
    plan_ids = {r.run_id for r in plan}
    records = {k: v for k, v in sweep.records.items() if k in plan_ids}
    sweep.stats["rows"] = write_runs_csv(out_dir / "runs.csv", plan, records)
    summary = None
    if analyze:
        summary = analysis.analyze(exp, plan, records, out_dir, sweep.gts, log=sweep.log,
                                   calibration=load_calibration(out_dir))
        atomic_write_json(out_dir / "summary.json", summary.to_json())
        report.write_report(exp, summary, plan, records, out_dir, sweep.gts)
    wall = time.time() - t_start
    if analyze:
        manifest.write_manifest(out_dir, exp, sweep.backend, plan, records, sweep.gts, sweep.stats,
                                wall, argv)
    return ExperimentResult(stats=sweep.stats, wall_seconds=wall, summary=summary,
                            out_dir=sweep.out_dir)
