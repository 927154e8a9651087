"""Validation of values read from TOML (scene and experiment files) and from command-line flags.

Every check returns the converted value or raises one `InputError` whose field is the dotted path of
the offending value (`shapes[2].radius`, `experiment.spp[1]`, `--res`) and whose message says what is
allowed and what was given.
"""
from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from drtlab.errors import InputError

REQUIRED = object()         # sentinel default: the key must be present
# The kernels take a seed (and a pixel key) as a uint32 and a sample count as an int32.
MAX_SEED = 2**32 - 1
MAX_COUNT = 2**31 - 1
MAX_BUDGET_SECONDS = 1e7    # a time-budget render's longest budget (`drtlab render --seconds`)

def show(v: Any) -> str:
    """A value as the user wrote it (TOML spelling for booleans), shortened for messages."""
    if isinstance(v, bool):
        text = "true" if v else "false"
    elif isinstance(v, str):
        text = f"'{v}'"
    elif isinstance(v, dict):
        text = "a table"
    else:
        try:
            text = repr(v)
        except RecursionError:          # a list nested thousands deep
            text = f"a {type(v).__name__} nested too deep to show"
    return text if len(text) <= 80 else text[:77] + "..."


def is_number(v: Any) -> bool:
    # bool is a subclass of int in Python, but `true` is not a number in a scene file.
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def finite_float(v: Any) -> float | None:
    """float(v) if v is a finite number, else None (huge ints that overflow count as infinite)."""
    if not is_number(v):
        return None
    try:
        f = float(v)
    except OverflowError:
        return None
    return f if math.isfinite(f) else None


def number(v: Any, field: str, rule: str = "", ok: Callable[[float], bool] | None = None,
           limit: float = math.inf) -> float:
    f = finite_float(v)
    if f is None or abs(f) > limit or (ok is not None and not ok(f)):
        bound = f" of magnitude at most {limit:g}" if limit < math.inf else ""
        raise InputError(field, f"must be a finite number{bound}{' ' + rule if rule else ''}, got {show(v)}")
    return f


# Scene values are traced in float32 (about 3.4e38 at most): a position, size or radiance beyond
# this keeps its square, and its products with sampling weights, finite there. Beyond it a sphere
# silently vanished or emission rendered Inf pixels.
SCENE_LIMIT = 1e15
# What float32 holds: derived quantities (an area, a density, a normalisation, a product of two
# values) are checked against these, not only the values a file spells.
FLOAT32_MAX = float(np.finfo(np.float32).max)       # 3.4e38
FLOAT32_TINY = float(np.finfo(np.float32).tiny)     # 1.2e-38, the smallest normal float32
# MIS squares a light's solid-angle density d^2 / (A cos): that square stays finite while
# A >= d^2 / sqrt(FLOAT32_MAX), i.e. an emitter's area is at least this times the scene's extent
# squared (measured: a 1e-10 x 1e-10 quad light 2 units away rendered NaN pixels, 1e-9 did not).
EMITTER_AREA_SHARE = 1.0 / math.sqrt(FLOAT32_MAX)   # 5.4e-20
# A Phong lobe cos^n is narrower than float32 resolves near its axis (1 - cos steps by 2^-24) once
# n passes 2^24: its sampled cosines u^(1/(n+1)) round to 1 and its density overflows (measured:
# NaN pixels from n = 1e9, none at 1e8).
PHONG_EXPONENT_MAX = float(2 ** 24)
# A conductor's Fresnel squares eta^2 + k^2 (|eta + i k|^2 of each channel): that stays finite in
# float32 while eta^2 + k^2 <= sqrt(FLOAT32_MAX) (measured: eta = k = 3e9 renders, 1e10 gave NaN
# pixels; real metals have both below 10).
CONDUCTOR_NORM_MAX = math.sqrt(FLOAT32_MAX)          # 1.8e19


