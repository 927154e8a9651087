"""A texture on a sphere reads Mitsuba 3's uv (src/shapes/sphere.cpp): the hit's direction in the
sphere's own frame (its to_world's rotation undone), u = atan2(y, x) / 2 pi in [0, 1), v = acos(z) / pi.
Checked: kernels/intersection/primitives.py's sphere_uv at exact points and against that formula;
the importer keeping a textured sphere's rotation (Shape.to_local) and nothing for an untextured one;
and a render: a camera looking at the sphere along the direction where the formula puts the one
bright texel of a texture sees it at the image centre, while the cameras where a mirrored u or an
unrotated frame would put it see black (the negative controls). A checker keeps drtlab's own angles
(test_checker*.py, and the built-in images' hashes).
"""
from __future__ import annotations

import numpy as np
import pytest
import warp as wp

from drtlab.kernels.intersection.primitives import sphere_uv
from drtlab.kernels.scene_model.scene_file import load_scene


@wp.kernel
def _uv_kernel(dirs: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.vec2)):
    i = wp.tid()
    out[i] = sphere_uv(dirs[i])


def device_uv(dirs) -> np.ndarray:
    d = wp.array(np.asarray(dirs, np.float32), dtype=wp.vec3, device="cpu")
    out = wp.zeros(len(dirs), dtype=wp.vec2, device="cpu")
    wp.launch(_uv_kernel, dim=len(dirs), inputs=[d, out], device="cpu")
    return out.numpy()


def mitsuba_uv(local) -> np.ndarray:
    """Mitsuba's formula in float64: phi = atan2(y, x) (plus 2 pi where negative), theta = acos(z)."""
    local = np.asarray(local, np.float64)
    phi = np.arctan2(local[:, 1], local[:, 0])
    phi = np.where(phi < 0.0, phi + 2.0 * np.pi, phi)
    return np.stack([phi / (2.0 * np.pi), np.arccos(np.clip(local[:, 2], -1.0, 1.0)) / np.pi], axis=1)


def test_exact_values_at_the_axes():
    s = np.sqrt(0.5)
    dirs = [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0], [s, s, 0], [s, -s, 0], [s, 0, s], [0, -s, -s]]
    want = [[0, 0.5], [0.25, 0.5], [0.5, 0.5], [0.75, 0.5], [0.125, 0.5], [0.875, 0.5], [0, 0.25],
            [0.75, 0.75]]
    assert np.allclose(device_uv(dirs), want, atol=2e-7, rtol=0)
    assert np.allclose(device_uv([[0, 0, 1], [0, 0, -1]])[:, 1], [0.0, 1.0], atol=0)   # the poles


