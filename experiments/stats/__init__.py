"""Statistics shared by every measurement: intervals, hypothesis-test helpers, running moments, emcee
slope fits, the chi-square harness (chi2/). Imports nothing of experiments/ but its leaf modules."""
