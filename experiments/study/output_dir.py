"""A sweep's output folder, and drtlab's record of what in it is drtlab's.

The folder may hold the user's own files beside drtlab's (a notes file, their own `images/`): drtlab
removes only files it wrote. Before anything is written, every file the sweep will write is entered
in the record, `<out>/.drtlab-record.json` (a write-ahead: a kill during a write leaves a name
drtlab owns, never one it does not know). `--fresh` removes the recorded files (the variance-sources
cache `sources/` is kept, as the ground-truth cache is) and the recorded folders left empty; the
clean-up after a kill removes only the temp files of recorded names (`files.py` writes a file as
`.<name>.<8 random characters>.tmp` beside it, then renames it into place).

A folder that holds anything else is refused before any work unless the caller allows it
(`--allow-other-files`); even then a file at a path drtlab would write is never overwritten unless it
is recorded. A folder an earlier drtlab wrote (a `runs.parquet` and no record) is adopted: the files
at the paths this sweep writes and the cell files its table names are taken as drtlab's.
"""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

from drtlab.errors import InputError
from drtlab.experiments.files import atomic_write_json
from drtlab.experiments.study import run_store as store

RECORD = ".drtlab-record.json"
LOCK = ".lock"
KEPT_BY_FRESH = ("sources/",)          # a cache keyed by its parameters and the code version
FIXED_FILES = (store.RUNS_FILE, "runs.csv", "summary.json", "report.md", "report.html", "manifest.json",
               store.CALIBRATION_FILE, LOCK, RECORD)           # the record too: its own temps are drtlab's
_TEMP = re.compile(r"^\.(?P<name>.+)\.[a-z0-9_]{8}\.tmp$")     # tempfile.mkstemp's 8 characters
_SHOWN = 3                             # other files a refusal names


def planned_files(exp, plan) -> list[str]:
    """Every file (relative to the folder, '/'-separated) a sweep of `plan` writes."""
    from drtlab.experiments.study.report import figure_files
    from drtlab.experiments.study.variance_sources import source_files
    return (list(FIXED_FILES) + [f"{store.CELLS_DIR}/{c}.npz" for c in sorted({r.cell for r in plan})]
            + figure_files(exp) + source_files(exp.studies))


def checked_record(out_dir: Path, exp, plan, allow_other_files: bool, gt_root: Path):
    """(the folder's record, the files the sweep of `plan` writes), the folder checked against them
    (`OutputRecord.check`, field `out_dir`); nothing is written."""
    planned = planned_files(exp, plan)
    record = OutputRecord.load(out_dir, planned) if Path(out_dir).is_dir() else OutputRecord(out_dir)
    record.check(planned, allow_other_files, "out_dir", skip=gt_root)
    return record, planned


