"""Mitsuba 3's side of `make bench-compare`: finding LLVM, the scene dict, and the translation check.

Mitsuba is an optional extra (`pip install -e '.[compare]'`): nothing here imports it at module
level, and every function that needs it takes the imported `mitsuba` module as an argument.

`mi.cornell_box()` is the source of truth for the comparison; drtlab's built-in `cornell-box` claims
to be its translation, and `translation_check` verifies that claim number for number (camera,
geometry as vertex sets and facing, BSDF albedos, emitter radiance) before anything is timed.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

# Dr.Jit's LLVM backend needs a recent libLLVM; Debian 12's default LLVM 14 crashes it.
LLVM_CANDIDATES = (
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/aarch64-linux-gnu/libLLVM-19.so",
)
LLVM_VARIANT = "llvm_ad_rgb"
SCALAR_VARIANT = "scalar_rgb"
GEOMETRY_TOL = 1e-5        # Mitsuba's ScalarTransform4f is float32; the TOML has 9 decimals
COLOUR_TOL = 1e-9


def find_libllvm() -> tuple[str | None, str]:
    """(path, how it was found) of the libLLVM Dr.Jit should load, or (None, why not)."""
    env = os.environ.get("DRJIT_LIBLLVM_PATH")
    if env:
        if Path(env).is_file():
            return env, "DRJIT_LIBLLVM_PATH"
        return None, f"DRJIT_LIBLLVM_PATH={env} does not exist"
    for cand in LLVM_CANDIDATES:
        if Path(cand).is_file():
            return cand, "found on disk"
    return None, ("no libLLVM-19.so under /usr/lib/llvm-19/lib or /usr/lib/x86_64-linux-gnu "
                  "(Debian: apt-get install libllvm19; or set DRJIT_LIBLLVM_PATH); LLVM 14 crashes Dr.Jit")


_PROBE = """
import mitsuba as mi, numpy as np
mi.set_variant({variant!r})
d = mi.cornell_box()
d['sensor']['film']['width'] = 8; d['sensor']['film']['height'] = 8
img = np.array(mi.render(mi.load_dict(d), spp=1))
assert img.shape == (8, 8, 3), img.shape
print('ok')
"""


def probe_variant(variant: str, timeout: float = 180.0, env: dict | None = None) -> tuple[bool, str]:
    """Render an 8x8 image with `variant` in a child process: a broken LLVM crashes (SIGSEGV) the
    process that loads it, and the benchmark must survive to say so."""
    try:
        r = subprocess.run([sys.executable, "-c", _PROBE.format(variant=variant)],
                           capture_output=True, text=True, timeout=timeout,
                           env={**os.environ, **(env or {})})
    except subprocess.TimeoutExpired:
        return False, f"{variant} probe render did not finish in {timeout:.0f} s"
    if r.returncode == 0 and r.stdout.strip().endswith("ok"):
        return True, "ok"
    tail = (r.stderr or r.stdout).strip().splitlines()[-1:] or ["no output"]
    return False, f"{variant} probe render failed (exit {r.returncode}): {tail[0][:200]}"


def scene_dict(mi, width: int, height: int, spp: int, max_depth: int) -> dict:
    """`mi.cornell_box()` with the comparison's settings: path integrator at `max_depth`, box pixel
    filter, the given film size and sample count. Everything else is left as Mitsuba ships it."""
    d = mi.cornell_box()
    d["integrator"] = {"type": "path", "max_depth": int(max_depth)}
    film = d["sensor"]["film"]
    film["width"], film["height"] = int(width), int(height)
    film["rfilter"] = {"type": "box"}
    d["sensor"]["sampler"]["sample_count"] = int(spp)
    return d


def _matrix(transform) -> np.ndarray:
    return np.array(transform.matrix, dtype=np.float64).reshape(4, 4)


def _apply(m: np.ndarray, p) -> np.ndarray:
    return m[:3, :3] @ np.asarray(p, dtype=np.float64) + m[:3, 3]


def vfov_for(d: dict, width: int, height: int) -> float:
    """drtlab's full vertical fov (degrees) that equals the Mitsuba sensor's fov on a W x H film."""
    s = d["sensor"]
    fov = float(s["fov"])
    axis = s.get("fov_axis", "x")
    aspect = width / height
    if axis == "smaller":
        axis = "x" if width < height else "y"
    elif axis == "larger":
        axis = "x" if width >= height else "y"
    if axis == "y":
        return fov
    if axis == "x":
        return math.degrees(2 * math.atan(math.tan(math.radians(fov) / 2) / aspect))
    raise ValueError(f"fov_axis {axis!r} is not handled")


def camera_of(d: dict) -> dict:
    """Position, unit forward and up of the Mitsuba sensor (its to_world applied to the camera frame)."""
    m = _matrix(d["sensor"]["to_world"])
    fwd = m[:3, :3] @ np.array([0.0, 0.0, 1.0])
    up = m[:3, :3] @ np.array([0.0, 1.0, 0.0])
    return {"position": m[:3, 3], "forward": fwd / np.linalg.norm(fwd), "up": up / np.linalg.norm(up)}


def _rgb(spec) -> np.ndarray:
    if isinstance(spec, dict) and spec.get("type") == "rgb":
        return np.asarray(spec["value"], dtype=np.float64)
    return np.asarray(spec, dtype=np.float64)


def _quad_vertices(s) -> np.ndarray:
    o, u, v = s.origin, s.edge_u, s.edge_v
    return np.array([o, o + u, o + v, o + u + v], dtype=np.float64)


def _distinct(points: np.ndarray, tol: float = 1e-7) -> np.ndarray:
    """The points with near-duplicates (closer than `tol`) merged: a cube's 24 face corners -> 8."""
    kept: list[np.ndarray] = []
    for p in points:
        if not any(np.linalg.norm(p - q) < tol for q in kept):
            kept.append(p)
    return np.array(kept)


