"""Mesh attributes at a hit (Mitsuba 3's `mesh_attribute` texture, src/textures/mesh_attribute.cpp
over Mesh::eval_attribute): a face attribute is its face's value; a vertex attribute is its face's
three vertex values weighted by the hit's barycentric coordinates, as a mesh hit's uv holds them
(Hit.uv = (u, v): weights u, v, 1 - u - v of the face's vertices 0, 1, 2, as its shading normal).
The model is kernels/scene_model/mesh_attributes.py; compiled only into variants of scenes with
mesh attributes (Features.mesh_attributes), read by material_at.py.

The values live per mesh (two meshes sharing a material each have their own), so the table is per
(pool texture, mesh): MeshData.attr_first[t * count + k] = (offset, per-vertex) such that the value
of global vertex or face i is attr_values[offset + i], `scale` applied at upload.
"""
import numpy as np
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.scene_model.texture import TEXTURE_KINDS

MESH_ATTRIBUTE = TEXTURE_KINDS.index("mesh_attribute")


def attribute_tables(pool: list, meshes: list) -> dict:
    """MeshData's attr_first (per pool texture and mesh) and attr_values of the scene's texture
    `pool` (texture.texture_pool) and mesh shapes (in upload order), as numpy-ready arrays."""
    vert0 = np.cumsum([0] + [len(s.mesh.vertices) for s in meshes])
    face0 = np.cumsum([0] + [len(s.mesh.faces) for s in meshes])
    first, values, n = [], [], 0
    for t in pool:
        for k, shape in enumerate(meshes):
            a = shape.mesh.attributes.get(t.name) if t.kind == "mesh_attribute" else None
            if a is None:                   # never read: no material of this mesh reads it
                first.append((0, 0))
                continue
            v = np.asarray(a, dtype=np.float32) * np.float32(t.scale)
            values.append(np.repeat(v, 3, axis=1) if v.shape[1] == 1 else v)
            first.append((n - int((vert0 if t.per_vertex else face0)[k]), int(t.per_vertex)))
            n += len(v)
    return {"attr_first": np.array(first or [(0, 0)], dtype=np.int32).reshape(-1, 2),
            "attr_values": (np.concatenate(values) if values else np.zeros((1, 3))).astype(np.float32)}


@wp.func
def attribute_value(sd: SceneData, t: int, face: int, uv: wp.vec2) -> wp.vec3:
    """Pool texture t, a mesh attribute, at global face `face` and barycentric coordinates uv."""
    e = sd.meshes.attr_first[t * sd.meshes.count + sd.meshes.tri_mesh[face]]
    if e[1] == 1:
        idx = sd.meshes.tri_index[face]
        return (sd.meshes.attr_values[e[0] + idx[0]] * uv[0]
                + sd.meshes.attr_values[e[0] + idx[1]] * uv[1]
                + sd.meshes.attr_values[e[0] + idx[2]] * (1.0 - uv[0] - uv[1]))
    return sd.meshes.attr_values[e[0] + face]
