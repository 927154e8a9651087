"""Mitsuba's `.serialized` triangle meshes (src/shapes/serialized.cpp), versions 3 and 4: what Mitsuba
3 up to 3.9 writes and reads.

A file is one or more meshes, each a little-endian header (uint16 0x041C, uint16 version) and then a
zlib stream: uint32 flags (0x1 vertex normals, 0x2 texture coordinates, 0x8 vertex colours, 0x10
face normals, 0x2000 double precision), the shape's name as a null-terminated string (version 4
only), uint64 vertex and triangle counts, positions (3 V), normals, texture coordinates (2 V) and
colours (3 V) where flagged, in float32 or float64, and 3 F uint32 vertex indices. The meshes follow
each other; the file ends with each mesh's offset (uint64 in version 4, uint32 in version 3) and the
uint32 count. Only positions, triangles and normals matter to drtlab.
"""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

MAGIC = 0x041C
VERSIONS = (3, 4)
HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS, FACE_NORMALS, DOUBLE = 0x1, 0x2, 0x8, 0x10, 0x2000


class SerializedError(ValueError):
    """What is wrong with a .serialized file, in words (the caller names the field)."""


def read_serialized(path: Path, shape_index: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(vertices (V, 3) float64, faces (F, 3) int64, vertex normals (V, 3) or None) of the
    shape_index-th mesh of a .serialized file; normals None where the file has none or asks for face
    normals."""
    data = Path(path).read_bytes()
    if len(data) < 4:
        raise SerializedError("is too short for a .serialized header")
    magic, version = struct.unpack_from("<HH", data, 0)
    if magic != MAGIC:
        raise SerializedError(f"is not a Mitsuba .serialized file (format id {magic:#06x}, not {MAGIC:#06x})")
    if version not in VERSIONS:
        raise SerializedError(f"is a version {version} .serialized file; versions "
                              f"{', '.join(map(str, VERSIONS))} are supported")
    start = 0
    if shape_index:
        count = struct.unpack_from("<I", data, len(data) - 4)[0]
        if shape_index >= count:
            raise SerializedError(f"holds {count} meshes; shape_index {shape_index} is out of range")
        size, fmt = (8, "<Q") if version == 4 else (4, "<I")
        start = struct.unpack_from(fmt, data, len(data) - 4 - size * (count - shape_index))[0]
    try:
        body = zlib.decompressobj().decompress(data[start + 4:])
    except zlib.error as exc:
        raise SerializedError(f"has a corrupt compressed stream ({exc})") from None
    return _mesh(body, version)


def _mesh(body: bytes, version: int):
    try:
        flags = struct.unpack_from("<I", body, 0)[0]
        at = 4
        if version == 4:
            at = body.index(b"\0", at) + 1
        vertices, faces = struct.unpack_from("<QQ", body, at)
        at += 16
        real = np.dtype("<f8" if flags & DOUBLE else "<f4")

        def take(count: int, dtype) -> np.ndarray:
            nonlocal at
            dtype = np.dtype(dtype)
            out = np.frombuffer(body, dtype=dtype, count=count, offset=at)
            at += count * dtype.itemsize
            return out

        positions = take(3 * vertices, real).reshape(-1, 3).astype(np.float64)
        normals = take(3 * vertices, real).reshape(-1, 3).astype(np.float64) if flags & HAS_NORMALS else None
        if flags & HAS_TEXCOORDS:
            take(2 * vertices, real)
        if flags & HAS_COLORS:
            take(3 * vertices, real)
        triangles = take(3 * faces, "<u4").reshape(-1, 3).astype(np.int64)
    except (struct.error, ValueError) as exc:
        raise SerializedError(f"is truncated or malformed ({exc})") from None
    return positions, triangles, None if flags & FACE_NORMALS else normals


def has_vertex_normals(path: Path) -> bool:
    """Whether the file's first mesh stores vertex normals (and does not ask for face normals)."""
    try:
        return read_serialized(path)[2] is not None
    except (OSError, SerializedError):
        return False            # the mesh loader then says what is wrong
