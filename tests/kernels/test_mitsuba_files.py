"""The file layer of the Mitsuba XML importer as Mitsuba 3 reads files: versions 0.6-3.x and the
upgrade of files older than 2.0, <include> (relative to the including file, nested, cycles refused),
<path>, `name` attributes where Mitsuba's writer puts them, <spectrum> wavelength:value pairs as
Mitsuba's RGB variants turn them into RGB, constant textures, the integrator wrappers (moment,
ptracer, direct), shapegroup/instance flattened, smooth normals of meshes without them, and
Mitsuba's defaults of what a file leaves out. Pure Python: nothing renders."""
from __future__ import annotations

import math
import struct
import zlib

import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.scene_model.mitsuba_files import camel_to_snake, parse_version
from drtlab.kernels.scene_model.mitsuba_spectrum import XYZ_TO_SRGB, spectrum_to_rgb
from drtlab.kernels.scene_model.scene_file import load_scene

SENSOR = ('<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm">'
          '<integer name="width" value="16"/><integer name="height" value="12"/><rfilter type="box"/>'
          '</film></sensor>')


def scene_xml(body: str, version: str = "3.0.0", sensor: str = SENSOR) -> str:
    """A scene of `body`; a lone sphere where it has no shape (drtlab needs one)."""
    if "<shape" not in body:
        body += '<shape type="sphere"/>'
    return f'<scene version="{version}">{sensor}{body}</scene>'


def load(tmp_path, text: str, name: str = "s.xml"):
    (tmp_path / name).write_text(text)
    return load_scene(tmp_path / name)


def refused(tmp_path, text: str, name: str = "s.xml") -> str:
    with pytest.raises(InputError) as e:
        load(tmp_path, text, name)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def albedo(scene, k=0):
    return scene.materials[k].albedo.tolist()


# ---- versions -------------------------------------------------------------------------------------

@pytest.mark.parametrize("text,want", [("3.0.0", (3, 0, 0)), ("2.1", (2, 1, 0)), ("0.6.0", (0, 6, 0)),
                                       ("0.5.0", None), ("4.0.0", None), ("three", None), ("", None)])
def test_versions_mitsuba3_reads(text, want):
    assert parse_version(text) == want


@pytest.mark.parametrize("name,want", [("intIOR", "int_ior"), ("sampleCount", "sample_count"),
                                       ("maxDepth", "max_depth"), ("diffuseReflectance", "diffuse_reflectance"),
                                       ("uoffset", "uoffset"), ("to_world", "to_world")])
def test_camel_case_as_mitsuba_renames_it(name, want):
    assert camel_to_snake(name) == want


def test_version_1_file_is_upgraded(tmp_path):
    s = load(tmp_path, scene_xml('<shape type="sphere"><bsdf type="diffuse"><rgb name="diffuseReflectance" '
                                 'value="0.1 0.2 0.3"/></bsdf></shape><shape type="sphere"><bsdf '
                                 'type="dielectric"><float name="intIOR" value="1.7"/></bsdf></shape>',
                                 version="0.6.0"))
    assert albedo(s) == [0.1, 0.2, 0.3]
    assert s.materials[1].ior == pytest.approx(1.7 / 1.000277, rel=1e-15)


def test_version_2_file_is_not_upgraded(tmp_path):
    msg = refused(tmp_path, scene_xml('<shape type="sphere"><bsdf type="diffuse"><rgb '
                                      'name="diffuseReflectance" value="0.5"/></bsdf></shape>', version="2.0.0"))
    assert "diffuseReflectance" in msg


def test_unsupported_version_is_one_line(tmp_path):
    assert "version must be 0.6 ... 3.x" in refused(tmp_path, scene_xml("", version="4.0.0"))


# ---- <include> and <path> -------------------------------------------------------------------------

def test_include_is_relative_to_the_including_file_and_nests(tmp_path):
    (tmp_path / "parts" / "deeper").mkdir(parents=True)
    (tmp_path / "parts" / "a.xml").write_text(
        '<scene version="2.0.0"><shape type="sphere"><float name="radius" value="2"/></shape>'
        '<include filename="deeper/b.xml"/></scene>')
    (tmp_path / "parts" / "deeper" / "b.xml").write_text(
        '<scene version="0.6.0"><shape type="sphere"><float name="radius" value="3"/></shape></scene>')
    s = load(tmp_path, scene_xml('<include filename="parts/a.xml"/>'))
    assert [sh.radius for sh in s.shapes] == [2.0, 3.0, 1.0]       # in document order


