"""A drtlab scene -> a Mitsuba 3 XML file (`drtlab export SCENE --format mitsuba OUT.xml`).

Written from the loaded `Scene` (world space: boxes are their six quads, sphere grids their spheres,
transforms applied), so that importing the file (mitsuba_import.py) gives back the same numbers and
the same image bit for bit. What Mitsuba 3 has no counterpart for is refused in one line naming the
scene key, before anything is written: the drt and whitted integrators, Phong lobes (glossy,
glossy_dielectric, plastic), drtlab's GGX (height-correlated masking; Mitsuba's is separable),
checker textures, moving shapes, a shutter, a background, pixel filters other than box, mitchell and
mitsuba_gaussian, environments other than a constant one. What it maps is said by tables
(`BSDF_OF_KIND`, `CAMERA_FIELDS`, `SCENE_FIELDS`): a material kind, camera field or scene field
they lack (a new one) is refused until it is mapped, never written as something else. Meshes are
written beside the XML as binary PLY files in float64.
"""
from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

import dataclasses

from drtlab.errors import InputError
from drtlab.fields import output_files
from drtlab.kernels.scene_model.material_kinds import KIND_BY_NAME
from drtlab.kernels.scene_model.mitsuba_xml import coordinate_up
from drtlab.kernels.scene_model.scene import Camera, Scene
from drtlab.kernels.scene_model.texture import slot_key

# drtlab's kinds that are Mitsuba's roughconductor (material "none"), by its `distribution`.
ROUGH_CONDUCTORS = {"beckmann": "beckmann", "ggx_separable": "ggx", "beckmann_conductor": "beckmann",
                    "ggx_conductor": "ggx"}
# The conductors with a complex index of refraction (`eta`, `k` written as Mitsuba's rgb values).
METALS = ("conductor", "beckmann_conductor", "ggx_conductor")
# ... and its roughdielectric.
ROUGH_DIELECTRICS = {"beckmann_dielectric": "beckmann", "ggx_dielectric_separable": "ggx"}
# ... and its plastic (None) and roughplastic, by distribution; the `_nonlinear` kinds with nonlinear.
PLASTICS = {"smooth_plastic": None, "beckmann_plastic": "beckmann", "ggx_plastic": "ggx"}
# Every kind the exporter writes, and the Mitsuba 3 BSDF it becomes (mitsuba_materials.py reads it
# back as the same kind); a kind not here is refused.
BSDF_OF_KIND = {"diffuse": "diffuse", "emitter": "diffuse", "mirror": "conductor", "conductor": "conductor",
                "dielectric": "dielectric", **dict.fromkeys(ROUGH_CONDUCTORS, "roughconductor"),
                **dict.fromkeys(ROUGH_DIELECTRICS, "roughdielectric"),
                **{f"{k}{nl}": "plastic" if d is None else "roughplastic" for k, d in PLASTICS.items()
                   for nl in ("", "_nonlinear")},
                "principled": "principled", "principled_thin": "principledthin"}
# Why the kinds Mitsuba 3 has no counterpart for are refused (any other unmapped kind: not mapped).
SEPARABLE = "uses height-correlated Smith masking; Mitsuba 3's GGX uses the separable form (kind {})"
NO_COUNTERPART = {**dict.fromkeys(("glossy", "glossy_dielectric", "plastic"),
                                  "has a modified-Phong lobe, which Mitsuba 3 lacks"),
                  "ggx": SEPARABLE.format("ggx_separable"),
                  "ggx_dielectric": SEPARABLE.format("ggx_dielectric_separable")}
# The camera's fields and where the sensor holds them; any other must keep its default.
CAMERA_FIELDS = {"position": "to_world lookat origin", "look_at": "to_world lookat target",
                 "up": "to_world lookat up", "vfov_deg": "fov (fov_axis y)",
                 "aperture_radius": "thinlens aperture_radius",
                 "focus_distance": "thinlens focus_distance (a pinhole reads none)",
                 "filter": "the film's rfilter", "filter_stddev": "the rfilter's stddev",
                 "filter_clip": "the film's sample_border (false: the filter cut at the film's edge)"}
# The scene's fields the exporter writes or checks (the integrator: path or direct; the background:
# black only), and those that only name and describe it; any other is refused.
SCENE_FIELDS = ("width", "height", "spp", "integrator", "max_depth", "rr_depth", "russian_roulette",
                "emitter_samples", "bsdf_samples",
                "background", "camera", "materials", "shapes", "point_lights", "directional_lights",
                "environment")
