"""Albedo textures (kernels/materials/texture.py, kernels/scene_model/texture.py): the device lookup
against Mitsuba 3's bitmap and checkerboard formulas transcribed here in numpy (bitmap.cpp's
bilinear_weights and Dr.Jit's wrap modes; checkerboard.cpp), at many uv, to float32 rounding; a
textured diffuse quad lit straight down by a directional light against the closed form
texture(u, v) E / π per pixel (a z-test, Bonferroni over the pixels); negative controls (v flipped,
sRGB not decoded, no half-texel shift); the loader's one-line refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy.stats import norm

from drtlab.errors import InputError
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import features_of
from drtlab.kernels.materials.texture import texture_value
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import scene_from_dict
from drtlab.kernels.scene_upload import upload

EPS32 = float(np.finfo(np.float32).eps)
W, H = 7, 5           # not square: a transposed lookup shows


# ---- Mitsuba's formulas, numpy, float64 from the float32 texel coordinates ----

def wrap(i, n, mode):
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "repeat":
        return np.mod(i, n)
    r = np.mod(i, 2 * n)
    return np.where(r >= n, 2 * n - r - 1, r)


def mitsuba_bitmap(px, uv, filt, mode, flip_v=False, shift=0.5):
    """Texture `px` (H, W, 3) at uv' (N, 2) as Dr.Jit's Texture::eval: nearest texel floor(uv' res),
    or the four texels around uv' res - 1/2 weighted bilinearly, each index wrapped."""
    h, w = px.shape[:2]
    u, v = uv[:, 0].astype(np.float64), uv[:, 1].astype(np.float64)
    if flip_v:
        v = 1.0 - v
    if filt == "nearest":
        x, y = np.floor(u * w).astype(int), np.floor(v * h).astype(int)
        return px[wrap(y, h, mode), wrap(x, w, mode)].astype(np.float64)
    p, q = u * w - shift, v * h - shift
    x, y = np.floor(p).astype(int), np.floor(q).astype(int)
    a, b = (p - x)[:, None], (q - y)[:, None]
    f = lambda dx, dy: px[wrap(y + dy, h, mode), wrap(x + dx, w, mode)].astype(np.float64)
    return (1 - b) * ((1 - a) * f(0, 0) + a * f(1, 0)) + b * ((1 - a) * f(0, 1) + a * f(1, 1))


def mitsuba_checkerboard(c0, c1, uv):
    m = (uv - np.floor(uv)) > 0.5
    return np.where((m[:, 0] == m[:, 1])[:, None], c0, c1)


# ---- the device lookup ----

@wp.kernel
def _lookups(sd: SceneData, m: int, uv: wp.array(dtype=wp.vec2), out: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    out[i] = texture_value(sd, sd.materials.tex[m], uv[i])


def quad_scene(texture: dict, resolution: int = 8, spp: int = 1) -> dict:
    """A textured [-1, 1]^2 quad in y = 0 facing up (u along z, v along x), seen straight down by an
    orthographic camera whose film is the quad, lit straight down by a directional light."""
    return {"scene": {"description": "a textured quad", "resolution": [resolution, resolution],
                      "spp": spp, "integrator": "path", "max_depth": 2},
            "camera": {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
                       "fov": 30.0, "ortho_height": 2.0},
            "materials": {"plain": {"albedo": [0.5] * 3}, "tex": {"albedo_texture": texture}},
            "shapes": [{"kind": "quad", "material": "tex", "origin": [-1.0, 0.0, -1.0],
                        "edge_u": [0.0, 0.0, 2.0], "edge_v": [2.0, 0.0, 0.0]}],
            "lights": [{"kind": "directional", "direction": [0.0, -1.0, 0.0],
                        "irradiance": list(IRRADIANCE)}]}


IRRADIANCE = (2.0, 3.0, 4.0)


def device_lookup(texture: dict, uv: np.ndarray) -> np.ndarray:
    scene = scene_from_dict(quad_scene(texture))
    sd = upload(scene, "cpu")
    m = [x.name for x in scene.materials].index("tex")
    a = wp.array(uv.astype(np.float32), dtype=wp.vec2, device="cpu")
    out = wp.zeros(len(uv), dtype=wp.vec3, device="cpu")
    wp.launch(_lookups, dim=len(uv), inputs=[sd, m, a, out], device="cpu")
    return out.numpy().astype(np.float64)


def write_image(path, pixels: np.ndarray) -> None:
    import OpenImageIO as oiio
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    fmt = oiio.UINT8 if pixels.dtype == np.uint8 else oiio.FLOAT
    assert out.open(str(path), oiio.ImageSpec(w, h, c, fmt))
    assert out.write_image(pixels)
    out.close()


@pytest.fixture(scope="module")
def exr_texture(tmp_path_factory):
    px = np.random.default_rng(7).random((H, W, 3)).astype(np.float32)
    path = tmp_path_factory.mktemp("tex") / "t.exr"
    write_image(path, px)
    return str(path), px


TO_UV = np.array([[2.0, 0.0, -0.5], [0.0, 2.0, -0.5]])      # the suite's scale 2, translate -1/2


def uv_points(n: int = 20000) -> np.ndarray:
    return np.random.default_rng(11).uniform(-1.3, 2.2, (n, 2)).astype(np.float32)


def mapped(uv: np.ndarray) -> np.ndarray:
    """uv' = to_uv uv as the kernel computes it (float32)."""
    m = TO_UV.astype(np.float32)
    return np.stack([m[0, 0] * uv[:, 0] + m[0, 1] * uv[:, 1] + m[0, 2],
                     m[1, 0] * uv[:, 0] + m[1, 1] * uv[:, 1] + m[1, 2]], axis=1).astype(np.float32)


def off_edges(uvp: np.ndarray, cells: tuple[int, int]) -> np.ndarray:
    """Points not within 1e-4 cell of a cell edge, where float32 rounding may pick either side."""
    f = uvp.astype(np.float64) * np.array(cells)
    return np.all(np.abs(f - np.round(f)) > 1e-4, axis=1)


def tolerance(uvp: np.ndarray) -> float:
    # uv' rounds by an ulp of |uv' res| and the weights and sums by a few ulps of the values in [0, 1]
    return 8.0 * EPS32 * (1.0 + float(np.max(np.abs(uvp))) * max(W, H))


@pytest.mark.parametrize("filt", ["bilinear", "nearest"])
@pytest.mark.parametrize("mode", ["repeat", "mirror", "clamp"])
def test_bitmap_lookup_is_mitsubas(exr_texture, filt, mode):
    path, px = exr_texture
    uv = uv_points()
    got = device_lookup({"file": path, "filter": filt, "wrap": mode, "to_uv": TO_UV.tolist()}, uv)
    uvp = mapped(uv)
    keep = off_edges(uvp, (W, H)) if filt == "nearest" else np.ones(len(uv), bool)
    assert keep.sum() > 0.9 * len(uv)
    want = mitsuba_bitmap(px, uvp, filt, mode)
    tol = tolerance(uvp)
    assert np.max(np.abs(got - want)[keep]) <= tol
    # negative controls: v flipped, and (bilinear) no half-texel shift, are rejected far above it
    assert np.max(np.abs(got - mitsuba_bitmap(px, uvp, filt, mode, flip_v=True))[keep]) > 100 * tol
    if filt == "bilinear":
        assert np.max(np.abs(got - mitsuba_bitmap(px, uvp, filt, mode, shift=0.0))) > 100 * tol


def test_wrap_modes_differ_outside_the_unit_square(exr_texture):
    path, _ = exr_texture
    uv = uv_points(2000)
    got = {mode: device_lookup({"file": path, "wrap": mode, "to_uv": TO_UV.tolist()}, uv)
           for mode in ("repeat", "mirror", "clamp")}
    assert not np.allclose(got["repeat"], got["mirror"]) and not np.allclose(got["mirror"], got["clamp"])


def test_checkerboard_lookup_is_mitsubas():
    c0, c1 = [0.9, 0.1, 0.3], [0.05, 0.6, 0.2]
    uv = uv_points()
    got = device_lookup({"kind": "checkerboard", "color0": c0, "color1": c1,
                         "to_uv": TO_UV.tolist()}, uv)
    uvp = mapped(uv)
    keep = off_edges(uvp, (2, 2))
    want = mitsuba_checkerboard(np.array(c0, np.float32), np.array(c1, np.float32), uvp.astype(np.float64))
    assert np.array_equal(got[keep], want[keep])
    assert not np.array_equal(got[keep], mitsuba_checkerboard(np.array(c1, np.float32),
                                                              np.array(c0, np.float32),
                                                              uvp.astype(np.float64))[keep])


# ---- sRGB decoding of an 8-bit file ----

@pytest.fixture(scope="module")
def png_texture(tmp_path_factory):
    codes = np.random.default_rng(5).integers(0, 256, (8, 8, 3)).astype(np.uint8)
    path = tmp_path_factory.mktemp("tex") / "t.png"
    write_image(path, codes)
    return str(path), codes


def test_png_texels_are_srgb_decoded_unless_raw(png_texture):
    import colour
    path, codes = png_texture
    scene = scene_from_dict(quad_scene({"file": path}))
    raw = scene_from_dict(quad_scene({"file": path, "raw": True}))
    decoded = colour.cctf_decoding(codes / 255.0, function="sRGB")
    tex = scene.materials[1].textures["albedo"].pixels
    assert np.max(np.abs(tex - decoded)) < 4 * EPS32
    assert np.max(np.abs(raw.materials[1].textures["albedo"].pixels - codes / 255.0)) < 4 * EPS32
    assert np.max(np.abs(tex - codes / 255.0)) > 0.1         # negative control: not decoded


# ---- a render: texture x irradiance / π per pixel ----

N, SPP = 16, 64


def pixel_moments(px: np.ndarray, flip_v=False, q: int = 16):
    """Each pixel's mean and spread of texture(u, v) E / π over its footprint (q x q midpoints)."""
    t = (np.arange(N * q) + 0.5) / (N * q)        # film coordinate in [0, 1]: columns x, rows z
    Z, X = np.meshgrid(t, t, indexing="ij")
    uv = np.stack([Z.ravel(), X.ravel()], axis=1)  # u = (z + 1) / 2, v = (x + 1) / 2
    L = mitsuba_bitmap(px, uv, "bilinear", "repeat", flip_v=flip_v).reshape(N, q, N, q, 3)
    L = L * np.array(IRRADIANCE) / math.pi
    return L.mean(axis=(1, 3)), L.std(axis=(1, 3))


@pytest.fixture(scope="module")
def quad_image(png_texture):
    path, _ = png_texture
    scene = scene_from_dict(quad_scene({"file": path}, resolution=N, spp=SPP))
    assert features_of(scene, "path").textures
    return render(scene, spp=SPP, seed=3, sampler="independent")


def z_max(img, mean, std):
    sigma = np.sqrt(std ** 2 / SPP + (1e-5 * mean) ** 2 + 1e-12)
    return float(np.max(np.abs(img - mean) / sigma))


def test_textured_quad_matches_the_closed_form(quad_image, png_texture):
    import colour
    _, codes = png_texture
    alpha = 1e-3
    z_crit = norm.isf(alpha / (2 * quad_image.size))
    decoded = colour.cctf_decoding(codes / 255.0, function="sRGB")
    assert z_max(quad_image, *pixel_moments(decoded)) < z_crit
    # negative controls: v flipped, and the sRGB codes read as linear, are rejected
    assert z_max(quad_image, *pixel_moments(decoded, flip_v=True)) > z_crit
    assert z_max(quad_image, *pixel_moments(codes / 255.0)) > z_crit


# ---- the loader ----

@pytest.mark.parametrize("texture,field", [
    ({"file": "x.png", "filter": "cubic"}, "materials.tex.albedo_texture.filter"),
    ({"file": "x.png", "wrap": "border"}, "materials.tex.albedo_texture.wrap"),
    ({"kind": "noise"}, "materials.tex.albedo_texture.kind"),
    ({"file": "/nonexistent/x.png"}, "materials.tex.albedo_texture.file"),
    ({}, "materials.tex.albedo_texture.file"),
    ({"file": "x.png", "to_uv": [[1, 0]]}, "materials.tex.albedo_texture.to_uv"),
    ({"file": "x.png", "raw": 1}, "materials.tex.albedo_texture.raw"),
    ({"kind": "checkerboard", "file": "x.png"}, "materials.tex.albedo_texture.file"),
    ({"kind": "checkerboard", "color0": [1, 2]}, "materials.tex.albedo_texture.color0"),
])
def test_loader_refuses_bad_textures(texture, field):
    with pytest.raises(InputError) as e:
        scene_from_dict(quad_scene(texture))
    assert e.value.field == field and "\n" not in str(e.value)


def test_a_texture_only_where_the_kind_reads_an_albedo(exr_texture):
    d = quad_scene({"file": exr_texture[0]})
    d["materials"]["tex"]["kind"] = "dielectric"
    with pytest.raises(InputError) as e:
        scene_from_dict(d)
    assert "albedo_texture" in e.value.field


def test_scenes_without_textures_compile_none():
    d = quad_scene({"kind": "checkerboard"})
    d["shapes"][0]["material"] = "plain"
    assert not features_of(scene_from_dict(d), "path").textures


# ---- an OBJ mesh's texture coordinates (v flipped, as Mitsuba reads OBJ files) ----

def obj_square(path) -> None:
    """The quad of quad_scene as an OBJ file facing +y, whose (vt.x, 1 - vt.y) are the quad's uv."""
    corners = [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)]          # (x, z)
    lines = [f"v {x} 0 {z}" for x, z in corners]
    lines += [f"vt {(z + 1) / 2} {1 - (x + 1) / 2}" for x, z in corners]
    lines += ["f 1/1 2/2 3/3", "f 1/1 3/3 4/4"]
    path.write_text("\n".join(lines) + "\n")


def test_textured_obj_matches_the_closed_form(png_texture, tmp_path):
    import colour
    path, codes = png_texture
    obj_square(tmp_path / "square.obj")
    d = quad_scene({"file": path}, resolution=N, spp=SPP)
    d["shapes"] = [{"kind": "mesh", "material": "tex", "file": str(tmp_path / "square.obj")}]
    img = render(scene_from_dict(d), spp=SPP, seed=3, sampler="independent")
    z_crit = norm.isf(1e-3 / (2 * img.size))
    decoded = colour.cctf_decoding(codes / 255.0, function="sRGB")
    assert z_max(img, *pixel_moments(decoded)) < z_crit
    assert z_max(img, *pixel_moments(decoded, flip_v=True)) > z_crit    # the file's v unflipped
