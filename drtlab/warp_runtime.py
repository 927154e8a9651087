"""Warp, imported and initialised once and quietly, for every layer (a leaf module like errors.py): its banner and the missing-driver notice of a
machine without a GPU would otherwise precede every line the CLI prints."""
import os
import threading

import warp as wp

if hasattr(wp, "LOG_ERROR"):
    wp.config.log_level = wp.LOG_ERROR
else:  # Warp < 1.19
    wp.config.quiet = True

_lock = threading.Lock()
_ready = False


def warp():
    """The initialised `warp` module (the first call initialises it with stderr silenced)."""
    global _ready
    with _lock:
        if not _ready:
            # The native library writes the notice to fd 2 itself, below Python's sys.stderr.
            saved = os.dup(2)
            try:
                with open(os.devnull, "w") as devnull:
                    os.dup2(devnull.fileno(), 2)
                    wp.init()
            finally:
                os.dup2(saved, 2)
                os.close(saved)
            _ready = True
    return wp