def scene_number(v: Any, field: str, rule: str = "", ok: Callable[[float], bool] | None = None) -> float:
    """`number` within the scene's range (SCENE_LIMIT)."""
    return number(v, field, rule, ok, SCENE_LIMIT)


def scene_numbers(v: Any, field: str, n: int, rule: str = "",
                  ok: Callable[[float], bool] | None = None) -> np.ndarray:
    """`numbers` within the scene's range (SCENE_LIMIT)."""
    return numbers(v, field, n, rule, ok, SCENE_LIMIT)


def scene_colour(v: Any, field: str) -> np.ndarray:
    """A radiance-like colour of a scene: 3 numbers, any non-negative value."""
    return scene_numbers(v, field, 3, ">= 0", lambda x: x >= 0.0)


def scene_albedo(v: Any, field: str) -> np.ndarray:
    """A reflectance-like colour of a scene: energy conservation needs every channel in [0, 1]."""
    return scene_numbers(v, field, 3, "in [0, 1]", lambda x: 0.0 <= x <= 1.0)


def integer(v: Any, field: str, rule: str = "", ok: Callable[[int], bool] | None = None) -> int:
    if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or (ok is not None and not ok(v)):
        raise InputError(field, f"must be an integer{' ' + rule if rule else ''}, got {show(v)}")
    return int(v)


def numbers(v: Any, field: str, n: int, rule: str = "",
            ok: Callable[[float], bool] | None = None, limit: float = math.inf) -> np.ndarray:
    """A list of exactly n finite numbers (magnitude at most `limit`), each satisfying `ok` (the
    per-channel rule)."""
    bound = f" of magnitude at most {limit:g}" if limit < math.inf else ""
    what = f"a list of {n} finite numbers{bound}{' each ' + rule if rule else ''}"
    if not isinstance(v, (list, tuple)) or len(v) != n:
        raise InputError(field, f"must be {what}, got {show(v)}")
    values = [finite_float(x) for x in v]
    if any(x is None or abs(x) > limit for x in values) or (ok is not None and not all(ok(x) for x in values)):
        raise InputError(field, f"must be {what}, got {show(v)}")
    return np.array(values, dtype=np.float64)



def string(v: Any, field: str, choices: Sequence[str] | None = None) -> str:
    if choices is not None:
        if not isinstance(v, str) or v not in choices:
            raise InputError(field, f"must be one of {', '.join(choices)}; got {show(v)}")
        return v
    if not isinstance(v, str):
        raise InputError(field, f"must be a string, got {show(v)}")
    return v


def nonempty_string(v: Any, field: str) -> str:
    if not isinstance(v, str) or not v.strip():
        raise InputError(field, f"must be a non-empty string, got {show(v)}")
    return v


def check_keys(table: Any, allowed: Sequence[str], path: str, what: str = "") -> None:
    """`table` is a dict whose every key is in `allowed`; `path` is its dotted name ('' at the top)."""
    if not isinstance(table, dict):
        raise InputError(path or "file", f"must be a table{f' ({what})' if what else ''}, got {show(table)}")
    for key in table:
        if key not in allowed:
            raise InputError(f"{path}.{key}" if path else str(key),
                             f"unknown key '{key}'{f' in {what}' if what else ''}; "
                             f"allowed keys: {', '.join(allowed)}")


def boolean(v: Any, field: str) -> bool:
    if not isinstance(v, bool):
        raise InputError(field, f"must be true or false, got {show(v)}")
    return v


class Table:
    """One TOML table under validation: knows its dotted path, checks its keys, reads its values."""

    def __init__(self, value: Any, path: str, what: str):
        if not isinstance(value, dict):
            raise InputError(path, f"must be a table ({what}), got {show(value)}")
        self.data = value
        self.path = path
        self.what = what

    def field(self, key: str) -> str:
        return f"{self.path}.{key}"

    def check_keys(self, allowed: Sequence[str]) -> None:
        check_keys(self.data, allowed, self.path, self.what)

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, default: Any, describe: str) -> Any:
        """The raw value, the default, or an error saying the key is required and what it holds."""
        if key in self.data:
            return self.data[key]
        if default is REQUIRED:
            raise InputError(self.field(key), f"is required ({describe}) but missing")
        return default


