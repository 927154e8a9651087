"""CIEDE2000 of many images against one reference, as a Warp kernel: the per-run colour difference a
study records for every repetition (colour-science's vectorised numpy spends ~15 ms on a 96x72 image;
a study scores ten thousand of them).

Each displayed pixel (`colour.displayed`: NaN -> 0, clipped to [0, 1]) goes linear sRGB -> XYZ (the
sRGB colourspace's matrix, D65, no adaptation) -> CIELAB (D65 white, CIE 1976 lightness with its
linear segment) -> CIEDE2000 (Sharma, Wu & Dalal 2005, kL = kC = kH = 1) against the reference's
Lab, in float64: `colour.to_lab` and `colour.delta_E(..., method="CIE 2000")` computed the same way
(tests check agreement to 1e-9 on random and edge-case colours).
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import warp as wp

from drtlab.warp_runtime import warp as _wp

F = wp.float64


@wp.func
def _displayed(x: wp.float64) -> wp.float64:
    if wp.isnan(x):
        return F(0.0)
    return wp.min(wp.max(x, F(0.0)), F(1.0))


@wp.func
def _lab_f(t: wp.float64) -> wp.float64:
    # CIE 1976: cube root above (24/116)^3, the linear segment below it
    if t > F(216.0) / F(24389.0):
        return wp.cbrt(t)                    # exact cube root: pow(t, 1/3) is slower and rounds 1/3
    return F(841.0) / F(108.0) * t + F(16.0) / F(116.0)


@wp.func
def displayed_lab(rgb: wp.vec3d, m: wp.mat33d, white: wp.vec3d) -> wp.vec3d:
    """CIELAB of a displayed linear sRGB pixel (`m`, `white`: `srgb_constants()`)."""
    c = wp.vec3d(_displayed(rgb[0]), _displayed(rgb[1]), _displayed(rgb[2]))
    xyz = m * c
    fx = _lab_f(xyz[0] / white[0])
    fy = _lab_f(xyz[1] / white[1])
    fz = _lab_f(xyz[2] / white[2])
    return wp.vec3d(F(116.0) * fy - F(16.0), F(500.0) * (fx - fy), F(200.0) * (fy - fz))


COS30, SIN30 = math.cos(math.radians(30)), math.sin(math.radians(30))
COS6, SIN6 = math.cos(math.radians(6)), math.sin(math.radians(6))
COS63, SIN63 = math.cos(math.radians(63)), math.sin(math.radians(63))


@wp.func
def _chroma_weight(c: wp.float64) -> wp.float64:
    """sqrt(C^7 / (C^7 + 25^7)), by multiplications (pow is the kernel's slowest call)."""
    c2 = c * c
    c7 = c2 * c2 * c2 * c
    return wp.sqrt(c7 / (c7 + F(6103515625.0)))


@wp.func
def _hue_sum(c1p: wp.float64, a1p: wp.float64, b1: wp.float64, c2p: wp.float64, a2p: wp.float64,
             b2: wp.float64) -> wp.vec4d:
    """(dH', mean hue h' in degrees, cos h', sin h') of two colours as CIEDE2000 defines them.

    Both chromatic: the hues as unit vectors u1, u2; cos and sin of dh' = h2' - h1' (wrapped into
    [-180, 180]) are their dot and cross products, sin and cos of dh'/2 follow by half angles, and
    the mean hue is u1 turned by dh'/2 (that is Sharma's rule for the mean across the 0/360 seam), so
    one atan2 replaces two, and cos/sin of the mean hue need no call (3 of the kernel's 9
    transcendental calls saved). At |dh'| = 180 exactly, where Sharma's mean jumps by 180 degrees,
    the branch follows the sign of h2' - h1' as the reference formula does."""
    deg = F(180.0) / F(3.141592653589793)
    if c1p * c2p == F(0.0):
        # A neutral colour has hue 0: the mean hue is the other's, dH' is 0.
        a = a1p + a2p
        b = b1 + b2
        c = c1p + c2p
        if c == F(0.0):
            return wp.vec4d(F(0.0), F(0.0), F(1.0), F(0.0))
        h = wp.atan2(b, a) * deg
        if h < F(0.0):
            h = h + F(360.0)
        return wp.vec4d(F(0.0), h, a / c, b / c)
    x1 = a1p / c1p
    y1 = b1 / c1p
    x2 = a2p / c2p
    y2 = b2 / c2p
    cos_d = wp.clamp(x1 * x2 + y1 * y2, F(-1.0), F(1.0))
    sin_d = x1 * y2 - y1 * x2
    c_half = wp.sqrt(F(0.5) * (F(1.0) + cos_d))
    s_half = F(0.0)
    if c_half > F(0.5):                       # |dh'| < 120: no cancellation in sin / (2 cos)
        s_half = sin_d / (F(2.0) * c_half)
    else:
        s_half = wp.sqrt(F(0.5) * (F(1.0) - cos_d))
        if sin_d < F(0.0) or (sin_d == F(0.0) and wp.atan2(y2, x2) < wp.atan2(y1, x1)):
            s_half = -s_half
    ch = x1 * c_half - y1 * s_half
    sh = y1 * c_half + x1 * s_half
    h = wp.atan2(sh, ch) * deg
    if h < F(0.0):
        h = h + F(360.0)
    return wp.vec4d(F(2.0) * wp.sqrt(c1p * c2p) * s_half, h, ch, sh)


@wp.func
def ciede2000(lab1: wp.vec3d, lab2: wp.vec3d) -> wp.float64:
    deg = F(3.141592653589793) / F(180.0)
    L1 = lab1[0]
    a1 = lab1[1]
    b1 = lab1[2]
    L2 = lab2[0]
    a2 = lab2[1]
    b2 = lab2[2]
    c_bar = F(0.5) * (wp.sqrt(a1 * a1 + b1 * b1) + wp.sqrt(a2 * a2 + b2 * b2))
    g = F(0.5) * (F(1.0) - _chroma_weight(c_bar))
    a1p = (F(1.0) + g) * a1
    a2p = (F(1.0) + g) * a2
    c1p = wp.sqrt(a1p * a1p + b1 * b1)
    c2p = wp.sqrt(a2p * a2p + b2 * b2)
    hue = _hue_sum(c1p, a1p, b1, c2p, a2p, b2)
    dHp = hue[0]
    hbp = hue[1]
    ch = hue[2]
    shh = hue[3]
    dLp = L2 - L1
    dCp = c2p - c1p
    Lbp = F(0.5) * (L1 + L2)
    Cbp = F(0.5) * (c1p + c2p)
    # T's four cosines from cos and sin of the mean hue (multiple-angle recurrences)
    c2 = F(2.0) * ch * ch - F(1.0)
    s2 = F(2.0) * shh * ch
    c3 = c2 * ch - s2 * shh
    s3 = s2 * ch + c2 * shh
    c4 = F(2.0) * c2 * c2 - F(1.0)
    s4 = F(2.0) * s2 * c2
    t = (F(1.0) - F(0.17) * (ch * F(COS30) + shh * F(SIN30)) + F(0.24) * c2
         + F(0.32) * (c3 * F(COS6) - s3 * F(SIN6)) - F(0.20) * (c4 * F(COS63) + s4 * F(SIN63)))
    e = (hbp - F(275.0)) / F(25.0)
    d_theta = F(30.0) * wp.exp(-e * e)
    rc = F(2.0) * _chroma_weight(Cbp)
    l50 = (Lbp - F(50.0)) * (Lbp - F(50.0))
    sl = F(1.0) + F(0.015) * l50 / wp.sqrt(F(20.0) + l50)
    sc = F(1.0) + F(0.045) * Cbp
    sh = F(1.0) + F(0.015) * Cbp * t
    rt = -wp.sin(F(2.0) * d_theta * deg) * rc
    x = dLp / sl
    y = dCp / sc
    z = dHp / sh
    return wp.sqrt(x * x + y * y + z * z + rt * y * z)


@wp.kernel(enable_backward=False)
def _delta_e_kernel(images: wp.array2d(dtype=wp.vec3d), ref_lab: wp.array(dtype=wp.vec3d),
                    m: wp.mat33d, white: wp.vec3d, out: wp.array2d(dtype=wp.float64)):
    r, p = wp.tid()
    out[r, p] = ciede2000(displayed_lab(images[r, p], m, white), ref_lab[p])


@wp.kernel(enable_backward=False)
def _lab_kernel(images: wp.array(dtype=wp.vec3d), m: wp.mat33d, white: wp.vec3d,
                out: wp.array(dtype=wp.vec3d)):
    p = wp.tid()
    out[p] = displayed_lab(images[p], m, white)


@wp.kernel(enable_backward=False)
def _pair_kernel(lab1: wp.array(dtype=wp.vec3d), lab2: wp.array(dtype=wp.vec3d),
                 out: wp.array(dtype=wp.float64)):
    p = wp.tid()
    out[p] = ciede2000(lab1[p], lab2[p])


_SRGB: tuple | None = None


def srgb_constants():
    """The sRGB -> XYZ matrix and D65 white XYZ as Warp values (kernels/colour.py holds them)."""
    global _SRGB
    if _SRGB is None:
        from drtlab.kernels.colour import D65_XYZ, SRGB_TO_XYZ
        _SRGB = (wp.mat33d(*np.ravel(SRGB_TO_XYZ)), wp.vec3d(*D65_XYZ))
    return _SRGB


def delta_e_2000(images: np.ndarray, ref_lab: np.ndarray, threads: int = 2) -> np.ndarray:
    """(R, H, W) CIEDE2000 of each displayed pixel of (R, H, W, 3) linear images against the
    reference's Lab (H, W, 3); `threads` CPU launches side by side (each releases the GIL)."""
    _wp()
    m, white = srgb_constants()
    x = np.ascontiguousarray(np.asarray(images, dtype=np.float64))
    R, P = x.shape[0], int(np.prod(x.shape[1:-1]))
    ref = wp.array(np.ascontiguousarray(ref_lab, dtype=np.float64).reshape(P, 3), dtype=wp.vec3d,
                   device="cpu")
    out = np.empty((R, P), dtype=np.float64)
    chunks = [c for c in np.array_split(np.arange(R), max(1, min(threads, R))) if c.size]

    def run(c):
        src = wp.array(x[c[0]:c[-1] + 1].reshape(c.size, P, 3), dtype=wp.vec3d, device="cpu")
        dst = wp.zeros((c.size, P), dtype=wp.float64, device="cpu")
        wp.launch(_delta_e_kernel, dim=(c.size, P), inputs=[src, ref, m, white, dst], device="cpu")
        out[c[0]:c[-1] + 1] = dst.numpy()

    if len(chunks) == 1:
        run(chunks[0])
    else:
        with ThreadPoolExecutor(len(chunks)) as pool:
            list(pool.map(run, chunks))
    return out.reshape(x.shape[:-1])


def lab_of(images: np.ndarray) -> np.ndarray:
    """The kernel's CIELAB of displayed linear images (..., 3) (tests compare it with colour's)."""
    _wp()
    m, white = srgb_constants()
    x = np.ascontiguousarray(np.asarray(images, dtype=np.float64).reshape(-1, 3))
    out = wp.zeros(x.shape[0], dtype=wp.vec3d, device="cpu")
    wp.launch(_lab_kernel, dim=x.shape[0], inputs=[wp.array(x, dtype=wp.vec3d, device="cpu"), m, white, out],
              device="cpu")
    return out.numpy().reshape(np.shape(images))


def delta_e_of_labs(lab1: np.ndarray, lab2: np.ndarray) -> np.ndarray:
    """The kernel's CIEDE2000 of Lab pairs (..., 3) (tests compare it with colour's)."""
    _wp()
    a = np.ascontiguousarray(np.asarray(lab1, dtype=np.float64).reshape(-1, 3))
    b = np.ascontiguousarray(np.asarray(lab2, dtype=np.float64).reshape(-1, 3))
    out = wp.zeros(a.shape[0], dtype=wp.float64, device="cpu")
    wp.launch(_pair_kernel, dim=a.shape[0], inputs=[wp.array(a, dtype=wp.vec3d, device="cpu"),
                                                    wp.array(b, dtype=wp.vec3d, device="cpu"), out],
              device="cpu")
    return out.numpy().reshape(np.shape(lab1)[:-1])
