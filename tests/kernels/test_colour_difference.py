"""The CIEDE2000 kernel (kernels/colour_difference.py) computes what colour-science computes: CIELAB
of displayed linear sRGB and CIEDE2000 of Lab pairs to 1e-9, on random colours and on the cases
Sharma et al. single out (neutral colours with undefined hue, hue differences across 0/360 and at
180 degrees), and on non-finite and out-of-range pixels."""
import numpy as np
import pytest

colour = pytest.importorskip("colour")

from drtlab.kernels.colour import to_lab                                          # noqa: E402
from drtlab.kernels.colour_difference import delta_e_2000, delta_e_of_labs, lab_of  # noqa: E402


def test_lab_of_displayed_pixels_matches_colour():
    rng = np.random.default_rng(0)
    x = rng.uniform(-0.5, 2.0, (4000, 3))
    x[:4] = [[np.nan, 0.2, 0.3], [np.inf, 0.0, 1.0], [-np.inf, 0.5, 0.5], [0.0, 0.0, 0.0]]
    x[4:8] = [[1, 1, 1], [1e-6, 1e-6, 1e-6], [0.008, 0.008, 0.008], [0.5, 0.5, 0.5]]  # linear segment
    assert np.max(np.abs(lab_of(x) - to_lab(x))) < 1e-9


def test_ciede2000_matches_colour_on_random_and_edge_pairs():
    rng = np.random.default_rng(1)
    n = 20000
    l1 = np.column_stack([rng.uniform(0, 100, n), rng.uniform(-128, 128, n), rng.uniform(-128, 128, n)])
    l2 = l1 + rng.normal(0, 8, l1.shape)
    l1[:200, 1:] = 0                                   # neutral first colour: hue undefined
    l2[100:300, 1:] = 0                                # neutral second colour (and both, 100-199)
    h = np.radians(rng.uniform(0, 360, 200))           # pairs across the 0/360 seam and at 180
    l1[300:500, 1:] = np.column_stack([np.cos(h), np.sin(h)]) * 40
    l2[300:400, 1:] = np.column_stack([np.cos(h[:100] + 0.05), np.sin(h[:100] + 0.05)]) * 40
    # nearly opposite hues, on both sides of |dh| = 180 (exactly 180 is a discontinuity of the
    # mean hue, where float rounding alone picks the branch)
    k = h[100:] + np.pi + np.where(np.arange(100) % 2 == 0, 0.02, -0.02)
    l2[400:500, 1:] = np.column_stack([np.cos(k), np.sin(k)]) * 30
    got = delta_e_of_labs(l1, l2)
    want = colour.delta_E(l1, l2, method="CIE 2000")
    assert np.max(np.abs(got - want)) < 1e-9
    assert np.all(delta_e_of_labs(l1, l1) == 0)


def test_images_against_a_reference_match_colour_per_pixel():
    rng = np.random.default_rng(2)
    images = rng.uniform(0, 1.2, (7, 9, 11, 3))
    images[3, 2, 2] = np.nan
    ref = rng.uniform(0, 1, (9, 11, 3))
    ref_lab = to_lab(ref)
    for threads in (1, 2, 3):
        got = delta_e_2000(images, ref_lab, threads=threads)
        assert got.shape == (7, 9, 11)
        want = colour.delta_E(to_lab(images), ref_lab, method="CIE 2000")
        assert np.max(np.abs(got - want)) < 1e-9