SCENE_METADATA = ("name", "description", "source", "text")
UNMAPPED_WHY = {"shutter": "the shutter only moves shapes, and moving shapes are not exported; "
                           "leave it closed"}
# The procedural environment's default lat-long size: what an imported constant emitter becomes.
DEFAULT_ENV_SHAPE = (32, 64)


def check_exportable(scene: Scene) -> None:
    """One InputError for the first thing of `scene` Mitsuba 3 cannot render as drtlab does."""
    if scene.integrator not in ("path", "direct"):
        raise InputError("scene.integrator", f"'{scene.integrator}' has no Mitsuba 3 counterpart "
                                             "(exportable: path, direct)")
    if np.any(scene.background != 0.0):
        raise InputError("scene.background", "an unsampled background has no Mitsuba 3 counterpart; "
                                             "use [environment] kind = \"constant\" (Mitsuba's constant emitter)")
    if scene.camera.orthographic:
        raise InputError("camera.ortho_height", "an orthographic camera is not exported (the export "
                                                "writes a perspective sensor)")
    if scene.camera.filter not in ("box", "mitchell", "mitsuba_gaussian"):
        raise InputError("camera.filter", f"'{scene.camera.filter}' is not exported (Mitsuba's filter "
                                          "of that name differs or is missing; exportable: box, mitchell, "
                                          "mitsuba_gaussian)")
    for m in scene.materials:
        if m.kind not in BSDF_OF_KIND:
            why = NO_COUNTERPART.get(m.kind, "is not mapped to a Mitsuba 3 BSDF")
            raise InputError(f"materials.{m.name}.kind", f"'{m.kind}' {why} (exportable: "
                                                         f"{', '.join(BSDF_OF_KIND)})")
        if m.checker is not None:
            raise InputError(f"materials.{m.name}.checker", "checker textures are not exported")
        for slot in m.textures:
            raise InputError(f"materials.{m.name}.{slot_key(slot)}", "textures are not exported")
        if m.opacity < 1.0:     # (an opacity texture is refused above)
            raise InputError(f"materials.{m.name}.opacity", "masks are not exported")
        if m.one_sided and m.kind in ("emitter", "principled", "principled_thin"):
            raise InputError(f"materials.{m.name}.one_sided", f"a one-sided {m.kind} is not exported")
    for i, light in enumerate(scene.point_lights):
        if light.projects:
            raise InputError(f"lights[{i}]", "projectors and spots' textures are not exported")
    for i, s in enumerate(scene.shapes):
        if np.any(s.velocity != 0.0):
            raise InputError("shapes.velocity", f"shape '{s.name or i}' moves: moving shapes (motion "
                                                "blur) have no Mitsuba 3 counterpart")
    env = scene.environment
    if env is not None and (env.kind != "constant" or env.image.shape[:2] != DEFAULT_ENV_SHAPE):
        raise InputError("environment", "only a constant environment of the default resolution is "
                                        f"exported (Mitsuba's constant emitter), got {env.kind} "
                                        f"{env.width}x{env.height}")
    _check_fields(scene)


def _default(f: dataclasses.Field):
    if f.default is not dataclasses.MISSING:
        return f.default
    return f.default_factory() if f.default_factory is not dataclasses.MISSING else dataclasses.MISSING


def _same(a, b) -> bool:
    return np.array_equal(np.asarray(a), np.asarray(b)) if b is not dataclasses.MISSING else False


def _check_fields(scene: Scene) -> None:
    """A scene or camera field the tables do not map must keep its default (a field without one is
    refused): what the export does not write cannot change the render."""
    for f in dataclasses.fields(Camera):
        value = getattr(scene.camera, f.name)
        if f.name not in CAMERA_FIELDS and not _same(value, _default(f)):
            why = UNMAPPED_WHY.get(f.name, f"is not exported (a Mitsuba export writes only "
                                           f"{', '.join(CAMERA_FIELDS)}); leave it at its default")
            raise InputError(f"camera.{f.name}", f"{value!r}: {why}")
    for f in dataclasses.fields(Scene):
        value = getattr(scene, f.name)
        if f.name not in SCENE_FIELDS + SCENE_METADATA and not _same(value, _default(f)):
            raise InputError(f"scene.{f.name}", f"is not exported (a Mitsuba export writes only "
                                                f"{', '.join(SCENE_FIELDS)}); leave it at its default")


