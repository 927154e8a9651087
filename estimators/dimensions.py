"""The one place the sample dimensions are laid out ("chaining the ray id", Cook 1984).

A sample is keyed by (seed, pixel, sample index); every random decision of that sample reads one
dimension of the point set. The layout is fixed, so a dimension means the same thing whether or not
a scene uses the others (a static scene never reads TIME, yet its LENS values are unchanged).

    0-1   pixel position (2D)
    2-3   lens position (2D)
    4     time within the shutter (1D)
    5 + 8*b + ...   for bounce b = 0, 1, 2, ...
        +0  light choice (1D)
        +1  position on the light (2D: +1, +2)
        +3  lobe choice (reflect / transmit) (1D)
        +4  scattered direction (2D: +4, +5)
        +6  Russian roulette (1D)
        +7  reserved

The dimension groups (what a variance decomposition, `drtlab sources`, draws from a second seed one
at a time), each a distributed effect of Cook 1984:
    pixel      0-1: the pixel area (antialiasing)
    lens       2-3: the lens aperture (depth of field)
    time       4: the shutter time (motion blur)
    light      bounce 0, +0 ... +2: which light and where on it, at the first hit (soft shadows)
    direction  bounce 0, +3 ... +5: the lobe and the scattered direction at the first hit (gloss,
               translucency, the first diffuse bounce)
    later      every dimension of bounces 1, 2, ... and the first hit's Russian roulette: what the
               path does after its first scattering, together

An integrator's own decisions (a plugin's splitting count, one-sample MIS's choice of technique:
its `DIMENSIONS`, ((name, size), ...)) get dimensions of their own, after every built-in one:
    OWN_BASE + stride * b + offset(name)    (stride: the sum of the sizes it declares)
so declaring one moves no built-in dimension (an integrator that reads only the built-in ones draws
exactly today's values) and no other of its own (`own_layout`). Their group is `later`.

Everything that computes with the layout is here, in Python (`split`, `slot`, `label`, `group_of`,
`tracer_dims`) and in Warp (`warp_functions()`: a bounce's first dimension, a dimension's offset
within its bounce, its group), so that no other module redoes the arithmetic.
"""
import functools
from typing import NamedTuple

PIXEL = 0
LENS = 2
TIME = 4
BOUNCE_BASE = 5
PER_BOUNCE = 8
LIGHT_CHOICE = 0
LIGHT_POSITION = 1
LOBE_CHOICE = 3
DIRECTION = 4
ROULETTE = 6
# The first dimension of an integrator's own decisions: past any built-in one a path reads
# (bounce_dim(DEPTH_CAP = 512, 0) is ~4e3), so no layout of bounces reaches it.
OWN_BASE = 1 << 20
# What the API names the built-in per-bounce decisions (their offset within a bounce's 8).
BUILT_IN = {"light_choice": (LIGHT_CHOICE, 1), "light_position": (LIGHT_POSITION, 2),
            "lobe_choice": (LOBE_CHOICE, 1), "direction": (DIRECTION, 2), "roulette": (ROULETTE, 1)}


def bounce_dim(bounce: int, offset: int) -> int:
    return BOUNCE_BASE + PER_BOUNCE * bounce + offset


def own_layout(declared) -> tuple[dict, int]:
    """({name: offset within a bounce's own block}, the block's size) of an integrator's own
    decisions `declared`, ((name, size), ...), in the order declared; ValueError on a bad entry
    (the registration words it for the user)."""
    offsets, at = {}, 0
    for entry in declared or ():
        if not (isinstance(entry, tuple) and len(entry) == 2 and isinstance(entry[0], str)
                and isinstance(entry[1], int) and not isinstance(entry[1], bool) and entry[1] >= 1):
            raise ValueError(f"each entry is (name, size >= 1), got {entry!r}")
        name, size = entry
        if name in offsets or name in BUILT_IN:
            raise ValueError(f"the decision {name!r} is declared twice or is a built-in one "
                             f"({', '.join(BUILT_IN)})")
        offsets[name] = at
        at += size
    return offsets, at


def own_dim(stride: int, bounce: int, offset: int) -> int:
    """The dimension of an integrator's own decision at `offset` of bounce `bounce` (own_layout)."""
    return OWN_BASE + stride * bounce + offset


def split(dim: int) -> tuple[int, int] | None:
    """(bounce, offset within it) of a built-in per-bounce dimension; None for the camera's (pixel,
    lens, time) and an integrator's own (OWN_BASE on)."""
    return None if dim < BOUNCE_BASE or dim >= OWN_BASE else divmod(dim - BOUNCE_BASE, PER_BOUNCE)


