"""Colour of linear sRGB / Rec. 709 radiance: luminance (ITU-R BT.709 Y weights, for light power), the
sRGB encoding of what a display shows (previews, image strips) and its inverse (8-bit files read
back), and the displayed image in CIELAB (colour differences). colour-science is imported only by
to_lab: `import colour` takes ~2 s (its `__init__` loads colour.plotting, matplotlib and scipy), more
than a small render, so the sRGB transfer every PNG needs is written out here, and
tests/kernels/test_colour.py checks it bit for bit against colour-science's on a dense grid."""
import numpy as np

# IEC 61966-2-1's linear sRGB -> CIE XYZ matrix (D65, no adaptation), as colour-science's sRGB
# colourspace holds it, and the D65 white point's xy chromaticity (CIE 1931 2 degree observer):
# tests/kernels/test_colour.py checks both against colour-science's values exactly.
SRGB_TO_XYZ = ((0.4124, 0.3576, 0.1805),
               (0.2126, 0.7152, 0.0722),
               (0.0193, 0.1192, 0.9505))
D65_XY = (0.3127, 0.329)
D65_XYZ = (D65_XY[0] / D65_XY[1], 1.0, (1.0 - D65_XY[0] - D65_XY[1]) / D65_XY[1])
REC709_Y = SRGB_TO_XYZ[1]           # luminance: the Y row of the same matrix


def luminance(rgb) -> np.ndarray | float:
    """Y of linear RGB values, shape (..., 3) -> (...)."""
    c = np.asarray(rgb, dtype=np.float64)
    return REC709_Y[0] * c[..., 0] + REC709_Y[1] * c[..., 1] + REC709_Y[2] * c[..., 2]


def displayed(image: np.ndarray) -> np.ndarray:
    """Linear radiance as a display shows it: float64 in [0, 1], NaN as 0 and +Inf as 1."""
    linear = np.nan_to_num(np.asarray(image, dtype=np.float64), nan=0.0, posinf=1.0)
    return np.clip(linear, 0.0, 1.0)


def to_srgb(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> display sRGB in [0, 1] (`displayed`, then the IEC 61966-2-1 transfer):
    colour.cctf_encoding(..., function="sRGB"), the same operations in the same order."""
    return _encode(displayed(image))


# Where IEC 61966-2-1's linear segment ends, in linear values and (as colour-science takes it) in
# display values.
_KNEE = 0.0031308


def _encode(linear: np.ndarray) -> np.ndarray:
    return np.where(linear <= _KNEE, linear * 12.92, 1.055 * linear ** (1 / 2.4) - 0.055)


_KNEE_DISPLAYED = float(_encode(_KNEE))


def srgb_to_linear(codes: np.ndarray) -> np.ndarray:
    """sRGB display values in [0, 1] (an 8-bit file's codes / 255) -> linear values, by the inverse
    IEC 61966-2-1 transfer; the dtype is kept (float32 pixels stay float32)."""
    return np.where(codes <= _KNEE_DISPLAYED, codes / 12.92, ((codes + 0.055) / 1.055) ** 2.4)


def to_lab(image: np.ndarray) -> np.ndarray:
    """CIELAB (D65) of the displayed image, the space in which CIEDE2000 compares colours."""
    import colour
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    xyz = colour.RGB_to_XYZ(displayed(image), colour.RGB_COLOURSPACES["sRGB"], illuminant=d65,
                            apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, d65)
