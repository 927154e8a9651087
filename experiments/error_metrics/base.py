"""One interface for every error metric, and the registry the built-ins and plugins share."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from drtlab.errors import InputError

PLUGIN_PREFIX = "metric:"        # a plugin metric's column in runs.parquet / runs.csv


@dataclass(frozen=True)
class ErrorMetric:
    """A study's error: per run, a mean of squared errors with the reference's noise removed.

    `per_run(images, reference, reference_stderr)`: (R, H, W, 3), (H, W, 3), (H, W, 3) float64 arrays
    -> R finite values, one per image (a plugin's; None for the built-ins, which `error_sums` scores).
    `cell_fields`: the built-ins' Cell fields (error interval, squared-error interval, efficiency);
    a plugin's live in `Cell.metrics[name]`. `fingerprint`: its source's hash (plugins: a changed
    metric re-renders the runs it scores)."""
    name: str
    description: str
    label: str                   # the error, as reports print it (the root of the squared error)
    mse_label: str               # the squared error
    per_run: Callable | None = None
    cell_fields: tuple | None = None
    fingerprint: str = ""

    @property
    def record(self) -> str:
        """The run record's key of its squared error (noise floor removed)."""
        return self.cell_fields[1] if self.per_run is None else PLUGIN_PREFIX + self.name

    def score(self, images: np.ndarray, reference: np.ndarray, stderr: np.ndarray) -> list[float]:
        """A plugin metric's value of each image of a batch; one line naming the metric where its
        function fails or returns other than one finite value per image."""
        try:
            v = np.asarray(self.per_run(images, reference, stderr), dtype=np.float64)
        except Exception as e:                           # noqa: BLE001 - the user's code: one line
            raise InputError(f"metric {self.name}", f"its per_run raised {type(e).__name__}: {e}") from None
        n = np.shape(images)[0]
        if v.shape != (n,) or not np.all(np.isfinite(v)):
            raise InputError(f"metric {self.name}", f"per_run must return {n} finite values (one per "
                                                    f"image), got shape {v.shape}" +
                             ("" if v.shape != (n,) else f" with {int(np.sum(~np.isfinite(v)))} non-finite"))
        return [float(x) for x in v]


METRICS: dict[str, ErrorMetric] = {}
BUILT_IN = ("mse", "relmse")             # their modules register them (error_metrics/__init__.py)


def register(metric: ErrorMetric) -> ErrorMetric:
    METRICS[metric.name] = metric
    return metric


def record_key(name: str) -> str:
    return METRICS[name].record


def plugin_metrics(names) -> list[ErrorMetric]:
    """The metrics among `names` that a plugin computes (the runner scores them per batch)."""
    return [METRICS[n] for n in dict.fromkeys(names) if n in METRICS and METRICS[n].per_run is not None]


def check_name(name, field: str) -> str:
    """`name` if a registered metric (an installed package's plugins are loaded on a miss), else
    InputError naming `field` and the allowed values."""
    if name not in METRICS:
        from drtlab.estimators.plugins import load_entry_points
        load_entry_points()
    if name not in METRICS:
        raise InputError(field, f"must be one of {', '.join(METRICS)}, got {name!r}")
    return name


def register_metric(name: str, per_run: Callable, description: str = "", label: str | None = None,
                    mse_label: str | None = None) -> ErrorMetric:
    """Register a user's error metric (`drtlab.register_metric`, docs/plugins.md): `per_run(images,
    reference, reference_stderr)` -> one mean squared error per image, the reference's noise removed.
    Checked at once on a small batch: it must return one finite value per image, and 0 for images
    equal to a noiseless reference (it measures an error). Its name must not be a built-in's."""
    from drtlab.estimators.plugins import NAME, attribute
    who = f"register_metric {name!r}"
    if not isinstance(name, str) or not NAME.match(name):
        raise InputError(who, "a metric's name is lower-case letters, digits, - and _ (at most 40, "
                              f"starting with a letter), got {name!r}")
    if name in METRICS and METRICS[name].per_run is None:
        raise InputError(who, f"'{name}' is a built-in metric ({', '.join(BUILT_IN)}); give yours another name")
    if not callable(per_run):
        raise InputError(who, f"per_run must be a function (images, reference, reference_stderr), "
                              f"got {type(per_run).__name__}")
    who, fp = attribute("metric", name, per_run)
    metric = ErrorMetric(name=name, description=str(description), label=label or f"√{name}",
                         mse_label=mse_label or name, per_run=per_run, fingerprint=fp)
    rng = np.random.default_rng(0)
    reference = rng.uniform(0.1, 1.0, (6, 8, 3))
    images = reference[None] + np.stack([np.zeros_like(reference), 0.1 * rng.standard_normal(reference.shape)])
    try:
        values = metric.score(images, reference, np.zeros_like(reference))
    except InputError as e:
        raise InputError(who, e.message) from None
    if abs(values[0]) > 1e-9 or not values[1] > 0:
        raise InputError(who, f"per_run must measure an error: 0 for an image equal to a noiseless "
                              f"reference and > 0 for a noisy one, got {values[0]!r} and {values[1]!r}")
    return register(metric)

