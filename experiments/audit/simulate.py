"""Synthetic studies with a known truth, shaped like the default study: one scene, a baseline sampler
against one other, ladder N = 1, 4, 16, 64 with 320 / 80 / 20 / 5 runs, 96 x 72 pixels, batches cut
(`plan.batch_ranges`) and interleaved in time (cells take turns, `zip_longest`) as the runner does.

Truth of a sampler: mean MSE at N is A N^(2b) (RMSE slope b); a run's MSE is that mean times X with
E[X] = 1 drawn from the setting's law. A batch of `reps` repetitions takes

    (CALL + reps (PER_REP + c N pixels)) x noise,   log noise ~ Normal(-sd^2 / 2, sd),

with sd drawn per study in NOISE_SD: the noise has mean 1, so the true cost of one repetition is
PER_REP + c N pixels + CALL x its share of a call exactly (the cost model fits a mean, not a median;
the share is `cost_model.call_share` over the runner's batches, DESIGN). A load-step setting
multiplies every batch after the middle of the sweep (in batch order) by LOAD_STEP, both samplers
alike; the truth is the unloaded cost. Each sampler's batches also share a process factor
(log-normal, sd PROCESS_SD, mean 1): the speed of one run's process against the machine's, which
its batches cannot see.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import zip_longest

import numpy as np

from drtlab.experiments.stats.cost_model import PROCESS_SD, call_share
from drtlab.experiments.study.plan import batch_ranges

PIXELS = 96 * 72
RUNS = {1: 320, 4: 80, 16: 20, 64: 5}       # runs per N, as the default study
LADDER = tuple(RUNS)
BASELINE, OTHER = "baseline", "other"
BASELINE_SLOPE = -0.5
SCALE = 1e-2                                 # mean MSE at N = 1 of both samplers
CALL, PER_REP = 3e-3, 5e-4                   # seconds per call, per repetition
PER_SAMPLE = {BASELINE: 150e-9, OTHER: 170e-9}
NOISE_SD = (0.02, 0.10)                      # range of a study's timing noise (log sd)
LOAD_STEP = 1.3


# Per sample count of the ladder, the mean 1/reps of the runner's batches: the design every
# simulated cost model is fitted on, which defines a repetition's share of a call.
DESIGN = tuple((n * PIXELS, float(np.mean([1.0 / (b - a) for a, b in batch_ranges(k, PIXELS, n)])))
               for n, k in RUNS.items())


def _gamma(cv: float):
    return lambda rng, k: rng.gamma(1.0 / cv ** 2, cv ** 2, size=k)


def _lognormal(sigma: float):
    return lambda rng, k: rng.lognormal(-0.5 * sigma ** 2, sigma, size=k)


def _pareto(alpha: float):
    # numpy's pareto is the Lomax law; (1 + it) x_m is Pareto's, mean alpha x_m / (alpha - 1) = 1.
    return lambda rng, k: (alpha - 1.0) / alpha * (1.0 + rng.pareto(alpha, size=k))


# name -> (draws of X with mean 1, heavy-tailed, words). "Heavy" is the truth of the law, used to
# choose the pass criterion; the analysis decides resolution from the runs alone.
LAWS = {
    "gamma0.05": (_gamma(0.05), False, "gamma, CV 0.05 (real renders: 0.02-0.07)"),
    "gamma0.3": (_gamma(0.3), False, "gamma, CV 0.3"),
    "lognormal1": (_lognormal(1.0), True, "log-normal, sigma 1"),
    "pareto2.5": (_pareto(2.5), True, "Pareto, alpha 2.5 (finite variance)"),
}


@dataclass(frozen=True)
class Setting:
    name: str
    law: str
    slope: float            # the other sampler's RMSE slope
    load_step: bool = False

    @property
    def equal(self) -> bool:
        """The two samplers are equal in truth (same law, scale and cost): any claim is false."""
        return self.slope == BASELINE_SLOPE

    @property
    def heavy(self) -> bool:
        return LAWS[self.law][1]

    @property
    def description(self) -> str:
        law = LAWS[self.law][2]
        other = "equal samplers" if self.equal else f"other sampler's slope {self.slope:g}"
        step = f"; load x{LOAD_STEP:g} after mid-sweep" if self.load_step else ""
        return f"{law}; {other}{step}"


SETTINGS = {s.name: s for s in (
    Setting("light-equal", "gamma0.05", -0.5),
    Setting("light-s0.75", "gamma0.05", -0.75),
    Setting("light-s1", "gamma0.05", -1.0),
    Setting("gamma0.3-equal", "gamma0.3", -0.5),
    Setting("gamma0.3-s0.75", "gamma0.3", -0.75),
    Setting("lognormal-equal", "lognormal1", -0.5),
    Setting("lognormal-s0.75", "lognormal1", -0.75),
    Setting("pareto-equal", "pareto2.5", -0.5),
    Setting("pareto-s0.75", "pareto2.5", -0.75),
    Setting("load-step-equal", "gamma0.05", -0.5, load_step=True),
)}


@dataclass(frozen=True)
class SamplerTruth:
    scale: float             # mean MSE at N = 1
    slope: float             # RMSE slope b: mean MSE = scale N^(2b)
    per_rep: float
    per_sample: float

    def mse(self, n: float) -> float:
        return self.scale * n ** (2 * self.slope)

    def work_seconds(self, n: float, pixels: int = PIXELS) -> float:
        """Seconds of one repetition's own work (per repetition + per sample), without the call."""
        return self.per_rep + self.per_sample * n * pixels

    def seconds(self, n: float, pixels: int = PIXELS) -> float:
        """Cost of one repetition at N samples per pixel as the study renders it: with its share of
        its batch's call (cost_model.call_share over the runner's batches of the ladder)."""
        return self.work_seconds(n, pixels) + CALL * float(call_share(n * pixels, DESIGN)[0])

    def seconds_to(self, target_rmse: float, pixels: int = PIXELS) -> float:
        """Cost of one render that reaches `target_rmse` (N* from the true law, not rounded)."""
        n = (target_rmse / math.sqrt(self.scale)) ** (1.0 / self.slope)
        return self.seconds(n, pixels)


