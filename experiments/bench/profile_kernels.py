"""Microbenchmarks of the render kernels: where a sample's time goes.

    python -m drtlab.experiments.bench.profile_kernels rays   [--scene cornell-box] [--rays 200000]
    python -m drtlab.experiments.bench.profile_kernels render [--scene cornell-box ...] [--res 64] [--spp 64]
    python -m drtlab.experiments.bench.profile_kernels check  [--scene ...]
    python -m drtlab.experiments.bench.profile_kernels compile [--experiment stratified] [--threads 2]
    python -m drtlab.experiments.bench.profile_kernels images (--save F.npz | --compare F.npz)
    python -m drtlab.experiments.bench.profile_kernels pointsets [--sets stratified sobol ...] [--spp 64]
    python -m drtlab.experiments.bench.profile_kernels components [--scene cornell-box ...] [--sampler ...]

`rays` times the scene's intersection alone, on three ray populations built from the scene: camera
rays (closest hit), cosine-distributed bounce rays from the camera rays' hit points (closest hit),
and shadow rays from those points to uniform points on the first area light (`visible`). `render`
times whole renders (best of --repeats, 1 thread unless --threads). `check` compares the tracer's
`intersect` / `visible` against a brute-force closest hit over the scene's quads and spheres with
`hit_quad` / `hit_sphere` (the reference formulas of tests/kernels/test_geometry.py): how many rays disagree
on the shape hit, and the largest relative difference of the hit distance. `compile` builds, in an
empty Warp kernel cache, every kernel variant an experiment needs (its scenes x samplers, and the
ground truth's sampler) and sums their cold compile seconds, one after the other; with --threads N
it compiles them N at a time as an experiment does (`render.compile_variants`) and reports the wall
time. `images` renders every built-in scene
with each of its integrators and a range of samplers at a small size and saves them, or compares them
with saved ones (bit for bit, and the largest difference relative to the image's mean): the check
that a speed change left the images alone. `pointsets` times each point set's draws as a render makes
them (count word once per pixel, then per sample and bounce one get2d and one get1d at the tracer's
dimensions): CPU ns per draw pair (one 2D + one 1D draw) and the ratio to `independent`'s, the sets
taking turns within each of --repeats rounds (best round each) so that load from other jobs falls on
all alike; --write stores them where `drtlab samplers` reads them (`estimators/draw_costs.py`). `components` is
the render's profile: what each part of a sample costs inside a whole render (features.REPEATS: a
variant that does the part twice, less the plain variant), per sample and as a share of it; the
second call sees perturbed inputs (a reversed ray, swapped coordinates), so a part's cost is that
of a like call, not of the same one.
"""

import sys
import time

import numpy as np

from drtlab.estimators.defaults import DEFAULT_SAMPLER
from drtlab.experiments.bench import draw_cost


def _setup():
    from drtlab.warp_runtime import warp as _wp
    return _wp()


def _ray_kernels(features):
    import warp as wp
    from drtlab.kernels.device_scene import SceneData
    from drtlab.kernels.intersection.scene_rays import make_intersect
    from drtlab.kernels.intersection.motion import make_motion
    rays = make_intersect(features, motion=make_motion())
    intersect, visible = rays.intersect, rays.visible

    @wp.kernel(enable_backward=False, module="unique")
    def closest(sd: SceneData, o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3),
                t_out: wp.array(dtype=float), kind_out: wp.array(dtype=int),
                index_out: wp.array(dtype=int), n_out: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        h = intersect(sd, o[i], d[i], 1.0e30, 0.0)
        t_out[i] = h.t
        kind_out[i] = h.kind
        index_out[i] = h.index
        n_out[i] = h.n

    @wp.kernel(enable_backward=False, module="unique")
    def shadow(sd: SceneData, o: wp.array(dtype=wp.vec3), d: wp.array(dtype=wp.vec3),
               dist: wp.array(dtype=float), target_kind: int, target: int,
               out: wp.array(dtype=int)):
        i = wp.tid()
        out[i] = visible(sd, o[i], d[i], dist[i], 0.0, target_kind, target)

    return closest, shadow


