"""The chi-square harness's adapter of triangle-mesh light sampling: `MeshLightAdapter` wraps
`make_lights` (kernels/lights.py) with mesh lights compiled in and motion out in one CPU kernel, like
`LightAdapter` does for spheres and quads, on a SceneData that may hold all three.

Sampling: li = pick_light(u0), then sample_light(li, x, (u1, u2)); a mesh light picks a triangle by
area and a uniform point on it (area sampling) or one uniform in its solid angle (solid angle
sampling, kernels/lights.py). The claimed density of a direction w is the sum over lights of
light_pdf(li, x, y, ny) at the nearest point y where the ray x + t w meets the light (a mesh: by the
renderer's own mesh ray query, ny the face normal), counted only where y faces x. That is the
sampler's density exactly when each direction meets a light at most once facing x: spheres, quads,
and meshes that are convex or height fields seen steeply from below (what the tests use). `mesh_fault` compiles
features.MESH_PDF_HIGH_10PCT, the negative control of the chi-square test.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drtlab.experiments.stats.chi2.light_adapter import LightAdapter, LightSamples, make_light_kernel


@dataclass
class MeshLightSamples(LightSamples):
    face: np.ndarray = None     # a mesh light's sampled face (in the per-face arrays), else 0


class MeshLightAdapter(LightAdapter):
    """LightAdapter's harness interface over a kernel that also samples mesh lights (and reports
    the sampled face)."""
    _kernels: dict = {}
    _SAMPLES = MeshLightSamples
    _EXTRA = ("face",)

    def __init__(self, solid_angle: bool = True, power_pick: bool = True, mesh_fault: bool = False,
                 faults=()):
        super().__init__(solid_angle, power_pick, mesh_fault, faults)

    @staticmethod
    def _build(solid_angle: bool, power_pick: bool, mesh_fault: bool, faults=frozenset()):
        return make_light_kernel(solid_angle, power_pick, False, faults, meshes=True,
                                 mesh_fault=mesh_fault)
