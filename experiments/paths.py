"""Where results go by default: `results/` (or $DRTLAB_RESULTS) and the ground-truth cache in it."""
from __future__ import annotations

import os
from pathlib import Path


def results_root() -> Path:
    return Path(os.environ.get("DRTLAB_RESULTS", "results"))


def default_out_dir(experiment_name: str) -> Path:
    return results_root() / experiment_name


def default_gt_root() -> Path:
    """The ground-truth cache: $DRTLAB_GT_DIR, else results/ground-truth."""
    return Path(os.environ.get("DRTLAB_GT_DIR", results_root() / "ground-truth"))
