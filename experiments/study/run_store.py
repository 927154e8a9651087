"""The run files of an experiment folder: one table of runs and one array file per cell.

* `runs.parquet`: one row per finished run (`pandas.read_parquet` reads it), rewritten atomically
  (temp file + os.replace) after every batch of repetitions.
* `cells/<cell>.npz`: per (scene, integrator, resolution, sampler, spp) cell what the analysis and
  the report need of its images: the per-pixel mean over its repetitions and the total of squared
  deviations from it (the bias and its noise), the first repetition's image (the strips), the ids of
  the batches merged in, and with `keep_images` every repetition's image.

Commit protocol (a `kill -9` at any moment leaves a consistent folder): the table is written first,
then the cell files of the batches it added. A run counts as done when its row is in the table AND its batch is listed
in its cell file, so rows of a batch whose cell file was not replaced are dropped on load and that
batch renders again (same seeds, same images). `runs.csv` is an export of the table.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drtlab.experiments.error_metrics.base import PLUGIN_PREFIX
from drtlab.experiments.files import atomic_savez, atomic_write_bytes, atomic_write_json, atomic_write_text

RUNS_FILE = "runs.parquet"
CELLS_DIR = "cells"
CSV_COLUMNS = (
    "run_id", "studies", "scene", "sampler", "integrator", "width", "height", "spp", "rep", "seed",
    "rmse", "rmse_corrected", "mse", "mse_corrected", "gt_var", "relmse", "relmse_corrected", "mae",
    "mean_error", "ciede2000", "flip", "render_seconds", "cpu_seconds", "compile_seconds", "wall_seconds",
    "samples_per_second", "gt_spp", "worker", "batch", "batch_reps",
)
# What a row holds beyond the CSV's columns (the resume keys).
TABLE_COLUMNS = CSV_COLUMNS + ("scene_key", "cell", "fingerprint", "gt_key", "code_version", "finite",
                               "batch_time")
# Columns that measure the machine, not the estimator: they differ between reruns and workers.
TIMING_COLUMNS = ("render_seconds", "cpu_seconds", "compile_seconds", "wall_seconds",
                  "samples_per_second", "worker", "batch_time")


# ---------------------------------------------------------------------------------------------------
# Per-cell moments
# ---------------------------------------------------------------------------------------------------

@dataclass
class CellMoments:
    """n repetitions' per-pixel mean and the sum over pixels and channels of their squared deviations
    from it: enough for the bias of the cell's mean image and its noise (metrics.cell_bias)."""
    n: int
    mean: np.ndarray              # (H, W, 3) float64
    m2: float                     # sum over elements of sum_r (x_r - mean)^2

    @classmethod
    def of(cls, images: np.ndarray) -> "CellMoments":
        """The moments of a batch as the runner computes them (`error_sums.batch_sums`, which scores
        a batch and takes its moments in one pass; here against a zero reference)."""
        from drtlab.kernels.error_sums import batch_sums
        s = batch_sums(images, np.zeros(np.shape(images)[1:]), None, 1.0)
        return cls(int(np.shape(images)[0]), s.mean, s.m2)

    def merged(self, other: "CellMoments") -> "CellMoments":
        """Chan et al.'s pairwise update: the moments of both sets of repetitions together."""
        n = self.n + other.n
        delta = other.mean - self.mean
        mean = self.mean + delta * (other.n / n)
        m2 = self.m2 + other.m2 + float(np.sum(np.square(delta))) * self.n * other.n / n
        return CellMoments(n, mean, m2)

    def pixel_variance(self) -> float:
        """Mean over pixels and channels of the per-pixel sample variance of one repetition."""
        return self.m2 / (self.mean.size * (self.n - 1)) if self.n > 1 else float("nan")


@dataclass
class CellFile:
    """What `cells/<cell>.npz` holds (see the module docstring)."""
    moments: CellMoments | None
    batches: tuple = ()
    first: np.ndarray | None = None           # repetition 0's image, float32
    images: np.ndarray | None = None          # (n, H, W, 3) float32, with keep_images
    reps: np.ndarray | None = None            # the repetition of each of `images` (commit order)

    def with_batch(self, batch: str, images: np.ndarray, reps: list, keep: bool,
                   moments: CellMoments | None = None) -> "CellFile":
        """This file with one more batch; `moments` are its images' (computed when not given)."""
        m = CellMoments.of(images) if moments is None else moments
        kept = images.astype(np.float32) if keep else None     # else only the first image is kept
        return CellFile(moments=m if self.moments is None else self.moments.merged(m),
                        batches=self.batches + (batch,),
                        first=images[reps.index(0)].astype(np.float32) if 0 in reps else self.first,
                        images=(kept if self.images is None else np.concatenate([self.images, kept]))
                        if keep else None,
                        reps=(np.asarray(reps) if self.reps is None else
                              np.concatenate([self.reps, reps])) if keep else None)


def cell_path(out_dir: Path, cell: str) -> Path:
    return Path(out_dir) / CELLS_DIR / f"{cell}.npz"


def load_cell(out_dir: Path, cell: str) -> CellFile:
    """The cell file of `cell`, or an empty one."""
    p = cell_path(out_dir, cell)
    if not p.is_file():
        return CellFile(None)
    with np.load(p, allow_pickle=False) as z:
        moments = CellMoments(int(z["n"]), z["mean"].astype(np.float64), float(z["m2"]))
        return CellFile(moments, tuple(str(b) for b in z["batches"]),
                        z["first"] if "first" in z.files else None,
                        z["images"] if "images" in z.files else None,
                        z["reps"] if "reps" in z.files else None)


