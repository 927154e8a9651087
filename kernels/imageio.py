"""Image output: float32 EXR with metadata (OpenImageIO) and an sRGB PNG preview (kernels/colour.py)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drtlab.kernels.colour import srgb_to_linear, to_srgb


def to_srgb8(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB."""
    return np.clip(np.round(to_srgb(image) * 255.0), 0, 255).astype(np.uint8)


# An EXR int attribute is 32 bits: an integer outside them (a seed up to 2^32 - 1, any Python int)
# is stored as its decimal text under this prefix instead, and read back as the int.
INT_TEXT = "drtlab-int:"
INT32 = (-2**31, 2**31 - 1)


def _attributes(metadata) -> list[tuple[str, object]]:
    """(attribute name, value) of each metadata entry, as OpenImageIO stores it losslessly."""
    from drtlab.errors import InputError
    if metadata is None:
        return []
    if not isinstance(metadata, dict) or not all(isinstance(k, str) and k for k in metadata):
        raise InputError("metadata", f"must be a dict of names (non-empty strings) to numbers or "
                                     f"strings, got {_shown(metadata)}")
    out = []
    for key, value in metadata.items():
        if isinstance(value, (bool, np.bool_)):
            out.append((f"drtlab:{key}", str(bool(value)).lower()))
        elif isinstance(value, (int, np.integer)):
            value = int(value)
            out.append((f"drtlab:{key}", value) if INT32[0] <= value <= INT32[1]
                       else (f"{INT_TEXT}{key}", str(value)))
        elif isinstance(value, (float, np.floating)):
            out.append((f"drtlab:{key}", float(value)))
        else:
            out.append((f"drtlab:{key}", str(value)))
    return out


def _metadata(spec) -> dict:
    """The drtlab metadata of an image's attributes (`_attributes` read back)."""
    meta = {}
    for a in spec.extra_attribs:
        if a.name.startswith("drtlab:"):
            meta[a.name[len("drtlab:"):]] = a.value
        elif a.name.startswith(INT_TEXT):
            try:
                meta[a.name[len(INT_TEXT):]] = int(a.value)
            except (TypeError, ValueError):
                meta[a.name[len(INT_TEXT):]] = a.value
    return meta