def export_mitsuba(scene: Scene, out: Path, data: dict | None = None, field: str = "out") -> list[Path]:
    """Write `scene` as Mitsuba 3 XML at `out` (and its meshes beside it); the files written.
    `data`, the scene's table (scene_file.scene_data), gives directional lights as written: the
    loader's normalisation of a unit vector can move its last bit. Everything is written to
    temporary names first and renamed at the end: nothing half-written. Every file's name is checked
    first (`field` names `out` in the error): a mesh file whose name is a folder writes nothing."""
    check_exportable(scene)
    meshes: list[tuple[Path, object]] = []
    root = ET.Element("scene", version="3.0.0")
    _integrator(root, scene)
    _sensor(root, scene)
    names = _bsdfs(root, scene)
    used_ids = set(names.values())
    for i, s in enumerate(scene.shapes):
        m = scene.materials[s.material]
        shape = ET.SubElement(root, "shape", type={"quad": "rectangle", "sphere": "sphere",
                                                   "mesh": "ply"}[s.kind])
        if s.name and s.name not in used_ids and _is_id(s.name):
            shape.set("id", s.name)
            used_ids.add(s.name)
        if s.kind == "quad":
            _rectangle(shape, s)
        elif s.kind == "sphere":
            _vec(shape, "point", "center", s.center)
            _num(shape, "float", "radius", s.radius)
        else:
            path = out.with_name(f"{out.stem}-mesh{i}.ply")
            meshes.append((path, s.mesh))
            _num(shape, "string", "filename", path.name)
            if s.mesh.normals is None:
                _num(shape, "boolean", "face_normals", "true")
        ET.SubElement(shape, "ref", id=names[m.name])
        if m.emissive:
            emitter = ET.SubElement(shape, "emitter", type="area")
            _vec(emitter, "rgb", "radiance", m.emission)
    _lights(root, scene, data)
    ET.indent(root)
    files = [(out, ET.tostring(root, encoding="unicode") + "\n")]
    files += [(p, _ply_bytes(mesh)) for p, mesh in meshes]
    output_files([p for p, _ in files], field)
    temps = [path.with_name(f".{path.stem[:64]}.{i}.{os.getpid()}.tmp")
             for i, (path, _) in enumerate(files)]
    try:
        for (path, content), tmp in zip(files, temps):
            (tmp.write_text if isinstance(content, str) else tmp.write_bytes)(content)
        for (path, _), tmp in zip(files, temps):
            os.replace(tmp, path)
    finally:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
    return [p for p, _ in files]


def _is_id(name: str) -> bool:
    return all(c.isalnum() or c in "-_." for c in name) and not name[0].isdigit()


def _num(parent, tag: str, name: str, value) -> None:
    ET.SubElement(parent, tag, name=name, value=value if isinstance(value, str) else repr(float(value))
                  if tag == "float" else str(value))


def _vec(parent, tag: str, name: str, v) -> None:
    text = " ".join(repr(float(x)) for x in v)
    if tag == "rgb":
        ET.SubElement(parent, tag, name=name, value=text)
    else:
        x, y, z = (repr(float(c)) for c in v)
        ET.SubElement(parent, tag, name=name, x=x, y=y, z=z)


def _integrator(root, scene: Scene) -> None:
    if scene.integrator == "direct":
        it = ET.SubElement(root, "integrator", type="direct")
        for name in ("emitter_samples", "bsdf_samples"):
            ET.SubElement(it, "integer", name=name, value=str(getattr(scene, name)))
        return
    it = ET.SubElement(root, "integrator", type="path")
    ET.SubElement(it, "integer", name="max_depth", value=str(scene.max_depth))
    # rr_depth means the same vertex index in both (mitsuba_import.py); a roulette-free path rolls
    # only from max_depth on, where no path goes.
    rr = scene.rr_depth if scene.russian_roulette else scene.max_depth
    ET.SubElement(it, "integer", name="rr_depth", value=str(rr))


