"""`make bench`'s primitive-count sweep (experiments/bench/scenes.py --scaling-primitives): render speed
against the number of primitives, the loop over spheres against their BVH, and BVH build times
-> the "primitives" table of results/bench/render.json and results/bench/primitives.png.

Spheres: the built-in `sphere-grid` with `shapes[1].count` = N (N^2 spheres, 4 ... 10^4), rendered
with the loop and with the wp.Bvh forced (features.SPHERE_BVH_MIN); the crossover is where the BVH
first renders at least as fast as the loop (interpolated in log count between the measured points).
Triangles: the built-in `displaced-sphere` without its lamp, `shapes[2].subdivisions` = 0 ... 6
(20 ... 81920 triangles); meshes always use their BVH (there is no loop to compare).
Speed is M samples/s of the launches alone on one thread at PRIM_RES^2 pixels and PRIM_SPP, best of
`repeats`; build time is the best of 3 fresh builds on the CPU of the boxes and the BVH (and, for
meshes, the tables: areas, cdf, normals), what an upload of a new scene pays.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

SPHERE_GRIDS = (2, 3, 4, 6, 8, 10, 16, 32, 100)      # N x N spheres: 4 ... 10^4
SUBDIVISIONS = (0, 1, 2, 3, 4, 5, 6)                   # 20 * 4^s triangles: 20 ... 81920
PRIM_RES, PRIM_SPP = 32, 16


def _speed(scene, sampler: str, repeats: int) -> float:
    from drtlab.kernels.render import render_with_stats
    render_with_stats(scene, spp=1, sampler=sampler, res=8, threads=1, progress=False)   # compile
    best = max(render_with_stats(scene, spp=PRIM_SPP, sampler=sampler, res=PRIM_RES, threads=1,
                                 seed=rep, progress=False).samples_per_second
               for rep in range(repeats))
    return round(best / 1e6, 4)


def _build_seconds(build) -> float:
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        build()
        best = min(best, time.perf_counter() - t0)
    return round(best, 6)


def _sphere_row(n: int, sampler: str, repeats: int) -> dict:
    import drtlab.kernels.features as features
    from drtlab.kernels.scene_upload import scene_extent
    from drtlab.kernels.intersection.bvh_build import build_bvh, sphere_boxes
    from drtlab.kernels.scene_model.scene_file import load_scene
    scene = load_scene("sphere-grid", {"shapes[1].count": n})
    spheres = [s for s in scene.shapes if s.kind == "sphere"]
    saved = features.SPHERE_BVH_MIN
    try:
        features.SPHERE_BVH_MIN = 1 << 40
        loop = _speed(scene, sampler, repeats)
        features.SPHERE_BVH_MIN = 0
        bvh = _speed(scene, sampler, repeats)
    finally:
        features.SPHERE_BVH_MIN = saved
    extent = scene_extent(scene)
    build = _build_seconds(lambda: build_bvh(*sphere_boxes(spheres, 0.0, 0.0, extent), "cpu"))
    return {"spheres": len(spheres), "msamples_per_second_loop": loop,
            "msamples_per_second_bvh": bvh, "bvh_build_seconds": build}


def _triangle_row(s: int, sampler: str, repeats: int) -> dict:
    import tomllib
    from drtlab.kernels.scene_upload import scene_extent
    from drtlab.kernels.intersection.bvh_build import build_bvh, mesh_tables
    from drtlab.kernels.scene_model.scene_file import BUILTIN_DIR, scene_from_dict
    data = tomllib.loads((BUILTIN_DIR / "displaced-sphere.toml").read_text())
    data["shapes"] = [sh for sh in data["shapes"] if sh.get("name") != "lamp"]
    data["shapes"][2]["subdivisions"] = s
    scene = scene_from_dict(data, name="displaced-sphere")
    meshes = [sh for sh in scene.shapes if sh.kind == "mesh"]
    extent = scene_extent(scene)

    def build():
        tables = mesh_tables(meshes, 0.0, extent)
        for lo, hi in tables.boxes:
            build_bvh(lo, hi, "cpu")

    return {"triangles": sum(len(m.mesh.faces) for m in meshes),
            "msamples_per_second": _speed(scene, sampler, repeats),
            "bvh_build_seconds": _build_seconds(build)}


def crossover(rows: list) -> float | None:
    """Sphere count from which the BVH is at least as fast as the loop (log-linear between the
    bracketing measurements), None if it never is; the smallest count if it always is."""
    ratio = [(r["spheres"], math.log(r["msamples_per_second_bvh"] / r["msamples_per_second_loop"]))
             for r in rows]
    if ratio[0][1] >= 0.0:
        return float(ratio[0][0])
    for (n0, r0), (n1, r1) in zip(ratio, ratio[1:]):
        if r1 >= 0.0 > r0:
            f = -r0 / (r1 - r0)
            return round(math.exp(math.log(n0) + f * (math.log(n1) - math.log(n0))), 1)
    return None


def primitives(sampler: str, repeats: int) -> dict:
    """The sweep (module doc); prints each row as it is measured."""
    t0 = time.perf_counter()
    spheres, triangles = [], []
    for n in SPHERE_GRIDS:
        spheres.append(_sphere_row(n, sampler, repeats))
        r = spheres[-1]
        print(f"  {r['spheres']:6d} spheres   loop {r['msamples_per_second_loop']:7.3f}   bvh "
              f"{r['msamples_per_second_bvh']:7.3f} M samples/s   build {r['bvh_build_seconds']:.5f} s",
              flush=True)
    for s in SUBDIVISIONS:
        triangles.append(_triangle_row(s, sampler, repeats))
        r = triangles[-1]
        print(f"  {r['triangles']:6d} triangles bvh {r['msamples_per_second']:7.3f} M samples/s   "
              f"build {r['bvh_build_seconds']:.5f} s", flush=True)
    return {"sampler": sampler, "repeats": repeats, "resolution": f"{PRIM_RES}x{PRIM_RES}",
            "spp": PRIM_SPP, "threads": 1, "spheres": spheres, "triangles": triangles,
            "sphere_bvh_crossover": crossover(spheres),
            "seconds": round(time.perf_counter() - t0, 1)}


def plot_primitives(result: dict, path: Path) -> None:
    """Log-log samples/s and BVH build time against primitive count."""
    from drtlab.experiments.plotting import pyplot
    plt = pyplot()
    sp, tr = result["spheres"], result["triangles"]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    ax.loglog([r["spheres"] for r in sp], [r["msamples_per_second_loop"] for r in sp], "o-",
              color="#D55E00", label="spheres, loop")
    ax.loglog([r["spheres"] for r in sp], [r["msamples_per_second_bvh"] for r in sp], "s--",
              color="#0072B2", label="spheres, BVH")
    ax.loglog([r["triangles"] for r in tr], [r["msamples_per_second"] for r in tr], "^:",
              color="#009E73", label="triangles (mesh BVH)")
    if result.get("sphere_bvh_crossover"):
        ax.axvline(result["sphere_bvh_crossover"], color="#999999", lw=0.8)
    ax.set(xlabel="primitives", ylabel="M samples/s (1 thread)",
           title=f"render speed, {result['resolution']} x {result['spp']} spp")
    ax.legend()
    bx.loglog([r["spheres"] for r in sp], [r["bvh_build_seconds"] for r in sp], "s--",
              color="#0072B2", label="spheres")
    bx.loglog([r["triangles"] for r in tr], [r["bvh_build_seconds"] for r in tr], "^:",
              color="#009E73", label="triangles (with tables)")
    bx.set(xlabel="primitives", ylabel="seconds", title="BVH build (CPU)")
    bx.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