def integer_in(v: Any, field: str, low: int, high: int | None = None) -> int:
    """An integer in [low, high] (high None: no upper bound)."""
    rule = f">= {low}" if high is None else f"in [{low}, {high}]"
    return integer(v, field, rule, lambda n: n >= low and (high is None or n <= high))


def int_text(text: str, field: str, low: int, high: int | None = None) -> int:
    """A command-line integer such as `--spp 64`."""
    try:
        value = int(text)
    except (TypeError, ValueError):
        rule = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise InputError(field, f"must be an integer {rule}, got {show(text)}") from None
    return integer_in(value, field, low, high)


def budget_seconds(v: Any, field: str) -> float:
    """A time budget in seconds, > 0 and at most MAX_BUDGET_SECONDS; text (a flag) is read as a
    number first."""
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            pass
    return number(v, field, f"of seconds in (0, {MAX_BUDGET_SECONDS:g}]",
                  lambda x: 0.0 < x <= MAX_BUDGET_SECONDS)


def resolution(v: Any, field: str, aspect: float | None = None,
               name_elements: bool = False) -> tuple[int, int]:
    """[W, H] or `WxH`; also `N` (width N, height N * aspect) where an aspect (H / W) is known.

    With `name_elements`, a bad entry of a two-entry list is named as `field[i]`."""
    if name_elements and isinstance(v, (list, tuple)) and len(v) == 2:
        w, h = (integer_in(x, f"{field}[{i}]", 1) for i, x in enumerate(v))
        return w, h
    vals: list = []
    if isinstance(v, str):
        try:
            vals = [int(p) for p in v.lower().split("x")]
        except ValueError:
            vals = []
    elif isinstance(v, (int, np.integer)) and not isinstance(v, bool):
        vals = [int(v)]
    elif isinstance(v, (list, tuple)) and all(isinstance(x, (int, np.integer)) and not isinstance(x, bool)
                                              for x in v):
        vals = [int(x) for x in v]
    if len(vals) == 2 and min(vals) >= 1:
        return vals[0], vals[1]
    if len(vals) == 1 and vals[0] >= 1 and aspect is not None:
        return vals[0], max(1, round(vals[0] * aspect))
    allowed = "[width, height] of 2 integers >= 1, or WxH"
    if aspect is not None:
        allowed += ", or N (width N, height from the scene's aspect)"
    raise InputError(field, f"must be {allowed}, got {show(v)}")


def path_text(text: str, field: str) -> str:
    """A path from a flag or the environment: an empty one is refused (Python reads '' as the
    current folder, so it would write there, or to the default, unasked)."""
    if not text.strip():
        raise InputError(field, "is empty: give a path, or leave it out for the default")
    return text


def writable_location(path, field: str, folder: bool = False):
    """Check, before any long work, that `path` (a file, or a folder with `folder`) can be written:
    its first existing ancestor is a folder in which files can be created. Folders made to probe are
    removed again, so a rejected path leaves nothing behind. Returns `path` as a Path."""
    import tempfile
    from pathlib import Path
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(field, f"must be a {'folder' if folder else 'file'} path (a str or "
                                f"os.PathLike), got {show(path)}")
    if isinstance(path, str):
        path_text(path, field)
    target = Path(path).expanduser()
    name_lengths(target, field)
    if folder and target.exists() and not target.is_dir():
        raise InputError(field, f"{target} exists and is not a folder")
    if not folder and target.is_dir():
        raise InputError(field, f"{target} is a folder; give a file path")
    start = target if folder else target.parent
    missing = []
    probe_dir = start
    while not probe_dir.exists():
        missing.append(probe_dir)
        probe_dir = probe_dir.parent
    if not probe_dir.is_dir():
        raise InputError(field, f"cannot write {target}: {probe_dir} is a file, not a folder")
    made = []
    try:
        for d in reversed(missing):
            d.mkdir()
            made.append(d)
        fd, probe = tempfile.mkstemp(prefix=".drtlab-probe-", dir=start)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise InputError(field, f"cannot write {target}: {reason} ({exc.filename or start})") from None
    finally:
        for d in reversed(made):
            try:
                d.rmdir()
            except OSError:
                pass
    return target


