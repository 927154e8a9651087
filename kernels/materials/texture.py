"""Textures at a hit (the model: kernels/scene_model/texture.py): Mitsuba 3's `bitmap`, a
Dr.Jit texture lookup (bitmap.cpp: uv' = to_uv uv; bilinear: p = uv' res - 1/2, the four texels
around floor(p) wrapped and weighted by p - floor(p); nearest: the texel floor(uv' res) wrapped),
and its `checkerboard` (color0 where both fractions of uv' are <= 1/2 or both > 1/2, else color1).
Evaluated once per hit by the textured material_at (material_at.py), compiled only into variants
of scenes with textures (Features.textures)."""
import numpy as np
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.scene_model.texture import (FILTERS, LUMINANCE, TEXTURE_KINDS, TEXTURE_SLOTS, WRAPS,
                                                texture_pool)

BITMAP, CHECKERBOARD = (TEXTURE_KINDS.index(k) for k in ("bitmap", "checkerboard"))
NEAREST = FILTERS.index("nearest")
REPEAT, MIRROR, CLAMP = (WRAPS.index(w) for w in ("repeat", "mirror", "clamp"))
SLOT = {s: i for i, s in enumerate(TEXTURE_SLOTS)}     # a slot's column in MaterialData.tex
N_SLOTS = len(TEXTURE_SLOTS)


def texture_tables(materials: list, lights: list = ()) -> dict:
    """The MaterialData texture arrays of `materials` (device_scene.py), as numpy-ready lists, and
    `index`: each pool texture's index by id (what a light's upload stores for its texture)."""
    pool = texture_pool(materials, lights)
    index = {id(t): i for i, t in enumerate(pool)}
    tex = [index[id(m.textures[s])] if s in m.textures else -1 for m in materials for s in TEXTURE_SLOTS]
    # 1: a texture reads the hit's uv (a mesh attribute reads the barycentric uv a mesh hit has)
    textured = [int(any(t.kind != "mesh_attribute" for t in m.textures.values())) for m in materials]
    mode, size, rows_u, rows_v, texels, first = [], [], [], [], [], 0
    for t in pool:
        h, w = t.pixels.shape[:2]
        mode.append((TEXTURE_KINDS.index(t.kind), FILTERS.index(t.filter), WRAPS.index(t.wrap), first))
        size.append((w, h))
        rows_u.append(t.to_uv[0])
        rows_v.append(t.to_uv[1])
        texels.append(np.asarray(t.pixels, dtype=np.float32).reshape(-1, 3))
        first += w * h
    return {"tex": tex, "textured": textured, "tex_mode": mode, "tex_size": size, "tex_u": rows_u,
            "tex_v": rows_v, "texels": np.concatenate(texels) if texels else [], "index": index}


@wp.func
def material_texture(sd: SceneData, m: int, slot: int) -> int:
    """The pool index of material m's texture in `slot` (SLOT[name]), -1 where it has none."""
    return sd.materials.tex[m * wp.static(N_SLOTS) + slot]


@wp.func
def wrap_texel(i: int, n: int, wrap: int) -> int:
    """Texel index i of a row (or column) of n as Dr.Jit's wrap modes map it into [0, n)."""
    if wrap == wp.static(CLAMP):
        return wp.clamp(i, 0, n - 1)
    if wrap == wp.static(REPEAT):
        r = i % n
        if r < 0:
            r += n
        return r
    r = i % (2 * n)                  # mirror: every other repetition reversed
    if r < 0:
        r += 2 * n
    if r >= n:
        r = 2 * n - r - 1
    return r


@wp.func
def texel(sd: SceneData, first: int, w: int, h: int, wrap: int, x: int, y: int) -> wp.vec3:
    return sd.materials.texels[first + wrap_texel(y, h, wrap) * w + wrap_texel(x, w, wrap)]


@wp.func
def texture_scalar(sd: SceneData, t: int, uv: wp.vec2) -> float:
    """Texture t as a float parameter at uv, as Mitsuba's eval_1: a bitmap's luminance (its RGB
    luminance weights), and a checkerboard's colours swapped against its RGB eval (checkerboard.cpp:
    eval_1 gives color0 where exactly one fraction of uv' is > 1/2)."""
    c = texture_value(sd, t, uv)
    mode = sd.materials.tex_mode[t]
    if mode[0] == wp.static(CHECKERBOARD):
        first = mode[3]
        if c == sd.materials.texels[first]:
            c = sd.materials.texels[first + 1]
        else:
            c = sd.materials.texels[first]
    return luminance(c)


@wp.func
def luminance(c: wp.vec3) -> float:
    """Mitsuba 3's luminance of an RGB value (core/spectrum.h; its bitmap's eval_1 too). A grey
    value (drtlab's one-channel image or float colour, held as three equal channels) is itself, as
    Mitsuba's eval_1 of a one-channel image or a float is."""
    if c[0] == c[1] and c[1] == c[2]:
        return c[0]
    return (c[0] * wp.static(LUMINANCE[0]) + c[1] * wp.static(LUMINANCE[1])
            + c[2] * wp.static(LUMINANCE[2]))


@wp.func
def texture_value(sd: SceneData, t: int, uv: wp.vec2) -> wp.vec3:
    """Texture t at surface coordinates uv (linear RGB)."""
    mode = sd.materials.tex_mode[t]
    ru = sd.materials.tex_u[t]
    rv = sd.materials.tex_v[t]
    u = ru[0] * uv[0] + ru[1] * uv[1] + ru[2]
    v = rv[0] * uv[0] + rv[1] * uv[1] + rv[2]
    first = mode[3]
    if mode[0] == wp.static(CHECKERBOARD):
        mu = (u - wp.floor(u)) > 0.5
        mv = (v - wp.floor(v)) > 0.5
        if mu == mv:
            return sd.materials.texels[first]
        return sd.materials.texels[first + 1]
    size = sd.materials.tex_size[t]
    w = size[0]
    h = size[1]
    wrap = mode[2]
    if mode[1] == wp.static(NEAREST):
        return texel(sd, first, w, h, wrap, int(wp.floor(u * float(w))), int(wp.floor(v * float(h))))
    px = u * float(w) - 0.5
    py = v * float(h) - 0.5
    fx = wp.floor(px)
    fy = wp.floor(py)
    x = int(fx)
    y = int(fy)
    w1x = px - fx
    w1y = py - fy
    w0x = 1.0 - w1x
    w0y = 1.0 - w1y
    c0 = w0x * texel(sd, first, w, h, wrap, x, y) + w1x * texel(sd, first, w, h, wrap, x + 1, y)
    c1 = w0x * texel(sd, first, w, h, wrap, x, y + 1) + w1x * texel(sd, first, w, h, wrap, x + 1, y + 1)
    return w0y * c0 + w1y * c1
