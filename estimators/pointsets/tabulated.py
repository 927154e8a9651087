"""Point sets from a table of points (a `.npy` array, UTK's text format, a `scipy.stats.qmc` engine
or a QMCPy generator): `tabulated(name, source, ...)` builds a PointSet a render and a study use
like a built-in one. Not a point set itself (no POINTSET): a factory, as `digital.py` is a toolbox.

The table (M points x D dimensions in [0, 1)) is compiled into the kernel as 32-bit fixed-point
digits (a static array of a `wp.func_native` snippet: at most MAX_VALUES values), so a draw is one
load. A pixel that takes spp samples reads rows 0 ... spp - 1 (spp > M: rows repeat in sub-blocks
of M, each randomized anew), sample dimensions 0 ... D - 1 jointly from the table's columns (the
pixel (0,1), lens (2,3) and time (4) read the same row: their joint structure is the table's);
dimensions past D are *padded* as pbrt-v4's padded samplers do: 1D dimensions read column 0 and 2D
pairs columns (0, 1), the rows permuted per (seed, pixel, dimension) so they are independent of the
other dimensions while keeping each column's own stratification. The joint dimensions' rows go
through one permutation of their own (per seed, pixel and block: the points stay the table's, in
another order): against an unpermuted order, a padded copy of the same column kept a correlation
(pixel.y against light_pos0.y, (spp - 1) E[r^2] = 1.6 where independent dimensions give 1).

Randomization, per (seed, pixel, dimension, block), so pixels and seeds decorrelate and every value
is uniform on [0, 1) (the estimator unbiased):

* `shift`: Cranley-Patterson rotation, x + U mod 1 (exact in fixed point: addition mod 2^32). Keeps a
  lattice a lattice (a rank-1 lattice or the R2 sequence keeps its spacing and minimum distance on
  the torus); it breaks the elementary intervals of a digital net.
* `xor`: a random digital shift, x XOR U in base 2. Keeps every (t,m,s)-net of a base-2 digital
  net (Sobol', a Sobol'-based scipy engine without scrambling); not a lattice's spacing.
* `owen`: Owen's nested uniform scramble (`digital.owen_scramble`, Burley's hash). Keeps every
  base-2 (t,m,s)-net and, for smooth integrands, gives the scrambled-net variance rates; not a
  lattice's spacing.
* `none`: the table as it is, in its order, the same points in every pixel and for every seed:
  biased by design (a negative control, like Cook's pre-sampled tables).
"""

import hashlib
from pathlib import Path

import numpy as np
import warp as wp

from drtlab.errors import InputError
from drtlab.fields import file_kind

RANDOMIZATIONS = ("owen", "xor", "shift", "none")
MAX_VALUES = 1 << 16            # table entries compiled into a kernel (compile time grows with it)
_UTK_SUFFIXES = (".txt", ".dat", ".pts", ".utk")


