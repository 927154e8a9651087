"""The scenes of `drtlab check INTEGRATOR` (experiments/checks/integrator.py): one small scene per
effect an integrator may claim (`Integrator.handles`), the white furnace, and the hard cases.

Each effect scene isolates one effect at the shortest depth that shows it, so that every unbiased
integrator that handles the effect has the same expected image as `path` there (an integrator with
a narrower estimand, such as drt without diffuse interreflection, still agrees: no scene but
`indirect` has a path that scatters diffusely before its last segment):

    direct        a diffuse floor and sphere under a sphere light and a quad light (depth 2)
    indirect      a closed diffuse box lit by a quad under its ceiling (depth 4, roulette from 1)
    glossy        a Phong floor (exponent 20) and sphere (60) under the two lights (depth 3)
    specular      a mirror floor and a Phong sphere (10) under the two lights (depth 3)
    transmission  a glass sphere (ior 1.5) on a Phong floor (10) under the two lights (depth 4)
    environment   the direct scene under a constant environment as well (depth 2)
    point_lights  the direct scene with a point light and a directional light as well (depth 2)
    lens          the direct scene through a thin lens (aperture 0.15, focused on the sphere)
    motion        the direct scene over an open shutter, the sphere and the sphere light moving
    meshes        the direct scene with the sphere a displaced-sphere mesh (smooth normals) and the
                  quad light an emitting mesh disk (depth 2)

The effects are the registry's (estimators/integrators.EFFECTS), one scene each.

Every scene is built from the same shape types and material kinds (lights are black diffuse
emitters; KIT adds tiny spheres of the other kinds 50 units below the floor, where nothing but a
stray ray 1e-7 of whose directions point there reaches them), so all but the environment, point
light and mesh scenes compile to one kernel variant per integrator: the check costs at most four
compilations, not twelve.
"""
from __future__ import annotations

import copy

from drtlab.estimators.integrators import EFFECTS
from drtlab.experiments.audit.renderer import EXACT as FURNACE_EXACT
from drtlab.experiments.audit.renderer import furnace_scene

RES = (16, 12)
MATERIALS = {
    "floor": {"kind": "diffuse", "albedo": [0.7, 0.7, 0.7]},
    "clay": {"kind": "diffuse", "albedo": [0.8, 0.5, 0.3]},
    "lamp": {"kind": "diffuse", "albedo": [0.0, 0.0, 0.0], "emission": [6.0, 5.0, 4.0]},
    "panel": {"kind": "diffuse", "albedo": [0.0, 0.0, 0.0], "emission": [3.0, 4.0, 5.0]},
    "kit-glossy": {"kind": "glossy", "albedo": [0.5, 0.5, 0.5], "exponent": 10.0},
    "kit-mirror": {"kind": "mirror", "albedo": [0.5, 0.5, 0.5]},
    "kit-glass": {"kind": "dielectric", "albedo": [1.0, 1.0, 1.0], "ior": 1.5},
}
KIT = [{"kind": "sphere", "material": m, "center": [3.0 * i, -50.0, 0.0], "radius": 0.01}
       for i, m in enumerate(("clay", "kit-glossy", "kit-mirror", "kit-glass"))]
CAMERA = {"position": [0.0, 2.0, -4.0], "look_at": [0.0, 0.3, 0.5], "up": [0.0, 1.0, 0.0], "fov": 45.0}
FLOOR = {"kind": "quad", "material": "floor", "origin": [-3.0, 0.0, -3.0], "edge_u": [0.0, 0.0, 6.0],
         "edge_v": [6.0, 0.0, 0.0]}
BALL = {"kind": "sphere", "material": "clay", "center": [0.3, 0.5, 0.5], "radius": 0.5}
LAMP = {"kind": "sphere", "material": "lamp", "center": [-1.0, 2.2, 1.0], "radius": 0.4}
PANEL = {"kind": "quad", "material": "panel", "origin": [0.5, 2.5, -0.5], "edge_u": [1.0, 0.0, 0.0],
         "edge_v": [0.0, 0.0, 1.0]}          # edge_u x edge_v = -y: it lights the floor


def _scene(description: str, shapes: list, depth: int, materials: dict | None = None,
           camera: dict | None = None, res=RES) -> dict:
    return {"scene": {"description": f"drtlab check integrator: {description}",
                      "resolution": [int(res[0]), int(res[1])], "spp": 16, "integrator": "path",
                      "max_depth": depth, "russian_roulette": True, "rr_depth": 1},
            "camera": copy.deepcopy(camera or CAMERA),
            "materials": {**copy.deepcopy(MATERIALS), **(materials or {})},
            "shapes": copy.deepcopy(shapes) + copy.deepcopy(KIT)}


def _with(shape: dict, **changes) -> dict:
    return {**copy.deepcopy(shape), **changes}


def _indirect() -> dict:
    from drtlab.kernels.scene_model.procedural import inward_box_faces
    walls = [{"kind": "quad", "material": "floor", "origin": [float(x) for x in o],
              "edge_u": [float(x) for x in u], "edge_v": [float(x) for x in v]}
             for _, _, o, u, v in inward_box_faces([-1.0] * 3, [1.0] * 3)]
    light = {"kind": "quad", "material": "panel", "origin": [-0.3, 0.98, -0.3], "edge_u": [0.6, 0.0, 0.0],
             "edge_v": [0.0, 0.0, 0.6]}
    cam = {"position": [0.0, 0.0, -0.9], "look_at": [0.2, -0.3, 1.0], "up": [0.0, 1.0, 0.0], "fov": 60.0}
    return _scene("indirect: a closed diffuse box lit from under its ceiling", walls + [light], 4, camera=cam)


