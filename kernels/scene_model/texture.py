"""Textures of a material's parameters, as Mitsuba 3 defines them: `bitmap` (src/textures/bitmap.cpp,
a Dr.Jit texture: bilinear or nearest, repeat / mirror / clamp), `checkerboard`
(src/textures/checkerboard.cpp) and `mesh_attribute` (src/textures/mesh_attribute.cpp: a vertex or
face attribute of the mesh it lies on, kernels/scene_model/mesh_attributes.py, times `scale`). The scene-file table (`albedo_texture`, SCENE_FORMAT.md) and the
model the device upload reads (kernels/materials/texture.py evaluates it once per hit). A material
holds one texture per textured parameter, its slot (TEXTURE_SLOTS); the scene's textures are one pool
(texture_pool), which lights may index too.

Texel (x, y) is column x, row y of the image as stored (row 0 the top row): Mitsuba's uv (0, 0)
addresses the first stored texel, so a shape's v grows down the image.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drtlab.errors import InputError
from drtlab.fields import FLOAT32_MAX, existing_file, show

TEXTURE_KINDS = ("bitmap", "checkerboard", "mesh_attribute")
FILTERS = ("bilinear", "nearest")        # bitmap.cpp's filter_type (bilinear its default)
WRAPS = ("repeat", "mirror", "clamp")     # bitmap.cpp's wrap_mode (repeat its default)
KEYS = {"bitmap": ("kind", "file", "filter", "wrap", "raw", "to_uv"),
        "checkerboard": ("kind", "color0", "color1", "to_uv"),
        "mesh_attribute": ("kind", "name", "scale"),
        "constant": ("kind", "value")}
# A constant (Mitsuba's `rawconstant`) is a one-texel nearest bitmap on the device: the table kinds
TABLE_KINDS = TEXTURE_KINDS + ("constant",)
# The slots a mesh attribute may fill (the lookup that knows the hit's face reads these only).
ATTRIBUTE_SLOTS = ("albedo", "weight")
MAX_TEXELS = 1 << 24
# Mitsuba's `luminance` of linear Rec. 709 RGB: what a float texture reads of a colour (eval_1)
LUMINANCE = (0.212671, 0.715160, 0.072169)
# A material's textured parameters, in the order of the device's per-material slot table
# (MaterialData.tex): a new slot is one name here, then its lookup where the parameter is read.
TEXTURE_SLOTS = (
    "albedo",
    "opacity",      # a mask's (kernels/materials/mask.py): the texture's luminance
    "emission",     # an area light's radiance (kernels/emission.py)
    "roughness", "anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint",
    "clearcoat", "clearcoat_gloss", "flatness", "diff_trans",      # principled_params.PARAMS
    "weight",       # a diffuse's blend of albedo (at 0) and blend_albedo (at 1)
    "normal",       # a normal map (raw RGB, 2 rgb - 1 in the tangent frame)
    "bump",         # a bump map (its luminance a height; Material.bump_scale)
    "alpha_u", "alpha_v",   # an anisotropic kind's roughness along and across the tangent
)


def slot_key(slot: str) -> str:
    """A slot's key in a material's scene-file table."""
    return f"{slot}_texture"


@dataclass(eq=False)
class Texture:
    kind: str                          # one of TEXTURE_KINDS
    # (H, W, 3) float32 linear texels; a checkerboard's are (1, 2, 3): color0, color1; a mesh
    # attribute has none, (0, 0, 3)
    pixels: np.ndarray
    filter: str = "bilinear"
    wrap: str = "repeat"
    # uv' = to_uv[:, :2] @ uv + to_uv[:, 2]: Mitsuba's to_uv (a 2D affine map, 2 x 3)
    to_uv: np.ndarray = field(default_factory=lambda: np.eye(2, 3))
    source: str = ""
    name: str = ""                     # a mesh attribute's: "vertex_..." or "face_..."
    scale: float = 1.0                 # a mesh attribute's factor

    @property
    def per_vertex(self) -> bool:
        return self.name.startswith("vertex_")

    def digest(self) -> str:
        """Hash of the texels and the lookup: what the TOML text cannot show of an image file."""
        h = hashlib.sha256(np.ascontiguousarray(self.pixels, dtype=np.float32).tobytes())
        h.update(repr((self.kind, self.filter, self.wrap, self.to_uv.tolist(), self.name,
                       self.scale)).encode())
        return h.hexdigest()


def texture_pool(materials: list, lights: list = ()) -> list[Texture]:
    """The scene's distinct textures in upload order: every material's, slot by slot, then any a
    light holds (a `texture` attribute); a texture shared by several is one entry."""
    pool: dict[int, Texture] = {}
    for m in materials:
        for slot in TEXTURE_SLOTS:
            if slot in m.textures:
                pool.setdefault(id(m.textures[slot]), m.textures[slot])
    for light in lights:
        t = getattr(light, "texture", None)
        if t is not None:
            pool.setdefault(id(t), t)
    return list(pool.values())


def parse_texture(value: Any, where: str) -> Texture:
    """A material's `<slot>_texture` table -> Texture (InputError naming the field)."""
    if not isinstance(value, dict):
        raise InputError(where, f"must be a table (kind = {' | '.join(TEXTURE_KINDS)}), got {show(value)}")
    kind = value.get("kind", "bitmap")
    if kind not in TABLE_KINDS:
        raise InputError(f"{where}.kind", f"must be one of {', '.join(TABLE_KINDS)}, got {show(kind)}")
    extra = sorted(set(value) - set(KEYS[kind]))
    if extra:
        raise InputError(f"{where}.{extra[0]}", f"is not a key of a {kind} texture (keys: "
                                                f"{', '.join(KEYS[kind])})")
    if kind == "mesh_attribute":
        return _mesh_attribute(value, where)
    if kind == "constant":
        if "value" not in value:
            raise InputError(f"{where}.value", "a constant texture needs a value (a number or 3 numbers)")
        return Texture("bitmap", np.array([[_colour(value["value"], f"{where}.value")]], dtype=np.float32),
                       "nearest", source="constant")
    to_uv = _to_uv(value.get("to_uv"), f"{where}.to_uv")
    if kind == "checkerboard":
        colours = [_colour(value.get(k, d), f"{where}.{k}") for k, d in (("color0", 0.4), ("color1", 0.2))]
        return Texture("checkerboard", np.array([colours], dtype=np.float32), to_uv=to_uv)
    filt = _choice(value.get("filter", "bilinear"), f"{where}.filter", FILTERS)
    wrap = _choice(value.get("wrap", "repeat"), f"{where}.wrap", WRAPS)
    raw = value.get("raw", False)
    if not isinstance(raw, bool):
        raise InputError(f"{where}.raw", f"must be true or false (true: no sRGB decoding), got {show(raw)}")
    if "file" not in value or not isinstance(value["file"], str):
        raise InputError(f"{where}.file", f"needs a path to an image (PNG, JPEG, EXR), got "
                                          f"{show(value.get('file'))}")
    return Texture("bitmap", read_bitmap(value["file"], raw, f"{where}.file"), filt, wrap, to_uv,
                   source=value["file"])


