"""The error metrics a study can rank samplers by: one module per metric, each registered here the
way a user's plugin registers its own (`drtlab.register_metric`, docs/plugins.md).

A metric is a mean of squared errors over the pixels, with the reference's own noise removed (so its
expectation is the estimator's, and under independent sampling it falls as 1/N): the study's
intervals, slopes (of its square root), MSE ratios, efficiencies and speed-ups then mean for it what
they mean for the MSE. The built-ins (`mse`, `relmse`) come from the one pass over the pixels of
`kernels/error_sums.py`; a plugin's from its `per_run` function, on each batch of images."""
from drtlab.experiments.error_metrics.base import (  # noqa: F401
    METRICS, ErrorMetric, check_name, plugin_metrics, record_key, register, register_metric)
from drtlab.experiments.error_metrics import mse, relmse  # noqa: F401,E402  (the built-ins register)
