"""An error metric of your own: the MSE on the reference's edges only (the 10% of pixels with the
steepest luminance gradient), where anti-aliasing and soft-shadow penumbrae live and where
stratification acts; the whole-image MSE dilutes it with flat regions.

    drtlab experiment compare.toml       (its third study ranks samplers by `metric = "edge-mse"`)

A metric is a mean of squared errors per image with the reference's own noise removed, so that its
expectation is the estimator's: the study's intervals, slopes, efficiencies and speed-ups then mean
for it what they mean for the MSE."""
import numpy as np

import drtlab

EDGE_FRACTION = 0.1
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])     # Rec. 709


def edge_mask(reference: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels whose luminance gradient lies in the top EDGE_FRACTION."""
    gy, gx = np.gradient(reference @ LUMINANCE)
    g = np.hypot(gx, gy)
    return g >= np.quantile(g, 1.0 - EDGE_FRACTION)


def edge_mse(images: np.ndarray, reference: np.ndarray, reference_stderr: np.ndarray) -> np.ndarray:
    """Per image of an (R, H, W, 3) batch: the MSE over the edge pixels, less the reference's own
    variance there (E[(X - G)^2] = E[(X - mu)^2] + Var G for a reference G independent of X)."""
    mask = edge_mask(reference)
    d = images[:, mask] - reference[mask]
    return np.mean(d * d, axis=(1, 2)) - np.mean(np.square(reference_stderr[mask]))


drtlab.register_metric("edge-mse", edge_mse, description="MSE on the reference's edges (top 10% gradient)",
                       label="edge RMSE", mse_label="edge MSE")
