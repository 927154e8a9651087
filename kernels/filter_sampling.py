"""The pixel filters on the device: each filter's 1D profile, filter importance sampling and the
splatting weight (the definitions and the tables: kernels/filters.py).

`make_pixel_filter(features)` returns a PixelFilter of Warp functions, or None for the box (whose
pixel is today's square, with no filter code compiled in):
    profile(x) -> f1(x)                           the separable profile, 0 outside the radius
    sample(sd, u) -> vec3(dx, dy, w)              an offset from the pixel centre drawn from the table
                                                  of |f1| x |f1| and its weight f / (p integral f)
    weight(dx, dy) -> f(dx, dy)                   what a splatted sample at that offset adds
"""
from __future__ import annotations

from typing import NamedTuple

import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import FILTER_NO_SIGN, FILTER_RADIUS_HIGH_10PCT, Features
from drtlab.kernels.filters import BH_COEFFS, BOX, GAUSSIAN_SIGMA, MITCHELL_B, MITCHELL_C

INV_SQRT_2PI = wp.constant(0.3989422804014327)


class PixelFilter(NamedTuple):
    profile: wp.Function
    sample: wp.Function
    weight: wp.Function


def _profile(name: str) -> wp.Function:
    if name == "gaussian":
        sigma = wp.constant(float(GAUSSIAN_SIGMA))

        @wp.func
        def gaussian(x: float, r: float) -> float:
            g = wp.exp(-0.5 * (x / sigma) * (x / sigma))
            gr = wp.exp(-0.5 * (r / sigma) * (r / sigma))
            return wp.max(0.0, (g - gr) * (INV_SQRT_2PI / sigma))
        return gaussian
    if name == "mitchell":
        b, c = float(MITCHELL_B), float(MITCHELL_C)
        # Mitchell-Netravali's two cubics, coefficients of x^3, x^2, x, 1 over 6.
        i3, i2, i0 = wp.constant((12 - 9 * b - 6 * c) / 6), wp.constant((-18 + 12 * b + 6 * c) / 6), \
            wp.constant((6 - 2 * b) / 6)
        o3, o2, o1, o0 = wp.constant((-b - 6 * c) / 6), wp.constant((6 * b + 30 * c) / 6), \
            wp.constant((-12 * b - 48 * c) / 6), wp.constant((8 * b + 24 * c) / 6)

        @wp.func
        def mitchell(x: float, r: float) -> float:
            t = wp.abs(2.0 * x / r)
            v = float(0.0)
            if t <= 1.0:
                v = (i3 * t + i2) * t * t + i0
            elif t <= 2.0:
                v = ((o3 * t + o2) * t + o1) * t + o0
            return v
        return mitchell
    if name == "blackman_harris":
        a0, a1, a2, a3 = (wp.constant(float(a)) for a in BH_COEFFS)

        @wp.func
        def blackman_harris(x: float, r: float) -> float:
            v = float(0.0)
            if wp.abs(x) <= r:
                t = wp.pi * (x + r) / r
                v = a0 - a1 * wp.cos(t) + a2 * wp.cos(2.0 * t) - a3 * wp.cos(3.0 * t)
            return v
        return blackman_harris
    raise ValueError(f"no device profile for filter {name!r}")


def make_pixel_filter(f: Features) -> PixelFilter | None:
    if f.filter == BOX:
        return None
    profile = _profile(f.filter)
    NO_SIGN = FILTER_NO_SIGN in f.faults
    spread = wp.constant(1.1 if FILTER_RADIUS_HIGH_10PCT in f.faults else 1.0)

    @wp.func
    def sample_1d(sd: SceneData, u: float) -> wp.vec2:
        # (x, density): the bin whose CDF interval holds u (cdf[0] = 0 <= u < 1 = cdf[bins], so
        # the bin has mass), then uniform within it.
        lo = int(0)
        hi = sd.filter.bins
        while hi - lo > 1:
            mid = (lo + hi) / 2
            if sd.filter.cdf[mid] <= u:
                lo = mid
            else:
                hi = mid
        c0 = sd.filter.cdf[lo]
        mass = sd.filter.cdf[lo + 1] - c0
        h = 2.0 * sd.filter.radius / float(sd.filter.bins)
        t = wp.clamp((u - c0) / mass, 0.0, 1.0)
        return wp.vec2(-sd.filter.radius + h * (float(lo) + t), mass / h)

    @wp.func
    def weight(sd: SceneData, dx: float, dy: float) -> float:
        r = sd.filter.radius
        if wp.abs(dx) > r or wp.abs(dy) > r:
            return 0.0
        return profile(dx, r) * profile(dy, r)

    @wp.func
    def sample(sd: SceneData, u: wp.vec2) -> wp.vec3:
        sx = sample_1d(sd, u[0])
        sy = sample_1d(sd, u[1])
        fv = weight(sd, sx[0], sy[0])
        if wp.static(NO_SIGN):
            fv = wp.abs(fv)
        w = fv / (sx[1] * sy[1]) * sd.filter.inv_integral
        return wp.vec3(sx[0] * spread, sy[0] * spread, w)

    return PixelFilter(profile=profile, sample=sample, weight=weight)
