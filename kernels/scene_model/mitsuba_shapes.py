"""Mitsuba 3 XML shapes and emitters -> the drtlab scene dict's shapes, lights and environment.

A mixin of the importer (kernels/scene_model/mitsuba_import.py), which gives it the property access (`get`,
`number`, `colour`, `string`, `done`, ...) and the material mapping (kernels/scene_model/mitsuba_materials.py).

A disk becomes a triangle fan (kernels/scene_model/procedural.py `disk`, DISK_SEGMENTS triangles: its area
within 1e-5 of the circle's). An envmap becomes an image environment with Mitsuba's bilinear lookup
and its lat-long frame: Mitsuba's map frame has u = atan2(x, -z) / 2 pi (u = 0 towards -z, turning
towards +x) and v = acos(y) / pi, drtlab's u = atan2(z, x) / 2 pi; MITSUBA_TO_DRTLAB takes a
direction of Mitsuba's frame to the one of drtlab's frame with the same (u, v).
"""
from __future__ import annotations

import numpy as np

from drtlab.fields import file_kind
from drtlab.kernels.imageio import image_size
from drtlab.kernels.scene_model.mesh_file import file_has_vertex_normals
from drtlab.kernels.scene_model.mitsuba_xml import (Obj, chain_matrix, chain_point, chain_vector, coordinate_up,
                                                  drtlab_transform)
from drtlab.kernels.scene_model.procedural import DISK_SEGMENTS
from drtlab.kernels.scene_model.scene import SPOT_CUTOFF_DEFAULT

SHAPES = ("rectangle", "cube", "sphere", "obj", "ply", "serialized", "disk", "cylinder")
EMITTERS = ("area", "point", "directional", "spot", "projector", "constant", "envmap")
MITSUBA_TO_DRTLAB = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
ENVMAP_FORMATS = (".exr", ".hdr")
# Mitsuba's disk flips its normal by to_world @ scale(1, 1, -1) (src/shapes/disk.cpp).
FLIP_Z = ("scale", np.diag([1.0, 1.0, -1.0, 1.0]), [1.0, 1.0, -1.0])


