"""How a cell grows past its planned repetitions: a precision target (`target_rel_ci`: double the
runs until the 95% interval of its mean error is within the target or `max_samples_per_cell` is
spent) and unresolved cells (`max_seconds`: double the runs of a cell its own runs do not resolve,
within the study's render-second budget). A mixin of the sweep (runner._Sweep): it reads the
sweep's plan and records and returns the new runs' batches (`_batches`)."""
from __future__ import annotations

import numpy as np

from drtlab.experiments.error_metrics import record_key
from drtlab.experiments.seeds import run_seed
from drtlab.experiments.stats.intervals import repetitions_for_precision
from drtlab.experiments.study.plan import RunSpec, batch_ranges


class CellGrowth:
    def _targeted(self, cells: dict) -> bool:
        return any(getattr(self._settings(cruns[0]), "target_rel_ci", None) for cruns in cells.values())

    def _grow(self, cell: str, cruns: list[RunSpec], gt) -> list | None:
        """The batches of a precision-targeted cell's next repetitions (those not stored yet), or None
        when its target is met or its budget spent (recorded in `targets`)."""
        settings = self._settings(cruns[0])
        target = getattr(settings, "target_rel_ci", None)
        if not target:
            return None
        have = [r for r in self.plan if r.cell == cell]
        study = self.studies[cruns[0].studies[0]]
        key = record_key(study.metric)
        values = [self.records[r.run_id][key] for r in have if r.run_id in self.records]
        prec = repetitions_for_precision(values, target)
        budget = settings.max_runs_at(cruns[0].spp)
        met = bool(prec["enough"])
        self.targets[cell] = {"target_rel_ci": target, "mse_rel_ci": prec["current_rel_halfwidth"],
                              "target_met": met, "runs": len(have), "max_runs": budget,
                              "runs_needed": prec["repetitions"]}
        if met or len(have) >= budget:
            return None
        self.stats["runs_added_for_precision"] += min(2 * len(have), budget) - len(have)
        return self._extend(cell, cruns, gt, study, have, min(2 * len(have), budget))

    def _extend(self, cell: str, cruns: list[RunSpec], gt, study, have: list, new_n: int) -> list:
        """The plan grown by a cell's repetitions len(have)..new_n, and their batches."""
        r0 = cruns[0]
        extra = [RunSpec(r0.scene, r0.sampler, r0.integrator, r0.resolution, r0.spp, rep,
                         run_seed(study.seed, r0.scene.key, r0.sampler, r0.integrator, r0.resolution,
                                  r0.spp, rep), r0.studies)
                 for rep in range(len(have), new_n)]
        self.plan.extend(extra)
        pixels = r0.resolution[0] * r0.resolution[1]
        self.bar.add_work(sum(r.spp * pixels for r in extra), len(extra))
        return self._batches(cell, have + extra, gt, batch_ranges(new_n, pixels, r0.spp, start=len(have)))

    def _resolve(self, cell: str, cruns: list[RunSpec], gt, spent: dict) -> list | None:
        """The batches that double an unresolved cell's repetitions (within `max_samples_per_cell`
        and the study's `max_seconds`, of which each scene gets its share), or None. Unresolved here
        means by the cell's own runs (resolution.cell_resolution without the sampler's tail: more
        runs do not lighten a heavy tail)."""
        from drtlab.experiments.stats.intervals import positive_mean_ci
        from drtlab.experiments.stats.resolution import cell_resolution
        study = self.studies[cruns[0].studies[0]]
        settings = self._settings(cruns[0])
        budget = getattr(settings, "max_seconds", None)
        if not budget:
            return None
        have = [r for r in self.plan if r.cell == cell]
        recs = [self.records[r.run_id] for r in have if r.run_id in self.records]
        values = [rec[record_key(study.metric)] for rec in recs]
        if not recs or cell_resolution(values, positive_mean_ci(values)["lo"])[0]:
            return None
        per_rep = float(np.mean([rec["render_seconds"] for rec in recs]))
        new_n = min(2 * len(have), settings.max_runs_at(cruns[0].spp))
        cost = per_rep * (new_n - len(have))
        share = budget / max(1, len(study.scenes))
        if new_n <= len(have) or spent.get(study.name, 0.0) + cost > share:
            return None
        spent[study.name] = spent.get(study.name, 0.0) + cost
        self.stats["runs_added_for_resolution"] += new_n - len(have)
        return self._extend(cell, cruns, gt, study, have, new_n)
