"""Runnable examples of the Python API (a study defined as a dict, run, plotted). Import only the
public `drtlab` API, as a user's code would."""
