"""The light adapter of the chi-square harness: next-event estimation's light samples (kernels/lights.py
`make_lights`, the strategy's light selection) and the density MIS evaluates, from a scene uploaded
by `upload_scene` (see the package docstring, drtlab.experiments.stats.chi2)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from drtlab.experiments.stats.chi2.adapters import (as_vec3, input_points, outputs, routine_variant,
                                                    uniform)
from drtlab.warp_runtime import warp as _wp
from drtlab.experiments.stats.chi2.harness import PdfFunc, SampleFunc
from drtlab.kernels.device_scene import SPHERE, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN, MESH_PDF_HIGH_10PCT


@dataclass
class LightSamples:
    wi: np.ndarray          # (n, 3)
    dist: np.ndarray
    pdf: np.ndarray         # the solid-angle pdf the sample carries (light choice included)
    valid: np.ndarray       # bool
    light: np.ndarray       # picked light index
    pdf_eval: np.ndarray    # light_pdf at the sampled point, evaluated separately
    radiance: np.ndarray    # (n, 3)
    pmf: np.ndarray         # light_pick_pmf of the picked light


class LightAdapter:
    """`make_lights` with motion compiled out on an uploaded SceneData, seen from a point x.

    Sampling: li = pick_light(u0), then sample_light(li, x, (u1, u2)) from a first vertex (bounce
    index 0, where lights.SPHERICAL_MAX_BOUNCE allows solid angle). The claimed density of a
    direction w is the sum over lights of light_pdf(li, x, y, ny) where y is the nearest point at
    which the ray x + t w meets light li's shape and ny its normal (spheres: outward; quads: their
    normal), counted only where that point faces x (a one-sided quad seen from behind, or a sphere
    point facing away, is never a valid sample). `wrong_jacobian` compiles the renderer's fault
    (area samples converted to solid angle without the cosine at the light): a negative control for
    the pdf consistency check, which a chi-square test of the directions cannot see."""

    _kernels: dict = {}
    # What the kernel writes per sample: LightSamples' fields in order, then `_EXTRA` fields.
    _OUTPUTS = (wp.vec3, float, float, int, int, float, wp.vec3, float, int)
    _SAMPLES = LightSamples
    _EXTRA: tuple = ()          # names of the kept outputs past LightSamples' (the face: unused)

    def __init__(self, solid_angle: bool, power_pick, wrong_jacobian: bool = False,
                 faults=()):
        """`power_pick`: True (power), False (uniform) or a registered light selection's name."""
        from drtlab.kernels.light_selection import LIGHT_SELECTIONS
        pick = power_pick if isinstance(power_pick, str) else bool(power_pick)
        key = (bool(solid_angle), pick, bool(wrong_jacobian), frozenset(faults))
        kernels = type(self)._kernels
        cached = (key, LIGHT_SELECTIONS[pick].fingerprint if isinstance(pick, str) else "")
        if cached not in kernels:
            kernels[cached] = self._build(*key)
        self.kernel = kernels[cached]

    @staticmethod
    def _build(*key):
        return make_light_kernel(*key)

    def _launch(self, mode, sd, x, n, seed, pts=None):
        wp = _wp()
        inp, n = input_points(pts, n)
        arrays = outputs(n, *self._OUTPUTS)
        wp.launch(self.kernel, dim=n, device="cpu",
                  inputs=[int(mode), sd, as_vec3(x), wp.uint32(seed), inp, *arrays])
        return [a.numpy() for a in arrays]

    def sample(self, sd, x, n: int, seed: int = 0) -> LightSamples:
        wi, dist, pdf, valid, li, pdf_eval, rad, pmf, *extra = self._launch(0, sd, x, n, seed)
        extra = extra[:len(self._EXTRA)]
        return self._SAMPLES(wi=wi, dist=dist, pdf=pdf.astype(np.float64), valid=valid == 1,
                             light=li, pdf_eval=pdf_eval.astype(np.float64), radiance=rad,
                             pmf=pmf.astype(np.float64), **dict(zip(self._EXTRA, extra)))

    def sampler(self, sd, x) -> SampleFunc:
        def sample(n, seed):
            s = self.sample(sd, x, n, seed)
            return s.wi, s.valid
        return sample

    def pdf(self, sd, x) -> PdfFunc:
        def pdf(pts):
            return self._launch(1, sd, x, 0, 0, pts)[5].astype(np.float64)
        return pdf


@wp.func
def face_normal(sd: SceneData, face: int) -> wp.vec3:
    idx = sd.meshes.tri_index[face]
    a = sd.meshes.points[idx[0]]
    return wp.normalize(wp.cross(sd.meshes.points[idx[1]] - a, sd.meshes.points[idx[2]] - a))


