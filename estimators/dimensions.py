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
