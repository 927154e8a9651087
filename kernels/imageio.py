"""Image output: float32 EXR with metadata (OpenImageIO) and an sRGB PNG preview (kernels/colour.py)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from drtlab.kernels.colour import srgb_to_linear, to_srgb


def to_srgb8(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB."""
    return np.clip(np.round(to_srgb(image) * 255.0), 0, 255).astype(np.uint8)


def _write(path: Path, pixels: np.ndarray, fmt, metadata: dict | None) -> None:
    import OpenImageIO as oiio
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # Write beside the target and rename, so a crash never leaves a half-written image.
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    h, w, c = pixels.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    for key, value in (metadata or {}).items():
        if isinstance(value, bool):
            value = str(value).lower()
        if isinstance(value, (int, np.integer)):
            spec.attribute(f"drtlab:{key}", int(value))
        elif isinstance(value, (float, np.floating)):
            spec.attribute(f"drtlab:{key}", float(value))
        else:
            spec.attribute(f"drtlab:{key}", str(value))
    out = oiio.ImageOutput.create(str(tmp))
    if out is None or not out.open(str(tmp), spec):
        raise OSError(f"cannot write {path}: {oiio.geterror()}")
    ok = out.write_image(pixels)
    out.close()
    if not ok:
        tmp.unlink(missing_ok=True)
        raise OSError(f"cannot write {path}: {oiio.geterror()}")
    os.replace(tmp, path)


def write_exr(path, image: np.ndarray, metadata: dict | None = None) -> None:
    import OpenImageIO as oiio
    _write(Path(path), float32_pixels(image), oiio.FLOAT, metadata)


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
    _write(Path(path), np.ascontiguousarray(to_srgb8(image)), oiio.UINT8, metadata)


def read_exr(path) -> tuple[np.ndarray, dict]:
    """(pixels as float32 (H, W, C), drtlab metadata) of an image written by write_exr."""
    pixels, meta, _ = _read(path)
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


def _read(path) -> tuple[np.ndarray, dict, tuple[str, str]]:
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise OSError(f"cannot read {path}: {oiio.geterror()}")
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    # A truncated file opens (its header is whole) and reads as nothing: OpenImageIO returns None or
    # a 0-d array and sets its error instead of raising.
    error = inp.geterror() if hasattr(inp, "geterror") else oiio.geterror()
    meta = {a.name[len("drtlab:"):]: a.value for a in spec.extra_attribs
            if a.name.startswith("drtlab:")}
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
