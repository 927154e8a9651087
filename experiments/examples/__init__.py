"""Runnable examples of the Python API (a study defined as a dict, run, plotted). Import the public
`drtlab` API and the leaf modules a user's script would (drtlab.cli_args, experiments.paths) only."""
