"""kernels/colour.py writes out the sRGB transfer (IEC 61966-2-1) so that PNG previews need not import
colour-science (2 s): both directions must be colour-science's bit for bit in float64 (the PNG bytes
of every render depend on the encoding), on a dense grid of [0, 1] and at the floats around the
linear segment's end, where the IEC curve's two pieces meet (display value 0.04045 rounded from
colour's 0.0404482...)."""
import numpy as np
import pytest

colour = pytest.importorskip("colour")

from drtlab.kernels.colour import displayed, srgb_to_linear, to_srgb  # noqa: E402

# Every step of 2^-20 across [0, 1], and the floats next to each branch point.
GRID = np.linspace(0.0, 1.0, 2**20 + 1)
KNEES = np.array([np.nextafter(k, toward)
                  for k in (0.0031308, 0.04045, float(colour.cctf_encoding(0.0031308, function="sRGB")))
                  for toward in (-np.inf, k, np.inf)])


def test_srgb_encoding_is_colour_science_bit_for_bit():
    x = np.concatenate([GRID, KNEES])
    assert np.array_equal(to_srgb(x), colour.cctf_encoding(x, function="sRGB"))


def test_srgb_encoding_of_what_a_display_cannot_show_is_colour_science_of_the_clipped_value():
    x = np.array([-1.0, -1e-30, 1.0 + 1e-12, 7.5, np.inf, -np.inf, np.nan])
    assert np.array_equal(to_srgb(x), colour.cctf_encoding(displayed(x), function="sRGB"))
    assert np.array_equal(to_srgb(x), to_srgb(np.array([0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0])))


def test_srgb_decoding_is_colour_science():
    v = np.concatenate([GRID, KNEES])
    assert np.array_equal(srgb_to_linear(v), colour.cctf_decoding(v, function="sRGB"))
    # 8-bit codes read back as float32 stay float32, within float32 rounding of colour's value.
    codes = np.arange(256, dtype=np.float32) / 255
    got = srgb_to_linear(codes)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, colour.cctf_decoding(codes.astype(np.float64), function="sRGB"),
                               rtol=1e-6, atol=1e-9)


def test_srgb_matrix_and_d65_white_are_colour_science_s():
    # CIELAB (and so CIEDE2000) of every study run goes through these constants: they must be the
    # ones colour-science's sRGB colourspace and D65 illuminant hold, to the last bit.
    from drtlab.kernels.colour import D65_XYZ, REC709_Y, SRGB_TO_XYZ
    m = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ, dtype=np.float64)
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    assert np.array_equal(np.asarray(SRGB_TO_XYZ), m)
    assert np.array_equal(np.asarray(D65_XYZ), np.asarray(colour.xy_to_XYZ(d65), dtype=np.float64))
    assert np.array_equal(np.asarray(REC709_Y), m[1])
