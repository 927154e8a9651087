"""What the analysis hands to the report, to summary.json and to the CLI: typed results.

`analysis` builds these; `report` and `figures` read them; `Summary.to_json()` is summary.json's
content (key names and order are the file's format: changed here only). Every `to_json()` returns
plain Python values (non-finite floats stay floats; the JSON writer turns them into null).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from drtlab.experiments.error_metrics import METRICS
from drtlab.experiments.study.compare import Comparison
from drtlab.experiments.study.result_json import fields_json, from_json, to_json  # noqa: F401

NAN = float("nan")


@dataclass(frozen=True)
class Interval:
    """A mean with its 95% interval over repetitions (`sd` only where it was measured)."""
    NULLS_ARE_NAN = True        # its to_json leaves non-finite floats out (result_json.from_json)
    mean: float
    lo: float
    hi: float
    n: int
    sd: float | None = None

    @classmethod
    def of(cls, ci: dict) -> "Interval":
        """From `metrics.mean_ci`'s dict."""
        return cls(ci["mean"], ci["lo"], ci["hi"], ci["n"], ci.get("sd"))

    def to_json(self) -> dict:
        out = {"mean": self.mean, "lo": self.lo, "hi": self.hi}
        if self.sd is not None:
            out["sd"] = self.sd
        out["n"] = self.n
        return out


@dataclass(frozen=True)
class Bias:
    """Mean image - GT of a cell: signed mean with its 95% CI, debiased RMS, and the per-pixel
    variance over the repetitions."""
    signed: float
    lo: float
    hi: float
    rms: float
    pixel_variance: float
    significant: bool                   # Benjamini-Hochberg over every cell of the experiment
    p: float = NAN
    p_adjusted: float = NAN


@dataclass(frozen=True)
class MetricCell:
    """A plugin metric's view of a cell (the built-ins' are Cell fields): the root of its mean
    squared error, that mean, and 1 / (it x seconds)."""
    error: Interval
    mse: Interval
    efficiency: float


# Cell fields that summarise one number per run over the repetitions (named run_X in summary.json).
PER_RUN = ("rmse", "rmse_corrected", "mse", "mse_corrected", "relmse", "relmse_corrected", "mae",
           "ciede2000", "flip", "mean_error", "render_seconds", "compile_seconds", "wall_seconds")


