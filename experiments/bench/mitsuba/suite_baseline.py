"""What Mitsuba 3's own renders of its test scenes give against its reference images: the block L1
that `make crosscheck-suite` holds drtlab's renders to (suite.py). Mitsuba renders each scene of the
suite as the file says (its own integrator, `scalar_rgb`: the LLVM variants' JIT fails on this
machine's CPUs) at each spp of SPPS with SEEDS independent seeds; the mean of those L1s is the
scene's baseline at that spp. Written to suite.BASELINE (committed: the suite's check runs where Mitsuba is
not installed). Regenerate with the `compare` extra installed (Mitsuba 3.9.1):

    python -m drtlab.experiments.bench.mitsuba.suite_baseline
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from drtlab.cli_args import Help, Parser, run_main
from drtlab.experiments.bench.mitsuba.crosscheck_stats import block_l1
from drtlab.experiments.bench.mitsuba.suite import BASELINE, BLOCK, scenes, suite_dir
from drtlab.experiments.files import atomic_write_text

SPPS = (32, 256)
SEEDS = (0, 1, 2, 3)
VARIANT = "scalar_rgb"


def mitsuba_l1(mi, job: dict, spp: int, seeds=SEEDS) -> list[float]:
    """The block L1 (over the reference's mean) of Mitsuba's spp-sample render of `job`, per seed."""
    ref = np.array(mi.Bitmap(str(job["ref"])))[..., :3].astype(np.float64)
    scene = mi.load_file(str(job["file"]), spp=spp)
    return [block_l1(np.array(mi.render(scene, spp=spp, seed=s))[..., :3].astype(np.float64), ref, BLOCK)
            / float(ref.mean()) for s in seeds]


def build_parser() -> Parser:
    p = Parser(prog="python -m drtlab.experiments.bench.mitsuba.suite_baseline", formatter_class=Help,
               description="Render Mitsuba 3's test scenes with Mitsuba itself and store the block "
                           "L1 of its renders against its references (the crosscheck-suite baseline).")
    p.add_argument("--suite-dir", type=Path, default=None, help="the suite's folder (default: "
                   "$DRTLAB_MITSUBA_TESTS or ../shared/mitsuba-tests beside the checkout)")
    p.add_argument("--out", type=Path, default=BASELINE, help="the JSON file written")
    p.set_defaults(func=_command)
    return p


def _command(args) -> int:
    try:
        import mitsuba as mi
    except ImportError:
        print("suite_baseline: Mitsuba 3 is not installed (pip install -e '.[compare]')", file=sys.stderr)
        return 2
    root = args.suite_dir or suite_dir()
    if not (root / "tests" / "scenes").is_dir():
        print(f"suite_baseline: no Mitsuba test suite at {root}", file=sys.stderr)
        return 2
    mi.set_variant(VARIANT)
    l1 = {str(spp): {} for spp in SPPS}
    for job in scenes(root):
        for spp in SPPS:
            l1[str(spp)][job["name"]] = [round(x, 7) for x in mitsuba_l1(mi, job, spp)]
            print(f"suite_baseline: {job['name']} {spp} spp: {np.mean(l1[str(spp)][job['name']]):.5f}",
                  file=sys.stderr)
    data = {"mitsuba": mi.__version__, "variant": VARIANT, "seeds": list(SEEDS),
            "command": "python -m drtlab.experiments.bench.mitsuba.suite_baseline", "l1": l1}
    atomic_write_text(args.out, json.dumps(data, indent=1) + "\n")
    return 0


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


if __name__ == "__main__":
    sys.exit(main())
