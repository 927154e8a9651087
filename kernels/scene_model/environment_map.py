"""The environment light's model: a lat-long radiance image (procedural or from a file), the
`[environment]` table that makes it, and the tables that sample it by importance. numpy only (the
Warp side is kernels/environment.py).

Lat-long convention (the image's rows top to bottom, columns left to right):
    v = theta / pi, theta the angle from +y (row 0 looks up);  u = phi / (2 pi), phi = atan2(z, x)
    in [0, 2 pi) (column 0 starts at +x, turning towards +z);  d = (sin t cos p, cos t, sin t sin p).
Radiance is piecewise constant by default (`lookup = "texel"`): a direction sees the texel it falls
in (no filtering), so the image is exactly the function that is sampled and integrated (the closed
forms hold to float precision). An image map may instead be looked up as Mitsuba 3's envmap does
(`lookup = "bilinear"`): bilinear between samples at the column centres u = (c + 1/2) / W (periodic
in u) and at the rows' v = r / (H - 1) (row 0 at +y, the last at -y; clamped). An image map may be
turned by `to_world` (a rotation: the map's frame -> world; directions are looked up at
to_world^T d).

Importance sampling is pbrt's PiecewiseConstant2D over (u, v) in [0, 1)^2 of
func = luminance(texel) * sin(theta at the row's centre): a marginal distribution over rows and one
conditional distribution over columns per row, each a cdf with a leading 0 (a row or image whose
func is all 0 gets a uniform cdf, as pbrt-v4's PiecewiseConstant1D does). A texel's density over
(u, v) is func / mean(func); over solid angle it is that / (2 pi^2 sin theta), d omega =
2 pi^2 sin theta du dv. An all-black image samples func = sin(theta), i.e. about uniformly. A bilinear map samples the
same tables of the texels' 3 x 3 maximum (rows clamped, columns periodic): every texel the bilinear
radiance reaches is sampled (so next-event estimation alone stays unbiased), and the pdf that MIS
reads is the density of what is sampled.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import (REQUIRED, SCENE_LIMIT, Table, existing_file, scene_numbers as numbers,
                           scene_number as number, show, string)

KINDS = ("constant", "two_level", "gradient", "image")
PROCEDURAL_KEYS = ("resolution", "sun_direction", "sun_radiance")
KEYS = {
    "constant": ("kind", "radiance", "scale") + PROCEDURAL_KEYS,
    "two_level": ("kind", "upper", "lower", "scale") + PROCEDURAL_KEYS,
    "gradient": ("kind", "zenith", "horizon", "nadir", "scale") + PROCEDURAL_KEYS,
    "image": ("kind", "file", "scale", "lookup", "to_world"),
}
LOOKUPS = ("texel", "bilinear")
ROTATION_TOLERANCE = 1e-6   # |R R^T - I| and |det R - 1| of an accepted to_world
DEFAULT_RESOLUTION = (64, 32)
MAX_TEXELS = 1 << 22


@dataclass
class EnvironmentMap:
    """Radiance per texel, (H, W, 3) float64, row 0 = +y (the module's lat-long convention)."""
    kind: str
    image: np.ndarray
    source: str = ""                    # the file it came from, or the kind
    lookup: str = "texel"               # LOOKUPS: the texel a direction falls in, or bilinear
    to_world: np.ndarray | None = None  # (3, 3) rotation, the map's frame -> world; None: identity
    _digest: str = field(default="", repr=False)

    @property
    def height(self) -> int:
        return int(self.image.shape[0])

    @property
    def width(self) -> int:
        return int(self.image.shape[1])

    def digest(self) -> str:
        """Hash of the radiance: what a scene's content_hash cannot see in the TOML of a file map."""
        if not self._digest:
            h = hashlib.sha256(np.ascontiguousarray(self.image).tobytes())
            if self.lookup != "texel" or self.to_world is not None:
                h.update(self.lookup.encode())
                h.update(np.ascontiguousarray(self.frame()).tobytes())
            self._digest = h.hexdigest()
        return self._digest

    def frame(self) -> np.ndarray:
        """to_world, the identity when none was given."""
        return np.eye(3) if self.to_world is None else self.to_world

    def local(self, dirs: np.ndarray) -> np.ndarray:
        """World directions in the map's frame (to_world^T d)."""
        return np.asarray(dirs, dtype=np.float64) @ self.frame()

    def luminance_integral(self) -> float:
        """Integral over the sphere of the luminance, in W / (m^2) per unit radiance: the
        environment's share of the power pick (kernels/scene_upload.py)."""
        from drtlab.kernels.colour import luminance
        return float(np.sum(luminance(self.image) * texel_solid_angles(self.height, self.width)))


# ---------------------------------------------------------------------------------------------------
# Geometry of the lat-long grid
# ---------------------------------------------------------------------------------------------------
def row_cos_edges(height: int) -> np.ndarray:
    """cos theta at the H + 1 row edges, top (1) to bottom (-1)."""
    return np.cos(np.linspace(0.0, math.pi, height + 1))


def texel_solid_angles(height: int, width: int) -> np.ndarray:
    """(H, W) solid angle of each texel: (2 pi / W) (cos theta_top - cos theta_bottom)."""
    c = row_cos_edges(height)
    return np.repeat(((c[:-1] - c[1:]) * 2.0 * math.pi / width)[:, None], width, axis=1)


def directions(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit directions of lat-long coordinates (u, v) in [0, 1]^2."""
    theta, phi = np.asarray(v) * math.pi, np.asarray(u) * 2.0 * math.pi
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), np.cos(theta), s * np.sin(phi)], axis=-1)


def texels(dirs: np.ndarray, height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of the texel each direction falls in."""
    d = np.asarray(dirs, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    phi = np.mod(np.arctan2(d[..., 2], d[..., 0]), 2.0 * math.pi)
    row = np.minimum((theta / math.pi * height).astype(np.int64), height - 1)
    col = np.minimum((phi / (2.0 * math.pi) * width).astype(np.int64), width - 1)
    return row, col


# ---------------------------------------------------------------------------------------------------
# Importance sampling tables (PiecewiseConstant2D)
# ---------------------------------------------------------------------------------------------------
@dataclass
class SamplingTables:
    texel_pdf: np.ndarray       # (H, W) density over (u, v) of each texel
    marginal: np.ndarray        # (H + 1,) cdf over rows
    conditional: np.ndarray     # (H, W + 1) cdf over columns, per row


def _cdf(func: np.ndarray) -> np.ndarray:
    """Cdfs with a leading 0 along the last axis; a zero function gets the uniform cdf."""
    c = np.concatenate([np.zeros(func.shape[:-1] + (1,)), np.cumsum(func, axis=-1)], axis=-1)
    total = c[..., -1:]
    uniform = np.broadcast_to(np.linspace(0.0, 1.0, func.shape[-1] + 1), c.shape)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(total > 0.0, c / np.where(total > 0.0, total, 1.0), uniform)
    out[..., -1] = 1.0
    return out


def sampling_func(image: np.ndarray, sin_weight: bool = True, lookup: str = "texel") -> np.ndarray:
    """The function importance sampling follows: luminance times sin(theta) at the row centres
    (sin_weight=False drops the Jacobian: the chi-square test's negative control); for a bilinear
    lookup the luminance's 3 x 3 maximum, which covers the texels the bilinear radiance reaches."""
    from drtlab.kernels.colour import luminance
    h = image.shape[0]
    func = np.maximum(luminance(image), 0.0)
    if lookup == "bilinear":
        from scipy.ndimage import maximum_filter
        wrapped = np.concatenate([func[:, -1:], func, func[:, :1]], axis=1)
        func = maximum_filter(wrapped, size=3, mode="nearest")[:, 1:-1]
    s = np.sin((np.arange(h) + 0.5) / h * math.pi)[:, None]
    if not np.any(func > 0.0):
        func = np.ones_like(func)          # black: sample (about) uniformly over the sphere
    return func * s if sin_weight else func


def sampling_tables(image: np.ndarray, sin_weight: bool = True,
                    lookup: str = "texel") -> SamplingTables:
    func = sampling_func(image, sin_weight, lookup)
    mean = float(func.mean())
    return SamplingTables(texel_pdf=func / mean, marginal=_cdf(func.sum(axis=1)),
                          conditional=_cdf(func))


def direction_pdf(image: np.ndarray, dirs: np.ndarray, sin_weight: bool = True,
                  env: EnvironmentMap | None = None) -> np.ndarray:
    """The exact solid-angle density of importance sampling at `dirs` (float64): the chi-square
    test's claimed pdf, independent of the Warp code; `env` gives its lookup and to_world."""
    h, w = image.shape[:2]
    pdf_uv = sampling_tables(image, sin_weight, env.lookup if env else "texel").texel_pdf
    if env is not None:
        dirs = env.local(dirs)
    row, col = texels(dirs, h, w)
    d = np.asarray(dirs, dtype=np.float64)
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - d[..., 1] ** 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sin_t > 0.0, pdf_uv[row, col] / (2.0 * math.pi ** 2 * sin_t), 0.0)


# ---------------------------------------------------------------------------------------------------
# Procedural maps
# ---------------------------------------------------------------------------------------------------
def _row_cos_centres(height: int) -> np.ndarray:
    return np.cos((np.arange(height) + 0.5) / height * math.pi)


def procedural(kind: str, height: int, width: int, **radiance) -> np.ndarray:
    """(H, W, 3) radiance of a procedural kind: constant (radiance), two_level (upper where
    cos theta > 0, lower below: exact for an even height), gradient (zenith -> horizon -> nadir,
    linear in cos theta at the row centres)."""
    c = _row_cos_centres(height)[:, None]
    if kind == "constant":
        rows = np.broadcast_to(radiance["radiance"], (height, 3))
    elif kind == "two_level":
        rows = np.where(c > 0.0, radiance["upper"], radiance["lower"])
    else:
        up, mid, down = radiance["zenith"], radiance["horizon"], radiance["nadir"]
        rows = np.where(c > 0.0, mid + (up - mid) * c, mid + (down - mid) * (-c))
    return np.repeat(np.asarray(rows, dtype=np.float64)[:, None, :], width, axis=1).copy()


# ---------------------------------------------------------------------------------------------------
# The [environment] table
# ---------------------------------------------------------------------------------------------------
def _color(t: Table, key: str, default: Any) -> np.ndarray:
    return numbers(t.get(key, default, "a list of 3 finite numbers >= 0"), t.field(key), 3, ">= 0",
                   lambda x: x >= 0.0)


def _resolution(t: Table) -> tuple[int, int]:
    v = t.get("resolution", list(DEFAULT_RESOLUTION), "")
    ok = (isinstance(v, (list, tuple)) and len(v) == 2
          and all(isinstance(x, int) and not isinstance(x, bool) for x in v))
    if not ok or not (v[0] >= 1 and v[1] >= 2 and v[1] % 2 == 0 and v[0] * v[1] <= MAX_TEXELS):
        raise InputError(t.field("resolution"), "must be [width, height], integers, width >= 1, "
                                                "height even >= 2 (the horizon on a row edge), "
                                                f"width * height <= {MAX_TEXELS}, got {show(v)}")
    return int(v[0]), int(v[1])


def _read_image(t: Table) -> tuple[np.ndarray, str]:
    path = string(t.get("file", REQUIRED, "a path to a lat-long EXR/HDR image"), t.field("file"))
    from drtlab.kernels.imageio import channel_names, read_linear
    existing_file(path, t.field("file"), "an image file (EXR, HDR or any format OpenImageIO reads)")
    try:
        pixels, _, _ = read_linear(Path(path).expanduser())
    except OSError as exc:
        raise InputError(t.field("file"), f"cannot read a lat-long image from {path}: {exc}") from None
    px = np.asarray(pixels, dtype=np.float64)
    if px.ndim == 2:
        px = px[..., None]
    px = _as_rgb(px, channel_names(Path(path).expanduser()) or ("Y",) * px.shape[2], path,
                 t.field("file"))
    if px.shape[0] * px.shape[1] > MAX_TEXELS:
        raise InputError(t.field("file"), f"{path}: {px.shape[1]} x {px.shape[0]} texels, at most "
                                          f"{MAX_TEXELS} allowed")
    if not np.all(np.isfinite(px)) or np.any(px < 0.0):
        raise InputError(t.field("file"), f"{path}: every pixel must be finite and >= 0 (radiance)")
    return px, path


def _as_rgb(px: np.ndarray, names: tuple[str, ...], path: str, field: str) -> np.ndarray:
    """The RGB radiance of an image's channels as Mitsuba 3 reads a bitmap for its envmap: R, G, B
    (and A, ignored) as colour, Y (and A) as grey; any other set of channels (two channels R, G)
    has no colour reading and is refused, as Mitsuba refuses to convert it."""
    short = [n.rsplit(".", 1)[-1].upper() for n in names]
    alpha = int("A" in short)
    if all(c in short for c in "RGB") and len(short) == 3 + alpha:
        return px[..., [short.index(c) for c in "RGB"]]
    if "Y" in short and len(short) == 1 + alpha:
        return np.repeat(px[..., [short.index("Y")]], 3, axis=2)
    raise InputError(field, f"{path} has {len(names)} channels ({', '.join(names)}): an environment "
                            "map needs R, G, B (colour) or Y (grey), each optionally with A (read as "
                            "Mitsuba 3 reads them)")


def _rotation(t: Table) -> np.ndarray | None:
    v = t.get("to_world", None, "")
    if v is None:
        return None
    what = ("must be a rotation matrix: 3 rows of 3 finite numbers, orthonormal with determinant +1 "
            "(the map's frame -> world)")
    try:
        m = np.array([numbers(row, t.field("to_world"), 3) for row in v], dtype=np.float64)
    except (InputError, TypeError):
        m = None
    if (m is None or m.shape != (3, 3) or not np.allclose(m @ m.T, np.eye(3), rtol=0.0,
                                                          atol=ROTATION_TOLERANCE)
            or not abs(np.linalg.det(m) - 1.0) < ROTATION_TOLERANCE):
        raise InputError(t.field("to_world"), f"{what}, got {show(v)}")
    return m


def parse_environment(value: Any) -> EnvironmentMap:
    """The [environment] table validated (kernels/scene_model/SCENE_FORMAT.md): one InputError per bad key or
    value, naming it and what is allowed."""
    t = Table(value, "environment", "[environment]")
    kind = string(t.get("kind", REQUIRED, " | ".join(KINDS)), t.field("kind"), KINDS)
    t.check_keys(KEYS[kind])
    scale = number(t.get("scale", 1.0, ""), t.field("scale"), ">= 0", lambda x: x >= 0.0)
    if kind == "image":
        image, source = _read_image(t)
        lookup = string(t.get("lookup", "texel", ""), t.field("lookup"), LOOKUPS)
        if lookup == "bilinear" and image.shape[0] < 2:
            raise InputError(t.field("lookup"), f"'bilinear' needs an image of at least 2 rows (one "
                                                f"at each pole), {source} has {image.shape[0]}")
        return EnvironmentMap(kind, _scaled(image, scale, t), source, lookup, _rotation(t))
    width, height = _resolution(t)
    if kind == "constant":
        colours = dict(radiance=_color(t, "radiance", [1, 1, 1]))
    elif kind == "two_level":
        colours = dict(upper=_color(t, "upper", [1, 1, 1]), lower=_color(t, "lower", [0, 0, 0]))
    else:
        colours = dict(zenith=_color(t, "zenith", [0.3, 0.5, 1.0]),
                       horizon=_color(t, "horizon", [1, 1, 1]),
                       nadir=_color(t, "nadir", [0.2, 0.2, 0.2]))
    image = procedural(kind, height, width, **colours)
    if t.has("sun_direction") or t.has("sun_radiance"):
        sun = numbers(t.get("sun_direction", REQUIRED, "a non-zero list of 3 finite numbers (towards "
                                                       "the sun)"), t.field("sun_direction"), 3)
        if not np.linalg.norm(sun) > 0.0:
            raise InputError(t.field("sun_direction"), "must be a non-zero list of 3 finite numbers "
                                                       f"(towards the sun), got {show(sun.tolist())}")
        sun_l = _color(t, "sun_radiance", REQUIRED)
        row, col = texels(sun[None, :], height, width)
        image[row[0], col[0]] += sun_l          # one texel: the tiny, very bright source
    return EnvironmentMap(kind, _scaled(image, scale, t), kind)


def _scaled(image: np.ndarray, scale: float, t: Table) -> np.ndarray:
    """The radiance the renderer sees, texels x scale, within the scene's range (SCENE_LIMIT): each
    factor may be in range and their product not (3e38 x 10 is Inf in float32)."""
    with np.errstate(over="ignore"):
        brightest = float(image.max(initial=0.0)) * scale
    if not brightest <= SCENE_LIMIT:
        raise InputError(t.field("scale"), f"the radiance it gives, brightest texel "
                                           f"{float(image.max()):.3g} x scale {scale:g} = "
                                           f"{brightest:.3g}, must be at most {SCENE_LIMIT:g} (what "
                                           "float32 sums and weights of it hold)")
    return image * scale
