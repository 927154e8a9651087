"""drtlab's version, the one definition (pyproject.toml reads it; `drtlab.__version__` re-exports it):
a leaf, so a layer that stamps it into a manifest imports no part of the surface."""
__version__ = "0.1.0"