def make_light_kernel(solid_angle: bool, power_pick, wrong_jacobian: bool,
                      faults=frozenset(), meshes: bool = False, mesh_fault: bool = False):
    """The light-sampling kernel of LightAdapter (spheres and quads) and, with `meshes`, of
    chi2.mesh_adapter.MeshLightAdapter (mesh lights too; `mesh_fault` compiles its negative control).
    The mesh branches are compiled out without `meshes`."""
    wp = _wp()
    from drtlab.kernels.device_scene import MESH, QUAD
    from drtlab.kernels.intersection.primitives import hit_quad, hit_sphere
    from drtlab.kernels.intersection.bvh_traversal import make_mesh_rays, ray_shear
    from drtlab.kernels.intersection.motion import make_motion
    from drtlab.kernels.lights import make_lights

    faults = set(faults) | ({LIGHT_JACOBIAN} if wrong_jacobian else set())
    if mesh_fault:
        faults.add(MESH_PDF_HIGH_10PCT)
    motion = make_motion(moving=False)
    L = make_lights(*routine_variant(solid_angle=solid_angle, power_pick=power_pick, meshes=meshes,
                                     faults=frozenset(faults)), motion=motion)
    nearest_in_mesh = make_mesh_rays(motion=motion).nearest_in_mesh
    pick_light, light_pdf, sample_light, pick_pmf = (L.pick_light, L.light_pdf, L.sample_light,
                                                     L.light_pick_pmf)

    @wp.func
    def direction_pdf(sd: SceneData, x: wp.vec3, w: wp.vec3) -> float:
        """The claimed density of direction w: every light met facing x, at its nearest point."""
        total = float(0.0)
        for li in range(sd.lights.n_area):
            k = sd.lights.shape_kind[li]
            s = sd.lights.shape[li]
            t = float(1.0e30)
            ny = wp.vec3(0.0)
            face = int(0)
            if k == SPHERE:
                c = sd.spheres.center[s]
                t = hit_sphere(x, w, c, sd.spheres.radius[s], 1.0e30)
                if t < 1.0e30:
                    ny = wp.normalize(x + w * t - c)
            elif k == QUAD:
                t = hit_quad(x, w, sd.quads.origin[s], sd.quads.u[s], sd.quads.v[s], 1.0e30)
                ny = sd.quads.normal[s]
            elif wp.static(meshes):
                if k == MESH:
                    mh = nearest_in_mesh(sd, s, x, ray_shear(w), w, 1.0e30, 0.0)
                    if mh.mesh >= 0:
                        t = mh.t
                        ny = mh.n
                        face = sd.meshes.face0[s] + mh.face
            if t < 1.0e30:
                if wp.dot(ny, w) < 0.0:
                    total += light_pdf(sd, li, x, x + w * t, ny, face, 0, 0.0)
        return total

    @wp.kernel(enable_backward=False, module="unique")
    def light_kernel(mode: int, sd: SceneData, x: wp.vec3, seed: wp.uint32,
                     pts: wp.array(dtype=wp.vec3), out_wi: wp.array(dtype=wp.vec3),
                     out_dist: wp.array(dtype=float), out_pdf: wp.array(dtype=float),
                     out_valid: wp.array(dtype=int), out_light: wp.array(dtype=int),
                     out_pdf_eval: wp.array(dtype=float), out_rad: wp.array(dtype=wp.vec3),
                     out_pmf: wp.array(dtype=float), out_face: wp.array(dtype=int)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            li = pick_light(sd, x, uniform(seed, i, 0))
            ls = sample_light(sd, li, x, wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2)), 0,
                              0.0)
            out_light[tid] = li
            out_pmf[tid] = pick_pmf(sd, x, li)
            out_valid[tid] = ls.valid
            if ls.valid == 1:
                out_wi[tid] = ls.wi
                out_dist[tid] = ls.dist
                out_pdf[tid] = ls.pdf
                out_rad[tid] = ls.radiance
                y = x + ls.wi * ls.dist
                s = sd.lights.shape[li]
                k = sd.lights.shape_kind[li]
                ny = wp.vec3(0.0)
                if k == SPHERE:
                    ny = wp.normalize(y - sd.spheres.center[s])
                elif k == QUAD:
                    ny = sd.quads.normal[s]
                elif wp.static(meshes):
                    ny = face_normal(sd, ls.prim)
                    out_face[tid] = ls.prim
                # The pdf of the same point evaluated on its own, as MIS does from a BSDF hit.
                out_pdf_eval[tid] = light_pdf(sd, li, x, y, ny, ls.prim, 0, 0.0)
        else:
            out_pdf_eval[tid] = direction_pdf(sd, x, wp.normalize(pts[tid]))

    return light_kernel


def upload_scene(scene_dict: dict):
    """SceneData on the CPU for a scene dict (kernels/scene_model/SCENE_FORMAT.md), and the Scene itself."""
    from drtlab.kernels.scene_upload import upload
    from drtlab.kernels.scene_model.scene_file import scene_from_dict
    scene = scene_from_dict(scene_dict, name="chi2")
    return upload(scene, "cpu"), scene
