"""The sweep: ground truth, then every cell (scene, sampler, spp) of the plan in batches of
repetitions, resumable at batch level; precision-targeted cells grow until their target or budget;
then the analysis, summary.json, the report and the manifest.

A batch is one `render_batch` call: consecutive repetitions of one cell, rendered together so that
short renders stop paying per-call overhead and every call is long enough to time (`BATCH_SAMPLES`).
Batch boundaries follow from the cell's work alone (never from timings), so the tables are the same
whatever the machine, the thread count or a Dask cluster. Finished batches are committed by
`run_store` (the table of runs, then the changed cell files: see its docstring) every
`FLUSH_SECONDS`, at each group's end and when a sweep is interrupted, so a `kill -9` anywhere loses
at most the last seconds of batches and can never leave a torn file or a duplicate row.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from itertools import zip_longest
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments.study import analysis, manifest, report
from drtlab.experiments.study import ground_truth as gtmod
from drtlab.experiments.study.cell_growth import CellGrowth
from drtlab.experiments.study.config import Experiment
from drtlab.experiments.study.estimate import check_budget, estimate
from drtlab.experiments.study.interrupts import signals_held, stop_on_signals
from drtlab.experiments.study.output_dir import checked_record, lock_output
from drtlab.experiments.study.plan import (Batch, RunSpec, batch_ranges, check_image_sizes, gt_requirements,
                                           integrator_notes, plan_runs, run_fingerprint, run_record)
from drtlab.experiments.study.progress import Progress
from drtlab.experiments.files import atomic_write_json
from drtlab.experiments.paths import default_gt_root, default_out_dir
from drtlab.experiments.study.metrics import compile_metric_kernels, reference_lab, score_batch
from drtlab.experiments.error_metrics import plugin_metrics
from drtlab.experiments.study.experiment_result import ExperimentResult
from drtlab.experiments.study import run_store as store
from drtlab.experiments.seeds import run_seed, short_hash

# Seconds between commits of the table and the changed cell files (and at each group's end and an
# interrupted sweep's): rewriting a 10,000-row table after every batch was a tenth of the sweep.
FLUSH_SECONDS = 10.0


def run_experiment(exp: Experiment, out_dir: Path | None = None, gt_root: Path | None = None,
                   backend=None, threads: int | None = None, fresh: bool = False,
                   progress: bool = True, clock: Callable[[], float] = time.perf_counter,
                   log: Callable[[str], None] | None = None, analyze: bool = True,
                   argv: list[str] | None = None, executor=None,
                   keep_images: bool | None = None, yes: bool = False,
                   allow_other_files: bool = False) -> ExperimentResult:
    """Run (or resume) the sweep, then analyse it and write every output. Returns the run counts,
    the wall time and (with `analyze`) the typed summary; `result["studies"]` reads summary.json's
    content. With an `executor` (`cluster.DaskExecutor`) the batches render on its cluster and this
    process writes their results; the timing-only batches and the analysis stay here.
    `keep_images` (default: each study's setting) keeps every repetition's image in its cell file.
    Before any output: the study's estimated rendering time and memory (estimate.py), refused past
    its limits unless `yes`, and a folder holding files drtlab did not write, refused unless
    `allow_other_files` (output_dir.py: drtlab removes only what it wrote)."""
    if backend is None:
        from drtlab.experiments.study.backend import default_backend
        backend = default_backend()
    log = log or (lambda s: print(s, file=sys.stderr))
    t_start = time.time()
    from drtlab.fields import writable_location
    out_dir = writable_location(out_dir if out_dir is not None else default_out_dir(exp.name), "out_dir",
                                folder=True)
    gt_root = writable_location(gt_root if gt_root is not None else default_gt_root(), "gt_root",
                                folder=True)
    plan = plan_runs(exp, backend)
    gt_req = gt_requirements(exp, plan)
    check_image_sizes(exp, gt_req)            # before the folder, its lock or a compile
    record, planned = checked_record(out_dir, exp, plan, allow_other_files, gt_root)   # before any work
    cells = len({r.cell for r in plan})
    samples = sum(r.spp * r.resolution[0] * r.resolution[1] for r in plan)
    # The plan, the compile and the estimate are said once the study has passed its limits: a
    # refused study is one line, nothing before it.
    held: list[str] = []
    held.append(f"{exp.name} ({exp.profile}): {len(plan)} runs in {cells} cells of {len(gt_req)} scene(s), "
        + (f"{samples / 1e6:.1f} M samples" if samples >= 1e5 else f"{samples:,} samples"))
    held += integrator_notes(exp, backend)
    gt_pending = {g: gtmod.pending_samples(g[0], g[1], g[2], req[0], req[1], backend, gt_root)
                  for g, req in gt_req.items()}
    # Runs a resumed sweep has stored are not estimated (read only: nothing is written yet).
    stored = {} if fresh else store.load_records(out_dir)
    pending = [r for r in plan if r.run_id not in stored]
    check_budget(estimate(pending, gt_req, gt_pending, backend, threads, probe=False), yes)   # memory
    precompiled = _precompile(plan, backend, threads, executor, held.append)
    if pending or any(gt_pending.values()):
        cost = estimate(pending, gt_req, gt_pending, backend, threads, probe=executor is None)
        check_budget(cost, yes)
        held.append(cost.line())
    for line in held:
        log(line)

    out_dir.mkdir(parents=True, exist_ok=True)
    lock = lock_output(out_dir)               # one sweep at a time per output folder
    try:
        record.enter(planned)
        if fresh:
            record.remove_outputs()
        record.remove_orphaned_temps()
        sweep = _Sweep(plan, out_dir, gt_root, backend, threads, clock, log,
                       records=store.load_records(out_dir), executor=executor,
                       studies={s.name: s for s in exp.studies}, keep_images=keep_images)
        with stop_on_signals(log):            # SIGTERM, SIGHUP: the finished batches kept
            sweep.run(gt_req, gt_pending, progress, precompiled)
        if analyze:
            sweep.calibrate()
            if any(st.settings.variance_sources for st in exp.studies):
                from drtlab.experiments.study.variance_sources import decompose_studies
                sweep.stats["variance_sources_seconds"] = round(decompose_studies(
                    exp.studies, out_dir, backend, threads, log), 3)
        return _analyse_and_report(exp, sweep, analyze, argv, t_start)
    finally:
        lock.close()


def _precompile(plan, backend, threads, executor, log) -> dict | None:
    """Every kernel variant the sweep, its ground truths and its timing batches need, compiled
    side by side first (a cold kernel cache: ~4 s per variant, one core each); a warm cache
    loads them in milliseconds. Renders on a cluster compile there instead. Returns the facts the
    manifest records, or None."""
    if executor is not None or getattr(backend, "precompile", None) is None:
        return None
    scenes, jobs = {}, {}
    for r in plan:
        if r.scene not in scenes:
            scenes[r.scene] = backend.load_scene(r.scene.name, r.scene.overrides_dict or None)
        for sampler in (r.sampler, gtmod.GT_SAMPLER):
            jobs.setdefault((r.scene, sampler, r.integrator), (scenes[r.scene], sampler, r.integrator))
    facts = backend.precompile(list(jobs.values()), threads)
    # The metrics' kernels too: a cold cache compiles them in seconds the sweep would book as its own.
    metrics_s = compile_metric_kernels()
    facts = {**facts, "wall_seconds": facts["wall_seconds"] + metrics_s, "metric_kernels_seconds": metrics_s}
    if facts["compiled"]:
        log(f"compiled {facts['compiled']} kernel variants in {facts['wall_seconds']:.1f} s "
            f"on {facts['threads']} threads ({facts['compile_seconds']:.1f} s of compiles)")
    return {k: round(v, 3) if isinstance(v, float) else v for k, v in facts.items()}


@dataclass
class _Sweep(CellGrowth):
    """The cells of a plan, group by group (one ground truth in memory at a time): each batch of
    repetitions reused or rendered; precision-targeted cells grown batch by batch."""
    plan: list[RunSpec]
    out_dir: Path
    gt_root: Path
    backend: object
    threads: int | None
    clock: Callable[[], float]
    log: Callable[[str], None]
    records: dict                             # run id -> record, of the committed runs
    gts: dict = field(default_factory=dict)   # group -> _reference_info
    stats: dict = field(default_factory=dict)
    bar: Progress | None = None
    executor: object = None                   # cluster.DaskExecutor, or None: render here
    studies: dict = field(default_factory=dict)   # study name -> Study (settings, seed)
    keep_images: bool | None = None
    targets: dict = field(default_factory=dict)   # cell -> precision-target outcome
    cell_files: dict = field(default_factory=dict)   # cell -> run_store.CellFile, of this group
    dirty: set = field(default_factory=set)          # cells changed since the last commit
    loose: set = field(default_factory=set)          # cells committed uncompressed in this group

    def run(self, gt_req: dict, gt_pending: dict, progress: bool, precompiled: dict | None) -> None:
        # Work for one bar: pending GT samples + pending run samples (done runs checked below).
        candidates = [r for r in self.plan if r.run_id not in self.records]
        total = sum(gt_pending.values()) + sum(r.spp * r.resolution[0] * r.resolution[1] for r in candidates)
        self.bar = Progress(total, len(candidates), progress, log=self.log)
        self.stats = {"runs_planned": len(self.plan), "runs_new": 0, "runs_reused": 0,
                      "runs_added_for_precision": 0, "runs_added_for_resolution": 0, "batches": 0}
        self._seconds = {"render_total": 0.0, "ground_truth_total": 0.0}
        self._flushed_at = time.monotonic()
        if precompiled is not None:
            self.stats["kernel_precompile"] = precompiled
        t0 = time.perf_counter()
        try:
            groups: dict = {}
            for r in self.plan:
                groups.setdefault(r.group, []).append(r)
            for g, runs in groups.items():
                self._group(g, runs, *gt_req[g])
        finally:
            self._flush()                         # what finished before an interruption, kept
            self.bar.close()
            self._seconds["sweep_seconds"] = time.perf_counter() - t0
            self.stats.update({k: round(v, 3) for k, v in self._seconds.items()})

    def _code(self, sampler: str, integrator: str | None = None) -> str:
        """The code a sampler's runs were rendered and scored by: the backend's, with a plugin point
        set's fingerprint (an edited plugin re-renders its cells, and only those) and the plugin
        metrics' (a run keeps no image to score again)."""
        from drtlab.estimators.plugin_checks import sampler_fingerprint
        fps = [fp for fp in [sampler_fingerprint(sampler, integrator)] + [m.fingerprint for m in self._plugin_metrics()] if fp]
        return self.backend.code_version if not fps else short_hash([self.backend.code_version, *fps], 16)

    def _plugin_metrics(self, studies=None) -> list:
        """The plugin metrics of `studies` (names; default: every study of the experiment)."""
        names = self.studies if studies is None else studies
        return plugin_metrics(self.studies[s].metric for s in names) if self.studies else []

    def _settings(self, r: RunSpec):
        """The settings a cell follows: those of the first study that plans it."""
        return self.studies[r.studies[0]].settings if self.studies else None

    def _keeps_images(self, r: RunSpec) -> bool:
        if self.keep_images is not None:
            return self.keep_images
        return any(self.studies[s].settings.keep_images for s in r.studies) if self.studies else False

    def _group(self, g, runs: list[RunSpec], gt_spp: int, gt_batch: int) -> None:
        scene_ref, integrator, res = g
        if self.bar.bar is None:                  # no bar (output to a file or pipe): a line per scene
            pending = sum(r.run_id not in self.records for r in runs)
            self.log(f"{scene_ref.label} ({integrator}, {res[0]}x{res[1]}): its reference, then {pending} "
                     f"of its {len(runs)} runs")
        gt_backend = self.backend if self.executor is None else \
            self.executor.ground_truth_backend(self.backend, scene_ref, gt_spp)
        t0 = time.perf_counter()
        gt = gtmod.ensure_ground_truth(
            scene_ref, integrator, res, gt_spp, gt_batch, gt_backend, self.gt_root,
            threads=self.threads, progress=False, log=self.log,
            on_batch=lambda n, lab=scene_ref.label: self.bar.update(n, f"ground truth {lab}"))
        self._seconds["ground_truth_total"] += time.perf_counter() - t0
        self.gts[g] = gtmod.reference_info(gt)
        cells: dict = {}
        for r in runs:
            cells.setdefault(r.cell, []).append(r)
        # Cells take turns batch by batch, so that load from other jobs and drifts of the clock over
        # the group's minutes fall on every cell alike: their costs (and speed-ups) are compared.
        per_cell = [self._cell_batches(cell, cruns, gt) for cell, cruns in cells.items()]
        batches = [b for turn in zip_longest(*per_cell) for b in turn if b is not None]
        ctx = _GroupContext(self.backend.load_scene(scene_ref.name, scene_ref.overrides_dict or None)
                            if batches or self._targeted(cells) else None, gt, None)
        self._render_batches(batches, ctx)
        # Precision targets: grow each targeted cell (doubling its repetitions, within its budget)
        # until its mean MSE's interval is narrow enough; decisions read only the committed values.
        while True:
            grown = [self._grow(cell, cruns, gt) for cell, cruns in cells.items()]
            grown = [bs for bs in grown if bs is not None]
            if not grown:
                break
            self._render_batches([b for bs in grown for b in bs], ctx)
        # Resolution: the study's `max_seconds` (shared out over its scenes) grows the cells whose
        # largest run dominates their error, doubling their repetitions while the budget lasts.
        spent: dict = {}
        while True:
            grown = [self._resolve(cell, cruns, gt, spent) for cell, cruns in cells.items()]
            grown = [bs for bs in grown if bs is not None]
            if not grown:
                break
            self._render_batches([b for bs in grown for b in bs], ctx)
        self._flush(group_end=True)
        self.cell_files.clear()                   # one group's cell files in memory at a time

    def _cell_batches(self, cell: str, cruns: list[RunSpec], gt) -> list[Batch]:
        """The batches of a cell still to render; a cell with stored runs of other code or another
        reference starts over (its cell file merged those runs' images)."""
        key, code = gt.manifest.get("key"), self._code(cruns[0].sampler, cruns[0].integrator)
        if any(rec.get("cell") == cell and (rec.get("gt_key") != key or rec.get("code_version") != code)
               for rec in self.records.values()):
            for rid in [rid for rid, rec in self.records.items() if rec.get("cell") == cell]:
                del self.records[rid]
            store.cell_path(self.out_dir, cell).unlink(missing_ok=True)
            self.cell_files.pop(cell, None)
        pixels = cruns[0].resolution[0] * cruns[0].resolution[1]
        return self._batches(cell, cruns, gt, batch_ranges(len(cruns), pixels, cruns[0].spp))

    def _batches(self, cell: str, cruns: list[RunSpec], gt, ranges) -> list[Batch]:
        """The not yet committed runs of each range, as batches (a range whose runs are all stored
        is reused: its images are in the cell file already)."""
        out = []
        for a, b in ranges:
            fps = [run_fingerprint(r, gt, self._code(r.sampler, r.integrator)) for r in cruns[a:b]]
            todo = [(r, fp) for r, fp in zip(cruns[a:b], fps)
                    if self.records.get(r.run_id, {}).get("fingerprint") != fp]
            self.stats["runs_reused"] += (b - a) - len(todo)
            if todo:
                out.append(Batch(cell, [r for r, _ in todo], [fp for _, fp in todo]))
        return out

    def _render_batches(self, batches: list[Batch], ctx: "_GroupContext") -> None:
        if not batches:
            return
        if ctx.gt_lab is None:
            ctx.gt_lab = reference_lab(ctx.gt.mean)
        if self.executor is None:
            for b in batches:
                r0 = b.runs[0]
                t0 = self.clock()
                result = self.backend.batch(ctx.scene, spp=r0.spp, sampler=r0.sampler,
                                            integrator=r0.integrator, seeds=[r.seed for r in b.runs],
                                            res=r0.resolution, threads=self.threads)
                self._commit(b, result, self.clock() - t0, ctx, "local")
            return
        # A cluster finishes batches in any order; each cell merges its batches in list order (the
        # float64 merge is not associative), so a batch waits in memory for its cell's earlier ones.
        workers = self.stats.setdefault("workers", {})
        order = {id(b): i for i, b in enumerate(batches)}
        waiting: dict = {}                        # cell -> {position: (batch, result, wall, worker)}
        expected = {}
        for b in batches:
            expected.setdefault(b.cell, []).append(order[id(b)])
        for b, result, wall, worker in self.executor.render_batches(self.backend, ctx.scene, batches,
                                                                    self.threads):
            waiting.setdefault(b.cell, {})[order[id(b)]] = (b, result, wall, worker)
            queue = expected[b.cell]
            while queue and queue[0] in waiting[b.cell]:
                b_, result_, wall_, worker_ = waiting[b.cell].pop(queue.pop(0))
                self._commit(b_, result_, wall_, ctx, worker_)
                workers[worker_] = workers.get(worker_, 0) + len(b_.runs)

    def _commit(self, b: Batch, result, wall: float, ctx: "_GroupContext", worker: str) -> None:
        """A rendered batch: its metrics, its rows and its cell file (run_store's commit protocol)."""
        images = np.asarray(result.images, dtype=np.float64)
        metrics, sums = score_batch(images, ctx.gt.mean, ctx.gt.stderr, ctx.gt_lab,
                                    colour_rows=self._first_runs(b, "colour_difference_runs", None),
                                    flip_rows=self._first_runs(b, "flip_runs", 0))
        for m in self._plugin_metrics(b.runs[0].studies):
            for row, value in zip(metrics, m.score(images, ctx.gt.mean, ctx.gt.stderr)):
                row[m.record] = value
        with signals_held():                  # a batch is reported finished once it is dirty
            for r, fp, m in zip(b.runs, b.fingerprints, metrics):
                self.records[r.run_id] = run_record(r, fp, b, result, wall, ctx.gt, m,
                                                     self._code(r.sampler, r.integrator), worker)
            if b.cell not in self.cell_files:
                self.cell_files[b.cell] = store.load_cell(self.out_dir, b.cell)
            self.cell_files[b.cell] = self.cell_files[b.cell].with_batch(
                b.batch_id, images, [r.rep for r in b.runs], self._keeps_images(b.runs[0]),
                store.CellMoments(len(b.runs), sums.mean, sums.m2))
            self.dirty.add(b.cell)
            if time.monotonic() - self._flushed_at >= FLUSH_SECONDS:
                self._flush()
            self._seconds["render_total"] += float(result.render_seconds)
            self.stats["runs_new"] += len(b.runs)
            self.stats["batches"] += 1
            r0 = b.runs[0]
            self.bar.update(len(b.runs) * r0.spp * r0.resolution[0] * r0.resolution[1],
                            f"{r0.scene.label} {r0.sampler} {r0.spp}spp", runs_done=len(b.runs))

    def _first_runs(self, b: Batch, key: str, default: int | None) -> int | None:
        """How many of a batch's runs a per-run limit of the cell's settings (`key`: a cell's first
        N runs only; None: all) scores: a prefix, the batch being in repetition order."""
        limit = getattr(self._settings(b.runs[0]), key, default)
        return None if limit is None else sum(r.rep < limit for r in b.runs)

    def _flush(self, group_end: bool = False) -> None:
        """Commit the batches rendered since the last flush (run_store's protocol: table, then the
        changed cell files). Mid-group the cell files are written uncompressed (the group's cells
        take turns, so each commit rewrites all of them); at the group's end each is compressed."""
        with signals_held():                  # a commit is never cut short
            if self.dirty:
                store.commit(self.out_dir, self.records, [r.run_id for r in self.plan],
                             {c: self.cell_files[c] for c in self.dirty}, compress=group_end)
                self.loose = self.loose - self.dirty if group_end else self.loose | self.dirty
                self.dirty.clear()
            if group_end:
                for c in sorted(self.loose):
                    store.save_cell(self.out_dir, c, self.cell_files[c])
                self.loose.clear()
            self._flushed_at = time.monotonic()

    def calibrate(self) -> None:
        """Timing-only batches for the cells whose own batches took under store.MIN_TIMED_SECONDS in all
        (too short for the clock to time honestly), after the sweep; stored in calibration.json
        keyed by cell, backend, code version and threads, so a rerun reuses them. Per group, the
        cells take turns (round robin) so that load from other jobs hits them alike."""
        cal = store.load_calibration(self.out_dir)
        fp = short_hash({"code": self.backend.code_version, "backend": self.backend.name,
                         "threads": self.threads, "batches": store.CAL_BATCHES, "clock": 5}, 16)
        cpu = self.backend.name == "warp-cpu"
        t0 = time.perf_counter()
        by_group: dict = {}
        for r in self.plan:
            rec = self.records.get(r.run_id)
            if rec is not None:
                by_group.setdefault(r.group, {}).setdefault(r.cell, (r, []))[1].append(rec)
        for g, cells in by_group.items():
            # Each record carries its share of its batch's time: their sum is the cell's.
            small = {c: (r, recs) for c, (r, recs) in cells.items()
                     if sum(rec["cpu_seconds" if cpu else "render_seconds"] for rec in recs)
                     < store.MIN_TIMED_SECONDS and cal.get(c, {}).get("fingerprint") != fp}
            if not small:
                continue
            scene = self.backend.load_scene(g[0].name, g[0].overrides_dict or None)
            for c, entry in self._time_cells(scene, small, cpu).items():
                cal[c] = {"fingerprint": fp, **entry}
            store.save_calibration(self.out_dir, cal)
        self._seconds["calibration_total"] = time.perf_counter() - t0
        self.stats["calibration_seconds"] = round(self._seconds["calibration_total"], 3)

    def _time_cells(self, scene, small: dict, cpu: bool) -> dict:
        entries = {}
        for c, (r, recs) in small.items():
            per_rep = max(float(np.mean(store.batch_timings(recs, cpu))), 1e-6)
            reps = max(1, int(math.ceil(store.MIN_TIMED_SECONDS / store.CAL_BATCHES / per_rep)))
            entries[c] = {"reps": reps, "seconds": [], "clock": "cpu" if cpu else "wall",
                          "spp": r.spp}
        for i in range(store.CAL_BATCHES):                                   # round robin
            for c, (r, _) in small.items():
                e = entries[c]
                seeds = [run_seed(0xCA11B, r.scene.key, r.sampler, r.integrator, r.resolution,
                                  r.spp, 10_000 + i * e["reps"] + k) for k in range(e["reps"])]
                res = self.backend.batch(scene, spp=r.spp, sampler=r.sampler, integrator=r.integrator,
                                         seeds=seeds, res=r.resolution, threads=self.threads)
                t = float(getattr(res, "cpu_seconds", res.render_seconds)) if cpu else float(res.render_seconds)
                e["seconds"].append(t / e["reps"])
        return entries


@dataclass
class _GroupContext:
    """What every batch of one (scene, integrator, resolution) group shares."""
    scene: object
    gt: object
    gt_lab: object


def _analyse_and_report(exp, sweep: _Sweep, analyze: bool, argv, t_start: float) -> ExperimentResult:
    out_dir, plan = sweep.out_dir, sweep.plan
    if analyze:
        sweep.log("analysis: cost models, slope fits, comparisons, report and figures")
    # Only the plan's runs count; stale records (other code version, other plan) are left out.
    plan_ids = {r.run_id for r in plan}
    records = {k: v for k, v in sweep.records.items() if k in plan_ids}
    sweep.stats["rows"] = store.write_runs_csv(out_dir / "runs.csv", plan, records)
    summary = None
    if analyze:
        t0 = time.perf_counter()
        summary = analysis.analyze(exp, plan, records, out_dir, sweep.gts, log=sweep.log,
                                   calibration=store.load_calibration(out_dir),
                                   targets=sweep.targets, cpu=sweep.backend.name == "warp-cpu")
        atomic_write_json(out_dir / "summary.json", summary.to_json())
        report.write_report(exp, summary, plan, records, out_dir, sweep.gts)
        sweep.stats["analysis_seconds"] = round(time.perf_counter() - t0, 3)
    wall = time.time() - t_start
    if analyze:
        manifest.write_manifest(out_dir, exp, sweep.backend, plan, records, sweep.gts, sweep.stats,
                                wall, argv)
    return ExperimentResult(stats=sweep.stats, wall_seconds=wall, summary=summary,
                            out_dir=sweep.out_dir)
