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
from pathlib import Path

import numpy as np

from drtlab.experiments.files import atomic_savez, atomic_write_json, atomic_write_text

CSV_COLUMNS = (
    "run_id", "studies", "scene", "sampler", "integrator", "width", "height", "spp", "rep", "seed",
    "rmse", "rmse_corrected", "mse", "mse_corrected", "gt_var", "relmse", "relmse_corrected", "mae",
    "mean_error", "ciede2000", "render_seconds", "compile_seconds", "wall_seconds",
    "samples_per_second", "gt_spp",
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
