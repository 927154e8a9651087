"""Hashes of renders that a change which should not alter images must leave alone: run it before
and after, and diff the two files.

    python -m drtlab.experiments.bench.image_hashes [--out FILE]

One line per render, `LABEL sha256-prefix` (a kind's label starts `kind:`): every built-in scene
under its own integrator with four samplers and under whitted (48x36, 4 spp, seed 3); then every
material kind that scatters, put in place of glossy-ggx's ggx material, under drt and path with two
samplers and under whitted (24x18, 4 spp, seed 5). A render that fails prints its error in place of
the hash. The images are bit-identical across thread counts and tiles, so the hashes are too."""
from __future__ import annotations

import argparse
import hashlib
import sys

import numpy as np

SAMPLERS = ("independent+uniform", "stratified", "stratified+importance", "sobol+importance")
KIND_SAMPLERS = ("independent+uniform", "stratified+importance")


def _hash(img) -> str:
    return hashlib.sha256(np.ascontiguousarray(img).tobytes()).hexdigest()[:16]


def _renders():
    """(label, a function rendering it) of every render the file hashes."""
    from drtlab.kernels.render import render
    from drtlab.kernels.scene_model.material_kinds import KINDS
    from drtlab.kernels.scene_model.scene_file import builtin_names, load_scene
    for name in builtin_names():
        for s in SAMPLERS:
            yield f"{name} {s}", lambda name=name, s=s: render(name, spp=4, seed=3, sampler=s, res=(48, 36))
        yield f"{name} whitted", lambda name=name: render(name, spp=4, seed=3, integrator="whitted",
                                                                 res=(48, 36))

    def as_kind(kind, integrator):
        scene = load_scene("glossy-ggx", {"scene.resolution": [24, 18], "scene.integrator": integrator})
        for m in scene.materials:
            if m.kind == "ggx":
                m.kind = kind
        return scene
    for k in KINDS:
        if k.emitter:
            continue
        for integrator in ("drt", "path"):
            for s in KIND_SAMPLERS:
                yield (f"kind:{k.name} {integrator} {s}",
                       lambda k=k, i=integrator, s=s: render(as_kind(k.name, i), spp=4, sampler=s, seed=5))
        yield f"kind:{k.name} whitted", lambda k=k: render(as_kind(k.name, "whitted"), spp=4, seed=5)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m drtlab.experiments.bench.image_hashes",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", help="write the lines here (default: standard output)")
    args = ap.parse_args(argv)
    out = open(args.out, "w") if args.out else sys.stdout
    try:
        for label, render in _renders():
            try:
                line = f"{label} {_hash(render())}"
            except Exception as e:      # a failing render is a line of the diff, not the end of it
                line = f"{label} ERR {type(e).__name__}: {str(e)[:100]}"
            print(line, file=out, flush=True)
    finally:
        if out is not sys.stdout:
            out.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