def _shown(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def _path_argument(path, suffix: str | None = None) -> Path:
    """`path` as a Path, or an InputError naming `path` (not a path, or not ending in `suffix`; an
    output's name too long or a folder)."""
    from drtlab.errors import InputError
    from drtlab.fields import name_lengths
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InputError("path", f"must be a file path (a non-empty str or os.PathLike), got "
                                 f"{_shown(path)}")
    path = Path(path)
    if suffix is not None:
        if path.suffix.lower() != suffix:
            raise InputError("path", f"must be a file name ending in {suffix}, got {str(path)!r}")
        name_lengths(path, "path")
        if path.is_dir():
            raise InputError("path", f"{str(path)!r} is a folder; give a file name")
    return path


def _image_argument(image) -> np.ndarray:
    """`image` as an (H, W, C) array of real numbers with H, W, C >= 1, or an InputError naming it."""
    from drtlab.errors import InputError
    try:
        a = None if image is None else np.asarray(image)
    except (ValueError, TypeError) as exc:          # ragged, or nested past numpy's 64 dimensions
        raise InputError("image", f"must be an (H, W, C) array of real numbers, got a "
                                  f"{type(image).__name__} numpy cannot read as one ({exc})") from None
    if a is None or a.ndim != 3 or min(a.shape) < 1 or a.dtype.kind not in "biuf":
        what = ("None" if a is None else f"an array of shape {a.shape} and dtype {a.dtype}")
        raise InputError("image", f"must be an (H, W, C) array of real numbers with H, W, C >= 1 "
                                  f"(a single-channel image as (H, W, 1)), got {what}")
    return a


def _write(path: Path, pixels: np.ndarray, fmt, metadata: dict | None) -> None:
    import OpenImageIO as oiio
    path = Path(path)
    attributes = _attributes(metadata)
    h, w, c = pixels.shape
    path.parent.mkdir(parents=True, exist_ok=True)
    # Write beside the target and rename, so a crash never leaves a half-written image; the name is
    # bounded, so a target name near the file system's limit still has one.
    tmp = path.with_name(f".{path.stem[:64]}.{os.getpid()}.tmp{path.suffix}")
    spec = oiio.ImageSpec(w, h, c, fmt)
    for name, value in attributes:
        spec.attribute(name, value)
    try:
        out = oiio.ImageOutput.create(str(tmp))
        if out is None or not out.open(str(tmp), spec):
            raise OSError(f"cannot write {path}: {oiio.geterror()}")
        ok = out.write_image(pixels)
        out.close()
        if not ok:
            raise OSError(f"cannot write {path}: {oiio.geterror()}")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_exr(path, image: np.ndarray, metadata: dict | None = None) -> None:
    """A float32 EXR; a bad argument is an InputError naming it, before anything is written."""
    import OpenImageIO as oiio
    path = _path_argument(path, ".exr")
    _write(path, float32_pixels(_image_argument(image)), oiio.FLOAT, metadata)


def float32_pixels(image, field: str = "image") -> np.ndarray:
    """`image` as the float32 an EXR stores: real numbers only, and no finite value float32 turns
    into Inf (1e39); NaN and Inf already in it are kept, as written."""
    from drtlab.errors import InputError
    a = np.asarray(image)
    if a.dtype.kind not in "biuf":
        raise InputError(field, f"must hold real numbers (an EXR stores float32), got dtype {a.dtype}")
    if a.dtype.kind == "f" and a.dtype.itemsize > 4:
        finite = np.isfinite(a)
        big = np.abs(a, where=finite, out=np.zeros_like(a)) > np.finfo(np.float32).max
        if big.any():
            raise InputError(field, f"{int(big.sum())} finite values exceed float32's range "
                                    f"(|x| <= {np.finfo(np.float32).max:.3g}), e.g. "
                                    f"{float(a[big].flat[0]):.3g}: an EXR would store Inf")
    return np.ascontiguousarray(a, dtype=np.float32)


def nonfinite_note(image) -> str | None:
    """'N of M pixels are NaN or Inf' where an image has such pixels, else None."""
    a = np.asarray(image)
    bad = ~np.isfinite(a)
    if a.ndim == 3:
        bad = bad.any(axis=-1)
    count = int(bad.sum())
    if not count:
        return None
    return f"{count} of {bad.size} pixels are NaN or Inf"


def write_png(path, image: np.ndarray, metadata: dict | None = None) -> None:
    import OpenImageIO as oiio
    path = _path_argument(path, ".png")
    _write(path, np.ascontiguousarray(to_srgb8(_image_argument(image))), oiio.UINT8, metadata)


def read_exr(path) -> tuple[np.ndarray, dict]:
    """(pixels as float32 (H, W, C), drtlab metadata) of an image written by write_exr; a path that
    is no file (missing, a folder, a FIFO) is an InputError naming `path`."""
    from drtlab.fields import existing_file
    pixels, meta, _ = _read(existing_file(_path_argument(path), "path", "an image file (EXR)"))
    return pixels, meta


def read_linear(path) -> tuple[np.ndarray, dict, str]:
    """(linear float32 pixels (H, W, C), drtlab metadata, how the file stores them) of any image
    OpenImageIO reads. Integer pixels (8- or 16-bit PNG, JPEG, TIFF) are display codes of the sRGB
    transfer unless the file says linear, as write_png's are: they are decoded to linear values
    (pbrt-v4's imgtool does the same), so that a PNG compares with the EXR it previews; an alpha
    channel is left as it is."""
    pixels, meta, (fmt, colorspace) = _read(path)
    floats = {"float": "float32", "half": "float16", "double": "float64"}
    if fmt in floats or "linear" in colorspace.lower():
        return pixels, meta, floats.get(fmt, fmt)
    out = pixels.copy()
    out[..., :3] = srgb_to_linear(out[..., :3])
    return out, meta, f"{fmt}, sRGB-encoded (read as linear)"


def read_stored(path) -> tuple[np.ndarray, dict]:
    """(float32 pixels (H, W, C) as the file stores them, integer codes scaled to [0, 1] and not
    decoded, drtlab metadata): what a texture marked raw reads."""
    pixels, meta, _ = _read(path)
    return pixels, meta


def _read(path) -> tuple[np.ndarray, dict, tuple[str, str]]:
    import OpenImageIO as oiio
    path = _path_argument(path)
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    # A truncated file opens (its header is whole) and reads as nothing: OpenImageIO returns None or
    # a 0-d array and sets its error instead of raising.
    error = inp.geterror() if hasattr(inp, "geterror") else oiio.geterror()
    meta = _metadata(spec)
    stored = (str(spec.format), str(spec.getattribute("oiio:ColorSpace") or ""))
    inp.close()
    pixels = None if pixels is None else np.asarray(pixels)
    want = (spec.height, spec.width, spec.nchannels)
    if pixels is None or pixels.shape != want:
        first = (error or "no pixels read").strip().splitlines()[0]
        raise OSError(f"cannot read {path}: truncated or corrupt ({spec.width}x{spec.height} x "
                      f"{spec.nchannels} channels in its header; {first})")
    return pixels, meta, stored


def channel_names(path) -> tuple[str, ...]:
    """The channel names of an image file's header (R, G, B, A; Y for grey), () when it cannot be
    opened."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        return ()
    names = tuple(inp.spec().channelnames)
    inp.close()
    return names


def image_size(path) -> tuple[int, int] | None:
    """(width, height) from an image file's header, or None when it cannot be opened."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        return None
    spec = inp.spec()
    inp.close()
    return int(spec.width), int(spec.height)
