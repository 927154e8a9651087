"""Rendering machinery that stays fixed while a study varies estimators: scenes, kernels, I/O."""
import hashlib
from pathlib import Path


def _code_version() -> str:
    """Hash of the kernel and estimator sources: a ground truth rendered by other code is stale."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for folder in (root, root.parent / "estimators"):
        for path in sorted(folder.rglob("*.py")):
            h.update(path.relative_to(folder.parent).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()[:16]


CODE_VERSION = _code_version()