def _sensor(root, scene: Scene) -> None:
    c = scene.camera
    sensor = ET.SubElement(root, "sensor", type="thinlens" if c.has_lens else "perspective")
    _num(sensor, "float", "fov", c.vfov_deg)
    _num(sensor, "string", "fov_axis", "y")
    if c.has_lens:
        _num(sensor, "float", "aperture_radius", c.aperture_radius)
        _num(sensor, "float", "focus_distance", c.focus_distance)
    tw = ET.SubElement(sensor, "transform", name="to_world")
    ET.SubElement(tw, "lookat", **{k: ", ".join(repr(float(x)) for x in v) for k, v in
                                   (("origin", c.position), ("target", c.look_at), ("up", c.up))})
    sampler = ET.SubElement(sensor, "sampler", type="independent")
    ET.SubElement(sampler, "integer", name="sample_count", value=str(scene.spp))
    film = ET.SubElement(sensor, "film", type="hdrfilm")
    ET.SubElement(film, "integer", name="width", value=str(scene.width))
    ET.SubElement(film, "integer", name="height", value=str(scene.height))
    if c.filter != "box":       # Mitsuba's own; samples beyond the border count unless cut there
        ET.SubElement(film, "boolean", name="sample_border", value="false" if c.filter_clip else "true")
    rfilter = ET.SubElement(film, "rfilter", type="gaussian" if c.filter == "mitsuba_gaussian" else c.filter)
    if c.filter_stddev:
        _num(rfilter, "float", "stddev", c.filter_stddev)


def _bsdfs(root, scene: Scene) -> dict[str, str]:
    """One <bsdf id> per material (drtlab's surfaces are two-sided unless `one_sided`: `twosided`
    where Mitsuba's are one-sided; beckmann, ggx_separable and the rough metals are Mitsuba's roughconductor, beckmann_dielectric and
    ggx_dielectric_separable its roughdielectric, the plastics its plastic and roughplastic); material name -> its
    id."""
    ids: dict[str, str] = {}
    for k, m in enumerate(scene.materials):
        ident = m.name if _is_id(m.name) and m.name not in ids.values() else f"material{k}"
        ids[m.name] = ident
        if m.kind in ("dielectric",) + tuple(ROUGH_DIELECTRICS):
            rough = m.kind != "dielectric"
            b = ET.SubElement(root, "bsdf", type="roughdielectric" if rough else "dielectric", id=ident)
            if rough:
                _num(b, "string", "distribution", ROUGH_DIELECTRICS[m.kind])
                _num(b, "float", "alpha", m.roughness)
            _num(b, "float", "int_ior", m.ior)
            _num(b, "float", "ext_ior", 1.0)
            _vec(b, "rgb", "specular_transmittance", m.albedo)
            continue
        if m.kind in ("principled", "principled_thin"):      # two-sided as they are
            b = ET.SubElement(root, "bsdf", type=BSDF_OF_KIND[m.kind], id=ident)
            _vec(b, "rgb", "base_color", m.albedo)
            _num(b, "float", "eta", m.ior)
            for name in KIND_BY_NAME[m.kind].params:
                if name in m.params:
                    _num(b, "float", name, m.params[name])
            continue
        if m.kind == "emitter":         # black: the import turns it back into kind emitter
            b = ET.SubElement(root, "bsdf", type="diffuse", id=ident)
            _vec(b, "rgb", "reflectance", np.zeros(3))
            continue
        if m.one_sided:         # Mitsuba's own: a bare BSDF is black from behind
            outer, named = root, {"id": ident}
        else:
            outer, named = ET.SubElement(root, "bsdf", type="twosided", id=ident), {}
        if m.kind in ("mirror", "conductor") + tuple(ROUGH_CONDUCTORS):
            b = ET.SubElement(outer, "bsdf", **named, type="roughconductor" if m.kind in ROUGH_CONDUCTORS else "conductor")
            if m.kind in ROUGH_CONDUCTORS:
                _num(b, "string", "distribution", ROUGH_CONDUCTORS[m.kind])
                _num(b, "float", "alpha", m.roughness)
            if m.kind in METALS:
                _vec(b, "rgb", "eta", m.eta)
                _vec(b, "rgb", "k", m.k)
            _vec(b, "rgb", "specular_reflectance", m.albedo)
        elif m.kind.removesuffix("_nonlinear") in PLASTICS:
            rough = PLASTICS[m.kind.removesuffix("_nonlinear")]
            b = ET.SubElement(outer, "bsdf", **named, type="plastic" if rough is None else "roughplastic")
            if rough is not None:
                _num(b, "string", "distribution", rough)
                _num(b, "float", "alpha", m.roughness)
            _num(b, "float", "int_ior", m.ior)
            _num(b, "float", "ext_ior", 1.0)
            _num(b, "boolean", "nonlinear", "true" if m.kind.endswith("_nonlinear") else "false")
            _vec(b, "rgb", "diffuse_reflectance", m.albedo)
        elif BSDF_OF_KIND[m.kind] == "diffuse":
            b = ET.SubElement(outer, "bsdf", **named, type="diffuse")
            _vec(b, "rgb", "reflectance", m.albedo)
        else:       # a row of BSDF_OF_KIND without its branch here: never written as something else
            raise InputError(f"materials.{m.name}.kind", f"'{m.kind}' is in BSDF_OF_KIND but not written")
    return ids


