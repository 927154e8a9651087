"""drtlab: Monte Carlo estimator variance studies for distribution ray tracing.

The top-level folders are mapped under this package: `drtlab.estimators`, `drtlab.kernels`,
`drtlab.experiments` (see pyproject.toml).
"""
import warp as _warp

# Warp's banner and missing-driver notice would precede every CLI line; keep the output ours.
if hasattr(_warp, "LOG_ERROR"):
    _warp.config.log_level = _warp.LOG_ERROR
else:  # Warp < 1.19
    _warp.config.quiet = True

__version__ = "0.1.0"


def render(*args, **kwargs):
    """`drtlab.kernels.render.render`: (H, W, 3) float64 linear radiance of a scene."""
    from drtlab.kernels.render import render as _render
    return _render(*args, **kwargs)
