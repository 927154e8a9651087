"""A Mitsuba `<spectrum>` as the RGB colour Mitsuba 3's RGB variants make of it
(Properties::get_texture_impl in src/core/properties.cpp, spectrum_list_to_srgb in
src/core/spectrum.cpp).

- Uniform (one value v): a reflectance or other bounded quantity is v in every channel; an emitter's
  is v times xyz_to_srgb(1, 1, 1), the slightly purple RGB of a flat spectrum under sRGB's D65 white
  (so that RGB variants match spectral ones).
- Wavelength:value pairs: the piecewise-linear spectrum (zero outside its first and last wavelength)
  times the CIE 1931 2-degree matching functions (their 5 nm table, 360-830 nm, interpolated
  linearly), and for anything but an emitter also times the CIE D65 illuminant, summed at 1000
  evenly spaced wavelengths over 360-830 nm and scaled so that a unit spectrum has luminance 1; then
  XYZ -> linear sRGB; negative channels clamp to 0, and a bounded quantity's channels to at most 1.

The tables come from colour-science (imported only when a file has such a spectrum). colour-science's
D65 ends at 780 nm; its constant extension to 830 nm moves a colour by under 1e-6 (the matching
functions are below 2e-4 there). The XYZ -> sRGB matrix is the inverse of kernels/colour.py's
(IEC 61966-2-1); Mitsuba's BT.709 matrix differs from it by under 1e-4 relative.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from drtlab.kernels.colour import SRGB_TO_XYZ

CIE_MIN, CIE_MAX, CIE_STEP = 360.0, 830.0, 5.0
STEPS = 1000
# Mitsuba's normalisations (MI_CIE_Y_NORMALIZATION, MI_CIE_D65_NORMALIZATION): a unit spectrum, and
# the D65 spectrum, each integrate to a luminance of 1.
CIE_Y_NORMALIZATION = 1.0 / 106.7502593994140625
CIE_D65_NORMALIZATION = 1.0 / 98.99741751876255
XYZ_TO_SRGB = np.linalg.inv(np.array(SRGB_TO_XYZ))


@lru_cache(maxsize=1)
def tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(wavelengths, CIE 1931 xyz (n, 3), D65 (n,)) at 5 nm over 360-830 nm, from colour-science."""
    import colour                               # ~2 s: only files with sampled spectra pay it
    grid = np.arange(CIE_MIN, CIE_MAX + CIE_STEP / 2, CIE_STEP)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(CIE_MIN, CIE_MAX, CIE_STEP))
    return grid, np.asarray(cmfs[grid], dtype=np.float64), np.asarray(d65[grid], dtype=np.float64)


def spectrum_to_rgb(wavelengths, values, emitter: bool, unbounded: bool = False) -> list[float]:
    """The linear sRGB colour of a spectrum property; `emitter` for an emitter's radiance,
    irradiance or intensity, `unbounded` for a property allowed above 1 (a conductor's eta, k)."""
    if len(wavelengths) == 0:
        v = float(values[0])
        return (v * XYZ_TO_SRGB.sum(axis=1)).tolist() if emitter else [v] * 3
    grid, cmfs, d65 = tables()
    w = CIE_MIN + np.arange(STEPS) / (STEPS - 1) * (CIE_MAX - CIE_MIN)
    w = w[(w >= wavelengths[0]) & (w <= wavelengths[-1])]
    v = np.interp(w, wavelengths, values)
    xyz_bar = np.stack([np.interp(w, grid, cmfs[:, k]) for k in range(3)], axis=1)
    weight = v if emitter else v * np.interp(w, grid, d65) * CIE_D65_NORMALIZATION
    xyz = (xyz_bar * weight[:, None]).sum(axis=0) * (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / STEPS
    rgb = np.maximum(XYZ_TO_SRGB @ xyz, 0.0)
    if not (emitter or unbounded):
        rgb = np.minimum(rgb, 1.0)
    return rgb.tolist()