class ShapeMapping:
    def shape_group(self, o: Obj) -> None:
        """A `shapegroup` renders nothing itself: its shapes are flattened into each instance."""
        if o.id is None:
            self.r.fail(o.path, "a shapegroup needs an id (instances refer to it)")
        for child in self.nested(o):
            if child.tag != "shape" or child.type in ("shapegroup", "instance"):
                self.r.fail(child.path, f"<{child.tag} type='{child.type}'> in a shapegroup is not "
                                        "supported (shapes only, as Mitsuba)")
        self.done(o)

    def instance(self, o: Obj) -> None:
        """An `instance` of a shapegroup: each of the group's shapes under its own to_world, then the
        instance's (flattened at load: one drtlab shape per shape and instance)."""
        chain = self.get(o, "to_world", ("transform",), [])
        groups = self.nested(o)
        if len(groups) != 1 or groups[0].type != "shapegroup":
            self.r.fail(o.path, "an instance refers to exactly one shapegroup")
        self.instances += 1
        for child in self.nested(groups[0]):
            self.shape(child, list(chain), f"[instance {self.instances}]")
        self.done(o)

    def shape(self, o: Obj, outer: list | None = None, label: str = "") -> None:
        kind = self.kind(o, SHAPES)
        chain = list(self.get(o, "to_world", ("transform",), [])) + (outer or [])
        flip = self.get(o, "flip_normals", ("boolean",), False)
        bsdf = emitter = None
        for child in self.nested(o):
            if child.tag == "bsdf" and bsdf is None:
                bsdf = child
            elif child.tag == "emitter" and emitter is None and child.type == "area":
                if outer is not None:
                    self.r.fail(child.path, "an emitter in a shapegroup is not supported (Mitsuba "
                                            "does not instance emitters)")
                emitter = child
            else:
                self.r.fail(child.path, f"<{child.tag} type='{child.type}'> in a shape is not "
                                        "supported (one bsdf and one area emitter)")
        shape: dict = {"material": self.material(o, bsdf, emitter)}
        if o.id is not None:
            shape["name"] = o.id + label
        if kind == "rectangle":
            # Each corner and edge through the chain (exact for an exporter's chain); a mirroring
            # transform or flip_normals turns the normal: drtlab's is edge_u x edge_v.
            u, v = chain_vector(chain, [2.0, 0, 0]), chain_vector(chain, [0, 2.0, 0])
            if (np.linalg.det(chain_matrix(chain)[:3, :3]) < 0) != bool(flip):
                u, v = v, u
            shape.update(kind="quad", origin=chain_point(chain, [-1.0, -1.0, 0]).tolist(),
                         edge_u=u.tolist(), edge_v=v.tolist())
        else:
            if flip and kind != "disk":
                self.r.fail(o.props["flip_normals"].path, f"true is not supported on a {kind} "
                                                          "(drtlab's faces out), only on a rectangle "
                                                          "or a disk")
            if kind == "disk":
                # In the z = 0 plane the flip moves no vertex; the mirror reverses the winding.
                chain = ([FLIP_Z] if flip else []) + list(chain)
                shape.update(kind="mesh", generate="disk", segments=DISK_SEGMENTS)
            elif kind == "cylinder":
                chain = self.cylinder_axis(o) + list(chain)
                shape.update(kind="mesh", generate="cylinder", segments=DISK_SEGMENTS,
                             radius=self.number(o, "radius", 1.0, lambda x: x > 0, "> 0"))
            elif kind == "cube":
                shape.update(kind="box", min=[-1.0] * 3, max=[1.0] * 3)
            elif kind == "sphere":
                own = self.get(o, "to_world", ("transform",), [])
                if own and np.linalg.det(chain_matrix(own)[:3, :3]) < 0:
                    # Mitsuba 3 turns a mirrored sphere's normals inwards (a one-sided BSDF is
                    # black from outside); drtlab's face out.
                    self.r.fail(o.props["to_world"].path, "a mirroring to_world on a sphere is not "
                                                          "supported (Mitsuba turns its normals "
                                                          "inwards, drtlab's face out)")
                shape.update(kind="sphere", center=list(self.get(o, "center", ("point",), [0.0] * 3)),
                             radius=self.number(o, "radius", 1.0, lambda x: x > 0, "> 0"))
            else:
                path, smooth = self.mesh_file(o, kind)
                shape.update(kind="mesh", file=path, **({"normals": "smooth"} if smooth else {}))
            transform = drtlab_transform(chain)
            if transform is not None:
                shape["transform"] = transform
        self.data["shapes"].append(shape)
        self.done(o)

    def cylinder_axis(self, o: Obj) -> list:
        """Mitsuba's cylinder from `p0` (0, 0, 0) to `p1` (0, 0, 1): the unit-height tube's z axis
        turned onto p1 - p0 and moved to p0 (no operation for the defaults)."""
        p0 = np.array(self.get(o, "p0", ("point",), [0.0, 0.0, 0.0]), dtype=np.float64)
        p1 = np.array(self.get(o, "p1", ("point",), [0.0, 0.0, 1.0]), dtype=np.float64)
        d = p1 - p0
        if not np.any(d):
            self.r.fail(o.path, "p0 and p1 must differ")
        if p0.tolist() == [0.0] * 3 and p1.tolist() == [0.0, 0.0, 1.0]:
            return []
        axis = d / np.linalg.norm(d)
        s = np.array(coordinate_up(axis))
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = s, np.cross(axis, s), d, p0
        return [("matrix", m, m)]

    def mesh_file(self, o: Obj, kind: str) -> tuple[str, bool]:
        """(the mesh file, whether drtlab computes Mitsuba's smooth normals for it)."""
        name = self.string(o, "filename", None)
        if name is None:
            self.r.fail(o.path, f"{kind} needs a filename")
        path = self.r.resolve(name)
        if not path.is_file():
            what = file_kind(path)
            self.r.fail(o.props["filename"].path, f"'{name}' is {what}, not a mesh file" if what
                        else f"mesh file '{name}' does not exist")
        if path.suffix.lower() != f".{kind}":
            self.r.fail(o.props["filename"].path, f"a {kind} shape needs a .{kind} file, got '{name}'")
        has_normals = file_has_vertex_normals(path)
        face_normals = self.get(o, "face_normals", ("boolean",), False)
        if face_normals and has_normals:
            self.r.fail(o.props["face_normals"].path, "true with a file that has vertex normals is not "
                                                      "supported (drtlab shades with the file's normals)")
        self.ignore(o, "flip_tex_coords")
        if kind == "serialized":
            self.number(o, "shape_index", 0, lambda n: n == 0, "0 (drtlab reads a file's first mesh)")
        return str(path), not face_normals and not has_normals

    def emitter(self, o: Obj) -> None:
        kind = self.kind(o, EMITTERS[1:])
        if kind in ("constant", "envmap") and "environment" in self.data:
            self.r.fail(o.path, "a second environment emitter (constant or envmap)")
        if kind == "constant":
            self.data["environment"] = {"kind": "constant",
                                        "radiance": self.colour(o, "radiance", 1.0, emitter=True)}
        elif kind == "envmap":
            self.data["environment"] = self.envmap(o)
        elif kind == "spot":
            self.data.setdefault("lights", []).append(self.spot(o))
        elif kind == "projector":
            self.data.setdefault("lights", []).append(self.projector(o))
        else:
            chain = self.get(o, "to_world", ("transform",), None)
            key, value = ("position", "intensity") if kind == "point" else ("direction", "irradiance")
            given = self.get(o, key, ("point", "vector"), None)
            if (given is None) == (chain is None):
                self.r.fail(o.path, f"a {kind} emitter needs either {key} or to_world")
            if given is None:
                given = (chain_point(chain, [0.0] * 3) if kind == "point"
                         else chain_vector(chain, [0, 0, 1.0])).tolist()
            self.data.setdefault("lights", []).append(
                {"kind": kind, key: list(given), value: self.colour(o, value, 1.0, emitter=True)})
        self.done(o)

    def spot(self, o: Obj) -> dict:
        """Mitsuba's spot: at to_world's origin, its axis to_world's +z (kept at its length: the
        loader normalises), the angles in degrees; absent ones keep the loader's (Mitsuba's) defaults."""
        chain = self.get(o, "to_world", ("transform",), [])
        lin = chain_matrix(chain)[:3, :3]
        gram = lin.T @ lin
        if gram[0, 0] == 0.0 or not np.allclose(gram, gram[0, 0] * np.eye(3), rtol=0.0, atol=1e-9 * gram[0, 0]):
            # Mitsuba measures the angle in the emitter's frame: a non-uniform scale skews the cone.
            self.r.fail(o.props["to_world"].path, "must be a rotation, a uniform scale and a translation "
                                                  f"for a spot, got the linear part {np.round(lin, 6).tolist()}")
        light = {"kind": "spot", "position": chain_point(chain, [0.0] * 3).tolist(),
                 "direction": chain_vector(chain, [0.0, 0.0, 1.0]).tolist(),
                 "intensity": self.colour(o, "intensity", 1.0, emitter=True)}
        cutoff = self.number(o, "cutoff_angle", None, lambda x: 0.0 < x <= 180.0, "in (0, 180] (degrees)")
        limit = SPOT_CUTOFF_DEFAULT if cutoff is None else cutoff
        beam = self.number(o, "beam_width", None, lambda x: 0.0 <= x <= limit,
                           f"in [0, cutoff_angle = {limit:g}] (degrees)")
        light.update({k: v for k, v in (("cutoff_angle", cutoff), ("beam_width", beam)) if v is not None})
        if "texture" in o.props:
            texture = self.texture_of(o, "texture")
            if texture is None:
                self.r.fail(o.props["texture"].path, "a spot's texture must be a bitmap or checkerboard "
                                                     "(Mitsuba: spatially varying)")
            light.update(texture=self.albedo_texture(texture), up=self.projection_up(o, lin))
        return light

    def projection_up(self, o: Obj, lin: np.ndarray) -> list:
        """The up of a projecting emitter's frame (to_world's y): its x must be to_world's x, which
        a mirroring transform reverses."""
        if np.linalg.det(lin) <= 0.0:
            self.r.fail(o.props["to_world"].path, "must not mirror (a projection's image would flip)")
        return (lin[:, 1] / np.linalg.norm(lin[:, 1])).tolist()

    def projector(self, o: Obj) -> dict:
        """Mitsuba's projector: at to_world's origin (a rotation and translation: its irradiance is
        measured at unit distance in its own frame), along +z, up +y; the irradiance a texture or a
        constant; the field of view as a camera's (parse_fov)."""
        chain = self.get(o, "to_world", ("transform",), [])
        lin = chain_matrix(chain)[:3, :3]
        if not np.allclose(lin.T @ lin, np.eye(3), rtol=0.0, atol=1e-9):
            self.r.fail(o.props["to_world"].path, "must be a rotation and a translation for a projector, "
                                                  f"got the linear part {np.round(lin, 6).tolist()}")
        light = {"kind": "projector", "position": chain_point(chain, [0.0] * 3).tolist(),
                 "direction": lin[:, 2].tolist(), "up": self.projection_up(o, lin),
                 "scale": self.number(o, "scale", 1.0, lambda x: x >= 0, ">= 0")}
        texture = self.texture_of(o, "irradiance")
        if texture is not None:
            light["irradiance_texture"] = self.albedo_texture(texture)
        else:
            light["irradiance"] = self.colour(o, "irradiance", 1.0, emitter=True)
        light["fov"], light["fov_axis"] = self.fov_along(o)
        return light

    def envmap(self, o: Obj) -> dict:
        name = self.string(o, "filename", None)
        if name is None:
            self.r.fail(o.path, "envmap needs a filename (an .exr or .hdr lat-long image)")
        path = self.r.resolve(name)
        if path.suffix.lower() not in ENVMAP_FORMATS:
            self.r.fail(o.props["filename"].path, f"must name an .exr or .hdr image, got '{name}'")
        if not path.is_file():
            what = file_kind(path)
            self.r.fail(o.props["filename"].path, f"'{name}' is {what}, not an image file" if what
                        else f"image file '{name}' does not exist")
        size = image_size(path)
        if size is not None and (size[0] < 2 or size[1] < 3):
            self.r.fail(o.props["filename"].path, f"'{name}' has {size[0]} x {size[1]} texels; at "
                                                  "least 2 x 3 are supported (Mitsuba pads smaller maps)")
        self.ignore(o, "mis_compensation")        # sampling only: the expected image is the same
        # Mitsuba turns directions by the linear part alone; its lookup needs unit vectors.
        rot = chain_matrix(self.get(o, "to_world", ("transform",), []))[:3, :3]
        if not (np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) and np.linalg.det(rot) > 0.0):
            self.r.fail(o.props["to_world"].path, "must be a rotation (and any translation) for an "
                                                  f"envmap, got the linear part {np.round(rot, 6).tolist()}")
        return {"kind": "image", "file": str(path), "lookup": "bilinear",
                "scale": self.number(o, "scale", 1.0, lambda x: x >= 0, ">= 0"),
                "to_world": (rot @ MITSUBA_TO_DRTLAB.T).tolist()}
