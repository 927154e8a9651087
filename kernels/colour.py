"""Luminance of linear sRGB / Rec. 709 radiance (ITU-R BT.709 Y weights), for light power."""
import numpy as np

REC709_Y = (0.2126, 0.7152, 0.0722)


def luminance(rgb) -> np.ndarray | float:
    """Y of linear RGB values, shape (..., 3) -> (...)."""
    c = np.asarray(rgb, dtype=np.float64)
    return REC709_Y[0] * c[..., 0] + REC709_Y[1] * c[..., 1] + REC709_Y[2] * c[..., 2]
