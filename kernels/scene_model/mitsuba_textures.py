"""Mitsuba 3 XML `bitmap`, `checkerboard` and `mesh_attribute` textures -> a drtlab material's
`<slot>_texture` table (kernels/scene_model/texture.py). A mixin of the importer (kernels/scene_model/mitsuba_import.py),
which gives it the property access (`get`, `string`, `colour`, `done`, `deref`).

Only a rectangle's uv ((x + 1) / 2, (y + 1) / 2 of its local square, the quad's parameters along
edge_u and edge_v), a sphere's (its angles in the frame of its to_world, kernels/intersection/
primitives.py: sphere_uv) and an OBJ file's texture coordinates (v flipped, Mitsuba's
flip_tex_coords) are Mitsuba's in drtlab; a texture on any other shape is refused.
"""
from __future__ import annotations

import numpy as np

from drtlab.kernels.scene_model.mitsuba_xml import Obj, Prop, Ref, chain_matrix
from drtlab.kernels.scene_model.texture import FILTERS, TEXTURE_SLOTS, WRAPS, slot_key

TEXTURES = ("bitmap", "checkerboard", "mesh_attribute")
ATTRIBUTE_SHAPES = ("ply",)         # where drtlab reads Mitsuba's mesh attributes
TEXTURED_SHAPES = ("rectangle", "sphere", "obj")


class TextureMapping:
    def texture_of(self, o: Obj, name: str) -> Obj | None:
        """The bitmap or checkerboard texture property `name` of `o` (through a <ref>), else None."""
        p = o.props.get(name)
        if p is not None and p.tag == "ref":
            p = Prop("texture", self.deref(Ref(p.value, p.path)), p.path)
        if p is not None and p.tag == "texture" and p.value.type in TEXTURES:
            o.used.add(name)
            return p.value
        return None

    def albedo_texture(self, t: Obj) -> dict:
        """A bitmap, checkerboard or mesh_attribute <texture> as drtlab's <slot>_texture table."""
        if t.type == "mesh_attribute":
            table = {"kind": t.type, "name": self.string(t, "name", None),
                     "scale": self.number(t, "scale", 1.0)}
            if not isinstance(table["name"], str) or not table["name"].startswith(("vertex_", "face_")):
                self.r.fail(t.path, "a mesh_attribute needs a name starting with 'vertex_' or 'face_'")
            self.done(t)
            return table
        chain = self.get(t, "to_uv", ("transform",), None)
        table = {"kind": t.type}
        if chain is not None:       # uv is the point (u, v, 0): the rows x, y of columns x, y, w
            table["to_uv"] = chain_matrix(chain)[:2, [0, 1, 3]].tolist()
        if t.type == "checkerboard":
            table["color0"] = self.colour(t, "color0", 0.4)
            table["color1"] = self.colour(t, "color1", 0.2)
        else:
            name = self.string(t, "filename", None)
            if name is None:
                self.r.fail(t.path, "a bitmap needs a filename")
            path = self.r.resolve(name)
            if not path.is_file():
                self.r.fail(t.props["filename"].path, f"texture file '{name}' does not exist")
            table["file"] = str(path)
            table["filter"] = self.string(t, "filter_type", "bilinear", FILTERS)
            table["wrap"] = self.string(t, "wrap_mode", "repeat", WRAPS)
            table["raw"] = bool(self.get(t, "raw", ("boolean",), False))
        self.done(t)
        return table

    def check_textured_shape(self, shape: Obj, spec: dict) -> None:
        """A texture reads Mitsuba's uv, which drtlab gives a rectangle facing its own +z, a sphere and
        an obj only."""
        tables = [spec[slot_key(slot)] for slot in TEXTURE_SLOTS if slot_key(slot) in spec]
        if not tables and "alpha_u" not in spec:     # an anisotropic lobe turns with dp/du
            return
        if any(t["kind"] == "mesh_attribute" for t in tables):
            if shape.type not in ATTRIBUTE_SHAPES:
                self.r.fail(shape.path, f"a mesh_attribute texture on a {shape.type} is not supported "
                                        "(drtlab reads mesh attributes from PLY files)")
            return
        if any(slot_key(s) in spec for s in ("normal", "bump")) and shape.type != "obj":
            self.r.fail(shape.path, f"a normal or bump map on a {shape.type} is not supported (drtlab "
                                    "has the tangent frame of an obj's triangles only)")
        if ("alpha_u" in spec or "alpha_u_texture" in spec) and shape.type not in ("obj", "rectangle"):
            self.r.fail(shape.path, f"anisotropic roughness on a {shape.type} is not supported (drtlab "
                                    "has Mitsuba's dp/du on an obj and a rectangle only)")
        if shape.type not in TEXTURED_SHAPES:
            self.r.fail(shape.path, f"a texture on a {shape.type} is not supported (drtlab's uv is "
                                    "Mitsuba's on a rectangle, a sphere and an obj only)")
        flip_uv = shape.props.get("flip_tex_coords")
        if flip_uv is not None and not flip_uv.value:
            self.r.fail(flip_uv.path, "false is not supported on a textured obj (drtlab reads an "
                                      "OBJ's v flipped, Mitsuba's default)")
        if shape.type == "rectangle":
            # drtlab's normal is edge_u x edge_v: a flip or a mirror swaps the edges, and u with v
            flip = shape.props.get("flip_normals")
            chain = self.get(shape, "to_world", ("transform",), [])
            mirrored = np.linalg.det(chain_matrix(chain)[:3, :3]) < 0
            if (flip is not None and bool(flip.value)) != bool(mirrored):
                self.r.fail(shape.path, "a flipped or mirrored textured rectangle is not supported "
                                        "(its u and v would swap)")
