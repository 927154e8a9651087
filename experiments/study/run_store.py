"""The run files of an experiment folder: `runs/<run id>.npz` (image), `runs/<run id>.json` (record)
and `runs.csv` (one row per finished run, in the plan's order).

Every file is written atomically (temp file + os.replace). The JSON is the commit point: a run is done
exactly when its JSON exists (beside its image), so the image is always written first. The runner
writes these files; the analysis and the report only read them.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from drtlab.experiments.files import atomic_savez, atomic_write_json, atomic_write_text

CSV_COLUMNS = (
    "run_id", "studies", "scene", "sampler", "integrator", "width", "height", "spp", "rep", "seed",
    "rmse", "rmse_corrected", "mse", "mse_corrected", "gt_var", "relmse", "relmse_corrected", "mae",
    "mean_error", "ciede2000", "render_seconds", "compile_seconds", "wall_seconds",
    "samples_per_second", "gt_spp", "worker",
)


def save_run(runs_dir: Path, run_id: str, image: np.ndarray, record: dict) -> None:
    """A finished run: its image (float32) and then its record, the commit point."""
    atomic_savez(Path(runs_dir) / f"{run_id}.npz", image=image.astype(np.float32))
    save_record(runs_dir, run_id, record)


def save_record(runs_dir: Path, run_id: str, record: dict) -> None:
    atomic_write_json(Path(runs_dir) / f"{run_id}.json", record)


def load_records(runs_dir: Path) -> dict:
    """run id -> record of every committed run in `runs_dir` (a JSON with its image beside it)."""
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
    """The image of a run of the experiment folder `out_dir`, as float64."""
    with np.load(Path(out_dir) / "runs" / f"{run_id}.npz", allow_pickle=False) as z:
        return z["image"].astype(np.float64)


def _record_row(rec: dict, studies: tuple[str, ...]) -> dict:
    row = {k: rec.get(k, "") for k in CSV_COLUMNS}
    row["studies"] = ";".join(studies)
    row["worker"] = rec.get("worker") or "local"      # records from before the column ran here
    return row


def write_runs_csv(path: Path, plan: list, records: dict) -> int:
    """`runs.csv` from the records of the plan's runs (RunSpec: run_id, studies), in plan order;
    floats as repr (round-trip exact). Returns the number of rows."""
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


# ---------------------------------------------------------------------------------------------------
# Cost calibration: `calibration.json`, and the cost model fitted from it and the runs' timings
# ---------------------------------------------------------------------------------------------------

CALIBRATION_FILE = "calibration.json"
# Run-to-run drift of the per-sample cost that repeats within one run cannot see (CPU clock, caches):
# fresh reruns of bitcheck/tiny.toml on the 2-core dev VM differed by 2-4%; the cost's 95% interval
# adds this relative half-width in quadrature.
SYSTEMATIC = 0.05


def load_calibration(out_dir: Path) -> dict:
    """key -> calibration entry (see `runner._calibrate`); {} when there is none."""
    try:
        return json.loads((Path(out_dir) / CALIBRATION_FILE).read_text())
    except (OSError, ValueError):
        return {}


def save_calibration(out_dir: Path, entries: dict) -> None:
    atomic_write_json(Path(out_dir) / CALIBRATION_FILE, entries)


def calibration_key(group_name: str, sampler: str) -> str:
    return f"{group_name}__{sampler}"


@dataclass
class CostModel:
    """cost(spp) = overhead + per_sample * pixels * spp. `per_sample` holds one value per calibration
    render of the faster half of the calibration renders (the t interval of their mean is the cost's);
    `overhead` is the lower quartile of the residuals `overhead_samples` pooled over the group's
    samplers (the launch cost does not depend on them; load from other jobs only adds time)."""
    per_sample: np.ndarray
    pixels: int
    overhead: float = 0.0
    overhead_samples: np.ndarray = field(default_factory=lambda: np.zeros(0))
    calibrated: bool = False
    clock: str = "wall"                  # "cpu": CPU seconds of the render call (see runner)

    @property
    def mean(self) -> float:
        return float(np.mean(self.per_sample))

    def t_halfwidth(self) -> float:
        """95% half-width of the mean per-sample cost: t over the renders, and `SYSTEMATIC`."""
        n = self.per_sample.size
        if n < 2:
            return float("nan")
        from scipy import stats
        h = float(stats.t.ppf(0.975, n - 1)) * float(np.std(self.per_sample, ddof=1)) / math.sqrt(n)
        return math.hypot(h, SYSTEMATIC * self.mean)

    def seconds(self, spp: int, per_sample: float | None = None, overhead: float | None = None) -> float:
        ps = self.mean if per_sample is None else per_sample
        return (self.overhead if overhead is None else overhead) + ps * self.pixels * spp

    def draw_per_sample(self, rng) -> float:
        """A draw of the mean per-sample cost from its t law (parametric bootstrap)."""
        n = self.per_sample.size
        if n < 2:
            return self.mean
        sd = float(np.std(self.per_sample, ddof=1)) / math.sqrt(n)
        sys_sd = SYSTEMATIC / 1.96 * self.mean
        return max(self.mean + sd * float(rng.standard_t(n - 1)) + sys_sd * float(rng.standard_normal()),
                   1e-3 * self.mean)


def _faster_half(values) -> list:
    """The faster half of repeated timings (at least 2): load from other jobs only slows a render
    down, so the faster renders are the ones that measure the code."""
    v = sorted(values)
    return v[:max(2, (len(v) + 1) // 2)] if len(v) > 2 else v


def _per_sample(entry: dict | None, recs: list, overhead: float) -> tuple[np.ndarray, bool]:
    if entry and entry.get("seconds"):
        work = entry["pixels"] * entry["spp"]
        # The faster half, of wall and of CPU seconds alike: a job sharing the two cores inflates the
        # CPU time of a render too (five reruns beside a test suite: speed-ups +-30-50% with every
        # render counted).
        ts = _faster_half(entry["seconds"])
        return np.array([max(t - overhead, 1e-3 * t) / work for t in ts]), True
    top = max(rec["spp"] for rec in recs)            # no calibration: the sweep's top cell
    return np.array([max(rec["render_seconds"] - overhead, 1e-3 * rec["render_seconds"])
                     / (rec["width"] * rec["height"] * rec["spp"]) for rec in recs if rec["spp"] == top]), False


def fit_cost_models(recs_by_sampler: dict, calibration: dict, group_name: str) -> dict:
    """sampler -> CostModel of one (scene, integrator, resolution) group, from its runs' records
    (sampler -> list of records) and the calibration entries."""
    entries = {s: calibration.get(calibration_key(group_name, s)) for s in recs_by_sampler}
    overhead = 0.0
    for _ in range(3):                               # per-sample and overhead, alternately
        ps = {s: _per_sample(entries[s], recs, overhead) for s, recs in recs_by_sampler.items()}
        # CPU-clock calibrations (see runner) pool only their own low-spp renders: the runs are wall.
        resid = [rec["render_seconds"] - float(np.mean(ps[s][0])) * rec["width"] * rec["height"] * rec["spp"]
                 for s, recs in recs_by_sampler.items() for rec in recs
                 if not (entries[s] and entries[s].get("clock") == "cpu")]
        for s, e in entries.items():
            if e and e.get("low_seconds"):
                resid += [t - float(np.mean(ps[s][0])) * e["pixels"] * e["low_spp"] for t in e["low_seconds"]]
        resid_a = np.array(resid)
        overhead = max(float(np.percentile(resid_a, 25)), 0.0) if resid_a.size else 0.0
        cpu = any(e and e.get("clock") == "cpu" for e in entries.values())
    pixels = {s: recs[0]["width"] * recs[0]["height"] for s, recs in recs_by_sampler.items()}
    return {s: CostModel(ps[s][0], pixels[s], overhead, resid_a, ps[s][1], "cpu" if cpu else "wall")
            for s in recs_by_sampler}
