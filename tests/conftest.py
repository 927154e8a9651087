"""Shared test setup: keep Warp's compiled kernels in the checkout's cache (as `make test` does)."""
import os
from pathlib import Path

# Set before anything imports Warp, so a plain `pytest` run reuses (and fills) the same kernel cache.
os.environ.setdefault("WARP_CACHE_PATH", str(Path(__file__).resolve().parent.parent / ".warp-cache"))
