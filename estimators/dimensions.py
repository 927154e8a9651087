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
"""
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


def bounce_dim(bounce: int, offset: int) -> int:
    return BOUNCE_BASE + PER_BOUNCE * bounce + offset


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
    bounce, offset = divmod(dim - BOUNCE_BASE, PER_BOUNCE)
    if bounce > 0 or offset >= ROULETTE:
        return 5
    return 3 if offset < LOBE_CHOICE else 4
