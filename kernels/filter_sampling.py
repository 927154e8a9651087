"""The pixel filters on the device: each filter's 1D profile, filter importance sampling and the
splatting weights (the definitions and the tables: kernels/filters.py).

`make_pixel_filter(features)` returns a PixelFilter of Warp functions, or None for the box (whose
pixel is today's square, with no filter code compiled in). A filter's radius, table size and integral
are compile-time constants (a variant per filter), so the profile's constants fold away and the
table search is a fixed number of steps:
    profile(x) -> f1(x)                     the separable profile, 0 outside the radius
    sample(sd, u, px, py) -> vec3(dx, dy, w)  an offset from the centre of pixel (px, py) drawn
                                            from the table of |f1| x |f1| and its weight
                                            f / (p integral f); with filter_clip, per axis from the
                                            table restricted to the film (the inverse CDF of
                                            [C(lo), C(hi)]) and weighed by f / (p_cut integral_cut f)
    reach(u) -> Reach                       for a sample at u within its pixel, f1 at its offsets
                                            from the centres of the 2 margin + 1 pixels in each
                                            direction around it (the gather multiplies them)
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import FILTER_NO_SIGN, FILTER_RADIUS_HIGH_10PCT, Features
from drtlab.kernels.filters import (BH_COEFFS, BOX, GAUSSIAN_SIGMA, MITCHELL_B, MITCHELL_C,
                                    MITSUBA_FILTER_RESOLUTION, MITSUBA_GAUSSIAN, filter_cdf,
                                    mitsuba_gaussian_table)


class PixelFilter(NamedTuple):
    profile: wp.Function
    sample: wp.Function
    reach: wp.Function
    reach_type: type            # the vector of reach's values, one per neighbour column (or row)


def _profile(name: str, radius: float) -> wp.Function:
    r = wp.constant(float(radius))
    if name == "gaussian":
        inv_two_var = wp.constant(float(0.5 / GAUSSIAN_SIGMA ** 2))
        norm = wp.constant(float(1.0 / (math.sqrt(2.0 * math.pi) * GAUSSIAN_SIGMA)))
        at_radius = wp.constant(float(math.exp(-0.5 * (radius / GAUSSIAN_SIGMA) ** 2)))

        @wp.func
        def gaussian(x: float) -> float:
            return wp.max(0.0, (wp.exp(-inv_two_var * x * x) - at_radius) * norm)
        return gaussian
    if name == MITSUBA_GAUSSIAN:
        # Mitsuba's CPU variants' table (kernels/filters.py): the same float32 values and bin index.
        table = mitsuba_gaussian_table(radius)
        n = MITSUBA_FILTER_RESOLUTION
        values = wp.constant(wp.types.vector(length=len(table), dtype=wp.float32)(*[float(v) for v in table]))
        scale = wp.constant(float(np.float32(n) / np.float32(radius)))
        last, last_f = wp.constant(n), wp.constant(float(n))

        @wp.func
        def mitsuba_gaussian(x: float) -> float:
            # Clamped before the int conversion (Mitsuba clamps after it: the same bin, no overflow).
            return values[wp.min(int(wp.min(wp.abs(x) * scale, last_f)), last)]
        return mitsuba_gaussian
    if name == "mitchell":
        b, c = float(MITCHELL_B), float(MITCHELL_C)
        # Mitchell-Netravali's two cubics in t = |2x / radius|: coefficients of t^3, t^2, t, 1, over 6.
        i3, i2, i0 = (wp.constant(v / 6.0) for v in (12 - 9 * b - 6 * c, -18 + 12 * b + 6 * c, 6 - 2 * b))
        o3, o2, o1, o0 = (wp.constant(v / 6.0) for v in (-b - 6 * c, 6 * b + 30 * c, -12 * b - 48 * c,
                                                         8 * b + 24 * c))
        scale = wp.constant(float(2.0 / radius))

        @wp.func
        def mitchell(x: float) -> float:
            t = wp.abs(x * scale)
            v = float(0.0)
            if t <= 1.0:
                v = (i3 * t + i2) * t * t + i0
            elif t <= 2.0:
                v = ((o3 * t + o2) * t + o1) * t + o0
            return v
        return mitchell
    if name == "blackman_harris":
        a0, a1, a2, a3 = (wp.constant(float(a)) for a in BH_COEFFS)
        freq = wp.constant(float(math.pi / radius))

        @wp.func
        def blackman_harris(x: float) -> float:
            v = float(0.0)
            if wp.abs(x) <= r:
                # cos 2t and cos 3t from cos t (one cosine per value).
                c1 = wp.cos(freq * (x + r))
                c2 = 2.0 * c1 * c1 - 1.0
                c3 = (4.0 * c1 * c1 - 3.0) * c1
                v = a0 - a1 * c1 + a2 * c2 - a3 * c3
            return v
        return blackman_harris
    raise ValueError(f"no device profile for filter {name!r}")


def make_pixel_filter(f: Features) -> PixelFilter | None:
    if f.filter == BOX:
        return None
    filt = f.filter_def
    profile = _profile(f.filter, filt.radius)
    bins = len(filter_cdf(filt)) - 1
    CLIP = f.filter_clip and filt.margin > 0
    MARGIN = filt.margin
    integral1 = wp.constant(float(filt.integral1))
    STEPS = int(math.log2(bins))
    assert 1 << STEPS == bins, "the table search halves a power-of-two table"
    r = wp.constant(float(filt.radius))
    bin_width = wp.constant(float(2.0 * filt.radius / bins))
    inv_integral = wp.constant(float(1.0 / filt.integral))
    NO_SIGN = FILTER_NO_SIGN in f.faults
    spread = wp.constant(1.1 if FILTER_RADIUS_HIGH_10PCT in f.faults else 1.0)
    K = 2 * filt.margin + 1
    reach_type = wp.types.vector(length=K, dtype=wp.float32)
    first = wp.constant(float(-filt.margin - 0.5))

    @wp.func
    def cut(sd: SceneData, p: int, n: int) -> wp.vec3:
        # Pixel p of n along an axis: (C(lo), C(hi), integral of f1 over [lo, hi]), the support
        # cut where the film ends (p pixels to its left edge, n - 1 - p to its right).
        c = wp.vec3(0.0, 1.0, integral1)
        if p < wp.static(MARGIN):
            row = sd.filter.clip[p]
            c = wp.vec3(row[0], c[1], c[2] - row[2])
        right = n - 1 - p
        if right < wp.static(MARGIN):
            row = sd.filter.clip[right]
            c = wp.vec3(c[0], row[1], c[2] - row[2])
        return c

    @wp.func
    def sample_1d(sd: SceneData, u: float) -> wp.vec2:
        # (x, density): the bin whose CDF interval holds u (cdf[0] = 0 <= u < 1 = cdf[bins], so
        # the bin has mass), then uniform within it.
        lo = int(0)
        half = int(bins)
        for _ in range(wp.static(STEPS)):
            half = half / 2
            if sd.filter.cdf[lo + half] <= u:
                lo = lo + half
        c0 = sd.filter.cdf[lo]
        mass = sd.filter.cdf[lo + 1] - c0
        t = wp.clamp((u - c0) / mass, 0.0, 1.0)
        return wp.vec2(-r + bin_width * (float(lo) + t), mass / bin_width)

    @wp.func
    def sample(sd: SceneData, u: wp.vec2, px: int, py: int) -> wp.vec3:
        inv_int = inv_integral
        if wp.static(CLIP):
            # The table restricted to [lo, hi]: u spans [C(lo), C(hi)], the density grows by
            # 1 / (C(hi) - C(lo)), and the filter is normalised over the cut support.
            cx = cut(sd, px, sd.width)
            cy = cut(sd, py, sd.height)
            u = wp.vec2(cx[0] + u[0] * (cx[1] - cx[0]), cy[0] + u[1] * (cy[1] - cy[0]))
            inv_int = (cx[1] - cx[0]) * (cy[1] - cy[0]) / (cx[2] * cy[2])
        sx = sample_1d(sd, u[0])
        sy = sample_1d(sd, u[1])
        fv = profile(sx[0]) * profile(sy[0])
        if wp.static(NO_SIGN):
            fv = wp.abs(fv)
        w = fv / (sx[1] * sy[1]) * inv_int
        return wp.vec3(sx[0] * spread, sy[0] * spread, w)

    @wp.func
    def reach(u: float) -> reach_type:
        out = reach_type()
        for i in range(wp.static(K)):
            out[i] = profile(first + float(i) + u)
        return out

    return PixelFilter(profile=profile, sample=sample, reach=reach, reach_type=reach_type)
