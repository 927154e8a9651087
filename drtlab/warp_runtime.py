"""Warp, imported and initialised once and quietly, for every layer (a leaf module like errors.py): its banner and the missing-driver notice of a
machine without a GPU would otherwise precede every line the CLI prints."""
import os
import threading

import warp as wp

if hasattr(wp, "LOG_ERROR"):
    wp.config.log_level = wp.LOG_ERROR
else:  # Warp < 1.19
    wp.config.quiet = True

from drtlab.errors import InputError
from drtlab.fields import writable_location

_lock = threading.Lock()
_ready = False


def warp():
    """The initialised `warp` module (the first call initialises it with stderr silenced)."""
    global _ready
    with _lock:
        if not _ready:
            _check_cache_path()
            # The native library writes the notice to fd 2 itself, below Python's sys.stderr.
            saved = os.dup(2)
            try:
                with open(os.devnull, "w") as devnull:
                    os.dup2(devnull.fileno(), 2)
                    wp.init()
            except OSError as exc:          # the kernel cache's folder, made by init
                raise InputError("WARP_CACHE_PATH", f"Warp cannot make its kernel cache "
                                                    f"{exc.filename or ''}: {exc.strerror or exc}") from None
            finally:
                os.dup2(saved, 2)
                os.close(saved)
            _ready = True
    return wp


def _check_cache_path() -> None:
    """$WARP_CACHE_PATH, where Warp keeps compiled kernels, is a folder it can write: otherwise one
    line naming the variable, not Warp's traceback from inside its initialisation."""
    path = os.environ.get("WARP_CACHE_PATH")
    if path:
        writable_location(path, "WARP_CACHE_PATH", folder=True)