def read_bitmap(path: str, raw: bool, where: str) -> np.ndarray:
    """The linear RGB texels (H, W, 3) float32 of an image file as Mitsuba's bitmap reads it: 8- and
    16-bit files sRGB-decoded unless `raw`, float files as stored; grey as three equal channels;
    alpha dropped."""
    from drtlab.kernels.imageio import read_linear, read_stored
    existing_file(path, where, "an image file (PNG, JPEG, EXR or any format OpenImageIO reads)")
    try:
        pixels = (read_stored if raw else read_linear)(Path(path).expanduser())[0]
    except OSError as exc:
        raise InputError(where, f"cannot read a texture from {path}: {exc}") from None
    px = np.asarray(pixels, dtype=np.float32)
    px = px[..., None] if px.ndim == 2 else px
    channels = px.shape[2]
    if channels not in (1, 2, 3, 4):
        raise InputError(where, f"{path}: {channels} channels; a texture has 1 (grey), 3 (RGB) or "
                                "either with alpha")
    px = np.repeat(px[..., :1], 3, axis=2) if channels <= 2 else px[..., :3]
    if px.shape[0] * px.shape[1] > MAX_TEXELS:
        raise InputError(where, f"{path}: {px.shape[1]} x {px.shape[0]} texels, at most {MAX_TEXELS}")
    if not np.all(np.isfinite(px)):
        raise InputError(where, f"{path}: every texel must be finite")
    return np.ascontiguousarray(px)


def _mesh_attribute(value: dict, where: str) -> Texture:
    name = value.get("name")
    if not isinstance(name, str) or not name.startswith(("vertex_", "face_")):
        raise InputError(f"{where}.name", "must name a mesh attribute, starting with 'vertex_' or "
                                          f"'face_' (e.g. 'vertex_color'), got {show(name)}")
    scale = value.get("scale", 1.0)
    if (not isinstance(scale, (int, float)) or isinstance(scale, bool) or not np.isfinite(scale)
            or abs(scale) > FLOAT32_MAX):
        raise InputError(f"{where}.scale", f"must be a finite number (the attribute's factor), got "
                                           f"{show(scale)}")
    return Texture("mesh_attribute", np.zeros((0, 0, 3), dtype=np.float32), name=name,
                   scale=float(scale), source=name)


def _choice(v: Any, where: str, choices: tuple[str, ...]) -> str:
    if v not in choices:
        raise InputError(where, f"must be one of {', '.join(choices)}, got {show(v)}")
    return v


def _colour(v: Any, where: str) -> list[float]:
    v = [v] * 3 if isinstance(v, (int, float)) and not isinstance(v, bool) else v
    if (not isinstance(v, list) or len(v) != 3
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)
                       for x in v)):
        raise InputError(where, f"must be a number or a list of 3 finite numbers, got {show(v)}")
    return [float(x) for x in v]


def _to_uv(v: Any, where: str) -> np.ndarray:
    if v is None:
        return np.eye(2, 3)
    m = np.asarray(v, dtype=object)
    if (m.shape != (2, 3) or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                     and np.isfinite(x) for x in m.ravel())):
        raise InputError(where, "must be 2 rows of 3 finite numbers [[a, b, c], [d, e, f]] "
                                f"(u' = a u + b v + c, v' = d u + e v + f), got {show(v)}")
    return m.astype(np.float64)