def test_include_cycle_is_refused(tmp_path):
    (tmp_path / "a.xml").write_text('<scene version="3.0.0"><include filename="b.xml"/></scene>')
    (tmp_path / "b.xml").write_text('<scene version="3.0.0"><include filename="a.xml"/></scene>')
    msg = refused(tmp_path, scene_xml('<include filename="a.xml"/>'))
    assert "cycle" in msg and "a.xml -> b.xml -> a.xml" in msg


def test_missing_include_is_one_line(tmp_path):
    assert "included file 'nope.xml' does not exist" in refused(tmp_path, scene_xml('<include filename="nope.xml"/>'))


def test_path_folder_finds_files_latest_first(tmp_path):
    for folder in ("one", "two"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "two" / "m.obj").write_text("v 0 0 0\nv 2 0 0\nv 0 2 0\nf 1 2 3\n")
    s = load(tmp_path, scene_xml('<path value="one"/><path value="two"/><shape type="obj">'
                                 '<string name="filename" value="m.obj"/></shape>'))
    assert s.shapes[0].mesh.vertices.max() == 2.0


def test_path_below_the_root_is_refused(tmp_path):
    (tmp_path / "one").mkdir()
    assert "<path> can only be a child of <scene>" in refused(
        tmp_path, scene_xml('<shape type="sphere"><path value="one"/></shape>'))


def test_missing_path_folder_is_one_line(tmp_path):
    assert "folder 'nowhere' does not exist" in refused(tmp_path, scene_xml('<path value="nowhere"/>'))


# ---- name attributes as Mitsuba's writer (mi.xml.dict_to_xml) puts them -------------------------

def test_names_of_mitsubas_writer_load(tmp_path):
    s = load(tmp_path, '<scene version="3.0.0"><integrator type="path" name="integrator"><integer '
                       'name="max_depth" value="3"/></integrator><sensor type="perspective" name="sensor">'
                       '<film type="hdrfilm" name="film"><rfilter type="box" name="rfilter"/></film>'
                       '<sampler type="independent" name="sampler"/></sensor><shape type="sphere" '
                       'name="ball"><bsdf type="diffuse" name="bsdf"/></shape><emitter type="constant" '
                       'name="sky"/></scene>')
    assert s.max_depth == 3 and len(s.shapes) == 1


# ---- spectra ------------------------------------------------------------------------------------

def test_uniform_spectrum_on_a_reflectance_is_grey_and_on_an_emitter_d65_purple(tmp_path):
    s = load(tmp_path, scene_xml('<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" '
                                 'value="0.25"/></bsdf></shape><emitter type="point"><point name="position" '
                                 'value="0"/><spectrum name="intensity" value="2"/></emitter>'))
    assert albedo(s) == [0.25] * 3
    assert s.point_lights[0].intensity.tolist() == (2.0 * XYZ_TO_SRGB.sum(axis=1)).tolist()


def test_flat_reflectance_spectrum_is_white_and_emitters_scale_linearly():
    white = spectrum_to_rgb((360.0, 830.0), (1.0, 1.0), emitter=False)
    # D65 under the CIE observer is sRGB's white: (1, 1, 1) up to the tables' rounding.
    assert white == pytest.approx([1.0, 1.0, 1.0], abs=3e-3)
    one = spectrum_to_rgb((400.0, 500.0, 600.0, 700.0), (0.0, 8.0, 15.6, 18.4), emitter=True)
    two = spectrum_to_rgb((400.0, 500.0, 600.0, 700.0), (0.0, 16.0, 31.2, 36.8), emitter=True)
    assert two == pytest.approx([2 * v for v in one], rel=1e-12)
    assert one[0] > one[1] > one[2] > 0            # red-heavy spectrum: a warm light


