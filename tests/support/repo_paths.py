"""Paths of the checkout the tests run in: the repository root and its .venv's executables."""
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SUPPORT = Path(__file__).resolve().parent
PYTHON = REPO / ".venv" / "bin" / "python"
DRTLAB = REPO / ".venv" / "bin" / "drtlab"
PLUGIN_EXAMPLES = REPO / "examples" / "plugins"