def _reference_kernel():
    import warp as wp
    from drtlab.kernels.device_scene import SceneData
    from drtlab.kernels.intersection.primitives import hit_quad, hit_sphere

    @wp.kernel(enable_backward=False, module="unique")
    def brute(sd: SceneData, qo: wp.array(dtype=wp.vec3), qu: wp.array(dtype=wp.vec3),
              qv: wp.array(dtype=wp.vec3), nq: int, o: wp.array(dtype=wp.vec3),
              d: wp.array(dtype=wp.vec3), t_out: wp.array(dtype=float),
              kind_out: wp.array(dtype=int), index_out: wp.array(dtype=int)):
        i = wp.tid()
        best = float(1.0e30)
        kind = int(-1)
        index = int(-1)
        for k in range(sd.spheres.count):
            t = hit_sphere(o[i], d[i], sd.spheres.center[k], sd.spheres.radius[k], best)
            if t < best:
                best = t
                kind = 0
                index = k
        for k in range(nq):
            t = hit_quad(o[i], d[i], qo[k], qu[k], qv[k], best)
            if t < best:
                best = t
                kind = 1
                index = k
        t_out[i] = best
        kind_out[i] = kind
        index_out[i] = index

    return brute


def _populations(scene, n: int, rng):
    """Camera rays through random pixels (numpy, float32), as the tracer builds them."""
    from drtlab.kernels.scene_upload import camera_basis
    cam = scene.camera
    pos, fwd, right, up = camera_basis(cam)
    hh = np.tan(np.radians(cam.vfov_deg) / 2)
    hw = hh * scene.width / scene.height
    sx = (2 * rng.random(n) - 1) * hw
    sy = (1 - 2 * rng.random(n)) * hh
    d = right * sx[:, None] + up * sy[:, None] + fwd
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.tile(pos, (n, 1)).astype(np.float32), d.astype(np.float32)


def _cosine_dirs(n_arr, rng):
    u1, u2 = rng.random(len(n_arr)), rng.random(len(n_arr))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0, 1 - u1))], 1)
    a = np.where(np.abs(n_arr[:, 0:1]) > 0.9, [[0.0, 1.0, 0.0]], [[1.0, 0.0, 0.0]])
    t = np.cross(n_arr, a)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n_arr, t)
    return (t * local[:, :1] + b * local[:, 1:2] + n_arr * local[:, 2:]).astype(np.float32)


