"""The chi-square harness's adapter of triangle-mesh light sampling: `MeshLightAdapter` wraps
`make_lights(False, solid_angle, power_pick, meshes=True, mesh_fault)` (kernels/lights.py) in one CPU
kernel, like `LightAdapter` does for spheres and quads, on a SceneData that may hold all three.

Sampling: li = pick_light(u0), then sample_light(li, x, (u1, u2)); a mesh light picks a triangle by
area and a uniform point on it. The claimed density of a direction w is the sum over lights of
light_pdf(li, x, y, ny) at the nearest point y where the ray x + t w meets the light (a mesh: by the
renderer's own mesh ray query, ny the face normal), counted only where y faces x. That is the
sampler's density exactly when each direction meets a light at most once facing x: spheres, quads,
and meshes that are convex or height fields seen steeply from below (what the tests use). `mesh_fault` compiles
features.MESH_PDF_HIGH_10PCT, the negative control of the chi-square test.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from drtlab.experiments.chi2.adapters import LightAdapter, LightSamples, uniform
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.warp_runtime import warp as _wp


@dataclass
class MeshLightSamples(LightSamples):
    face: np.ndarray = None     # a mesh light's sampled face (in the per-face arrays), else 0


class MeshLightAdapter(LightAdapter):
    """LightAdapter's harness interface over a kernel that also samples mesh lights (and reports
    the sampled face)."""
    _kernels: dict = {}
    _OUTPUTS = LightAdapter._OUTPUTS + (int,)
    _SAMPLES = MeshLightSamples
    _EXTRA = ("face",)

    def __init__(self, solid_angle: bool = True, power_pick: bool = True, mesh_fault: bool = False):
        super().__init__(solid_angle, power_pick, mesh_fault)

    @staticmethod
    def _build(*key):
        return _make_mesh_light_kernel(*key)


@wp.func
def face_normal(sd: SceneData, face: int) -> wp.vec3:
    idx = sd.tri_index[face]
    a = sd.mesh_points[idx[0]]
    return wp.normalize(wp.cross(sd.mesh_points[idx[1]] - a, sd.mesh_points[idx[2]] - a))


def _make_mesh_light_kernel(solid_angle: bool, power_pick: bool, mesh_fault: bool):
    wp = _wp()
    from drtlab.kernels.geometry import hit_quad, hit_sphere
    from drtlab.kernels.intersect import make_motion
    from drtlab.kernels.lights import make_lights
    from drtlab.kernels.mesh_rays import make_mesh_rays, ray_shear

    L = make_lights(False, solid_angle, power_pick, meshes=True, mesh_fault=mesh_fault)
    nearest_in_mesh = make_mesh_rays(make_motion(False).mesh_shift).nearest_in_mesh
    pick_light, light_pdf, sample_light, pick_pmf = (L.pick_light, L.light_pdf, L.sample_light,
                                                     L.light_pick_pmf)

    @wp.func
    def direction_pdf(sd: SceneData, x: wp.vec3, w: wp.vec3) -> float:
        total = float(0.0)
        for li in range(sd.n_lights):
            k = sd.light_shape_kind[li]
            s = sd.light_shape[li]
            t = float(1.0e30)
            ny = wp.vec3(0.0)
            if k == SPHERE:
                c = sd.sph_center[s]
                t = hit_sphere(x, w, c, sd.sph_radius[s], 1.0e30)
                if t < 1.0e30:
                    ny = wp.normalize(x + w * t - c)
            elif k == QUAD:
                t = hit_quad(x, w, sd.quad_origin[s], sd.quad_u[s], sd.quad_v[s], 1.0e30)
                ny = sd.quad_normal[s]
            elif k == MESH:
                mh = nearest_in_mesh(sd, s, x, ray_shear(w), w, 1.0e30, 0.0)
                if mh.mesh >= 0:
                    t = mh.t
                    ny = mh.n
            if t < 1.0e30:
                if wp.dot(ny, w) < 0.0:
                    total += light_pdf(sd, li, x, x + w * t, ny, 0.0)
        return total

    @wp.kernel(enable_backward=False, module="unique")
    def mesh_light_kernel(mode: int, sd: SceneData, x: wp.vec3, seed: wp.uint32,
                          pts: wp.array(dtype=wp.vec3), out_wi: wp.array(dtype=wp.vec3),
                          out_dist: wp.array(dtype=float), out_pdf: wp.array(dtype=float),
                          out_valid: wp.array(dtype=int), out_light: wp.array(dtype=int),
                          out_pdf_eval: wp.array(dtype=float), out_rad: wp.array(dtype=wp.vec3),
                          out_pmf: wp.array(dtype=float), out_face: wp.array(dtype=int)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            li = pick_light(sd, uniform(seed, i, 0))
            ls = sample_light(sd, li, x, wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2)), 0.0)
            out_light[tid] = li
            out_pmf[tid] = pick_pmf(sd, li)
            out_valid[tid] = ls.valid
            if ls.valid == 1:
                out_wi[tid] = ls.wi
                out_dist[tid] = ls.dist
                out_pdf[tid] = ls.pdf
                out_rad[tid] = ls.radiance
                y = x + ls.wi * ls.dist
                s = sd.light_shape[li]
                k = sd.light_shape_kind[li]
                ny = wp.vec3(0.0)
                if k == SPHERE:
                    ny = wp.normalize(y - sd.sph_center[s])
                elif k == QUAD:
                    ny = sd.quad_normal[s]
                else:
                    ny = face_normal(sd, ls.prim)
                    out_face[tid] = ls.prim
                # The pdf of the same point evaluated on its own, as MIS does from a BSDF hit.
                out_pdf_eval[tid] = light_pdf(sd, li, x, y, ny, 0.0)
        else:
            out_pdf_eval[tid] = direction_pdf(sd, x, wp.normalize(pts[tid]))

    return mesh_light_kernel
