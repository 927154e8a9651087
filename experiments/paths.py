"""Where results go by default: `results/` (or $DRTLAB_RESULTS) and the ground-truth cache in it."""
from __future__ import annotations

import os
from pathlib import Path


def _from_env(name: str) -> Path | None:
    """The folder an environment variable names; None when unset, and an empty one refused."""
    value = os.environ.get(name)
    if value is None:
        return None
    from drtlab.fields import path_text
    return Path(path_text(value, name))


def results_root() -> Path:
    return _from_env("DRTLAB_RESULTS") or Path("results")


def default_out_dir(experiment_name: str) -> Path:
    return results_root() / experiment_name


def default_gt_root() -> Path:
    """The ground-truth cache: $DRTLAB_GT_DIR, else results/ground-truth."""
    return _from_env("DRTLAB_GT_DIR") or results_root() / "ground-truth"