@dataclass(frozen=True)
class Cell:
    """One (scene, sampler, spp) over its repetitions: every metric's mean [95% CI], and more."""
    sampler: str
    spp: int
    n: int
    rmse: Interval
    rmse_corrected: Interval
    mse: Interval
    mse_corrected: Interval
    relmse: Interval
    relmse_corrected: Interval
    mae: Interval
    ciede2000: Interval
    # Keyword-only with a default: a summary.json written before FLIP was scored still reads back.
    flip: Interval = field(default=Interval(NAN, NAN, NAN, 0), kw_only=True)
    mean_error: Interval
    render_seconds: Interval
    compile_seconds: Interval
    wall_seconds: Interval
    rmse_of_mean_mse: Interval          # sqrt of the corrected-MSE interval
    rrmse_of_mean_relmse: Interval      # sqrt of the corrected-relMSE interval
    bias: Bias
    repetitions_for_10pct: dict         # per metric: repetitions a ±10% mean (95%) would need
    seconds: float                      # cost of one repetition (the sampler's cost model)
    efficiency: float                   # 1 / (corrected MSE x seconds)
    efficiency_relmse: float            # 1 / (corrected relMSE x seconds)
    seconds_ci: Interval | None = None  # 95% CI of that cost (the model's t interval; n: batches)
    measured_seconds: float = NAN       # median render seconds of the repetitions (wall, shared)
    timing_below_resolution: bool = False   # its batches were too short: timing-only batches
    mse_rel_ci: float = NAN             # relative half-width of the 95% CI of the mean MSE
    target_rel_ci: float | None = None  # the experiment's precision target, if it sets one
    target_met: bool | None = None      # whether mse_rel_ci reached it within the budget
    samples_needed: int | None = None   # samples per pixel (runs x spp) the target would need
    resolved: bool | None = None        # its interval may carry a claim (stats/resolution.py)
    unresolved_why: str | None = None
    metrics: dict[str, MetricCell] = field(default_factory=dict)   # the plugin metrics' (error_metrics)

    def _metric(self, metric: str, i: int):
        if metric in self.metrics:               # a plugin's: read back without the plugin loaded
            return getattr(self.metrics[metric], ("error", "mse", "efficiency")[i])
        return getattr(self, METRICS[metric].cell_fields[i])

    def error(self, metric: str) -> Interval:
        return self._metric(metric, 0)

    def error_mse(self, metric: str) -> Interval:
        return self._metric(metric, 1)

    def efficiency_of(self, metric: str) -> float:
        return self._metric(metric, 2)

    @staticmethod
    def json_key(name: str) -> str:
        return f"run_{name}" if name in PER_RUN else name

    def to_json(self, metric: str | None = None) -> dict:
        """Per-run statistics are `run_X` (the mean [95% CI] over repetitions of each run's X); the
        estimator's error is `rmse_of_mean_mse` (the root of the mean MSE); with `metric` (a study's)
        also the study's view of it: `study_error`, `study_error_mse`, `study_efficiency`."""
        out = {}
        for f in fields(self):
            out[self.json_key(f.name)] = to_json(getattr(self, f.name))
            if f.name == "bias":
                out["pixel_variance"] = self.bias.pixel_variance
        if metric is not None:
            out.update(study_error=self.error(metric).to_json(),
                       study_error_mse=self.error_mse(metric).to_json(),
                       study_efficiency=self.efficiency_of(metric))
        return out


@dataclass(frozen=True)
class FitLine:
    """The fitted line and its credible band on a grid of sample counts (for plots)."""
    n: list
    median: list
    lo: list
    hi: list


@dataclass(frozen=True)
class SlopeFit:
    """The slope b of a sampler's error (error ∝ N^b) with its credible interval: of the RMSE itself
    (`slopes.fit_rmse_slope`, `estimand` "rmse"), with the typical-error slope (geometric mean of the
    runs' errors, `slopes.fit_typical_slope`) beside it. Without `ok`, only the point counts and
    `reason` are set."""
    NULLS_ARE_NAN = True        # its to_json leaves non-finite floats out (result_json.from_json)
    n_points: int
    dropped: int
    level: float
    ok: bool
    reason: str | None = None
    estimand: str | None = None
    model: str | None = None
    slope: float | None = None
    slope_lo: float | None = None
    slope_hi: float | None = None
    resolved: bool | None = None        # interval narrow enough to tell the rates apart
    model_slope_lo: float | None = None # the Gamma likelihood's own interval (slope_lo/hi: the union
    model_slope_hi: float | None = None # of it and the cell means' t-interval)
    cell_means_slope: float | None = None   # least squares of log cell-mean RMSE on log N
    cell_means_lo: float | None = None
    cell_means_hi: float | None = None
    estimates_agree: bool | None = None # the two intervals overlap
    intercept: float | None = None
    intercept_lo: float | None = None
    intercept_hi: float | None = None
    sigma: float | None = None
    ols_slope: float | None = None
    cv_slope: float | None = None
    lack_of_fit_f: float | None = None
    lack_of_fit_p: float | None = None
    floor: float | None = None
    censored: int | None = None
    at_floor: list | None = None
    saturated_cells: list | None = None # sample counts where one run carries the cell's error
    cells: list | None = None
    acceptance_fraction: float | None = None
    autocorr_time: list | None = None
    steps: int | None = None
    burn: int | None = None
    walkers: int | None = None
    effective_samples: float | None = None
    converged: bool | None = None
    seed: int | None = None
    line: FitLine | None = None
    typical_slope: float | None = None
    typical_slope_lo: float | None = None
    typical_slope_hi: float | None = None
    erratic: bool = False               # log-error scatter far above pixel noise: heavy tails

    @classmethod
    def of(cls, fit: dict, erratic_sigma: float, typical: dict | None = None) -> "SlopeFit":
        kw = {k: v for k, v in fit.items() if k != "draws"}
        if kw.get("line") is not None:
            kw["line"] = FitLine(**kw["line"])
        if typical is not None and typical.get("ok"):
            kw.update(typical_slope=typical["slope"], typical_slope_lo=typical["slope_lo"],
                      typical_slope_hi=typical["slope_hi"])
        kw["erratic"] = bool(fit.get("ok") and fit["sigma"] > erratic_sigma)
        return cls(**kw)

    def to_json(self) -> dict:
        return fields_json(self, skip_none=True)

    @property
    def stated(self) -> bool:
        """Whether the slope may be stated and drawn as a number: fitted, its interval resolved and
        its runs not heavy-tailed (a few repetitions of rare, huge errors cannot pin a rate down,
        whatever the interval says). The one rule the findings, the summary line and the figures
        follow."""
        return bool(self.ok) and self.resolved is not False and not self.erratic

    def slope_text(self, digits: int = 2) -> str:
        """'b=-0.50 [-0.51,-0.49]', or the interval alone when the slope is not `stated`."""
        ci = f"[{self.slope_lo:.{digits}f}, {self.slope_hi:.{digits}f}]"
        if self.stated:
            return f"b={self.slope:.{digits}f} {ci}"
        return f"b not resolved{' (heavy tails)' if self.erratic else ''} {ci}"

    def table_row(self) -> dict:
        return {"ok": self.ok, "slope": self.slope, "slope_lo": self.slope_lo,
                "slope_hi": self.slope_hi, "resolved": self.resolved,
                "typical_slope": self.typical_slope,
                "typical_slope_lo": self.typical_slope_lo, "typical_slope_hi": self.typical_slope_hi,
                "heavy_tailed": self.erratic, "converged": self.converged,
                "lack_of_fit_p": self.lack_of_fit_p}


