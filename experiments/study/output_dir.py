"""A sweep's output folder: its lock (one writer at a time), the temp files a kill left, and the
outputs `--fresh` removes."""
from __future__ import annotations

import shutil
from pathlib import Path

from drtlab.experiments.study import run_store as store

OUTPUT_NAMES = (store.RUNS_FILE, store.CELLS_DIR, "runs.csv", "summary.json", "report.md", "report.html",
                "plots", "images", "manifest.json", store.CALIBRATION_FILE)


def lock_output(out_dir: Path):
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


def remove_orphaned_temps(out_dir: Path) -> None:
    """Temp files of writes a kill interrupted (never read: the os.replace never happened)."""
    for d in (out_dir, out_dir / store.CELLS_DIR):
        for p in d.glob(".*"):
            if p.is_file() and p.suffix in (".tmp", ".exr", ".npz", ".json", ".csv"):
                p.unlink(missing_ok=True)


def clean_outputs(out_dir: Path) -> None:
    for name in OUTPUT_NAMES:
        p = out_dir / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()
