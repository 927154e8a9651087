"""A PLY file's vertex and face attributes as Mitsuba 3 names them (src/shapes/ply.h,
find_other_fields), for the `mesh_attribute` texture (kernels/scene_model/texture.py).

Properties other than the reserved ones (x y z nx ny nz u v of a vertex, the index list of a face)
are grouped in the order the header lists them: `r g b` (or `red green blue`) is `{vertex|face}_color`
(`a`/`alpha` a 4th channel); otherwise consecutive properties `PREFIX_S` with one-letter suffixes
running x y z w, r g b a, 0 1 2 3 or 1 2 3 4 from the first letter are `{vertex|face}_PREFIX` (with
`_color` appended for r g b a). A group of other than 1 or 3 properties is not an attribute (Mitsuba
warns and ignores it), and neither is a property without such a suffix. Integer properties are
normalised by their type's maximum and sRGB-decoded (ply.h flags them Normalized | Gamma); float ones
are read as stored. Values are float32, as Mitsuba keeps them.
"""
from __future__ import annotations

import numpy as np

from drtlab.errors import InputError
from drtlab.kernels.colour import srgb_to_linear

PREFIXES = ("vertex_", "face_")
RESERVED = {"vertex": {"x", "y", "z", "nx", "ny", "nz", "u", "v", "texture_u", "texture_v", "s", "t"},
            "face": {"vertex_index", "vertex_indices"}}
# Suffix sequences: the first suffix picks the row; rgba appends "_color" to the name.
SUFFIXES = ("xyzw", "rgba", "0123", "1234")
COLOR_NAMES = (("r", "g", "b", "a"), ("red", "green", "blue", "alpha"))


def ply_attributes(raw: dict) -> dict[str, np.ndarray]:
    """Mitsuba's attributes of a PLY read by trimesh (its metadata["_ply_raw"]: per element its
    `properties` in header order and their `data`, a structured array of a binary file or a dict of
    (rows, 1) arrays of an ASCII one) -> {name: (rows, channels) float32}."""
    out: dict[str, np.ndarray] = {}
    for element in ("vertex", "face"):
        if element not in raw:
            continue
        data = raw[element]["data"]
        names = [n for n in raw[element]["properties"] if n not in RESERVED[element]]
        for name, columns in _groups(names):
            out[f"{element}_{name}"] = np.stack([_as_float(data[c]) for c in columns], axis=1)
    return out


def _groups(names: list[str]) -> list[tuple[str, list[str]]]:
    """(attribute name without its element prefix, the properties it reads) in Mitsuba's order."""
    groups = []
    for plain in COLOR_NAMES:
        if all(c in names for c in plain[:3]):
            columns = list(plain[:4] if plain[3] in names else plain[:3])
            groups.append(("color", columns))
            names = [n for n in names if n not in plain]
            break
    i, seen = 0, set()
    while i < len(names):
        prefix, _, suffix = names[i].rpartition("_")
        row = next((r for r in SUFFIXES if len(suffix) == 1 and r[0] == suffix), None)
        if not prefix or row is None or prefix in seen:
            i += 1
            continue
        run = [names[i]]
        while (i + len(run) < len(names) and len(run) < 4
               and names[i + len(run)] == f"{prefix}_{row[len(run)]}"):
            run.append(names[i + len(run)])
        i += len(run)
        while i < len(names) and names[i].rpartition("_")[0] == prefix:
            i += 1                  # a broken sequence: the rest of the prefix is ignored too
            run = []
        seen.add(prefix)
        if len(run) in (1, 3):
            groups.append((prefix + ("_color" if row == "rgba" else ""), run))
    return groups


def _as_float(column: np.ndarray) -> np.ndarray:
    column = np.asarray(column).reshape(-1)
    if column.dtype.kind in "iu":
        return srgb_to_linear(column.astype(np.float64) / np.iinfo(column.dtype).max).astype(np.float32)
    return column.astype(np.float32)


def check_attribute_textures(shapes: list, materials: list) -> None:
    """Every mesh_attribute texture lies on meshes that have its attribute, with 1 or 3 channels (a
    weight: 1), one finite value per vertex or face: else one InputError naming the texture."""
    for i, shape in enumerate(shapes):
        m = materials[shape.material]
        for slot, t in m.textures.items():
            if t.kind != "mesh_attribute":
                continue
            where = f"materials.{m.name}.{slot}_texture.name"
            if shape.kind != "mesh":
                raise InputError(where, f"shape '{shape.name or i}' is a {shape.kind}: a mesh attribute "
                                        "lies on a mesh")
            have = shape.mesh.attributes
            if t.name not in have:
                listed = ", ".join(f"{n} ({a.shape[1]} channels)" for n, a in have.items()) or "none"
                raise InputError(where, f"mesh {shape.mesh.source} has no attribute {t.name!r} (its "
                                        f"attributes: {listed})")
            a = have[t.name]
            channels = (1,) if slot == "weight" else (1, 3)
            if a.shape[1] not in channels:
                raise InputError(where, f"{t.name!r} of mesh {shape.mesh.source} has {a.shape[1]} "
                                        f"channels; a {slot} reads {' or '.join(map(str, channels))}")
            rows = len(shape.mesh.vertices if t.per_vertex else shape.mesh.faces)
            if len(a) != rows or not np.all(np.isfinite(a)):
                raise InputError(where, f"{t.name!r} of mesh {shape.mesh.source} needs one finite value "
                                        f"per {'vertex' if t.per_vertex else 'face'} ({rows})")