@dataclass(frozen=True)
class TimeToTarget:
    """Seconds of one render reaching the target error; `how`: interpolated (its N* within the
    ladder) or extrapolated."""
    seconds: float
    how: str


@dataclass(frozen=True)
class Speed:
    """Speed against error: each sampler's time to a common target, and the speed-up that gives."""
    target_rmse: float
    target_auto: bool                   # the target is the lowest error every sampler reached
    time_to_target: dict[str, TimeToTarget]
    speedup_vs_baseline: dict[str, float]
    speedup_lo: dict[str, float] = field(default_factory=dict)    # 95% interval from draws
    speedup_hi: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class RatioCI:
    ratio: float
    lo: float
    hi: float


@dataclass(frozen=True)
class BaselineComparison:
    """A sampler against the study's baseline at one spp."""
    spp: int
    mse_ratio: RatioCI                  # baseline's squared error / this sampler's
    efficiency_ratio: float
    efficiency_ratio_lo: float = NAN    # 95% interval from draws (error and cost)
    efficiency_ratio_hi: float = NAN


@dataclass(frozen=True)
class TopEfficiency:
    """Efficiency at the largest spp a sampler has, and relative to the baseline's."""
    spp: int
    efficiency: float
    relative: float
    relative_lo: float = NAN            # 95% interval from draws (error and cost)
    relative_hi: float = NAN


@dataclass(frozen=True)
class NoiseFloor:
    """The reference's own variance against the smallest MSE measured in its scene, and what its
    subtraction leaves: the error's sd against the narrowest cell interval (analysis.NOISE_FLOOR_SHARE)."""
    gt_dir: str
    gt_spp: int
    gt_variance: float
    smallest_mse: float
    fraction_of_smallest_mse: float
    warning: bool
    correction_sd: float = NAN          # sd of the error the subtraction of gt_variance leaves
    narrowest_half_width: float = NAN   # the smallest 95% half-width of a cell's mean MSE
    share_of_half_width: float = NAN    # Z_CI x correction_sd / narrowest_half_width


