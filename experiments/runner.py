"""The sweep: ground truth, then every (scene, sampler, spp, repetition) run, resumable at run level.

Each finished run is two files under `<out>/runs/`, both written atomically (temp file + os.replace):
`<run id>.npz` (the image, float32) and then `<run id>.json` (its record: seeds, metrics, timings).
The JSON is the commit point: a run is done exactly when its JSON exists and its fingerprint (code
version, ground-truth key, scene hash) matches. `runs.csv` is regenerated from the records after every
run, also atomically, in the plan's order, so a `kill -9` anywhere loses at most the run in flight,
and can never leave a torn file or a duplicate row.
"""
from __future__ import annotations

import csv
import io
import json
import shutil
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np

from drtlab.experiments import groundtruth as gtmod
from drtlab.experiments.config import Experiment, SceneRef
from drtlab.experiments.files import atomic_savez, atomic_write_json, atomic_write_text
from drtlab.experiments.paths import default_gt_root, default_out_dir
from drtlab.experiments.metrics import _lab, image_metrics
from drtlab.experiments.seeds import run_seed, short_hash

CSV_COLUMNS = (
    "run_id", "studies", "scene", "sampler", "integrator", "width", "height", "spp", "rep", "seed",
    "rmse", "rmse_corrected", "mse", "mse_corrected", "gt_var", "relmse", "relmse_corrected", "mae",
    "mean_error", "ciede2000", "render_seconds", "compile_seconds", "wall_seconds",
    "samples_per_second", "gt_spp",
)
OUTPUT_NAMES = ("runs", "runs.csv", "summary.json", "report.md", "plots", "images", "manifest.json")


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
    for st in exp.studies:
        s = st.settings
        for sc in st.scenes:
            if (sc, s.resolution) not in res_cache:
                if s.resolution:
                    res_cache[(sc, s.resolution)] = tuple(s.resolution)
                else:
                    scene = backend.load_scene(sc.name, sc.overrides_dict or None)
                    res_cache[(sc, s.resolution)] = (int(scene.width), int(scene.height))
            res = res_cache[(sc, s.resolution)]
            for sampler in st.samplers:
                for spp in s.spp:
                    for rep in range(s.repetitions):
                        seed = run_seed(st.seed, sc.key, sampler, st.integrator, res, spp, rep)
                        r = RunSpec(sc, sampler, st.integrator, res, spp, rep, seed, (st.name,))
                        old = plan.get(r.run_id)
                        if old is None:
                            plan[r.run_id] = r
                        elif st.name not in old.studies:
                            plan[r.run_id] = replace(old, studies=old.studies + (st.name,))
    # Group by scene so that one ground truth is in memory at a time.
    runs = list(plan.values())
    order = {}
    for r in runs:
        order.setdefault(r.group, len(order))
    return sorted(runs, key=lambda r: order[r.group])     # stable: keeps study/sampler/spp order


def gt_requirements(exp: Experiment, plan: list[RunSpec]) -> dict:
    """(scene, integrator, resolution) -> (gt_spp, gt_batch_spp): the most any study asks for."""
    by_name = {st.name: st for st in exp.studies}
    req: dict = {}
    for r in plan:
        for name in r.studies:
            s = by_name[name].settings
            prev = req.get(r.group)
            if prev is None or s.gt_spp > prev[0]:
                req[r.group] = (s.gt_spp, s.gt_batch_spp)
    return req


def _fingerprint(r: RunSpec, gt, code_version: str) -> str:
    return short_hash({"run": r.run_id, "gt_key": gt.manifest.get("key"), "code": code_version}, 16)


def _record_row(rec: dict, studies: tuple[str, ...]) -> dict:
    row = {k: rec.get(k, "") for k in CSV_COLUMNS}
    row["studies"] = ";".join(studies)
    return row


def write_runs_csv(path: Path, plan: list[RunSpec], records: dict) -> int:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, lineterminator="\n")
    w.writeheader()
    n = 0
    for r in plan:
        rec = records.get(r.run_id)
        if rec is not None:
            row = _record_row(rec, r.studies)
            for k, v in row.items():
                if isinstance(v, float):
                    row[k] = repr(v)
            w.writerow(row)
            n += 1
    atomic_write_text(path, buf.getvalue())
    return n


def load_records(runs_dir: Path) -> dict:
    out = {}
    if not runs_dir.is_dir():
        return out
    for f in runs_dir.glob("*.json"):
        try:
            rec = json.loads(f.read_text())
        except (OSError, ValueError):
            continue                       # cannot happen with atomic writes; treat as not done
        if rec.get("run_id") == f.stem and (runs_dir / f"{f.stem}.npz").is_file():
            out[f.stem] = rec
    return out


def load_run_image(out_dir: Path, run_id: str) -> np.ndarray:
    with np.load(Path(out_dir) / "runs" / f"{run_id}.npz", allow_pickle=False) as z:
        return z["image"].astype(np.float64)


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
                self.bar.set_postfix_str(f"{what} | runs {self.runs_done}/{self.runs_total}", refresh=False)
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def run_experiment(exp: Experiment, out_dir: Path | None = None, gt_root: Path | None = None,
                   backend=None, threads: int | None = None, fresh: bool = False,
                   progress: bool = True, clock: Callable[[], float] = time.perf_counter,
                   log: Callable[[str], None] | None = None, analyze: bool = True,
                   argv: list[str] | None = None) -> dict:
    """Run (or resume) the sweep, then analyse it and write every output. Returns the summary."""
    if backend is None:
        from drtlab.experiments.backend import default_backend
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
        return _sweep_and_report(exp, plan, gt_req, out_dir, gt_root, backend, threads, progress,
                                 clock, log, analyze, argv, t_start)
    finally:
        lock.close()


