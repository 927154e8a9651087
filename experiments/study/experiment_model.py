"""The experiment model: what an experiment file means once loaded (`Experiment` -> its `Study`s,
each with its `Settings` and `SceneRef`s), the keys a file may hold and their defaults. config.py
turns files into it (and documents the format)."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drtlab.experiments.seeds import short_hash

EXPERIMENT_DIR = Path(__file__).resolve().parent.parent / "studies"     # the built-in study specifications
DEFAULT_PROFILE = "quick"

SETTINGS_KEYS = ("spp", "repetitions", "samples_per_cell", "resolution", "gt_spp", "gt_batch_spp",
                 "target_rmse", "strip_spp", "target_rel_ci", "max_samples_per_cell", "max_seconds",
                 "keep_images", "colour_difference_runs", "flip_runs", "variance_sources")
EXPERIMENT_KEYS = ("description", "seed", "integrator", "include", "plugins") + SETTINGS_KEYS
STUDY_KEYS = ("name", "description", "scenes", "samplers", "baseline", "integrator", "metric")
SCENE_KEYS = ("name", "overrides", "label")
DEFAULTS: dict[str, Any] = {
    "spp": (1, 4, 16, 64, 256),
    "repetitions": 4,
    "samples_per_cell": None,
    "resolution": None,
    "gt_spp": 16384,
    "gt_batch_spp": 512,
    "target_rmse": None,
    "strip_spp": None,
    "target_rel_ci": None,
    "max_samples_per_cell": None,
    "max_seconds": None,
    "keep_images": False,
    "colour_difference_runs": None,
    # One HDR-FLIP per cell: at 96x72 one costs 25-92 ms of CPU (2-7 exposures, which the reference's
    # dynamic range sets; 256x256: 0.26-0.9 s), so the default study's 96 cells spend ~4.5 s on it:
    # 7% of its renders' CPU seconds on a busy machine (9.5 s of its 168 s sweep's wall, 5.7%), ~11%
    # of a quiet machine's render seconds. Two per cell would double that, and buy little: a run's
    # FLIP varies by 0.7-1.8% (coefficient of variation, 10 runs of 8 cells at 1 and 16 spp), so one
    # run puts the cell's mean within about +-4% (95%).
    "flip_runs": 1,
    "variance_sources": None,
}
MIN_GT_BATCHES = 4
MAX_RUNS_PER_CELL = 4096
MAX_STUDY_SECONDS = 7 * 24 * 3600.0      # a week: beyond it a budget is a typo


@dataclass(frozen=True)
class SceneRef:
    name: str                       # built-in name or path, as written
    label: str                      # short name used in file names, tables and plots
    overrides: tuple = ()           # sorted ((dotted key, value), ...)

    @property
    def overrides_dict(self) -> dict:
        return {k: _thaw(v) for k, v in self.overrides}

    @property
    def key(self) -> str:
        """Identity of the scene as rendered (name + overrides), used in seeds and cache names."""
        if not self.overrides:
            return self.label
        return f"{self.label}~{short_hash(self.overrides_dict, 8)}"


@dataclass(frozen=True)
class Settings:
    spp: tuple[int, ...]
    repetitions: int
    resolution: tuple[int, int] | None
    gt_spp: int
    gt_batch_spp: int
    target_rmse: float | None
    strip_spp: tuple[int, ...]
    samples_per_cell: int | None = None
    target_rel_ci: float | None = None     # precision target of a cell's mean MSE (relative 95% CI)
    max_samples_per_cell: int | None = None     # the target's budget, samples per pixel of a cell
    max_seconds: float | None = None     # render seconds per study for growing unresolved cells
    keep_images: bool = False
    colour_difference_runs: int | None = None   # CIEDE2000 of each cell's first runs only (None: all)
    flip_runs: int = DEFAULTS["flip_runs"]      # HDR-FLIP of each cell's first runs (0: none)
    variance_sources: int | None = None         # samples per pixel of each scene's decomposition

    def max_runs_at(self, spp: int) -> int:
        """The most repetitions a precision-targeted cell at `spp` may grow to."""
        budget = MAX_RUNS_PER_CELL if self.max_samples_per_cell is None else \
            max(self.max_samples_per_cell // spp, 1)
        return max(self.runs_at(spp), min(budget, MAX_RUNS_PER_CELL))

    def runs_at(self, spp: int) -> int:
        """Repetitions of a cell at `spp`: `repetitions`, or with `samples_per_cell` at least
        ceil(samples_per_cell / spp). Equal samples per cell matter under heavy tails: a rare, huge
        sample then has the same chance to land in every cell, so the cells' means are biased alike
        (by the samples none of them saw) and the slope is not; with equal runs the small-spp cells
        see it least often and the fitted error falls too slowly (tests/experiments/stats/test_slope_fit.py)."""
        if self.samples_per_cell is None:
            return self.repetitions
        return max(self.repetitions, -(-self.samples_per_cell // spp))

    @property
    def runs_per_spp(self) -> list[int]:
        return [self.runs_at(n) for n in self.spp]


@dataclass(frozen=True)
class Study:
    name: str
    description: str
    experiment: str                 # the file it came from (differs from the top one for includes)
    seed: int
    scenes: tuple[SceneRef, ...]
    samplers: tuple[str, ...]       # canonical sampler names
    baseline: str
    integrator: str
    settings: Settings
    metric: str = "mse"             # the error samplers are ranked by: mse | relmse


@dataclass(frozen=True)
class Experiment:
    name: str
    description: str
    path: str
    profile: str
    text_hash: str                  # hash of this file and every included file's text
    studies: tuple[Study, ...]
    sources: dict = field(default_factory=dict, compare=False)   # file -> text hash
    profiles: tuple[str, ...] = ()  # the [profile.NAME] sections of the file and its includes

    def scenes(self) -> list[tuple[SceneRef, str, tuple | None]]:
        """Unique (scene, integrator, resolution) triples, in first-seen order."""
        seen: dict = {}
        for st in self.studies:
            for sc in st.scenes:
                k = (sc, st.integrator, st.settings.resolution)
                seen.setdefault(k, None)
        return list(seen)


def freeze(v):
    if isinstance(v, list):
        return tuple(freeze(x) for x in v)
    if isinstance(v, dict):
        return tuple(sorted((k, freeze(x)) for k, x in v.items()))
    return v


def _thaw(v):
    return [_thaw(x) for x in v] if isinstance(v, tuple) else v