def test_spectrum_integrates_what_lies_inside_its_wavelengths():
    # 400-700 nm only, flat 0.78: less than 0.78 (no light outside the interval), neutral-ish.
    rgb = spectrum_to_rgb((400.0, 500.0, 600.0, 700.0), (0.78,) * 4, emitter=False)
    assert all(0.7 < v < 0.78 for v in rgb)
    # A bounded spectrum clamps at 1, an emitter's does not.
    assert max(spectrum_to_rgb((360.0, 830.0), (3.0, 3.0), emitter=False)) == 1.0
    assert min(spectrum_to_rgb((360.0, 830.0), (3.0, 3.0), emitter=True)) > 2.5


def test_spectrum_matches_a_float64_quadrature_of_colour_sciences_tables():
    import colour
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    w = np.linspace(500.0, 600.0, 100001)
    xyz = np.trapezoid(cmfs[w] * np.interp(w, [500, 600], [1.0, 3.0])[:, None], w, axis=0) / 106.7502593994140625
    want = np.maximum(XYZ_TO_SRGB @ xyz, 0.0)
    got = spectrum_to_rgb((500.0, 600.0), (1.0, 3.0), emitter=True)
    # Mitsuba's 1000-point sum and 5 nm table against a fine quadrature of the 1 nm table: 1%.
    assert got == pytest.approx(want.tolist(), rel=1e-2, abs=1e-3)


def test_bad_spectrum_is_one_line(tmp_path):
    msg = refused(tmp_path, scene_xml('<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" '
                                      'value="500:1, 400:2"/></bsdf></shape>'))
    assert "increasing" in msg and "spectrum[@name=reflectance]" in msg


# ---- constant textures --------------------------------------------------------------------------

def test_constant_textures_where_a_value_is_meant(tmp_path):
    s = load(tmp_path, scene_xml('<texture type="srgb" id="c"><rgb name="color" value="0.1 0.2 0.3"/></texture>'
                                 '<shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="c"/>'
                                 '</bsdf></shape><shape type="sphere"><bsdf type="diffuse"><texture '
                                 'type="uniform" name="reflectance"><float name="value" value="0.7"/></texture>'
                                 '</bsdf></shape>'))
    assert albedo(s, 0) == [0.1, 0.2, 0.3] and albedo(s, 1) == [0.7] * 3


def test_bitmap_texture_is_refused_naming_it(tmp_path):
    msg = refused(tmp_path, scene_xml('<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" '
                                      'name="reflectance"><string name="filename" value="x.png"/></texture>'
                                      '</bsdf></shape>'))
    assert "texture(bitmap)" in msg


# ---- integrators --------------------------------------------------------------------------------

def test_moment_renders_its_inner_integrator(tmp_path):
    s = load(tmp_path, scene_xml('<integrator type="moment"><integrator type="path"><integer name="max_depth" '
                                 'value="4"/></integrator></integrator>'))
    assert (s.integrator, s.max_depth) == ("path", 4)


def test_ptracer_renders_with_path_and_says_so(tmp_path):
    s = load(tmp_path, scene_xml('<integrator type="ptracer"><integer name="max_depth" value="4"/></integrator>'))
    assert (s.integrator, s.max_depth) == ("path", 4)
    assert "ptracer renders with path" in s.description


def test_direct_maps_onto_drtlab(tmp_path):
    from drtlab.estimators.integrators import INTEGRATORS
    s = load(tmp_path, scene_xml('<integrator type="direct"/>'))
    if "direct" in INTEGRATORS:
        assert s.integrator == "direct"
    else:       # today: emitter and BSDF sample combined by MIS, a path of depth 2
        assert (s.integrator, s.max_depth) == ("path", 2)


# ---- shapes -------------------------------------------------------------------------------------

def test_instances_of_a_shapegroup_are_flattened(tmp_path):
    s = load(tmp_path, scene_xml(
        '<shape type="shapegroup" id="g"><shape type="sphere"><transform name="to_world"><scale value="0.5"/>'
        '<translate x="1"/></transform></shape></shape><shape type="instance"><ref id="g"/></shape>'
        '<shape type="instance"><ref id="g"/><transform name="to_world"><scale value="2"/><translate z="3"/>'
        '</transform></shape>'))
    assert [(sh.center.tolist(), sh.radius) for sh in s.shapes] == [([1.0, 0.0, 0.0], 0.5), ([2.0, 0.0, 3.0], 1.0)]