@dataclass(frozen=True)
class Truth:
    base: SamplerTruth
    other: SamplerTruth

    def mse_ratio(self, n: float) -> float:
        return self.base.mse(n) / self.other.mse(n)

    def efficiency(self, n: float) -> float:
        return self.mse_ratio(n) * self.base.seconds(n) / self.other.seconds(n)

    def speedup(self, target_rmse: float) -> float:
        if not (target_rmse > 0 and math.isfinite(target_rmse)):
            return float("nan")
        return self.base.seconds_to(target_rmse) / self.other.seconds_to(target_rmse)

    def of(self, sampler: str) -> SamplerTruth:
        return self.base if sampler == BASELINE else self.other


@dataclass
class Study:
    runs: dict               # columns sampler, spp, value
    batches: dict            # columns sampler, spp, seconds, reps, time
    truth: Truth
    noise_sd: float
    step_after: int | None   # batches with a larger `time` carry the load step


def truth_of(setting: Setting) -> Truth:
    equal = setting.equal
    return Truth(SamplerTruth(SCALE, BASELINE_SLOPE, PER_REP, PER_SAMPLE[BASELINE]),
                 SamplerTruth(SCALE, setting.slope, PER_REP,
                              PER_SAMPLE[BASELINE if equal else OTHER]))


def simulate_study(setting: Setting, rng: np.random.Generator) -> Study:
    """One study of `setting` drawn with `rng`."""
    truth = truth_of(setting)
    draw = LAWS[setting.law][0]
    noise_sd = float(rng.uniform(*NOISE_SD))
    runs = {"sampler": [], "spp": [], "value": []}
    per_cell = []                        # cells in the runner's order: sampler-major, then N
    for s in (BASELINE, OTHER):
        t = truth.of(s)
        for n, k in RUNS.items():
            runs["sampler"] += [s] * k
            runs["spp"] += [n] * k
            runs["value"] += list(t.mse(n) * draw(rng, k))
            per_cell.append([(s, n, b - a) for a, b in batch_ranges(k, PIXELS, n)])
    order = [b for turn in zip_longest(*per_cell) for b in turn if b is not None]
    # Each sampler's speed in this process (cost_model.PROCESS_SD): the truth is the machine's.
    process = {s: rng.lognormal(-0.5 * PROCESS_SD ** 2, PROCESS_SD) for s in (BASELINE, OTHER)}
    step_after = len(order) // 2 if setting.load_step else None
    batches = {"sampler": [], "spp": [], "seconds": [], "reps": [], "time": []}
    for i, (s, n, reps) in enumerate(order, start=1):
        t = truth.of(s)
        sec = (CALL + reps * t.work_seconds(n)) * rng.lognormal(-0.5 * noise_sd ** 2, noise_sd) * process[s]
        if step_after is not None and i > step_after:
            sec *= LOAD_STEP
        for key, v in zip(batches, (s, n, sec, reps, i)):
            batches[key].append(v)
    return Study(runs, batches, truth, noise_sd, step_after)
