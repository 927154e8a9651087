"""The tangent reaches the anisotropic BSDF in the renderer (kernels/intersection/tangent.py,
kernels/materials/material_at.py). A point light over a large floor, path tracing to depth 2 with
nothing else in the scene: each pixel is the light's eval_bsdf at the hit (the BSDF-sampled ray
escapes into black), so renders of the same seed compare to float rounding.
* A quad's lobe follows edge_u: alphas (a, b) along edge_u = x equal alphas (b, a) along edge_u = z
  (the same square, the same normal). Negative control: (b, a) along x differs by far more.
* A mesh's lobe follows its uv's dp/du: the square as two OBJ triangles with u along x renders as the
  quad; with u along z and the alphas swapped, too; without uv, as Mitsuba's coordinate_system of
  the face normal (+y: its first axis is +x).
"""
from __future__ import annotations

import numpy as np

import drtlab

KIND = "beckmann_conductor_anisotropic"
A, B = 0.05, 0.4


def _scene(material: dict, floor: dict) -> dict:
    return {"scene": {"description": "an anisotropic floor under a point light", "resolution": [24, 16],
                      "integrator": "path", "max_depth": 2},
            "camera": {"position": [0.0, 1.5, 2.5], "look_at": [0.0, 0.0, -0.3], "fov": 40.0},
            "materials": {"m": {"kind": KIND, "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.4, 2.2], **material}},
            "shapes": [{"material": "m", **floor}],
            "lights": [{"kind": "point", "position": [0.4, 1.0, -0.8], "intensity": [5.0, 5.0, 5.0]}]}


QUAD_X = {"kind": "quad", "origin": [-10, 0, 10], "edge_u": [20, 0, 0], "edge_v": [0, 0, -20]}
QUAD_Z = {"kind": "quad", "origin": [10, 0, 10], "edge_u": [0, 0, -20], "edge_v": [-20, 0, 0]}


def _render(material, floor):
    return drtlab.render(drtlab.load_scene(_scene(material, floor)), spp=2, seed=3)


def _obj(path, u_along_x: bool | None):
    """The floor as two triangles, u along x or z, or (None) without texture coordinates."""
    corners = [(-10, 10), (10, 10), (10, -10), (-10, -10)]                 # (x, z), a floor facing +y
    lines = [f"v {x} 0 {z}" for x, z in corners]
    for x, z in corners if u_along_x is not None else ():
        u, v = ((x + 10) / 20, (z + 10) / 20) if u_along_x else ((10 - z) / 20, (x + 10) / 20)
        lines.append(f"vt {u} {v}")
    lines += (["f 1/1 2/2 3/3", "f 1/1 3/3 4/4"] if u_along_x is not None else ["f 1 2 3", "f 1 3 4"])
    path.write_text("\n".join(lines) + "\n")
    return {"kind": "mesh", "file": str(path)}


def test_a_quads_lobe_turns_with_edge_u():
    x = _render({"alpha_u": A, "alpha_v": B}, QUAD_X)
    z = _render({"alpha_u": B, "alpha_v": A}, QUAD_Z)
    wrong = _render({"alpha_u": B, "alpha_v": A}, QUAD_X)
    assert x.max() > 0.05 and np.isfinite(x).all()
    scale = x.max()
    np.testing.assert_allclose(z, x, rtol=1e-3, atol=1e-5 * scale)
    assert np.abs(wrong - x).max() > 0.2 * scale


def test_a_meshs_lobe_turns_with_its_uv(tmp_path):
    x = _render({"alpha_u": A, "alpha_v": B}, QUAD_X)
    mesh_x = _render({"alpha_u": A, "alpha_v": B}, _obj(tmp_path / "x.obj", True))
    mesh_z = _render({"alpha_u": B, "alpha_v": A}, _obj(tmp_path / "z.obj", False))
    # Without uv: Mitsuba's coordinate_system of the face normal +y, whose first axis is +x.
    bare = _render({"alpha_u": A, "alpha_v": B}, _obj(tmp_path / "bare.obj", None))
    for m in (mesh_x, mesh_z, bare):
        np.testing.assert_allclose(m, x, rtol=1e-3, atol=1e-5 * x.max())


def test_a_sphere_renders_finite_through_its_pole():
    """A sphere's tangent (drtlab's u direction) vanishes at its poles (y = +-r): the lobe falls back
    to an arbitrary tangent there, and the image stays finite; swapping the alphas changes it."""
    sphere = {"kind": "sphere", "center": [0.0, -1.0, -0.3], "radius": 1.0}
    one = _render({"alpha_u": A, "alpha_v": B}, sphere)
    other = _render({"alpha_u": B, "alpha_v": A}, sphere)
    assert np.isfinite(one).all() and one.max() > 0.01
    assert np.abs(one - other).max() > 0.1 * one.max()