@pytest.mark.parametrize("body,words", [
    ('<shape type="shapegroup"><shape type="sphere"/></shape>', "needs an id"),
    ('<shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>'
     '<shape type="instance"><ref id="g"/></shape>', "emitter in a shapegroup"),
    ('<shape type="shapegroup" id="g"><shape type="sdfgrid"/></shape><shape type="instance"><ref id="g"/></shape>',
     "shape type 'sdfgrid' is not supported"),
])
def test_shapegroup_refusals_are_one_line(tmp_path, body, words):
    assert words in refused(tmp_path, scene_xml(body))


def test_mesh_without_normals_gets_mitsubas_angle_weighted_normals(tmp_path):
    # A bent strip: the shared vertices' normals differ by weighting scheme.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.5], [2, 0, 1.0]], dtype=float)
    f = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3]])
    (tmp_path / "m.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v)
                                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    s = load(tmp_path, scene_xml('<shape type="obj"><string name="filename" value="m.obj"/></shape>'))
    want = np.zeros_like(v)
    for tri in f:
        p = v[tri]
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n /= np.linalg.norm(n)
        for k in range(3):
            a, b = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
            want[tri[k]] += n * math.acos(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b))
    want /= np.linalg.norm(want, axis=1)[:, None]
    np.testing.assert_allclose(s.shapes[0].mesh.normals, want, rtol=0, atol=1e-12)
    flat = load(tmp_path, scene_xml('<shape type="obj"><string name="filename" value="m.obj"/>'
                                    '<boolean name="face_normals" value="true"/></shape>'), "flat.xml")
    assert flat.shapes[0].mesh.normals is None


# ---- Mitsuba's defaults of what a file leaves out -----------------------------------------------

def vfov_from_x(fov_x: float, aspect: float) -> float:
    return math.degrees(2 * math.atan(math.tan(math.radians(fov_x) / 2) / aspect))


@pytest.mark.parametrize("sensor,check", [
    # perspective: fov_axis x (a 16x12 film: the vertical fov follows from the horizontal one)
    (SENSOR, lambda s: s.camera.vfov_deg == pytest.approx(vfov_from_x(40.0, 16 / 12), rel=1e-14)),
    # no fov: focal_length 50mm on the 36 x 24 mm diagonal
    ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="36"/><integer name="height" '
     'value="24"/></film></sensor>',
     lambda s: s.camera.vfov_deg == pytest.approx(2 * math.degrees(math.atan(12 / 50)), rel=1e-12)),
    # no film: 768 x 576, Mitsuba's Gaussian cut at the film's edge; no sampler: 4 spp
    ('<sensor type="perspective"/>', lambda s: (s.width, s.height, s.spp, s.camera.filter_clip) == (768, 576, 4, True)),
])
def test_sensor_defaults_are_mitsubas(tmp_path, sensor, check):
    assert check(load(tmp_path, scene_xml("", sensor=sensor)))


def test_integrator_defaults_are_mitsubas(tmp_path):
    s = load(tmp_path, scene_xml(""))                                     # no integrator: path
    assert (s.integrator, s.max_depth, s.russian_roulette, s.rr_depth) == ("path", -1, True, 5)
    s = load(tmp_path, scene_xml('<integrator type="path"/>'), "p.xml")   # path: max_depth -1, rr 5
    assert (s.max_depth, s.russian_roulette, s.rr_depth) == (-1, True, 5)