def test_against_the_formula_on_random_directions():
    d = np.random.default_rng(7).standard_normal((2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    got, want = device_uv(d), mitsuba_uv(d)
    du = np.abs(got[:, 0] - want[:, 0])
    du = np.minimum(du, 1.0 - du)               # u wraps at +x (a float32 phi of -0 or 2 pi)
    assert du.max() < 2e-6 and np.abs(got[:, 1] - want[:, 1]).max() < 2e-6
    assert np.all((got[:, 0] >= 0.0) & (got[:, 0] <= 1.0))
    mirrored = mitsuba_uv(d * [1, -1, 1])       # the negative control: u mirrored is not it
    assert np.abs(got[:, 0] - mirrored[:, 0]).max() > 0.4


# A sphere rotated and moved by its to_world, with a centre: Mitsuba's to_world is
# chain * translate(center) * scale(radius).
CENTER, RADIUS = [0.1, 0.0, 0.0], 1.2
CHAIN = ('<rotate x="1" angle="70"/><rotate z="1" angle="30"/><rotate y="1" angle="-40"/>'
         '<translate x="0.5" y="-0.2" z="0.3"/>')
W, H, BRIGHT = 8, 4, (5, 1)                     # the texture's size; its bright texel (column, row)


def chain_of_xml() -> np.ndarray:
    """The 4 x 4 matrix of CHAIN as Mitsuba composes it (each later element applied after)."""
    import xml.etree.ElementTree as ET
    m = np.eye(4)
    for e in ET.fromstring(f"<t>{CHAIN}</t>"):
        a = {k: float(v) for k, v in e.attrib.items()}
        if e.tag == "translate":
            step = np.eye(4)
            step[:3, 3] = [a.get("x", 0.0), a.get("y", 0.0), a.get("z", 0.0)]
        else:
            from scipy.spatial.transform import Rotation
            axis = np.array([a.get("x", 0.0), a.get("y", 0.0), a.get("z", 0.0)])
            step = np.eye(4)
            step[:3, :3] = Rotation.from_rotvec(np.radians(a["angle"]) * axis / np.linalg.norm(axis)).as_matrix()
        m = step @ m
    return m


def scene_xml(folder, camera_dir: np.ndarray, textured: bool = True) -> str:
    world = chain_of_xml()
    center = world[:3, :3] @ CENTER + world[:3, 3]
    eye = center + 6.0 * camera_dir
    up = [0, 0, 1] if abs(camera_dir[2]) < 0.9 else [1, 0, 0]
    bsdf = ('<bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
            '<string name="filename" value="t.exr"/><string name="filter_type" value="nearest"/>'
            '</texture></bsdf>') if textured else '<bsdf type="diffuse"/>'
    text = (f'<scene version="3.0.0"><integrator type="path"/>'
            f'<sensor type="perspective"><float name="fov" value="4"/>'
            f'<transform name="to_world"><lookat origin="{",".join(map(str, eye))}" '
            f'target="{",".join(map(str, center))}" up="{",".join(map(str, up))}"/></transform>'
            f'<film type="hdrfilm"><integer name="width" value="9"/><integer name="height" value="9"/>'
            f'<rfilter type="box"/></film></sensor><emitter type="constant"/>'
            f'<shape type="sphere"><point name="center" value="{",".join(map(str, CENTER))}"/>'
            f'<float name="radius" value="{RADIUS}"/><transform name="to_world">{CHAIN}</transform>'
            f'{bsdf}</shape></scene>')
    path = folder / "s.xml"
    path.write_text(text)
    return path


@pytest.fixture()
def folder(tmp_path):
    from drtlab.kernels.imageio import write_exr
    texels = np.zeros((H, W, 3), np.float32)
    texels[BRIGHT[1], BRIGHT[0]] = 1.0
    write_exr(tmp_path / "t.exr", texels)
    return tmp_path


def test_the_importer_keeps_a_textured_spheres_rotation(folder):
    rotation = chain_of_xml()[:3, :3]
    s = load_scene(scene_xml(folder, np.array([0.0, 0.0, 1.0]))).shapes[0]
    assert np.allclose(s.to_local, rotation.T, atol=1e-12)
    assert np.allclose(s.center, rotation @ CENTER + chain_of_xml()[:3, 3], atol=1e-12)
    assert abs(s.radius - RADIUS) < 1e-12
    plain = load_scene(scene_xml(folder, np.array([0.0, 0.0, 1.0]), textured=False)).shapes[0]
    assert plain.to_local is None               # nothing reads an untextured sphere's frame


def centre_pixel(folder, local_dir) -> float:
    from drtlab.kernels.render import render_with_stats
    world_dir = chain_of_xml()[:3, :3] @ local_dir
    stats = render_with_stats(load_scene(scene_xml(folder, world_dir)), spp=16, seed=0,
                              progress=False)
    return float(stats.image[H_C, W_C].mean())


H_C = W_C = 4


def local_direction(u: float, v: float) -> np.ndarray:
    """The sphere-frame direction with Mitsuba's uv (u, v)."""
    phi, theta = 2.0 * np.pi * u, np.pi * v
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def test_the_bright_texel_lands_where_the_formula_says(folder):
    u, v = (BRIGHT[0] + 0.5) / W, (BRIGHT[1] + 0.5) / H      # the texel's centre (top row first)
    assert centre_pixel(folder, local_direction(u, v)) > 0.5
    # Negative controls: u mirrored, and the formula in the world's axes (the rotation ignored).
    assert centre_pixel(folder, local_direction(1.0 - u, v)) == 0.0
    unrotated = chain_of_xml()[:3, :3].T @ local_direction(u, v)
    assert centre_pixel(folder, unrotated) == 0.0


def test_a_mirrored_sphere_is_refused_and_two_mirrors_are_a_turn(folder):
    """Mitsuba 3 turns the normals of a sphere whose to_world mirrors (determinant < 0) inwards: a
    diffuse one seen from outside is black there (Mitsuba 3.9.1: 0 at the centre pixel under a
    constant environment, 0.5 unmirrored), which drtlab's outward spheres cannot show, so it is
    refused in one line. Two mirrors are a half turn about z: loaded, its frame diag(-1, -1, 1)."""
    from drtlab.errors import InputError
    text = scene_xml(folder, np.array([0.0, 0.0, 1.0])).read_text()
    turned = text.replace(CHAIN, '<scale x="-1" y="-1"/>')
    (folder / "turned.xml").write_text(turned)
    assert np.allclose(load_scene(folder / "turned.xml").shapes[0].to_local, np.diag([-1.0, -1.0, 1.0]))
    (folder / "mirrored.xml").write_text(text.replace(CHAIN, '<scale z="-1"/>'))
    with pytest.raises(InputError) as e:
        load_scene(folder / "mirrored.xml")
    assert "\n" not in str(e.value) and "shape(sphere)/transform[@name=to_world]: a mirroring" in str(e.value)