def effect_scene(effect: str, res=RES) -> dict:
    """The scene dict that isolates `effect` (module docstring)."""
    lights = [LAMP, PANEL]
    if effect == "direct":
        return _scene("direct light", [FLOOR, BALL] + lights, 2, res=res)
    if effect == "indirect":
        return _indirect()
    if effect == "glossy":
        mats = {"floor": {"kind": "glossy", "albedo": [0.6, 0.6, 0.6], "exponent": 20.0},
                "clay": {"kind": "glossy", "albedo": [0.8, 0.5, 0.3], "exponent": 60.0}}
        return _scene("glossy reflection", [FLOOR, BALL] + lights, 3, materials=mats)
    if effect == "specular":
        mats = {"floor": {"kind": "mirror", "albedo": [0.8, 0.8, 0.8]},
                "clay": {"kind": "glossy", "albedo": [0.8, 0.5, 0.3], "exponent": 10.0}}
        return _scene("a mirror floor", [FLOOR, BALL] + lights, 3, materials=mats)
    if effect == "transmission":
        mats = {"floor": {"kind": "glossy", "albedo": [0.6, 0.6, 0.6], "exponent": 10.0},
                "clay": {"kind": "dielectric", "albedo": [1.0, 1.0, 1.0], "ior": 1.5}}
        return _scene("a glass sphere", [FLOOR, BALL] + lights, 4, materials=mats)
    if effect == "environment":
        d = _scene("a constant environment", [FLOOR, BALL] + lights, 2)
        d["environment"] = {"kind": "constant", "radiance": [0.4, 0.5, 0.6]}
        return d
    if effect == "point_lights":
        d = _scene("a point and a directional light", [FLOOR, BALL] + lights, 2)
        d["lights"] = [{"kind": "point", "position": [0.9, 1.4, -0.3], "intensity": [1.5, 1.2, 1.0]},
                       {"kind": "directional", "direction": [0.3, -1.0, 0.4], "irradiance": [0.3, 0.3, 0.4]}]
        return d
    if effect == "meshes":
        ball = {"kind": "mesh", "material": "clay", "generate": "displaced_sphere",
                "center": BALL["center"], "radius": BALL["radius"], "subdivisions": 2}
        disk = {"kind": "mesh", "material": "panel", "generate": "disk", "radius": 0.4,
                "transform": {"rotate": {"axis": [1.0, 0.0, 0.0], "degrees": 90.0},
                              "translate": [-0.8, 2.0, 1.2]}}
        return _scene("meshes", [FLOOR, ball, LAMP, disk], 2)
    if effect == "lens":
        cam = {**CAMERA, "aperture_radius": 0.15, "focus_distance": 4.5}
        return _scene("a thin lens", [FLOOR, BALL] + lights, 2, camera=cam)
    if effect == "motion":
        cam = {**CAMERA, "shutter": [0.0, 1.0]}
        return _scene("motion blur", [FLOOR, _with(BALL, velocity=[0.6, 0.0, 0.0]),
                                      _with(LAMP, velocity=[0.0, 0.0, 0.4]), PANEL], 2, camera=cam)
    raise KeyError(effect)


def furnace(res=RES) -> tuple[dict, float]:
    """(scene dict, exact radiance of every pixel and channel): the interval audit's white furnace
    (six emitting diffuse walls, depth 2: every pixel exactly Le (1 + rho)) with the kit outside it,
    so that it compiles to the effect scenes' variant."""
    d, exact = furnace_scene(res)
    d["shapes"] += copy.deepcopy(KIT)
    d["materials"].update({k: v for k, v in MATERIALS.items() if k.startswith("kit-") or k == "clay"})
    d["scene"].update(russian_roulette=True, rr_depth=1)
    return d, exact


def hard_cases(res=RES) -> dict:
    """A grazing view of the floor, a sphere light of radius 1e-3 2e-3 above it, a 200 x 200 light
    60 units up, a Phong sphere of exponent 1e4, a mirror and a nearly index-matched glass sphere
    (ior 1.01), to depth 6: every pixel must come out finite and non-negative."""
    mats = {"spark": {"kind": "diffuse", "albedo": [0.0, 0.0, 0.0], "emission": [5.0e4, 5.0e4, 5.0e4]},
            "sky": {"kind": "diffuse", "albedo": [0.0, 0.0, 0.0], "emission": [0.2, 0.2, 0.3]},
            "sharp": {"kind": "glossy", "albedo": [0.9, 0.9, 0.9], "exponent": 1.0e4},
            "thin-glass": {"kind": "dielectric", "albedo": [1.0, 1.0, 1.0], "ior": 1.01}}
    shapes = [FLOOR,
              {"kind": "sphere", "material": "spark", "center": [0.0, 2.0e-3, 0.5], "radius": 1.0e-3},
              {"kind": "quad", "material": "sky", "origin": [-100.0, 60.0, -100.0], "edge_u": [200.0, 0.0, 0.0],
               "edge_v": [0.0, 0.0, 200.0]},
              {"kind": "sphere", "material": "sharp", "center": [-0.8, 0.3, 1.0], "radius": 0.3},
              {"kind": "sphere", "material": "kit-mirror", "center": [0.8, 0.3, 1.2], "radius": 0.3},
              {"kind": "sphere", "material": "thin-glass", "center": [0.0, 0.3, 2.0], "radius": 0.3}]
    cam = {"position": [0.0, 0.02, -1.5], "look_at": [0.0, 0.0, 2.0], "up": [0.0, 1.0, 0.0], "fov": 50.0}
    return _scene("hard cases", shapes, 6, materials=mats, camera=cam, res=res)


__all__ = ["EFFECTS", "FURNACE_EXACT", "effect_scene", "furnace", "hard_cases"]