@pytest.mark.parametrize("bsdf,check", [
    ('<bsdf type="diffuse"/>', lambda m: m.albedo.tolist() == [0.5] * 3),
    ('<bsdf type="dielectric"/>', lambda m: m.ior == 1.5046 / 1.000277),                 # bk7 / air
    ('<bsdf type="plastic"/>', lambda m: (m.ior, m.albedo.tolist()) == (1.49 / 1.000277, [0.5] * 3)),
    ('<bsdf type="roughconductor"/>', lambda m: (m.kind, m.roughness) == ("beckmann", 0.1)),
    ('<bsdf type="conductor"/>', lambda m: m.kind == "mirror"),                           # material none
    ('<bsdf type="roughdielectric"/>',                                         # beckmann, alpha 0.1, bk7/air
     lambda m: (m.kind, m.roughness, m.ior, m.albedo.tolist()) == ("beckmann_dielectric", 0.1, 1.5046 / 1.000277,
                                                                   [1.0] * 3)),
    ('<bsdf type="roughplastic"/>',                                            # beckmann 0.1, polypropylene
     lambda m: (m.kind, m.roughness, m.ior, m.albedo.tolist()) == ("beckmann_plastic", 0.1, 1.49 / 1.000277,
                                                                   [0.5] * 3)),
])
def test_bsdf_defaults_are_mitsubas(tmp_path, bsdf, check):
    assert check(load(tmp_path, scene_xml(f'<shape type="sphere">{bsdf}</shape>')).materials[0])


def test_shape_and_emitter_defaults_are_mitsubas(tmp_path):
    s = load(tmp_path, scene_xml('<shape type="sphere"/><emitter type="constant"/>'
                                 '<emitter type="point"><point name="position" value="0"/></emitter>'
                                 '<emitter type="directional"><vector name="direction" value="0, 0, 1"/></emitter>'
                                 '<shape type="rectangle"><emitter type="area"/></shape>'
                                 '<shape type="cylinder"/>'))
    assert (s.shapes[0].center.tolist(), s.shapes[0].radius) == ([0.0] * 3, 1.0)
    assert s.point_lights[0].intensity.tolist() == [1.0] * 3           # every emitter's value: 1
    assert s.directional_lights[0].irradiance.tolist() == [1.0] * 3
    assert s.materials[s.shapes[1].material].emission.tolist() == [1.0] * 3
    assert s.environment.kind == "constant" and np.all(s.environment.image == 1.0)
    # The rectangle is [-1, 1]^2 at z = 0; the cylinder radius 1 from z = 0 to 1.
    assert s.shapes[1].origin.tolist() == [-1.0, -1.0, 0.0] and s.shapes[1].edge_u.tolist() == [2.0, 0.0, 0.0]
    m = s.shapes[2].mesh
    np.testing.assert_allclose(np.linalg.norm(m.vertices[:, :2], axis=1), 1.0, rtol=1e-15)
    assert (m.vertices[:, 2].min(), m.vertices[:, 2].max()) == (0.0, 1.0)


@pytest.mark.parametrize("prop", ["shading_samples", "bsdf_samples"])
def test_direct_with_more_samples_without_drtlabs_direct_is_one_line(tmp_path, prop):
    from drtlab.estimators.integrators import INTEGRATORS
    if "direct" in INTEGRATORS:
        pytest.skip("drtlab's direct integrator takes the counts")
    msg = refused(tmp_path, scene_xml(f'<integrator type="direct"><integer name="{prop}" value="2"/></integrator>'))
    assert f"integer[@name={prop}]" in msg and "must be 1" in msg


def test_direct_sample_counts_default_to_one(tmp_path):
    from drtlab.estimators.integrators import INTEGRATORS
    s = load(tmp_path, scene_xml('<integrator type="direct"><integer name="shading_samples" value="1"/></integrator>'))
    assert s.integrator == ("direct" if "direct" in INTEGRATORS else "path")


# ---- Mitsuba's .serialized meshes ---------------------------------------------------------------

def serialized_mesh(version: int, vertices, faces, normals=None, double=False, name=b"m") -> bytes:
    """One mesh as Mitsuba writes it (the format of src/shapes/serialized.cpp), written here
    independently of the reader."""
    real = "<f8" if double else "<f4"
    flags = (0x1 if normals is not None else 0) | (0x2000 if double else 0x1000)
    body = struct.pack("<I", flags) + (name + b"\0" if version == 4 else b"")
    body += struct.pack("<QQ", len(vertices), len(faces)) + np.asarray(vertices, real).tobytes()
    if normals is not None:
        body += np.asarray(normals, real).tobytes()
    body += np.asarray(faces, "<u4").tobytes()
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


TRI = ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])


