"""What `run_experiment` returns, and the same object read back from a finished results folder
(`open_results`, `drtlab.open_results`): the typed summary, its tables as pandas DataFrames, and
its figures redrawn from it, with nothing rendered or analysed again.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

from drtlab.errors import InputError
from drtlab.experiments.study.results import StudyResult, Summary

# `result.comparisons`'s columns after study, scene, sampler, baseline, spp (Comparison's fields).
COMPARISON_COLUMNS = ("mse_ratio", "mse_ratio_lo", "mse_ratio_hi", "efficiency", "efficiency_lo",
                      "efficiency_hi", "speedup", "speedup_lo", "speedup_hi", "resolved", "claim",
                      "claim_on", "p_adjusted", "mse_claim", "speedup_resolved", "extrapolated",
                      "target_rmse", "why")


@dataclass
class ExperimentResult:
    """What `run_experiment` returns: the run counts, the wall time, the summary (None when the
    sweep ran without analysis) and the output folder. Indexing it reads summary.json's content
    (`result["studies"]`); `runs`, `cells`, `slopes` and `comparisons` are tidy pandas DataFrames,
    and `plot_convergence()` redraws the error-vs-samples figures."""
    stats: dict                         # runs_planned, runs_new, runs_reused, batches, rows, ...
    wall_seconds: float
    summary: Summary | None = None
    out_dir: Path | None = None

    def __getitem__(self, key: str):
        if self.summary is None:
            raise KeyError(key)
        return self.summary.to_json()[key]

    def _studies(self) -> list[StudyResult]:
        if self.summary is None:
            raise ValueError("the experiment ran without analysis (analyze=False): no cells or slopes")
        return self.summary.studies

    @property
    def runs(self):
        """One row per run (runs.parquet): scene, sampler, spp, rep, seed, per-run errors, timings."""
        import pandas as pd
        return pd.read_parquet(Path(self.out_dir) / "runs.parquet")

    @property
    def cells(self):
        """One row per (study, scene, sampler, spp): the estimator's RMSE (root of the mean MSE over
        repetitions) with its interval, the mean per-run RMSE, bias, median seconds, efficiency."""
        import pandas as pd
        rows = []
        for study in self._studies():
            for scene in study.scenes:
                for c in scene.cells:
                    err = c.error(study.metric)
                    rows.append({"study": study.name, "scene": scene.scene, "sampler": c.sampler,
                                 "spp": c.spp, "repetitions": c.n, "metric": study.metric,
                                 "error": err.mean, "error_lo": err.lo, "error_hi": err.hi,
                                 "rmse_of_mean_mse": c.rmse_of_mean_mse.mean,
                                 "mean_run_rmse": c.rmse.mean, "bias": c.bias.signed,
                                 "bias_significant": c.bias.significant, "seconds": c.seconds,
                                 "efficiency": c.efficiency_of(study.metric),
                                 "mse_rel_ci": c.mse_rel_ci, "target_met": c.target_met,
                                 "samples_needed": c.samples_needed})
        return pd.DataFrame(rows)

    @property
    def slopes(self):
        """One row per (study, scene, sampler): the fitted slope b (error ∝ N^b) and its interval."""
        import pandas as pd
        rows = [{"study": study.name, "scene": scene.scene, "sampler": sampler, **fit.table_row()}
                for study in self._studies() for scene in study.scenes
                for sampler, fit in scene.slopes.items()]
        return pd.DataFrame(rows)

    @property
    def comparisons(self):
        """One row per (study, scene, sampler, spp), each sampler but the baseline against it at N:
        the MSE ratio (baseline's over the sampler's), the efficiency ratio (1/(MSE x seconds), the
        sampler's over the baseline's) and the speed-up (the baseline's time over the sampler's to
        reach the same error), each with its 95% interval; above 1 the sampler is better. `claim`
        (better / worse / no difference) is made by resolved comparisons only, Benjamini-Hochberg
        over the report's tests, on the speed-up where `speedup_resolved` else on the efficiency
        (`claim_on`); the others say "not resolved" and `why`."""
        import pandas as pd
        rows = [{"study": study.name, "scene": scene.scene, "sampler": r.sampler,
                 "baseline": r.baseline, "spp": r.spp, **{k: getattr(r, k) for k in COMPARISON_COLUMNS}}
                for study in self._studies() for scene in study.scenes for r in scene.comparisons]
        return pd.DataFrame(rows, columns=["study", "scene", "sampler", "baseline", "spp",
                                           *COMPARISON_COLUMNS])

    def plot_convergence(self, study: str | None = None):
        """The error-vs-samples figure of one study (by name; default the first) as a matplotlib
        Figure, drawn from the results alone (no renders)."""
        from drtlab.experiments.study.figures import plot_error_vs_spp
        studies = self._studies()
        chosen = next((s for s in studies if s.name == study), None) if study else studies[0]
        if chosen is None:
            raise ValueError(f"no study {study!r}; studies: {', '.join(s.name for s in studies)}")
        return plot_error_vs_spp(chosen)


def open_results(path) -> ExperimentResult:
    """A finished results folder (what `drtlab experiment` wrote; its summary.json also does) as
    the ExperimentResult its run returned: the summary rebuilt from summary.json, runs.parquet read
    when asked for, the run counts and wall time from manifest.json where there is one. Renders
    and analyses nothing; raises InputError naming `path` when it is no readable results folder."""
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise InputError("path", f"must be a results folder `drtlab experiment` wrote (a str or "
                                 f"os.PathLike, e.g. 'results/stratified'), got {path!r}")
    folder = Path(path)
    if folder.name == "summary.json" and folder.is_file():
        folder = folder.parent
    where = str(path)
    if not folder.exists():
        raise InputError(where, "no such folder: give a results folder `drtlab experiment` wrote "
                                "(e.g. results/stratified)")
    if not folder.is_dir():
        raise InputError(where, "not a folder: give a results folder `drtlab experiment` wrote "
                                "(the one holding summary.json)")
    if not (folder / "summary.json").is_file():
        raise InputError(where, "not a results folder: it has no summary.json (the analysis of "
                                "`drtlab experiment NAME` writes it)")
    try:
        data = json.loads((folder / "summary.json").read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise InputError(where, f"summary.json does not parse: {_one_line(e)}") from None
    try:
        summary = Summary.from_json(data)
    except (ValueError, TypeError, KeyError, AttributeError) as e:
        name = data.get("experiment", "NAME") if isinstance(data, dict) else "NAME"
        raise InputError(where, f"summary.json was written by an incompatible drtlab version "
                                f"({_one_line(e)}); `drtlab experiment {name}` re-analyses its "
                                f"stored runs and rewrites it") from None
    manifest = _manifest(folder)
    wall = manifest.get("wall_seconds")
    wall = wall.get("this_invocation") if isinstance(wall, dict) else wall
    return ExperimentResult(stats=manifest.get("runs") or {},
                            wall_seconds=float(wall) if wall is not None else math.nan,
                            summary=summary, out_dir=folder)


def _manifest(folder: Path) -> dict:
    # The manifest only adds run counts and timings: a folder without a readable one still opens.
    try:
        m = json.loads((folder / "manifest.json").read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return {}
    return m if isinstance(m, dict) else {}


def _one_line(e: Exception) -> str:
    return " ".join(str(e).split())
