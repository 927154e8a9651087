"""Measuring: variance studies, statistics, benchmarks, point-set analysis, the integrand testbed.

Subpackages (one kind of thing each) and the leaf modules here (paths, seeds, files, parallel, plotting)
that any of them may import; they import kernels/, estimators/ and drtlab's leaf modules (errors, fields,
warp_runtime, cli_args, __version__), never drtlab's commands; examples/ uses the public API as a user would."""
