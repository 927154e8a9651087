"""Where a scene's variance comes from: the Sobol' decomposition of its samples over the sample
dimension groups (`decompose.py`), and its table, JSON and figure (`report.py`)."""