def _match_sets(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance from a point of either set to the nearest point of the other (inf if the
    counts differ)."""
    if len(a) != len(b):
        return math.inf
    dist = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    return float(max(dist.min(axis=1).max(), dist.min(axis=0).max()))


def translation_check(d: dict, scene, width: int, height: int) -> dict:
    """Compare drtlab's scene (a `drtlab.kernels.scene_model.scene.Scene`) with Mitsuba's dict, number for number.

    Returns {"ok": bool, "checks": [{"what", "deviation", "ok"}...]}: rectangles are [-1, 1]^2 at z = 0
    with normal +z and cubes [-1, 1]^3 before to_world; a drtlab quad's normal is edge_u x edge_v."""
    checks = []

    def add(what, dev, tol):
        checks.append({"what": what, "deviation": float(dev), "ok": bool(dev <= tol)})

    cam = camera_of(d)
    dc = scene.camera
    fwd = np.asarray(dc.look_at, float) - np.asarray(dc.position, float)
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, dc.up)
    up = np.cross(right / np.linalg.norm(right), fwd)
    add("camera.position", np.abs(np.asarray(dc.position, float) - cam["position"]).max(), GEOMETRY_TOL)
    add("camera.forward", np.abs(fwd - cam["forward"]).max(), GEOMETRY_TOL)
    add("camera.up", np.abs(up - cam["up"]).max(), GEOMETRY_TOL)
    add(f"camera.vfov at {width}x{height} (deg)", abs(dc.vfov_deg - vfov_for(d, width, height)), 1e-6)
    add("resolution", 0.0 if (scene.width, scene.height) == (width, height) else math.inf, 0.0)

    shapes = {s.name: s for s in scene.shapes}
    mats = scene.materials
    for key, spec in d.items():
        if not isinstance(spec, dict) or spec.get("type") not in ("rectangle", "cube"):
            continue
        m = _matrix(spec["to_world"])
        normal_m = np.linalg.inv(m[:3, :3]).T
        if spec["type"] == "rectangle":
            mine = [shapes[key]] if key in shapes else []
            corners = [(-1, -1, 0), (1, -1, 0), (-1, 1, 0), (1, 1, 0)]
            ref = np.array([_apply(m, c) for c in corners])
            got = _quad_vertices(mine[0]) if mine else np.zeros((0, 3))
            add(f"{key}: corners", _match_sets(ref, got), GEOMETRY_TOL)
            if mine:
                n_ref = normal_m @ np.array([0.0, 0.0, 1.0])
                n_got = np.cross(mine[0].edge_u, mine[0].edge_v)
                cos = n_ref @ n_got / (np.linalg.norm(n_ref) * np.linalg.norm(n_got))
                add(f"{key}: facing (1 - cos)", 1.0 - cos, 1e-9)
        else:
            mine = [s for n, s in shapes.items() if n.startswith(key + ".")]
            corners = [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
            ref = np.array([_apply(m, c) for c in corners])
            got = _distinct(np.concatenate([_quad_vertices(s) for s in mine])) if mine \
                else np.zeros((0, 3))
            add(f"{key}: corners of {len(mine)} faces", _match_sets(ref, got), GEOMETRY_TOL)
            centre = _apply(m, (0, 0, 0))
            outward = all((np.cross(s.edge_u, s.edge_v) @ (s.origin + 0.5 * (s.edge_u + s.edge_v) - centre))
                          > 0 for s in mine) and len(mine) == 6
            add(f"{key}: 6 faces facing out", 0.0 if outward else math.inf, 0.0)
        if not mine:
            continue
        bsdf = spec.get("bsdf", {})
        ref_id = bsdf.get("id") if bsdf.get("type") == "ref" else None
        ref_bsdf = d.get(ref_id, bsdf) if ref_id else bsdf
        for s in mine:
            mat = mats[s.material]
            if ref_bsdf.get("type") != "diffuse" or mat.kind != "diffuse":
                add(f"{s.name}: BSDF kind {mat.kind} vs {ref_bsdf.get('type')}", math.inf, 0.0)
                continue
            add(f"{s.name}: albedo", np.abs(mat.albedo - _rgb(ref_bsdf["reflectance"])).max(), COLOUR_TOL)
            radiance = _rgb(spec["emitter"]["radiance"]) if "emitter" in spec else np.zeros(3)
            add(f"{s.name}: emission", np.abs(mat.emission - radiance).max(), COLOUR_TOL)
    # Nothing in drtlab's scene that Mitsuba's lacks.
    known = {k for k, v in d.items() if isinstance(v, dict) and v.get("type") in ("rectangle", "cube")}
    extra = [s.name for s in scene.shapes if s.name.split(".")[0] not in known]
    add(f"shapes only in drtlab: {extra or 'none'}", math.inf if extra else 0.0, 0.0)
    bad = [c for c in checks if not c["ok"]]
    worst_geom = max((c["deviation"] for c in checks if "corners" in c["what"] or "camera" in c["what"]),
                     default=0.0)
    return {"ok": not bad, "n_checks": len(checks), "failed": bad,
            "max_geometry_deviation": worst_geom, "checks": checks}
