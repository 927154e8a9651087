"""The interval audit: simulated studies with a known truth through the study's own analysis."""