def _sweep_and_report(exp, plan, gt_req, out_dir, gt_root, backend, threads, progress, clock, log,
                      analyze, argv, t_start) -> dict:
    runs_dir = out_dir / "runs"
    _remove_orphaned_temps(out_dir)
    records = load_records(runs_dir)

    # Work estimate for one bar: pending GT samples + pending run samples (done runs checked below).
    gt_pending = {g: gtmod.pending_samples(g[0], g[1], g[2], req[0], req[1], backend, gt_root)
                  for g, req in gt_req.items()}
    candidates = [r for r in plan if r.run_id not in records]
    total = sum(gt_pending.values()) + sum(r.spp * r.resolution[0] * r.resolution[1] for r in candidates)
    bar = _Progress(total, len(candidates), progress)
    stats = {"runs_planned": len(plan), "runs_new": 0, "runs_reused": 0, "runs_refreshed": 0}
    gts: dict = {}
    try:
        groups: dict = {}
        for r in plan:
            groups.setdefault(r.group, []).append(r)
        for g, runs in groups.items():
            sc, integ, res = g
            gt_spp, gt_batch = gt_req[g]
            gt = gtmod.ensure_ground_truth(
                sc, integ, res, gt_spp, gt_batch, backend, gt_root, threads=threads,
                progress=False, log=log,
                on_batch=lambda n, lab=sc.label: bar.update(n, f"ground truth {lab}"))
            gts[g] = {"dir": str(gt.directory), "spp": gt.spp, "batches": gt.batches,
                      "variance": gt.variance, "reused": gt.reused, "key": gt.manifest.get("key"),
                      "wall_seconds": gt.manifest.get("wall_seconds"),
                      "compile_seconds": gt.manifest.get("compile_seconds"),
                      "seeds": gt.manifest.get("seeds")}
            gt_lab = None
            scene_obj = None
            for r in runs:
                fp = _fingerprint(r, gt, backend.code_version)
                rec = records.get(r.run_id)
                if rec is not None and rec.get("fingerprint") == fp:
                    if rec.get("gt_spp") == gt.spp:
                        stats["runs_reused"] += 1
                        continue
                    # Same render, better reference: recompute the metrics, keep the timings.
                    if gt_lab is None:
                        gt_lab = _lab(gt.mean)
                    img = load_run_image(out_dir, r.run_id)
                    rec.update(image_metrics(img, gt.mean, gt.stderr, gt_lab), gt_spp=gt.spp)
                    atomic_write_json(runs_dir / f"{r.run_id}.json", rec)
                    stats["runs_refreshed"] += 1
                    continue
                if scene_obj is None:
                    scene_obj = backend.load_scene(sc.name, sc.overrides_dict or None)
                if gt_lab is None:
                    gt_lab = _lab(gt.mean)
                t0 = clock()
                res_ = backend.render(scene_obj, spp=r.spp, sampler=r.sampler, integrator=r.integrator,
                                      seed=r.seed, res=r.resolution, threads=threads)
                wall = clock() - t0
                img = np.asarray(res_.image, dtype=np.float64)
                m = image_metrics(img, gt.mean, gt.stderr, gt_lab)
                rec = {
                    "run_id": r.run_id, "fingerprint": fp,
                    "scene": r.scene.label, "scene_key": r.scene.key, "sampler": r.sampler,
                    "integrator": r.integrator, "width": r.resolution[0], "height": r.resolution[1],
                    "spp": r.spp, "rep": r.rep, "seed": r.seed,
                    **m,
                    "render_seconds": float(res_.render_seconds),
                    "compile_seconds": float(getattr(res_, "compile_seconds", 0.0)),
                    "wall_seconds": float(wall),
                    "samples_per_second": float(getattr(res_, "samples_per_second", 0.0)
                                                or (r.spp * img.shape[0] * img.shape[1]
                                                    / max(float(res_.render_seconds), 1e-12))),
                    "gt_spp": gt.spp, "gt_key": gt.manifest.get("key"),
                    "code_version": backend.code_version,
                }
                atomic_savez(runs_dir / f"{r.run_id}.npz", image=img.astype(np.float32))
                atomic_write_json(runs_dir / f"{r.run_id}.json", rec)       # the commit point
                records[r.run_id] = rec
                write_runs_csv(out_dir / "runs.csv", plan, records)
                stats["runs_new"] += 1
                bar.update(r.spp * r.resolution[0] * r.resolution[1],
                           f"{r.scene.label} {r.sampler} {r.spp}spp", run_done=True)
    finally:
        bar.close()

    # Only the plan's runs count; stale records (other code version, other plan) stay on disk unused.
    plan_ids = {r.run_id for r in plan}
    records = {k: v for k, v in records.items() if k in plan_ids}
    n_rows = write_runs_csv(out_dir / "runs.csv", plan, records)
    stats["rows"] = n_rows
    summary: dict = {}
    if analyze:
        from drtlab.experiments import analysis, manifest, report
        summary = analysis.analyze(exp, plan, records, out_dir, gts, log=log)
        summary["ground_truth"] = {f"{g[0].key}__{g[1]}__{g[2][0]}x{g[2][1]}":
                                   {k: v for k, v in info.items() if k != "seeds"}
                                   for g, info in gts.items()}
        atomic_write_json(out_dir / "summary.json", summary)
        report.write_report(exp, summary, plan, records, out_dir, gts)
        wall = time.time() - t_start
        manifest.write_manifest(out_dir, exp, backend, plan, records, gts, stats, wall, argv)
        summary["_stats"] = stats
        summary["_wall_seconds"] = wall
    return summary