def _time(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _build_rays(name: str, n: int, seed: int = 1, quad_test: str = "simd"):
    """(scene, sd, features, kernels, populations) for the ray benchmarks; `quad_test` "simd" as a
    CPU render tests quads (where the scene has few enough), "groups" by the scalar grouped tests."""
    wp = _setup()
    from dataclasses import replace
    from drtlab.kernels.scene_upload import upload, uses_vector_quads
    from drtlab.kernels.features import features_of
    from drtlab.kernels.scene_model.scene_file import load_scene
    scene = load_scene(name)
    f = replace(features_of(scene, "path"),
                quad_simd=quad_test == "simd" and uses_vector_quads(scene, "cpu"))
    sd = upload(scene, "cpu")
    closest, shadow = _ray_kernels(f)
    rng = np.random.default_rng(seed)
    o, d = _populations(scene, n, rng)
    arrs = {k: wp.array(v, dtype=wp.vec3) for k, v in (("o", o), ("d", d))}
    out = dict(t=wp.zeros(n, dtype=float), kind=wp.zeros(n, dtype=int),
               index=wp.zeros(n, dtype=int), n=wp.zeros(n, dtype=wp.vec3))
    wp.launch(closest, dim=n, inputs=[sd, arrs["o"], arrs["d"], out["t"], out["kind"],
                                      out["index"], out["n"]])
    t = out["t"].numpy()
    hit = t < 1e29
    p = o[hit] + d[hit] * t[hit, None]
    nn = out["n"].numpy()[hit]
    nn = np.where((np.sum(nn * d[hit], axis=1) > 0)[:, None], -nn, nn)
    p = p + nn * (1e-5 + 2e-6 * np.abs(p).max(axis=1, keepdims=True))
    pops = {"camera": (o, d)}
    pops["bounce"] = (p.astype(np.float32), _cosine_dirs(nn, rng))
    emitters = scene.emitter_shapes()
    light = None
    if emitters:
        s = scene.shapes[emitters[0]]
        same_kind = [x for x in scene.shapes if x.kind == s.kind]
        light = (0 if s.kind == "sphere" else 1, next(i for i, x in enumerate(same_kind) if x is s))
        if s.kind == "quad":
            u = rng.random((len(p), 2))
            y = s.origin + s.edge_u * u[:, :1] + s.edge_v * u[:, 1:]
        else:
            v = rng.normal(size=(len(p), 3))
            y = s.center + s.radius * v / np.linalg.norm(v, axis=1, keepdims=True)
        dd = y - p
        dist = np.linalg.norm(dd, axis=1)
        pops["shadow"] = (p.astype(np.float32), (dd / dist[:, None]).astype(np.float32),
                          dist.astype(np.float32))
    return scene, sd, f, (closest, shadow), pops, light


def cmd_rays(args) -> int:
    wp = _setup()
    for name in args.scene:
        scene, sd, f, (closest, shadow), pops, light = _build_rays(name, args.rays,
                                                                   quad_test=args.quad_test)
        for pop, val in pops.items():
            o = wp.array(val[0], dtype=wp.vec3)
            d = wp.array(val[1], dtype=wp.vec3)
            n = len(val[0])
            if pop == "shadow":
                dist = wp.array(val[2], dtype=float)
                res = wp.zeros(n, dtype=int)
                run = lambda: wp.launch(shadow, dim=n, inputs=[sd, o, d, dist, light[0], light[1], res])
            else:
                outs = [wp.zeros(n, dtype=float), wp.zeros(n, dtype=int), wp.zeros(n, dtype=int),
                        wp.zeros(n, dtype=wp.vec3)]
                run = lambda: wp.launch(closest, dim=n, inputs=[sd, o, d, *outs])
            run()
            s = _time(run, args.repeats)
            print(f"{name:14s} {pop:7s} {n:8d} rays  {s * 1e9 / n:7.1f} ns/ray  "
                  f"{n / s / 1e6:6.2f} M rays/s", flush=True)
    return 0


def cmd_check(args) -> int:
    wp = _setup()
    brute = _reference_kernel()
    for name in args.scene:
        scene, sd, f, (closest, shadow), pops, light = _build_rays(name, args.rays,
                                                                   quad_test=args.quad_test)
        quads = [s for s in scene.shapes if s.kind == "quad"]
        t_open = float(scene.camera.shutter[0])
        q = [wp.array(np.array([getattr(s, a) + (s.velocity * t_open if a == "origin" else 0)
                                for s in quads] or np.zeros((1, 3))), dtype=wp.vec3)
             for a in ("origin", "edge_u", "edge_v")]
        for pop in ("camera", "bounce"):
            o, d = (wp.array(x, dtype=wp.vec3) for x in pops[pop][:2])
            n = len(pops[pop][0])
            a = [wp.zeros(n, dtype=float), wp.zeros(n, dtype=int), wp.zeros(n, dtype=int),
                 wp.zeros(n, dtype=wp.vec3)]
            b = [wp.zeros(n, dtype=float), wp.zeros(n, dtype=int), wp.zeros(n, dtype=int)]
            wp.launch(closest, dim=n, inputs=[sd, o, d, *a])
            wp.launch(brute, dim=n, inputs=[sd, *q, len(quads), o, d, *b])
            ta, ka, ia = (x.numpy() for x in a[:3])
            tb, kb, ib = (x.numpy() for x in b)
            differ = (ka != kb) | (ia != ib)
            both = ~differ & (ia >= 0)
            rel = np.abs(ta[both] - tb[both]) / np.maximum(tb[both], 1e-30)
            # A different shape at (nearly) the same distance is a tie at a shared edge, not an error.
            tie = differ & (np.abs(ta - tb) <= 1e-5 * np.maximum(tb, 1e-30))
            absd = np.abs(ta[both] - tb[both])
            print(f"{name:14s} {pop:7s} {n} rays: {differ.sum()} hit another shape "
                  f"({tie.sum()} of them edge ties at equal distance), "
                  f"max rel t difference {rel.max() if rel.size else 0:.2e}, "
                  f"max abs {absd.max() if absd.size else 0:.2e}", flush=True)
    return 0


def cmd_render(args) -> int:
    _setup()
    from drtlab.kernels.render import render_with_stats
    for name in args.scene:
        render_with_stats(name, spp=1, sampler=args.sampler, res=args.res, threads=args.threads,
                          progress=False, integrator=args.integrator)
        best = None
        for rep in range(args.repeats):
            st = render_with_stats(name, spp=args.spp, sampler=args.sampler, res=args.res,
                                   threads=args.threads, seed=rep, progress=False,
                                   integrator=args.integrator, tile=args.tile)
            best = st if best is None or st.render_seconds < best.render_seconds else best
        print(f"{name:14s} {best.width}x{best.height} {args.spp:5d} spp {args.sampler:22s} "
              f"{best.threads} thr  {best.render_seconds:7.3f} s  "
              f"{best.samples_per_second / 1e6:6.3f} M samples/s", flush=True)
    return 0


def cmd_components(args) -> int:
    """Where a render's time goes, per sample: each probe of features.REPEATS compiled into its own
    variant, the variants taking turns in each of --repeats rounds (best round each, wall seconds
    at --threads), a part's cost the probe variant's time less the plain one's."""
    _setup()
    from drtlab.kernels.features import REPEATS
    from drtlab.kernels.render import render_with_stats
    variants = {"plain": (), **{r.removeprefix("repeat_"): (r,) for r in REPEATS}}
    for name in args.scene:
        kw = dict(sampler=args.sampler, res=args.res, threads=args.threads, progress=False,
                  integrator=args.integrator, tile=args.tile)
        for faults in variants.values():
            render_with_stats(name, spp=1, faults=faults, **kw)     # compiles, not timed
        best = dict.fromkeys(variants, float("inf"))
        for _ in range(args.repeats):
            for part, faults in variants.items():
                st = render_with_stats(name, spp=args.spp, faults=faults, **kw)
                best[part] = min(best[part], st.render_seconds)
        samples = st.width * st.height * args.spp
        plain = best["plain"] * 1e9 / samples
        print(f"{name}: {st.width}x{st.height}, {args.spp} spp, {args.sampler}, {st.threads} thread(s), "
              f"best of {args.repeats}: {plain:.0f} ns/sample")
        for part in variants:
            if part != "plain":
                ns = best[part] * 1e9 / samples - plain
                print(f"  {part:14s} {ns:7.1f} ns/sample  {100 * ns / plain:5.1f}%", flush=True)
    return 0


def cmd_compile(args) -> int:
    import tempfile
    import warp as wp
    wp.config.kernel_cache_dir = tempfile.mkdtemp(prefix="drtlab-compile-cache-")
    _setup()
    from drtlab.experiments.study.config import load_experiment
    from drtlab.experiments.study.ground_truth import GT_SAMPLER
    from drtlab.kernels.render import render_with_stats
    exp = load_experiment(args.experiment, profile=args.profile)
    jobs = {}
    for study in exp.studies:
        for ref in study.scenes:
            for sampler in (*study.samplers, GT_SAMPLER):
                jobs[(ref.name, sampler, study.integrator)] = dict(ref.overrides)
    from drtlab.kernels.scene_model.scene_file import load_scene
    if args.threads > 1:
        from drtlab.kernels.render import compile_variants
        c0 = time.process_time()
        facts = compile_variants([(load_scene(scene, ov or None), sampler, integ)
                                  for (scene, sampler, integ), ov in jobs.items()], threads=args.threads)
        print(f"total cold compile {facts['wall_seconds']:.1f} s wall on {facts['threads']} threads "
              f"({facts['compile_seconds']:.1f} s of compiles, {time.process_time() - c0:.1f} s CPU) "
              f"over {len(jobs)} (scene, sampler) pairs, {facts['compiled']} compiles")
        return 0
    total, total_cpu, first, compiles = 0.0, 0.0, None, 0
    for (scene, sampler, integ), overrides in jobs.items():
        c0 = time.process_time()
        st = render_with_stats(load_scene(scene, overrides or None), spp=1, sampler=sampler,
                               integrator=integ, res=(8, 6), threads=1, progress=False)
        cpu = time.process_time() - c0 if st.compile_seconds > 0 else 0.0
        total += st.compile_seconds
        total_cpu += cpu
        first = st.compile_seconds if first is None else first
        if st.compile_seconds > 0.2:
            compiles += 1
            print(f"{scene:14s} {sampler:24s} {st.variant[:48]:48s} {st.compile_seconds:6.2f} s "
                  f"({cpu:5.2f} s CPU)", flush=True)
    print(f"total cold compile {total:.1f} s ({total_cpu:.1f} s CPU) over {len(jobs)} (scene, "
          f"sampler) pairs, {compiles} compiles (the first, {first:.1f} s, includes Warp's "
          f"precompiled header)")
    return 0


IMAGE_SAMPLERS = ("uniform", "stratified", "importance", "stratified+importance")


def cmd_images(args) -> int:
    _setup()
    from drtlab.kernels.render import render
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
    images = {}
    for name in builtin_names():
        integrators = sorted({load_scene(name).integrator, "path", "drt", "whitted"})
        for integ in integrators:
            for sampler in (IMAGE_SAMPLERS if integ != "whitted" else ("uniform",)):
                images[f"{name}/{integ}/{sampler}"] = render(
                    name, spp=args.spp, sampler=sampler, integrator=integ, res=(32, 24),
                    threads=args.threads, progress=False, seed=7)
    if args.save:
        np.savez_compressed(args.save, **images)
        print(f"saved {len(images)} images to {args.save}")
        return 0
    ref = np.load(args.compare)
    identical = 0
    for key, img in images.items():
        old = ref[key]
        if np.array_equal(old, img):
            identical += 1
            continue
        diff = np.abs(old - img)
        print(f"{key:45s} differs: {np.mean(diff > 0):.4f} of values, max |diff| / mean "
              f"{diff.max() / max(np.mean(np.abs(old)), 1e-30):.2e}, mean diff / mean "
              f"{(np.mean(img) - np.mean(old)) / max(np.mean(np.abs(old)), 1e-30):+.2e}")
    print(f"{identical} of {len(images)} images bit-identical")
    return 0


def _parser():
    from drtlab.cli_args import Parser, int_flag
    ap = Parser(prog="python -m drtlab.experiments.bench.profile_kernels")
    ap.add_argument("mode", choices=("rays", "render", "check", "compile", "images", "pointsets",
                                    "components"))
    ap.add_argument("--save", default=None)
    ap.add_argument("--compare", default=None)
    ap.add_argument("--experiment", default="stratified")
    ap.add_argument("--profile", default="quick")
    ap.add_argument("--scene", nargs="+", default=["cornell-box"])
    ap.add_argument("--rays", type=int_flag(1, 1 << 28), default=200_000)
    ap.add_argument("--res", type=int_flag(1, 1 << 14), default=64)
    ap.add_argument("--spp", type=int_flag(1, 1 << 20), default=64)
    ap.add_argument("--sampler", default=DEFAULT_SAMPLER)
    ap.add_argument("--integrator", default=None)
    ap.add_argument("--threads", type=int_flag(1, 1024), default=1)
    ap.add_argument("--tile", type=int_flag(1, 1 << 16), default=None)
    ap.add_argument("--sets", nargs="+", default=None)
    ap.add_argument("--write", action="store_true",
                    help="pointsets: store the ratios for `drtlab samplers` (estimators/draw_costs.py)")
    ap.add_argument("--pixels", type=int_flag(1, 1 << 24), default=4096)
    ap.add_argument("--repeats", type=int_flag(1, 1000), default=5)
    ap.add_argument("--quad-test", choices=("simd", "groups"), default="simd",
                    help="rays, check: quads by the CPU's vector test or the scalar grouped tests")
    commands = {"rays": cmd_rays, "render": cmd_render, "check": cmd_check, "compile": cmd_compile,
                "images": cmd_images, "pointsets": draw_cost.cmd_pointsets, "components": cmd_components}
    ap.set_defaults(func=lambda args: commands[args.mode](args))
    return ap


def main(argv: list[str] | None = None) -> int:
    from drtlab.cli_args import run_main
    return run_main(_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
