"""Relative MSE, (x - y)^2 / (y^2 + error_sums.REL_EPS): for scenes whose MSE is carried by a few very
bright pixels (small lights seen directly), where it weighs every pixel by its own brightness."""
from drtlab.experiments.error_metrics.base import ErrorMetric, register

register(ErrorMetric(
    name="relmse", label="relative RMSE (√relMSE)", mse_label="relMSE",
    description="relative squared error (x - y)^2 / (y^2 + eps), the reference's noise removed",
    cell_fields=("rrmse_of_mean_relmse", "relmse_corrected", "efficiency_relmse")))
