"""The maps' polynomial sines and cosines (estimators/domain_maps.py `sincos_octant`,
`sincos_turns`) against float64 numpy: within 1.5e-7 (about one float32 ulp at 1) on a dense grid of
turns and at the octant boundaries, where they must be exact."""
import numpy as np
import warp as wp

from drtlab.estimators.domain_maps import sincos_octant, sincos_turns
from drtlab.warp_runtime import warp as _init

_init()


@wp.kernel(enable_backward=False)
def _trig(u: wp.array(dtype=float), turns: wp.array(dtype=wp.vec2), octant: wp.array(dtype=wp.vec2)):
    i = wp.tid()
    turns[i] = sincos_turns(u[i])
    octant[i] = sincos_octant((u[i] * 2.0 - 1.0) * 0.7853981633974483)


def _run(u):
    ua = wp.array(u, dtype=float)
    turns, octant = wp.zeros(len(u), dtype=wp.vec2), wp.zeros(len(u), dtype=wp.vec2)
    wp.launch(_trig, dim=len(u), inputs=[ua, turns, octant])
    return turns.numpy().astype(np.float64), octant.numpy().astype(np.float64)


def test_turns_and_octant_match_float64():
    rng = np.random.default_rng(7)
    u = np.concatenate([np.linspace(0.0, 1.0, 1 << 20, dtype=np.float32),
                        rng.random(1 << 18, dtype=np.float32)])
    turns, octant = _run(u)
    angle = 2.0 * np.pi * u.astype(np.float64)
    assert np.abs(turns[:, 0] - np.cos(angle)).max() < 1.5e-7
    assert np.abs(turns[:, 1] - np.sin(angle)).max() < 1.5e-7
    x = ((u * np.float32(2.0) - np.float32(1.0)) * np.float32(0.7853981633974483)).astype(np.float64)
    assert np.abs(octant[:, 0] - np.cos(x)).max() < 1.0e-7
    assert np.abs(octant[:, 1] - np.sin(x)).max() < 1.0e-7


def test_octant_boundaries_are_exact():
    turns, _ = _run(np.arange(9, dtype=np.float32) / 8.0)
    half = np.float32(np.sqrt(0.5))
    expect = np.array([[1, 0], [half, half], [0, 1], [-half, half], [-1, 0], [-half, -half],
                       [0, -1], [half, -half], [1, 0]], dtype=np.float64)
    np.testing.assert_allclose(turns, expect, rtol=0, atol=6e-8)
    # the axis directions exactly: a quarter turn is exact in turns
    assert np.all(turns[[0, 2, 4, 6, 8]] == expect[[0, 2, 4, 6, 8]])