def output_files(paths, field: str) -> list:
    """Check, before any long work, every file a command will write (an image and the files beside
    it): none is a folder or another non-file thing, each name fits the file system, and each folder
    takes new files (`writable_location`). A command that checks all of them first never stops
    halfway through its writes, with some files written and its work lost. Returns them as Paths."""
    from pathlib import Path
    out = []
    for path in paths:
        path = Path(path).expanduser()
        name_lengths(path, field)
        if path.is_dir():
            raise InputError(field, f"{path} is a folder, and this command writes a file of that name; "
                                    "choose another output name or move the folder")
        if path.exists() and not path.is_file():
            raise InputError(field, f"{path} exists and is not a regular file (a device, FIFO or "
                                    "socket); choose another output name")
        writable_location(path, field)
        out.append(path)
    return out


def name_lengths(path, field: str) -> None:
    """Each name along `path` fits its file system (a longer one fails every call on it, `exists`
    included): an InputError naming `field` otherwise."""
    from pathlib import Path
    path = Path(path)
    base, limit = Path(path.anchor or "."), 255
    for part in Path(path).parts[1 if path.anchor else 0:]:
        try:
            limit = os.pathconf(base, "PC_NAME_MAX") if base.is_dir() else limit
        except (OSError, ValueError):
            pass
        size = len(os.fsencode(part))
        if size > limit:
            raise InputError(field, f"the name {show(part)} is {size} bytes long; this file system "
                                    f"takes names of at most {limit} bytes")
        base = base / part


# Levels of arrays and tables a value may nest: far past any scene's or study's, and well within
# the recursion Python's parsers, copies and messages need (3000 levels raised RecursionError).
MAX_NESTING = 64


def too_deep(field: str) -> InputError:
    return InputError(field, f"arrays, tables or elements nested more than {MAX_NESTING} levels deep; "
                             "no value of drtlab's nests that far")


def check_nesting(value: Any, field: str) -> Any:
    """`value` (a parsed TOML table, a dict from the API) nests at most MAX_NESTING levels; walked
    without recursion, so any depth gets the one-line error."""
    stack = [(value, 0)]
    while stack:
        v, depth = stack.pop()
        if depth > MAX_NESTING:
            raise too_deep(field)
        if isinstance(v, dict):
            stack.extend((x, depth + 1) for x in v.values())
        elif isinstance(v, (list, tuple)):
            stack.extend((x, depth + 1) for x in v)
    return value


def file_kind(path) -> str | None:
    """What `path` is when it is no regular file: 'a folder', 'a FIFO (named pipe)', 'a device',
    'a socket'; None for a regular file or nothing at all."""
    import stat
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    for test, what in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return what
    return None


def existing_file(path, field: str, what: str):
    """`path` as a Path to an existing regular file, or one InputError saying what it is instead:
    empty, missing, a folder, a FIFO (reading one would wait for a writer for ever), a device.
    `what` names the file wanted ('an image file', 'a mesh file (.obj or .ply)')."""
    from pathlib import Path
    if not isinstance(path, (str, Path)) or not str(path).strip():
        raise InputError(field, f"must be a path to {what}, got {show(path)}")
    p = Path(path).expanduser()
    name_lengths(p, field)
    kind = file_kind(p)
    if kind is not None:
        raise InputError(field, f"'{path}' is {kind}, not {what}")
    if not p.is_file():
        raise InputError(field, f"'{path}' does not exist (wanted {what})")
    return p