def _rectangle(shape, s) -> None:
    """The quad as Mitsuba's [-1, 1]^2 rectangle: [-1, 1] -> [0, 1] first, then the matrix whose
    columns are edge_u, edge_v, the unit normal and origin, so that the importer's corner and edges
    come out as these numbers exactly (0 * x + o = o, 1 * u = u)."""
    n = np.cross(s.edge_u, s.edge_v)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = s.edge_u, s.edge_v, n / np.linalg.norm(n), s.origin
    tw = ET.SubElement(shape, "transform", name="to_world")
    ET.SubElement(tw, "translate", x="1.0", y="1.0", z="0.0")
    ET.SubElement(tw, "scale", x="0.5", y="0.5", z="1.0")
    ET.SubElement(tw, "matrix", value=" ".join(repr(float(x)) for x in m.ravel()))


def _lights(root, scene: Scene, data: dict | None) -> None:
    given = [light.get("direction") for light in (data or {}).get("lights", [])
             if isinstance(light, dict) and light.get("kind") == "directional"]
    for light in scene.point_lights:
        e = ET.SubElement(root, "emitter", type="spot" if light.spot else "point")
        if light.spot:
            _spot(e, light)
        else:
            _vec(e, "point", "position", light.position)
        _vec(e, "rgb", "intensity", light.intensity)
    for k, light in enumerate(scene.directional_lights):
        e = ET.SubElement(root, "emitter", type="directional")
        _vec(e, "vector", "direction", given[k] if len(given) == len(scene.directional_lights)
             else light.direction)
        _vec(e, "rgb", "irradiance", light.irradiance)
    if scene.environment is not None:
        e = ET.SubElement(root, "emitter", type="constant")
        _vec(e, "rgb", "radiance", scene.environment.image[0, 0])


def _spot(e, light) -> None:
    """A spot's frame as a matrix whose columns are |d| u, |d| v, d and the position (u, v a unit frame
    about d): rigid up to a uniform scale, as Mitsuba's cone needs, and the importer reads the position
    and d back exactly (0 * x + p = p, 1 * d = d)."""
    d = np.asarray(light.direction, dtype=np.float64)
    s = float(np.linalg.norm(d))
    u = np.asarray(coordinate_up(d / s))
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = s * u, s * np.cross(d / s, u), d, light.position
    tw = ET.SubElement(e, "transform", name="to_world")
    ET.SubElement(tw, "matrix", value=" ".join(repr(float(x)) for x in m.ravel()))
    _num(e, "float", "cutoff_angle", light.cutoff_angle)
    _num(e, "float", "beam_width", light.beam_width)


def _ply_bytes(mesh) -> bytes:
    """Binary little-endian PLY: double x y z (nx ny nz), faces as uchar-counted int lists."""
    v = np.asarray(mesh.vertices, dtype="<f8")
    cols = [v] if mesh.normals is None else [v, np.asarray(mesh.normals, dtype="<f8")]
    props = ["x", "y", "z"] + ([] if mesh.normals is None else ["nx", "ny", "nz"])
    header = ("ply\nformat binary_little_endian 1.0\n"
              f"element vertex {len(v)}\n" + "".join(f"property double {p}\n" for p in props)
              + f"element face {len(mesh.faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(mesh.faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
    faces["n"], faces["i"] = 3, mesh.faces
    return header.encode() + np.ascontiguousarray(np.hstack(cols)).tobytes() + faces.tobytes()
