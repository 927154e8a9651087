"""The surface's tangent frame at a hit: dp/du (and dp/dv), what orients an anisotropic lobe's
shading frame and a normal or bump map's tangent space (kernels/materials/shading_frame.py).

As Mitsuba 3 (src/render/mesh.cpp, interaction.h): a mesh triangle's dp/du and dp/dv from its
positions p0, p1, p2 and texture coordinates uv0, uv1, uv2 (the linear map taking the uv edges to
the position edges: dp0 = dp/du duv0.u + dp/dv duv0.v, and likewise for dp1); without texture
coordinates, or where their triangle is degenerate, Mitsuba's coordinate_system (Duff et al. 2017)
of the geometric normal. A quad's dp/du is its edge_u (Mitsuba's rectangle: to_world (2, 0, 0)); a
sphere's is Mitsuba's along its u (sphere.cpp: u = atan2(y, x) / 2 pi in the sphere's own frame,
dp/du = 2 pi r (-y, x, 0) there), 0 at its poles. The shading frame's s is dp/du made orthogonal to
the shading normal (`tangent_s`).
"""
import warp as wp

from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.intersection.primitives import Hit


@wp.struct
class Tangents:
    dpdu: wp.vec3
    dpdv: wp.vec3


@wp.func
def coordinate_system(n: wp.vec3) -> Tangents:
    """Mitsuba's coordinate_system (Duff et al. 2017), the tangents of a degenerate uv triangle."""
    sign = 1.0
    if n[2] < 0.0:
        sign = -1.0
    a = -1.0 / (sign + n[2])
    b = n[0] * n[1] * a
    r = Tangents()
    r.dpdu = wp.vec3(n[0] * n[0] * a * sign + 1.0, b * sign, -n[0] * sign)
    r.dpdv = wp.vec3(b, sign + n[1] * n[1] * a, -n[1])
    return r


@wp.func
def triangle_tangents(p0: wp.vec3, p1: wp.vec3, p2: wp.vec3, uv0: wp.vec2, uv1: wp.vec2,
                      uv2: wp.vec2, ng: wp.vec3) -> Tangents:
    """dp/du and dp/dv of a triangle: [p1 - p0, p2 - p0] = [dp_du, dp_dv] [uv1 - uv0, uv2 - uv0]."""
    dp0 = p1 - p0
    dp1 = p2 - p0
    duv0 = uv1 - uv0
    duv1 = uv2 - uv0
    det = duv0[0] * duv1[1] - duv0[1] * duv1[0]
    if det == 0.0:
        return coordinate_system(ng)
    inv = 1.0 / det
    r = Tangents()
    r.dpdu = (duv1[1] * dp0 - duv0[1] * dp1) * inv
    r.dpdv = (duv0[0] * dp1 - duv1[0] * dp0) * inv
    return r


@wp.func
def tangent_s(ns: wp.vec3, dpdu: wp.vec3) -> wp.vec3:
    """The shading frame's s: dp_du made orthogonal to ns (any tangent where dp_du is 0)."""
    if dpdu[0] == 0.0 and dpdu[1] == 0.0 and dpdu[2] == 0.0:
        return coordinate_system(ns).dpdu
    return wp.normalize(dpdu - ns * wp.dot(ns, dpdu))


@wp.func
def mesh_tangents(sd: SceneData, h: Hit) -> Tangents:
    idx = sd.meshes.tri_index[h.index]
    return triangle_tangents(sd.meshes.points[idx[0]], sd.meshes.points[idx[1]], sd.meshes.points[idx[2]],
                             sd.meshes.vert_uv[idx[0]], sd.meshes.vert_uv[idx[1]],
                             sd.meshes.vert_uv[idx[2]], h.n)


@wp.func
def hit_tangent(sd: SceneData, h: Hit) -> wp.vec3:
    """dp/du at hit h (module doc)."""
    if h.kind == MESH:
        return mesh_tangents(sd, h).dpdu
    if h.kind == QUAD:
        return sd.quads.geom[h.index].edge_u
    if h.kind == SPHERE:
        to_local = sd.spheres.to_local[h.index]
        n = to_local * h.n
        return (6.283185307179586 * sd.spheres.radius[h.index]) * (wp.transpose(to_local) * wp.vec3(-n[1], n[0], 0.0))
    return wp.vec3(0.0)