def slot(dim: int) -> tuple[int, int]:
    """(1 or 2, first dimension of the slot): how the tracer reads dimension `dim` (get1d, or one
    component of a get2d pair: pixel, lens, light position, direction)."""
    for start in (PIXEL, LENS):
        if start <= dim < start + 2:
            return 2, start
    at = split(dim)
    if at is not None:
        base = dim - at[1]
        for offset in (LIGHT_POSITION, DIRECTION):
            if base + offset <= dim < base + offset + 2:
                return 2, base + offset
    return 1, dim


_BOUNCE_LABELS = {LIGHT_CHOICE: "light_choice", LIGHT_POSITION: "light_pos.x",
                  LIGHT_POSITION + 1: "light_pos.y", LOBE_CHOICE: "lobe_choice",
                  DIRECTION: "direction.x", DIRECTION + 1: "direction.y", ROULETTE: "roulette"}
_CAMERA_LABELS = {PIXEL: "pixel.x", PIXEL + 1: "pixel.y", LENS: "lens.x", LENS + 1: "lens.y",
                  TIME: "time"}


def label(dim: int) -> str:
    """What the tracer reads dimension `dim` for: `pixel.x`, `direction0.y`, `reserved1` (a
    per-bounce dimension the tracer never reads)."""
    if dim >= OWN_BASE:
        return f"own.{dim - OWN_BASE}"
    at = split(dim)
    if at is None:
        return _CAMERA_LABELS[dim]
    bounce, offset = at
    name = _BOUNCE_LABELS.get(offset)
    if name is None:
        return f"reserved{bounce}"
    head, _, tail = name.partition(".")
    return f"{head}{bounce}" + (f".{tail}" if tail else "")


def tracer_dims(bounces: int) -> list[int]:
    """The dimensions a path of `bounces` bounces reads, in order (the reserved ones left out)."""
    return [d for d in range(bounce_dim(bounces, 0)) if not label(d).startswith("reserved")]


GROUPS = ("pixel", "lens", "time", "light", "direction", "later")


def group_of(dim: int) -> int:
    """The index in GROUPS of dimension `dim` (the kernels' `pickfreeze` point set computes the same
    in Warp; tests compare the two)."""
    if dim < LENS:
        return 0
    if dim < TIME:
        return 1
    if dim < BOUNCE_BASE:
        return 2
    if dim >= OWN_BASE:
        return 5
    bounce, offset = split(dim)
    if bounce > 0 or offset >= ROULETTE:
        return 5
    return 3 if offset < LOBE_CHOICE else 4


class WarpDimensions(NamedTuple):
    bounce_base: object      # (depth: int) -> uint32, the first dimension of bounce `depth`
    bounce_offset: object    # (dim: uint32) -> int, the offset within its bounce, -1 for the camera's
                             # and an integrator's own
    group: object            # (dim: uint32) -> int, group_of


@functools.cache
def warp_functions() -> WarpDimensions:
    """The layout's arithmetic as Warp functions (built on first use: this module stays Warp-free
    for the analysis code that imports it)."""
    import warp as wp

    @wp.func
    def bounce_base(depth: int) -> wp.uint32:
        return wp.uint32(wp.static(BOUNCE_BASE)) + wp.uint32(wp.static(PER_BOUNCE)) * wp.uint32(depth)

    @wp.func
    def bounce_offset(dim: wp.uint32) -> int:
        if dim < wp.uint32(wp.static(BOUNCE_BASE)) or dim >= wp.uint32(wp.static(OWN_BASE)):
            return -1
        return int((dim - wp.uint32(wp.static(BOUNCE_BASE))) % wp.uint32(wp.static(PER_BOUNCE)))

    @wp.func
    def group(dim: wp.uint32) -> int:
        d = int(dim)
        if d < wp.static(LENS):
            return 0
        if d < wp.static(TIME):
            return 1
        if d < wp.static(BOUNCE_BASE):
            return 2
        rel = d - wp.static(BOUNCE_BASE)
        offset = rel % wp.static(PER_BOUNCE)
        if rel >= wp.static(PER_BOUNCE) or offset >= wp.static(ROULETTE):
            return 5
        if offset < wp.static(LOBE_CHOICE):
            return 3
        return 4

    return WarpDimensions(bounce_base, bounce_offset, group)