class OutputRecord:
    """The files and folders of `out_dir` that drtlab wrote (relative, '/'-separated)."""

    def __init__(self, out_dir: Path, files=(), folders=(), stored: bool = False):
        self.out_dir, self.files, self.folders, self.stored = Path(out_dir), set(files), set(folders), stored

    @classmethod
    def load(cls, out_dir: Path, planned: list[str]) -> "OutputRecord":
        p = Path(out_dir) / RECORD
        try:
            data = json.loads(p.read_text())
            return cls(out_dir, data["files"], data["folders"], stored=True)
        except FileNotFoundError:
            return cls(out_dir, _legacy_files(Path(out_dir), planned))
        except (OSError, ValueError, KeyError, TypeError):
            raise InputError("out_dir", f"{p} is not drtlab's record of the folder (unreadable); move "
                                        "it away or choose another folder") from None

    def owns(self, rel: str) -> bool:
        if rel in self.files or rel in self.folders or rel in (RECORD, LOCK):
            return True
        m = _TEMP.match(rel.rsplit("/", 1)[-1])
        return m is not None and _join(rel.rpartition("/")[0], m["name"]) in self.files

    def others(self, skip: Path | None = None):
        """The paths under the folder drtlab did not write (lazily; links are not followed);
        `skip`: a folder inside it that is drtlab's in another role (the ground-truth cache)."""
        skip = None if skip is None else os.path.realpath(skip)
        for root, dirs, files in os.walk(self.out_dir):
            rel_root = os.path.relpath(root, self.out_dir).replace(os.sep, "/")
            rel_root = "" if rel_root == "." else rel_root
            for d in list(dirs):
                full = os.path.join(root, d)
                if skip is not None and os.path.realpath(full) == skip:
                    dirs.remove(d)
                elif os.path.islink(full):
                    dirs.remove(d)
                    files.append(d)
            for f in files:
                if not self.owns(_join(rel_root, f)):
                    yield _join(rel_root, f)
            if rel_root and not dirs and not files and rel_root not in self.folders:
                yield rel_root + "/"

    def check(self, planned: list[str], allow_other_files: bool, field: str, skip=None) -> None:
        """Refuse (before any work) a folder with files drtlab did not write, unless allowed, and
        always a file of the user's where the sweep would write one."""
        clash = [f for f in planned if f not in self.files and f not in (LOCK, RECORD)
                 and os.path.lexists(self.out_dir / f)]
        if clash:
            raise InputError(field, f"{self.out_dir / clash[0]} was not written by drtlab and this run "
                                    "would overwrite it: move it, or choose another folder")
        for parent in sorted({f.rpartition("/")[0] for f in planned} - {""}):
            p = self.out_dir / parent
            if os.path.lexists(p) and not p.is_dir():
                raise InputError(field, f"{p} is not a folder, and this sweep writes files in it: move "
                                        "it, or choose another folder")
        if allow_other_files:
            return
        shown = []
        for rel in self.others(skip):
            shown.append(rel)
            if len(shown) > _SHOWN:
                break
        if shown:
            more = ", ..." if len(shown) > _SHOWN else ""
            raise InputError(field, f"{self.out_dir} holds files drtlab did not write "
                                    f"({', '.join(shown[:_SHOWN])}{more}): choose a new or empty "
                                    "folder, or --allow-other-files (allow_other_files=True) to write "
                                    "beside them (drtlab removes only its own files)")

    def enter(self, planned: list[str]) -> None:
        """Record `planned` (and the folders they need that do not exist yet, which the sweep
        creates) before any of them is written."""
        for f in planned:
            parent = f.rpartition("/")[0]
            while parent and not (self.out_dir / parent).exists():
                self.folders.add(parent)
                parent = parent.rpartition("/")[0]
        self.files.update(planned)
        self.stored = True
        atomic_write_json(self.out_dir / RECORD, {"format": 1, "files": sorted(self.files),
                                                  "folders": sorted(self.folders)})

    def claim(self, names) -> None:
        """The folder made and `names` recorded as drtlab's, before they are written."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.enter(list(names))

    def remove_outputs(self) -> None:
        """`--fresh`: the recorded files (not the lock, the record or the kept caches), then the
        recorded folders left empty, deepest first."""
        for rel in sorted(self.files):
            if rel not in (LOCK, RECORD) and not rel.startswith(KEPT_BY_FRESH):
                p = self.out_dir / rel
                if p.is_file() or p.is_symlink():
                    p.unlink()
        for rel in sorted(self.folders, key=lambda r: -r.count("/")):
            try:
                (self.out_dir / rel).rmdir()
            except OSError:               # absent, or holds the user's files
                pass

    def remove_orphaned_temps(self) -> None:
        """Temp files of writes a kill interrupted (never read: the rename never happened), of
        recorded names only."""
        for folder in {f.rpartition("/")[0] for f in self.files}:
            d = self.out_dir / folder
            if not d.is_dir():
                continue
            for p in d.glob(".*.tmp"):
                m = _TEMP.match(p.name)
                if m and _join(folder, m["name"]) in self.files and p.is_file() and not p.is_symlink():
                    p.unlink(missing_ok=True)


def checked_folder(out_dir: Path, names, field: str = "--out") -> "OutputRecord":
    """A command that writes fixed names (`names`, relative) into a folder the user may name: refused
    before any work where a file drtlab did not write is at one of those names (a user's own
    `analysis.json` is never overwritten); other files beside them are left alone. Call `claim` on
    the result just before writing."""
    out_dir = Path(out_dir)
    record = OutputRecord.load(out_dir, []) if out_dir.is_dir() else OutputRecord(out_dir)
    record.check(list(names), True, field)
    return record


def _join(folder: str, name: str) -> str:
    return f"{folder}/{name}" if folder else name


def _legacy_files(out_dir: Path, planned: list[str]) -> set:
    """What of a folder an earlier drtlab wrote (runs.parquet, no record) is taken as drtlab's."""
    if not (out_dir / store.RUNS_FILE).is_file():
        return set()
    try:
        import pandas as pd
        cells = set(pd.read_parquet(out_dir / store.RUNS_FILE, columns=["cell"])["cell"])
    except Exception:                                     # noqa: BLE001 - not drtlab's table
        return set()
    mine = set(planned) | {f"{store.CELLS_DIR}/{c}.npz" for c in cells}
    return {f for f in mine if (out_dir / f).is_file()}


def lock_output(out_dir: Path):
    """An exclusive lock on `<out>/.lock`, released when the returned file is closed (or the process
    dies): a second sweep into the same folder stops with one line instead of racing the first."""
    f = open(out_dir / LOCK, "a+")
    try:
        import fcntl
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except ImportError:                       # no fcntl (Windows): no lock
        pass
    except OSError:
        f.close()
        raise InputError("--out", f"another `drtlab experiment` is writing to {out_dir}; wait for it "
                         f"or choose another --out") from None
    return f
