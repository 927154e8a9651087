"""Mesh attributes (Mitsuba 3's `mesh_attribute` texture: kernels/scene_model/mesh_attributes.py,
kernels/materials/mesh_attribute.py) and the blend of two diffuse albedos by a weight texture
(Mitsuba's blendbsdf): a PLY's properties named and scaled as Mitsuba's ply.h (8-bit sRGB-decoded);
the device lookup at real mesh hits against the barycentric interpolation of the hit's own vertices
(exact to float32 rounding; the weights rotated, a negative control, are rejected) and a face's
value exactly (the neighbouring face's, a negative control, differs); a weight of 0 and 1 giving
exactly either albedo, clipped outside [0, 1]; a face-coloured mesh rendered exactly as albedo E / π;
the Features flag; the Mitsuba importer's tables and its one-line refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp

from drtlab.errors import InputError
from drtlab.kernels.colour import srgb_to_linear
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import features_of
from drtlab.kernels.intersection.motion import make_motion
from drtlab.kernels.intersection.scene_rays import make_intersect
from drtlab.kernels.materials.material_at import material_at_for
from drtlab.kernels.render import render
from drtlab.kernels.scene_model.scene_file import load_scene, scene_from_dict
from drtlab.kernels.scene_upload import upload

EPS32 = float(np.finfo(np.float32).eps)
SUITE = "/work/shared/mitsuba-tests/tests/scenes/mesh_attributes"

# A 2 x 2 square in y = 0 of four triangles around its centre, vertices in an order that is not the
# faces' (so a lookup by the wrong index shows), each face's corners in a different rotation.
VERTS = np.array([[0.0, 0.0, 0.0], [-1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0],
                  [-1.0, 0.0, 1.0]])
FACES = np.array([[0, 1, 3], [2, 0, 3], [4, 2, 0], [1, 0, 4]])


def write_ply(path, vertex_props: dict, face_props: dict, faces=FACES, verts=VERTS) -> None:
    """An ASCII PLY: x y z, then `vertex_props` (name -> (type, values)) per vertex; the index list,
    then `face_props` per face."""
    lines = ["ply", "format ascii 1.0", f"element vertex {len(verts)}"]
    lines += [f"property float {c}" for c in "xyz"]
    lines += [f"property {t} {n}" for n, (t, _) in vertex_props.items()]
    lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    lines += [f"property {t} {n}" for n, (t, _) in face_props.items()] + ["end_header"]
    for i, v in enumerate(verts):
        lines.append(" ".join([repr(float(x)) for x in v] + [repr(vals[i]) for _, vals in vertex_props.values()]))
    for i, f in enumerate(faces):
        lines.append(" ".join(["3"] + [str(int(x)) for x in f] + [repr(vals[i]) for _, vals in face_props.values()]))
    path.write_text("\n".join(lines) + "\n")


RNG = np.random.default_rng(41)
VCOL = RNG.random((len(VERTS), 3)).astype(np.float32)
FCOL = RNG.random((len(FACES), 3)).astype(np.float32)
FWEIGHT = np.array([0.0, 1.0, 0.3125, -0.5], dtype=np.float32)      # the last one clipped to 0
R0, R1 = np.array([0.0, 0.5, 0.5]), np.array([1.0, 1.0, 0.0])


@pytest.fixture(scope="module")
def ply(tmp_path_factory):
    path = tmp_path_factory.mktemp("attr") / "square.ply"
    props = {f"color_{k}": ("float", [float(x) for x in VCOL[:, k]]) for k in range(3)}
    fprops = {f"color_{k}": ("float", [float(x) for x in FCOL[:, k]]) for k in range(3)}
    fprops["weight_0"] = ("float", [float(x) for x in FWEIGHT])
    write_ply(path, props, fprops)
    return str(path)


def square_scene(ply: str, material: dict, resolution: int = 8, spp: int = 1,
                 integrator: str = "direct") -> dict:
    """The square seen straight down by an orthographic camera whose film is the square, lit
    straight down by a directional light."""
    return {"scene": {"description": "an attributed square", "resolution": [resolution, resolution],
                      "spp": spp, "integrator": integrator, "max_depth": 2},
            "camera": {"position": [0.0, 3.0, 0.0], "look_at": [0.0, 0.0, 0.0], "up": [0.0, 0.0, -1.0],
                       "fov": 30.0, "ortho_height": 2.0},
            "materials": {"attr": material},
            "shapes": [{"kind": "mesh", "material": "attr", "file": ply}],
            "lights": [{"kind": "directional", "direction": [0.0, -1.0, 0.0],
                        "irradiance": list(IRRADIANCE)}]}


IRRADIANCE = (2.0, 3.0, 4.0)
_kernels: dict = {}


def hits(scene, xz: np.ndarray) -> dict:
    """intersect() and material_at_hit() of a variant with mesh attributes, for rays straight down
    onto the points (x, 0, z)."""
    f = features_of(scene, "path")
    assert f.textures and f.mesh_attributes
    if "k" not in _kernels:
        rays = make_intersect(f, motion=make_motion())
        material_at_hit = material_at_for(True, attributes=True)[1]

        @wp.kernel(enable_backward=False, module="unique")
        def k(sd: SceneData, o: wp.array(dtype=wp.vec3), face: wp.array(dtype=int),
              uv: wp.array(dtype=wp.vec2), p: wp.array(dtype=wp.vec3), albedo: wp.array(dtype=wp.vec3)):
            i = wp.tid()
            h = rays.intersect(sd, o[i], wp.vec3(0.0, -1.0, 0.0), 1.0e30, 0.0)
            face[i] = h.index
            uv[i] = h.uv
            p[i] = h.p
            albedo[i] = material_at_hit(sd, h).albedo

        _kernels["k"] = k
    sd = upload(scene, "cpu")
    n = len(xz)
    o = wp.array(np.stack([xz[:, 0], np.full(n, 2.0), xz[:, 1]], axis=1).astype(np.float32),
                 dtype=wp.vec3, device="cpu")
    out = {"face": wp.zeros(n, dtype=int, device="cpu"), "uv": wp.zeros(n, dtype=wp.vec2, device="cpu"),
           "p": wp.zeros(n, dtype=wp.vec3, device="cpu"), "albedo": wp.zeros(n, dtype=wp.vec3, device="cpu")}
    wp.launch(_kernels["k"], dim=n, inputs=[sd, o, *out.values()], device="cpu")
    return {key: a.numpy() for key, a in out.items()}


def points(n: int = 4000) -> np.ndarray:
    return RNG.uniform(-0.98, 0.98, (n, 2)).astype(np.float32)


# ---- a PLY's attributes, as Mitsuba names them ----

def test_ply_properties_are_grouped_named_and_decoded_as_mitsubas(tmp_path):
    import colour
    codes = np.array([[0, 128, 255], [10, 20, 30], [40, 50, 60], [70, 80, 90], [200, 1, 254]], np.uint8)
    vprops = {c: ("uchar", [int(x) for x in codes[:, k]]) for k, c in enumerate(("red", "green", "blue"))}
    vprops.update({f"albedo_{c}": ("float", [0.1 * k + 0.01 * i for i in range(5)]) for k, c in enumerate("rgb")})
    vprops.update({"k_0": ("float", [1.0] * 5), "k_1": ("float", [2.0] * 5), "quality": ("float", [9.0] * 5)})
    fprops = {"weight_1": ("float", [0.25, 0.5, 0.75, 1.0]), "q_x": ("float", [1.0, 2.0, 3.0, 4.0]),
              "q_y": ("float", [5.0] * 4), "q_z": ("float", [6.0] * 4)}
    path = tmp_path / "m.ply"
    write_ply(path, vprops, fprops)
    scene = scene_from_dict(square_scene(str(path), {"albedo": [0.5] * 3}))
    attrs = scene.shapes[0].mesh.attributes
    # r g b is `color`, an rgb suffix `_color`, x y z and 1 keep the prefix; a 2-property group
    # (k_0 k_1) and a property without a suffix (quality) are no attributes
    assert sorted(attrs) == ["face_q", "face_weight", "vertex_albedo_color", "vertex_color"]
    assert attrs["face_weight"].shape == (4, 1) and attrs["face_q"].shape == (4, 3)
    assert np.array_equal(attrs["face_q"][:, 0], [1.0, 2.0, 3.0, 4.0])
    want = colour.cctf_decoding(codes / 255.0, function="sRGB")
    assert attrs["vertex_color"].dtype == np.float32
    assert np.max(np.abs(attrs["vertex_color"] - want)) < 4 * EPS32
    assert np.max(np.abs(attrs["vertex_color"] - codes / 255.0)) > 0.1     # negative control: not decoded
    assert np.array_equal(attrs["vertex_color"], srgb_to_linear(codes / 255.0).astype(np.float32))


def test_the_suites_sphere_has_mitsubas_three_attributes():
    scene = load_scene(f"{SUITE}/test_mesh_attributes_3_vertex_direct.xml")
    a = scene.shapes[0].mesh.attributes
    assert {n: v.shape for n, v in a.items()} == {"vertex_color": (1192, 3), "face_color": (528, 3),
                                                    "face_weight": (528, 1)}


# ---- the device lookup at real hits ----

def test_vertex_attribute_is_the_barycentric_interpolation_at_the_hit(ply):
    scene = scene_from_dict(square_scene(ply, {"albedo_texture": {"kind": "mesh_attribute",
                                                                  "name": "vertex_color"}}))
    xz = points()
    r = hits(scene, xz)
    assert np.all(r["face"] >= 0)
    tri = FACES[r["face"]]
    u, v = r["uv"][:, :1].astype(np.float64), r["uv"][:, 1:].astype(np.float64)
    w = 1.0 - u - v
    # the hit's uv are barycentric weights of the face's vertices 0, 1, 2: they rebuild the point
    rebuilt = VERTS[tri[:, 0]] * u + VERTS[tri[:, 1]] * v + VERTS[tri[:, 2]] * w
    assert np.max(np.abs(rebuilt[:, [0, 2]] - xz)) < 1e-5
    c = VCOL.astype(np.float64)
    want = c[tri[:, 0]] * u + c[tri[:, 1]] * v + c[tri[:, 2]] * w
    tol = 8 * EPS32
    assert np.max(np.abs(r["albedo"] - want)) <= tol
    rotated = c[tri[:, 1]] * u + c[tri[:, 2]] * v + c[tri[:, 0]] * w       # negative control
    assert np.max(np.abs(r["albedo"] - rotated)) > 100 * tol


def test_face_attribute_is_its_faces_value_exactly_and_scaled(ply):
    scene = scene_from_dict(square_scene(ply, {"albedo_texture": {"kind": "mesh_attribute",
                                                                  "name": "face_color", "scale": 0.5}}))
    r = hits(scene, points())
    assert np.array_equal(r["albedo"], FCOL[r["face"]] * np.float32(0.5))
    shifted = FCOL[(r["face"] + 1) % len(FACES)] * np.float32(0.5)      # negative control: off by one
    assert np.all(np.any(r["albedo"] != shifted, axis=1))
    assert len(np.unique(r["face"])) == len(FACES)


def test_a_one_channel_attribute_reads_as_grey(ply):
    scene = scene_from_dict(square_scene(ply, {"albedo_texture": {"kind": "mesh_attribute",
                                                                  "name": "face_weight"}}))
    r = hits(scene, points(400))
    assert np.array_equal(r["albedo"], np.repeat(FWEIGHT[r["face"], None], 3, axis=1))


def test_weight_blends_two_albedos_exactly_at_0_and_1_and_clips(ply):
    scene = scene_from_dict(square_scene(ply, {"albedo": R0.tolist(), "blend_albedo": R1.tolist(),
                                               "weight_texture": {"kind": "mesh_attribute",
                                                                  "name": "face_weight"}}))
    r = hits(scene, points())
    r0, r1 = R0.astype(np.float32), R1.astype(np.float32)
    w = np.clip(FWEIGHT[r["face"]], 0.0, 1.0)[:, None]
    assert np.array_equal(r["albedo"][r["face"] == 0], np.broadcast_to(r0, (np.sum(r["face"] == 0), 3)))
    assert np.array_equal(r["albedo"][r["face"] == 1], np.broadcast_to(r1, (np.sum(r["face"] == 1), 3)))
    assert np.array_equal(r["albedo"][r["face"] == 3], np.broadcast_to(r0, (np.sum(r["face"] == 3), 3)))
    assert np.max(np.abs(r["albedo"] - ((1.0 - w) * R0 + w * R1))) <= 4 * EPS32
    unclipped = (1.0 - FWEIGHT[r["face"], None]) * R0 + FWEIGHT[r["face"], None] * R1   # negative control
    assert np.max(np.abs(r["albedo"] - unclipped)) > 0.1


def test_variants_without_attributes_compile_none(ply):
    f = features_of(load_scene("displaced-sphere"), "path")       # a mesh, no attributes
    assert f.meshes and not f.mesh_attributes and "mesh_attributes" not in f.key()
    textured = scene_from_dict(square_scene(ply, {"albedo_texture": {"kind": "checkerboard"}}))
    assert not features_of(textured, "path").mesh_attributes


# ---- a render: each face's colour x irradiance / π, exactly ----

def test_face_coloured_render_is_albedo_times_irradiance_over_pi(ply):
    n = 16
    scene = scene_from_dict(square_scene(ply, {"albedo_texture": {"kind": "mesh_attribute",
                                                                  "name": "face_color"}},
                                         resolution=n, spp=4))
    img = render(scene, spp=4, seed=1)
    # pixel (row, col) covers x in [-1 + 2 col / n, ...], z from -1 (top) by the camera's up -z;
    # a pixel wholly inside one face is lit the same at every sample
    centre = (np.arange(n) + 0.5) / n * 2.0 - 1.0
    Z, X = np.meshgrid(centre, centre, indexing="ij")
    half = 1.0 / n
    inside = (np.abs(np.abs(X) - np.abs(Z)) > 2.5 * half)        # away from both diagonals
    quadrant = np.where(np.abs(Z) > np.abs(X), np.where(Z < 0, 0, 2), np.where(X > 0, 1, 3))
    want = FCOL[quadrant].astype(np.float64) * np.array(IRRADIANCE) / math.pi
    assert inside.sum() > 100
    assert np.max(np.abs(img - want)[inside]) < 1e-6
    wrong = FCOL[(quadrant + 1) % 4].astype(np.float64) * np.array(IRRADIANCE) / math.pi
    assert np.min(np.max(np.abs(img - wrong), axis=2)[inside]) > 1e-3      # negative control


# ---- the scene file's and the importer's refusals, one line each ----

def refused_toml(ply, material: dict, **shape) -> str:
    d = square_scene(ply, material)
    d["shapes"][0].update(shape)
    with pytest.raises(InputError) as e:
        scene_from_dict(d)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def test_scene_file_refusals(ply):
    attr = lambda name, **kw: {"kind": "mesh_attribute", "name": name, **kw}
    assert "'vertex_colour'" in refused_toml(ply, {"albedo_texture": attr("vertex_colour")})
    assert "vertex_color (3 channels)" in refused_toml(ply, {"albedo_texture": attr("vertex_colour")})
    assert "'vertex_' or 'face_'" in refused_toml(ply, {"albedo_texture": attr("color")})
    assert "a weight reads 1" in refused_toml(ply, {"albedo": R0.tolist(), "blend_albedo": R1.tolist(),
                                                     "weight_texture": attr("face_color")})
    assert "blend_albedo" in refused_toml(ply, {"weight_texture": attr("face_weight")})
    assert "scale" in refused_toml(ply, {"albedo_texture": attr("face_color", scale="2")})
    msg = refused_toml(ply, {"kind": "glossy", "weight_texture": attr("face_weight"),
                             "blend_albedo": R1.tolist()})
    assert "weight_texture" in msg
    sphere = square_scene(ply, {"albedo_texture": attr("face_color")})
    sphere["shapes"] = [{"kind": "sphere", "material": "attr", "center": [0, 0, 0], "radius": 0.5}]
    with pytest.raises(InputError, match="is a sphere: a mesh attribute lies on a mesh"):
        scene_from_dict(sphere)


HEAD = ('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/>'
        '</film></sensor>')


def xml_scene(tmp_path, ply, bsdf: str, shape: str = "ply"):
    path = tmp_path / "s.xml"
    path.write_text(f'{HEAD}<shape type="{shape}"><string name="filename" value="{ply}"/>{bsdf}'
                    '</shape></scene>')
    return load_scene(path)


def xml_refused(tmp_path, *args) -> str:
    with pytest.raises(InputError) as e:
        xml_scene(tmp_path, *args)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


DIFFUSE = '<bsdf type="diffuse"><rgb name="reflectance" value="{}"/></bsdf>'


def test_the_suites_blend_is_a_diffuse_with_a_weight_texture():
    m = load_scene(f"{SUITE}/test_mesh_attributes_1_face_direct.xml").materials[0]
    assert m.kind == "diffuse" and m.textures["weight"].name == "face_weight"
    assert np.array_equal(m.albedo, [0.0, 0.5, 0.5]) and np.array_equal(m.albedo2, [1.0, 1.0, 0.0])
    m = load_scene(f"{SUITE}/test_mesh_attributes_3_vertex_direct.xml").materials[0]
    assert m.textures["albedo"].name == "vertex_color" and m.textures["albedo"].per_vertex


def test_a_constant_blend_weight_is_folded_into_the_albedo(tmp_path, ply):
    bsdf = ('<bsdf type="blendbsdf"><float name="weight" value="0.25"/>' + DIFFUSE.format("0 .5 .5")
            + DIFFUSE.format("1 1 0") + '</bsdf>')
    m = xml_scene(tmp_path, ply, bsdf).materials[0]
    assert m.kind == "diffuse" and not m.textures
    assert np.allclose(m.albedo, 0.75 * R0 + 0.25 * R1, rtol=0, atol=1e-15)


def test_importer_refusals(tmp_path, ply):
    other = ('<bsdf type="blendbsdf"><float name="weight" value="0.5"/>' + DIFFUSE.format("1 1 1")
             + '<bsdf type="conductor"/></bsdf>')
    assert "a blendbsdf of diffuse and conductor is not supported" in xml_refused(tmp_path, ply, other)
    attr = ('<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">'
            '<string name="name" value="{}"/></texture></bsdf>')
    assert "no attribute 'vertex_rgb'" in xml_refused(tmp_path, ply, attr.format("vertex_rgb"))
    obj = tmp_path / "t.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    assert "a mesh_attribute texture on a obj" in xml_refused(tmp_path, str(obj), attr.format("vertex_color"),
                                                              "obj")
    assert "'vertex_' or 'face_'" in xml_refused(tmp_path, ply, attr.format("colour"))