@pytest.mark.parametrize("version,double", [(3, False), (4, False), (4, True)])
def test_serialized_mesh_loads_exactly(tmp_path, version, double):
    v = [[0.5, 0.25, 0.0], [1.5, 0.25, 0.0], [0.5, 2.0, 0.0], [1.5, 2.0, 1.0]]
    n = [[0, 0, 1.0]] * 4
    (tmp_path / "m.serialized").write_bytes(serialized_mesh(version, v, [[0, 1, 2], [1, 3, 2]], n, double))
    s = load(tmp_path, scene_xml('<shape type="serialized"><string name="filename" value="m.serialized"/></shape>'))
    mesh = s.shapes[0].mesh
    assert mesh.vertices.tolist() == v and mesh.faces.tolist() == [[0, 1, 2], [1, 3, 2]]
    assert mesh.normals.tolist() == n


def test_serialized_mesh_without_normals_is_smooth_and_a_later_mesh_is_found(tmp_path):
    from drtlab.kernels.scene_model.mesh_serialized import read_serialized
    first = serialized_mesh(4, *TRI)
    second = serialized_mesh(4, [[0, 0, 0], [2, 0, 0], [0, 2, 0]], [[0, 1, 2]])
    data = first + second + struct.pack("<QQI", 0, len(first), 2)
    (tmp_path / "two.serialized").write_bytes(data)
    assert read_serialized(tmp_path / "two.serialized", 1)[0].max() == 2.0
    s = load(tmp_path, scene_xml('<shape type="serialized"><string name="filename" value="two.serialized"/></shape>'))
    assert s.shapes[0].mesh.normals.tolist() == [[0.0, 0.0, 1.0]] * 3       # Mitsuba's smooth normals


@pytest.mark.parametrize("data,words", [
    (b"\x1c\x04\x05\x00" + zlib.compress(b"\0" * 40), "version 5"),
    (b"PK\x03\x04", "not a Mitsuba .serialized file"),
    (serialized_mesh(4, *TRI)[:-6], "truncated"),
])
def test_bad_serialized_file_is_one_line(tmp_path, data, words):
    (tmp_path / "bad.serialized").write_bytes(data)
    msg = refused(tmp_path, scene_xml('<shape type="serialized"><string name="filename" value="bad.serialized"/></shape>'))
    assert words in msg


# ---- Mitsuba's cylinder -------------------------------------------------------------------------

def test_cylinder_is_a_tube_of_radial_normals_within_its_area_bound(tmp_path):
    from drtlab.kernels.scene_model.procedural import DISK_SEGMENTS, cylinder_area_deficit
    from drtlab.kernels.scene_model.scene_checks import scene_warnings
    s = load(tmp_path, scene_xml('<shape type="cylinder"><float name="radius" value="0.5"/>'
                                 '<point name="p0" value="1, 2, 3"/><point name="p1" x="1" y="2" z="5"/></shape>'))
    m = s.shapes[0].mesh
    radial = m.vertices[:, :2] - [1.0, 2.0]
    np.testing.assert_allclose(np.linalg.norm(radial, axis=1), 0.5, rtol=1e-14)
    assert sorted(set(np.round(m.vertices[:, 2], 12))) == [3.0, 5.0]
    np.testing.assert_allclose(m.normals[:, :2], radial / 0.5, atol=1e-12)
    assert np.all(m.normals[:, 2] == 0.0)
    a, b, c = (m.vertices[m.faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    outward = np.column_stack([((a + b + c) / 3)[:, :2] - [1.0, 2.0], np.zeros(len(a))])
    assert np.all(np.einsum("ij,ij->i", normals, outward) > 0)                  # wound outwards
    area = 0.5 * np.linalg.norm(normals, axis=1).sum()
    exact = 2 * math.pi * 0.5 * 2.0
    assert 1 - area / exact == pytest.approx(cylinder_area_deficit(DISK_SEGMENTS), rel=1e-6)
    assert cylinder_area_deficit(DISK_SEGMENTS) < 2e-6
    assert any("cylinder" in w and "1.6e-06" in w for w in scene_warnings(s))


def test_cylinder_flip_normals_is_refused(tmp_path):
    assert "not supported on a cylinder" in refused(
        tmp_path, scene_xml('<shape type="cylinder"><boolean name="flip_normals" value="true"/></shape>'))
