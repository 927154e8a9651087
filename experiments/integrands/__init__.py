"""The analytic integrand testbed (`make experiment-integrands`; `python -m drtlab.experiments.integrands`):
2D integrands with exact integrals, the study and its report. May import stats/ and study/ (metrics,
manifest)."""
