"""Colour of linear sRGB / Rec. 709 radiance: luminance (ITU-R BT.709 Y weights, for light power), the
sRGB encoding of what a display shows (previews, image strips) and its inverse (8-bit files read
back), and the displayed image in CIELAB (colour differences). colour-science is imported only by
to_srgb and to_lab: it is slow to load."""
import numpy as np

REC709_Y = (0.2126, 0.7152, 0.0722)


def luminance(rgb) -> np.ndarray | float:
    """Y of linear RGB values, shape (..., 3) -> (...)."""
    c = np.asarray(rgb, dtype=np.float64)
    return REC709_Y[0] * c[..., 0] + REC709_Y[1] * c[..., 1] + REC709_Y[2] * c[..., 2]


def displayed(image: np.ndarray) -> np.ndarray:
    """Linear radiance as a display shows it: float64 in [0, 1], NaN as 0 and +Inf as 1."""
    linear = np.nan_to_num(np.asarray(image, dtype=np.float64), nan=0.0, posinf=1.0)
    return np.clip(linear, 0.0, 1.0)


def to_srgb(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> display sRGB in [0, 1] (`displayed`, then the IEC 61966-2-1 transfer)."""
    import colour
    return colour.cctf_encoding(displayed(image), function="sRGB")


def srgb_to_linear(codes: np.ndarray) -> np.ndarray:
    """sRGB display values in [0, 1] (an 8-bit file's codes / 255) -> linear values, by the inverse
    IEC 61966-2-1 transfer; the dtype is kept (float32 pixels stay float32)."""
    return np.where(codes <= 0.04045, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)


def to_lab(image: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of the displayed image, the space in which CIEDE2000 compares colours."""
    import colour
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    xyz = colour.RGB_to_XYZ(displayed(image), colour.RGB_COLOURSPACES["sRGB"], illuminant=d65,
                            apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, d65)
