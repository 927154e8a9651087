"""Image output for the experiment code: EXR with metadata, sRGB display conversion, atomic writes.

Uses `drtlab.kernels.imageio` when present, with a thin OpenImageIO fallback, so that the experiment
code works whichever lands first.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np


def linear_to_srgb(img: np.ndarray) -> np.ndarray:
    """Linear radiance -> display sRGB in [0, 1] (clipped, IEC 61966-2-1 transfer curve)."""
    x = np.clip(np.nan_to_num(np.asarray(img, dtype=np.float64), nan=0.0, posinf=1.0), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_srgb8(img: np.ndarray) -> np.ndarray:
    return np.round(linear_to_srgb(img) * 255.0).astype(np.uint8)


def _tmp_near(path: Path, suffix: str) -> str:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    return tmp


def write_exr(path, img: np.ndarray, metadata: dict | None = None) -> None:
    """Write a float EXR atomically (temp file in the same folder + os.replace)."""
    path = Path(path)
    tmp = _tmp_near(path, ".exr")
    try:
        try:
            from drtlab.kernels.imageio import write_exr as _write  # type: ignore[import-not-found]
        except ImportError:
            _write = _oiio_write_exr
        _write(tmp, np.asarray(img, dtype=np.float32), metadata or {})
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _oiio_write_exr(path, img, metadata):
    import OpenImageIO as oiio
    h, w = img.shape[:2]
    c = img.shape[2] if img.ndim == 3 else 1
    spec = oiio.ImageSpec(w, h, c, "float")
    for k, v in metadata.items():
        spec.attribute(f"drtlab:{k}", v if isinstance(v, str) else json.dumps(v))
    out = oiio.ImageOutput.create(str(path))
    if out is None or not out.open(str(path), spec):
        raise OSError(f"cannot write {path}: {oiio.geterror()}")
    out.write_image(np.ascontiguousarray(img, dtype=np.float32))
    out.close()


def read_exr(path) -> np.ndarray:
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    try:
        return np.asarray(inp.read_image("float"), dtype=np.float32)
    finally:
        inp.close()


def atomic_write_bytes(path, data: bytes) -> None:
    path = Path(path)
    tmp = _tmp_near(path, ".tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def atomic_write_text(path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def clean_json(o):
    """Non-finite floats -> None (strict JSON), numpy scalars/arrays and tuples -> Python values."""
    if isinstance(o, dict):
        return {str(k): clean_json(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [clean_json(v) for v in o]
    if isinstance(o, np.ndarray):
        return clean_json(o.tolist())
    if isinstance(o, (np.floating, float)):
        f = float(o)
        return f if np.isfinite(f) else None
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    return o


def atomic_write_json(path, obj) -> None:
    text = json.dumps(clean_json(obj), indent=2, allow_nan=False, default=_json_default)
    atomic_write_text(path, text + "\n")


def atomic_savez(path, **arrays) -> None:
    import io
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


def _json_default(o):
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    if isinstance(o, tuple):
        return list(o)
    raise TypeError(f"not JSON serializable: {type(o).__name__}")