def read_table(source, n: int | None = None, field: str = "points") -> np.ndarray:
    """(M, D) float64 points in [0, 1) from an array, a .npy file, a UTK text file (one point per
    line, coordinates separated by blanks; lines starting with '#' skipped) or an engine with
    `random(n)` (scipy.stats.qmc) or `gen_samples(n)` (QMCPy), which needs `n`."""
    if hasattr(source, "random") or hasattr(source, "gen_samples"):
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise InputError("n", f"a point generator needs the number of points n >= 1, got {n!r}")
        table = source.random(n) if hasattr(source, "random") else source.gen_samples(n)
    elif isinstance(source, (str, Path)):
        path = Path(source)
        if file_kind(path) is not None:         # a FIFO would wait for a writer for ever
            raise InputError(field, f"{str(path)!r} is {file_kind(path)}, not a table of points: a "
                                    f".npy array or a UTK text file ({', '.join(_UTK_SUFFIXES)})")
        if not path.is_file():
            raise InputError(field, f"no file {str(path)!r}; expected a .npy array or a UTK text "
                                    f"file ({', '.join(_UTK_SUFFIXES)})")
        try:
            table = np.load(path) if path.suffix == ".npy" else np.loadtxt(path, comments="#", ndmin=2)
        except (ValueError, OSError) as e:
            raise InputError(field, f"{path.name}: not a table of numbers ({e})") from None
    else:
        table = source
    try:
        table = np.asarray(table, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(field, f"must be an (M, D) array of numbers in [0, 1), a file or a point "
                                f"generator, got {type(source).__name__}") from None
    if table.ndim == 1:
        table = table[:, None]
    if table.ndim != 2 or table.shape[0] < 1 or table.shape[1] < 2:
        raise InputError(field, f"must be M points x D >= 2 dimensions, got shape {table.shape}")
    if table.size > MAX_VALUES:
        raise InputError(field, f"{table.shape[0]} x {table.shape[1]} = {table.size} values; at most "
                                f"{MAX_VALUES} are compiled into a kernel (fewer points or dimensions)")
    bad = ~(np.isfinite(table) & (table >= 0.0) & (table < 1.0))
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise InputError(field, f"every value must lie in [0, 1); point {i} dimension {j} is "
                                f"{table[i, j]!r}")
    return table


def fixed_point(table: np.ndarray) -> np.ndarray:
    """uint32 digits: floor(x 2^32), so that 2^-32 units are exact and 1 never appears."""
    return np.minimum(np.floor(table * 4294967296.0), 4294967295.0).astype(np.uint32)


def _rename(fn, name: str):
    # Warp keys a function by its qualified name: two tables in one process need two names.
    fn.__name__ = fn.__qualname__ = name
    return fn


def tabulated(name: str, source, n: int | None = None, randomize: str = "owen",
              description: str | None = None):
    """A PointSet named `name` from the points of `source` (see `read_table`), randomized per pixel
    by `randomize` (module docstring). Its `fingerprint` is the hash of the table and the choice:
    the same table gives the same kernels, another one recompiles."""
    from drtlab.estimators.hashing import hash_key, permute_wide, unit_float, wide_key
    from drtlab.estimators.pointsets.base import PointSet
    from drtlab.estimators.pointsets.digital import owen_scramble

    if randomize not in RANDOMIZATIONS:
        raise InputError("randomize", f"must be one of {', '.join(RANDOMIZATIONS)}, got {randomize!r}")
    table = read_table(source, n)
    bits = fixed_point(table)
    rows, cols = (int(v) for v in bits.shape)
    digest = hashlib.sha256(bits.tobytes() + f"{rows}x{cols}:{randomize}".encode()).hexdigest()[:16]
    tag = f"tab_{digest}"
    mode = RANDOMIZATIONS.index(randomize)
    body = (f"static const unsigned int T[{rows * cols}] = {{{','.join(f'{v}u' for v in bits.ravel())}}};\n"
            f"return T[row * {cols} + col];")

    # Warp reads a native function's return type only under the decorator's own spelling.
    @wp.func_native(body)
    def lookup(row: int, col: int) -> wp.uint32:
        ...

    def randomized(v: wp.uint32, h: wp.uint32) -> wp.uint32:
        if wp.static(mode == 0):
            return owen_scramble(v, h)
        if wp.static(mode == 1):
            return v ^ h
        if wp.static(mode == 2):
            return v + h
        return v

    rand = wp.func(_rename(randomized, f"{tag}_randomized"))

    def draw(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32, spp: wp.uint32,
             comp: wp.uint32, width: wp.uint32) -> float:
        # One component of a `width`-wide slot starting at `dim`: (block, row) of the sample, the
        # column (joint below the table's width, padded past it), then the randomization.
        n = wp.max(spp, wp.uint32(1))
        per = wp.min(n, wp.uint32(wp.static(rows)))
        block = (index // n) * ((n + per - wp.uint32(1)) // per) + (index % n) // per
        row = (index % n) % per
        col = dim + comp
        key = wp.uint32(0x6A0177ED)                 # the joint dimensions share one row permutation
        if dim + width > wp.uint32(wp.static(cols)):
            key = dim
            col = comp
        if wp.static(mode != 3):
            row = permute_wide(row, per, wide_key(hash_key(seed, pixel, block, key), key))
        h = wp.uint32(0)
        if wp.static(mode != 3):
            h = hash_key(seed ^ wp.uint32(0x7AB1E5ED), pixel, block, dim + comp)
        return unit_float(rand(lookup(int(row), int(col)), h))

    draw_f = wp.func(_rename(draw, f"{tag}_draw"))

    def get1d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> float:
        return draw_f(seed, pixel, index, dim, spp, wp.uint32(0), wp.uint32(1))

    def get2d(seed: wp.uint32, pixel: wp.uint32, index: wp.uint32, dim: wp.uint32,
              spp: wp.uint32) -> wp.vec2:
        return wp.vec2(draw_f(seed, pixel, index, dim, spp, wp.uint32(0), wp.uint32(2)),
                       draw_f(seed, pixel, index, dim, spp, wp.uint32(1), wp.uint32(2)))

    what = description or f"a table of {rows} points in {cols} dimensions"
    return PointSet(name, f"{what}, {randomize} randomization per pixel", wp.func(_rename(get1d, f"{tag}_1d")),
                    wp.func(_rename(get2d, f"{tag}_2d")), biased=randomize == "none",
                    fingerprint=digest)