@dataclass(frozen=True)
class SceneResult:
    """One scene of one study: its cells (the study's samplers and ladder), fits and comparisons."""
    scene: str                          # label
    scene_name: str
    overrides: dict
    cells: list[Cell]
    slopes: dict[str, SlopeFit]         # per sampler, fitted on the study's metric
    noise_floor: NoiseFloor
    speed: Speed
    vs_baseline: dict[str, list[BaselineComparison]]
    efficiency: dict[str, TopEfficiency]
    comparisons: list[Comparison] = field(default_factory=list)   # every (sampler, N) vs baseline
    tails: dict = field(default_factory=dict)    # sampler -> resolution.tail_shape(...)
    costs: dict = field(default_factory=dict)    # sampler -> cost_model.CostModel

    def fit(self, sampler: str) -> SlopeFit | None:
        """The sampler's slope fit when it succeeded."""
        f = self.slopes.get(sampler)
        return f if f is not None and f.ok else None

    def cell(self, sampler: str, spp: int) -> Cell | None:
        return next((c for c in self.cells if c.sampler == sampler and c.spp == spp), None)

    def row(self, sampler: str, spp: int) -> Comparison | None:
        """The comparison of `sampler` with the baseline at `spp` (claims included)."""
        return next((r for r in self.comparisons if r.sampler == sampler and r.spp == spp), None)

    def comparison(self, sampler: str, spp: int) -> BaselineComparison | None:
        return next((x for x in self.vs_baseline.get(sampler, []) if x.spp == spp), None)

    def to_json(self, metric: str) -> dict:
        return fields_json(self, cells=lambda cells: [c.to_json(metric) for c in cells])


@dataclass(frozen=True)
class StudyResult:
    name: str
    description: str
    experiment: str
    integrator: str
    samplers: list[str]
    baseline: str
    metric: str                         # key of METRICS
    metric_label: str
    mse_label: str
    spp: list[int]
    repetitions: int
    resolution: list[int] | None
    gt_spp: int
    seed: int
    strip_spp: list[int]
    scenes: list[SceneResult]
    runs_per_spp: list[int] = field(default_factory=list)   # repetitions of each cell, along `spp`
    samples_per_cell: int | None = None                      # the setting behind runs_per_spp

    @property
    def repetitions_text(self) -> str:
        """'5 repetitions per cell', or with equal samples per cell the runs along the ladder."""
        runs = self.runs_per_spp or [self.repetitions] * len(self.spp)
        if len(set(runs)) == 1:
            return f"{runs[0]} repetitions per cell"
        return f"{'/'.join(map(str, runs))} repetitions at N = {'/'.join(map(str, self.spp))}"

    def to_json(self) -> dict:
        return fields_json(self, scenes=lambda scenes: [scene.to_json(self.metric) for scene in scenes])


@dataclass(frozen=True)
class ChainDiagnostics:
    """The emcee chains of every slope fit of the experiment."""
    fits: int
    converged: int
    not_converged: list[str]
    acceptance_fraction_range: list[float]
    max_autocorr_time: float


@dataclass(frozen=True)
class Summary:
    """Everything summary.json holds."""
    experiment: str
    description: str
    profile: str
    studies: list[StudyResult]
    noise_floor: dict[str, NoiseFloor]  # per (scene, integrator, resolution) group name
    warnings: list[str]
    chains: ChainDiagnostics
    ground_truth: dict[str, dict] = field(default_factory=dict)   # the runner's reference info
    load: dict = field(default_factory=dict)    # cost_model.load_shift over the sweep's batches

    def to_json(self) -> dict:
        return fields_json(self)

    @classmethod
    def from_json(cls, data: dict) -> "Summary":
        """summary.json's content back as a Summary. Its scenes' `costs` stay the plain dicts
        CostModel.to_json wrote: without the covariance it leaves out, no interval can be drawn."""
        return from_json(cls, data)
