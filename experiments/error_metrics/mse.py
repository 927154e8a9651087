"""MSE over pixels and channels, reported as its root (RMSE): the error of the variance theory."""
from drtlab.experiments.error_metrics.base import ErrorMetric, register

register(ErrorMetric(
    name="mse", label="RMSE", mse_label="MSE",
    description="mean squared error over pixels and channels, the reference's noise removed",
    cell_fields=("rmse_of_mean_mse", "mse_corrected", "efficiency")))
