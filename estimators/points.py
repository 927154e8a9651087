"""Point sets from Python, in the style of `scipy.stats.qmc`: the very values the render kernels use.

    from drtlab.estimators.points import points
    u = points("sobol", 64, 5, seed=0, pixel=0)      # (64, 5) float64 in [0, 1)

Row i is sample index i of pixel key `pixel` (spp = n, so the point set lays out n samples); column
d is sample dimension d as the tracer reads it (estimators/dimensions.py): a dimension inside a 2D
slot (pixel 0-1, lens 2-3, and per bounce light position +1/+2 and direction +4/+5) is that
component of get2d(slot start) - column 0 is get2d(seed, pixel, i, 0, n)[0], column 1 its [1] -
and every other dimension (time 4, light choice, lobe choice, roulette, and the reserved +7 that
the tracer never reads) is get1d(dimension). `slots(dims)` tells which. The values are computed by
a small Warp kernel calling the point set's own get1d / get2d, float32 values widened to float64
exactly, so they are bit-identical to a render's (same seed, pixel key, index, dimension, spp).
"""
from __future__ import annotations

import numpy as np

from drtlab import fields
from drtlab.errors import InputError
from drtlab.estimators import dimensions as D
from drtlab.warp_runtime import warp as _warp

_kernels: dict = {}


def slots(dims: int) -> list[tuple[int, int, int]]:
    """(1 or 2, slot start, component) for dimensions 0 ... dims - 1."""
    return [(kind, start, d - start) for d in range(dims) for kind, start in [D.slot(d)]]


def _kernel(name: str, ps=None):
    from drtlab.estimators.registry import POINTSETS
    wp = _warp()
    ps = POINTSETS[name] if ps is None else ps
    key = (name, ps.fingerprint)           # a replaced plugin set under the same name recompiles
    if key not in _kernels:
        get1d, get2d, count_word = ps.get1d, ps.get2d, ps.count_word

        @wp.kernel(enable_backward=False, module="unique")
        def evaluate(seed: wp.uint32, pixel: wp.uint32, spp: wp.uint32,
                     kinds: wp.array(dtype=int), starts: wp.array(dtype=wp.uint32),
                     comps: wp.array(dtype=int), out: wp.array2d(dtype=float)):
            i, c = wp.tid()
            idx = wp.uint32(i)
            word = count_word(spp)          # as a render passes spp
            if kinds[c] == 1:
                out[i, c] = get1d(seed, pixel, idx, starts[c], word)
            else:
                out[i, c] = get2d(seed, pixel, idx, starts[c], word)[comps[c]]

        _kernels[key] = evaluate
    return wp, _kernels[key]


def _uint32(value, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or \
            not 0 <= int(value) <= fields.MAX_SEED:
        raise InputError(field, f"must be an integer in [0, 2^32 - 1], got {fields.show(value)}")
    return int(value)


def points(name, n: int, dims: int, seed: int = 0, pixel: int = 0) -> np.ndarray:
    """(n, dims) float64: samples 0 ... n - 1 (spp = n) of point set `name` (a registered name, or a
    PointSet outside the registry) in dimensions 0 ... dims - 1 for (seed, pixel key), read as the
    tracer reads them (module docstring)."""
    from drtlab.estimators.pointsets.base import PointSet
    from drtlab.estimators.registry import POINTSETS
    own = name if isinstance(name, PointSet) else None
    if own is not None:
        name = own.name
    elif name not in POINTSETS:
        raise InputError("points", f"unknown point set {name!r}; allowed: {', '.join(POINTSETS)}")
    for value, field in ((n, "n"), (dims, "dims")):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or \
                not 1 <= int(value) <= fields.MAX_COUNT:
            raise InputError(field, f"must be an integer >= 1, got {value!r}")
    seed, pixel = _uint32(seed, "seed"), _uint32(pixel, "pixel")
    n, dims = int(n), int(dims)
    wp, kernel = _kernel(name, own)
    layout = slots(dims)
    arrays = [wp.array(np.array([c[0] for c in layout], dtype=np.int32), dtype=int, device="cpu"),
              wp.array(np.array([c[1] for c in layout], dtype=np.uint32), dtype=wp.uint32,
                       device="cpu"),
              wp.array(np.array([c[2] for c in layout], dtype=np.int32), dtype=int, device="cpu")]
    out = wp.zeros((n, dims), dtype=float, device="cpu")
    wp.launch(kernel, dim=(n, dims), device="cpu",
              inputs=[wp.uint32(seed), wp.uint32(pixel), wp.uint32(n), *arrays, out])
    return out.numpy().astype(np.float64)