def save_cell(out_dir: Path, cell: str, cf: CellFile, compress: bool = True) -> None:
    arrays = {"n": np.int64(cf.moments.n), "mean": cf.moments.mean.astype(np.float32),
              "m2": np.float64(cf.moments.m2), "batches": np.array(cf.batches, dtype=str)}
    if cf.first is not None:
        arrays["first"] = cf.first.astype(np.float32)
    if cf.images is not None:
        arrays["images"], arrays["reps"] = cf.images.astype(np.float32), cf.reps
    p = cell_path(out_dir, cell)
    p.parent.mkdir(parents=True, exist_ok=True)
    atomic_savez(p, compress, **arrays)


def first_image(out_dir: Path, cell: str) -> np.ndarray | None:
    """Repetition 0's image of a cell (float64), or None."""
    f = load_cell(out_dir, cell).first
    return None if f is None else f.astype(np.float64)


def cell_images(out_dir: Path, cell: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(repetitions, their images) of a cell in repetition order, for an experiment run with
    keep_images; else None."""
    cf = load_cell(out_dir, cell)
    if cf.images is None:
        return None
    order = np.argsort(cf.reps, kind="stable")
    return cf.reps[order], cf.images[order].astype(np.float64)


# ---------------------------------------------------------------------------------------------------
# The table of runs
# ---------------------------------------------------------------------------------------------------

def load_records(out_dir: Path) -> dict:
    """run id -> record of every committed run of the folder (row in the table and batch in its
    cell file)."""
    p = Path(out_dir) / RUNS_FILE
    if not p.is_file():
        return {}
    import pandas as pd
    rows = pd.read_parquet(p).to_dict("records")
    batches: dict = {}
    out = {}
    for row in rows:
        cell = row["cell"]
        if cell not in batches:
            batches[cell] = set(load_cell(out_dir, cell).batches)
        if row["batch"] in batches[cell]:
            out[row["run_id"]] = {k: _python(v) for k, v in row.items()}
    return out


def _python(v):
    """numpy scalars from the table -> Python values (records are compared and written as JSON)."""
    return v.item() if isinstance(v, np.generic) else v


def write_table(out_dir: Path, records: dict, order: list) -> None:
    """runs.parquet from `records` (run id -> record), rows in `order` (run ids) first."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    ids = [i for i in order if i in records] + sorted(set(records) - set(order))
    rows = [records[i] for i in ids]
    # Column by column into Arrow: a pandas frame of row dicts cost 20x more, at every commit.
    table = pa.table({k: [row.get(k) for row in rows] for k in _with_plugin_metrics(TABLE_COLUMNS, rows)})
    buf = pa.BufferOutputStream()
    # Plain encoding: dictionaries halved the write's speed and saved nothing (1.29 MB against
    # 1.23 MB for the default study's 10,200 rows).
    pq.write_table(table, buf, use_dictionary=False)
    atomic_write_bytes(Path(out_dir) / RUNS_FILE, buf.getvalue().to_pybytes())


def commit(out_dir: Path, records: dict, order: list, cells: dict, compress: bool = True) -> None:
    """Batches' rows (already in `records`) and then their cells' files (cell -> CellFile): the
    commit protocol. `compress=False` writes the cell files as plain npz (a sweep's commits
    in mid-group: compressing every cell of a group at every commit cost more than the commits)."""
    write_table(out_dir, records, order)
    for cell, cf in cells.items():
        save_cell(out_dir, cell, cf, compress)


def _with_plugin_metrics(columns: tuple, rows) -> tuple:
    """`columns` and the plugin metrics' columns any of `rows` holds (error_metrics.base)."""
    return columns + tuple(sorted({k for row in rows for k in row if k.startswith(PLUGIN_PREFIX)}))


def _record_row(rec: dict, studies: tuple[str, ...], columns: tuple) -> dict:
    row = {k: rec.get(k, "") for k in columns}
    row["studies"] = ";".join(studies)
    row["worker"] = rec.get("worker") or "local"
    return row


def write_runs_csv(path: Path, plan: list, records: dict) -> int:
    """`runs.csv` (the table's export) from the records of the plan's runs (RunSpec: run_id,
    studies), in plan order; floats as repr (round-trip exact). Returns the number of rows."""
    import csv
    buf = io.StringIO()
    columns = _with_plugin_metrics(CSV_COLUMNS, (records[r.run_id] for r in plan if r.run_id in records))
    w = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    w.writeheader()
    n = 0
    for r in plan:
        rec = records.get(r.run_id)
        if rec is not None:
            row = _record_row(rec, r.studies, columns)
            for k, v in row.items():
                if isinstance(v, float):
                    row[k] = repr(v)
            w.writerow(row)
            n += 1
    atomic_write_text(path, buf.getvalue())
    return n


# ---------------------------------------------------------------------------------------------------
# Timing-only batches for cells too small to time (their costs come from stats/cost_model.py)
# ---------------------------------------------------------------------------------------------------

CALIBRATION_FILE = "calibration.json"
MIN_TIMED_SECONDS = 0.2          # a cell whose batches took less than this gets timing-only batches
CAL_BATCHES = 4                  # timing-only batches per such cell


def load_calibration(out_dir: Path) -> dict:
    """cell -> timing-only batches ({"seconds": per-repetition seconds, "reps", "clock"}); {} when none."""
    import json
    try:
        return json.loads((Path(out_dir) / CALIBRATION_FILE).read_text())
    except (OSError, ValueError):
        return {}


def save_calibration(out_dir: Path, entries: dict) -> None:
    atomic_write_json(Path(out_dir) / CALIBRATION_FILE, entries)


def batch_timings(recs: list, cpu: bool) -> list:
    """Per-repetition seconds of each batch of a cell's records."""
    per: dict = {}
    for rec in recs:
        per.setdefault(rec["batch"], rec["cpu_seconds"] if cpu else rec["render_seconds"])
    return list(per.values())
