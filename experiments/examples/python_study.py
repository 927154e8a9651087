"""A study defined in Python, run, reopened and redrawn: the notebook workflow in one file.

    python -m drtlab.experiments.examples.python_study [--out DIR]

Defines an experiment as a dict (the same keys as an experiment TOML file, see
experiments/README.md), runs it through `drtlab.run_experiment`, prints the tidy tables the result
carries (cells, slopes, each sampler against the baseline), then reopens the finished folder with
`drtlab.open_results` and redraws the error-vs-samples figure from it alone.
"""
from __future__ import annotations

import sys
from pathlib import Path

import drtlab
from drtlab.cli_args import Help, Parser, run_main
from drtlab.experiments.paths import results_root

STUDY = {
    "experiment": {
        "description": "Does stratification help the soft shadow as much as the edges?",
        "seed": 7,
        "integrator": "drt",
        "spp": [1, 4, 16],
        "repetitions": 3,
        "resolution": [24, 18],
        "gt_spp": 1024,
        "gt_batch_spp": 256,
    },
    "study": [{
        "name": "stratification",
        "scenes": ["aa-edges", "soft-shadows"],
        "samplers": ["uniform", "stratified"],
        "baseline": "uniform",
    }],
}


def build_parser() -> Parser:
    parser = Parser(prog="python -m drtlab.experiments.examples.python_study", formatter_class=Help,
                    description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=results_root() / "example-python-study",
                        help="output folder (its ground truth goes in OUT/ground-truth)")
    parser.set_defaults(func=_command)
    return parser


def main(argv: list[str] | None = None) -> int:
    return run_main(build_parser, argv)


def _command(args) -> int:
    # allow_other_files: the folder also holds this script's own figure (below), which drtlab
    # then leaves alone (without it a rerun would refuse a folder holding files it did not write).
    result = drtlab.run_experiment(STUDY, name="example-python-study", out_dir=args.out,
                                   gt_root=args.out / "ground-truth", progress=False,
                                   allow_other_files=True)
    cells = result.cells
    print(cells[["scene", "sampler", "spp", "error", "error_lo", "error_hi"]].to_string(index=False))
    print(result.slopes[["scene", "sampler", "slope", "slope_lo", "slope_hi"]].to_string(index=False))
    print(result.comparisons[["scene", "sampler", "spp", "speedup", "speedup_lo", "speedup_hi",
                              "claim"]].to_string(index=False))
    # What a later session does with a finished folder: read it back, render and analyse nothing.
    done = drtlab.open_results(args.out)
    figure = done.plot_convergence("stratification")
    figure.savefig(args.out / "redrawn-convergence.png")
    print(f"{len(done.runs)} runs; figure redrawn to {args.out / 'redrawn-convergence.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
