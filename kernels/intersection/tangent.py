"""The surface's tangent dp/du at a hit: what orients an anisotropic BSDF's shading frame (its s
axis, kernels/materials/beckmann_anisotropic.py: dp/du made orthogonal to the shading normal).

A mesh triangle's is Mitsuba 3's (src/render/mesh.cpp, compute_surface_interaction, up to 3.5): with
positions p0, p1, p2 and texture coordinates uv0, uv1, uv2,
    dp0 = p1 - p0, dp1 = p2 - p0, duv0 = uv1 - uv0, duv1 = uv2 - uv0,
    det = duv0.x duv1.y - duv0.y duv1.x,   dp/du = (duv1.y dp0 - duv0.y dp1) / det,
the solution of dp = dp/du du + dp/dv dv on the triangle (any vertex order gives the same); without
texture coordinates, or where det = 0, the first axis of Mitsuba's coordinate_system of the
geometric normal (Duff et al. 2017, frame_to_world's). A quad's is its edge_u (its u runs along it:
Mitsuba's rectangle has dp/du = to_world (2, 0, 0)); a sphere's follows drtlab's own uv
(u = 1/2 + atan2(n.z, n.x) / 2 pi): 2 pi r (-n.z, 0, n.x), 0 at its poles.
"""
import warp as wp

from drtlab.estimators.domain_maps import frame_to_world
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.intersection.primitives import Hit


@wp.func
def mesh_tangent(sd: SceneData, face: int, n: wp.vec3) -> wp.vec3:
    """dp/du of triangle `face` (an index into the per-face arrays), n its unit geometric normal."""
    idx = sd.meshes.tri_index[face]
    p0 = sd.meshes.points[idx[0]]
    uv0 = sd.meshes.vert_uv[idx[0]]
    dp0 = sd.meshes.points[idx[1]] - p0
    dp1 = sd.meshes.points[idx[2]] - p0
    duv0 = sd.meshes.vert_uv[idx[1]] - uv0
    duv1 = sd.meshes.vert_uv[idx[2]] - uv0
    det = duv0[0] * duv1[1] - duv0[1] * duv1[0]
    if det == 0.0:
        return frame_to_world(wp.vec3(1.0, 0.0, 0.0), n)
    return (duv1[1] * dp0 - duv0[1] * dp1) / det


@wp.func
def hit_tangent(sd: SceneData, h: Hit) -> wp.vec3:
    """dp/du at hit h (module doc)."""
    if h.kind == MESH:
        return mesh_tangent(sd, h.index, h.n)
    if h.kind == QUAD:
        return sd.quads.geom[h.index].edge_u
    if h.kind == SPHERE:
        return (6.283185307179586 * sd.spheres.radius[h.index]) * wp.vec3(-h.n[2], 0.0, h.n[0])
    return wp.vec3(0.0)
