"""`drtlab check NAME`: the scorecard of a registered point set (`pointset.py`) or light selection
(`light_selection.py`), a built-in's or a plugin's, one line per check (`scorecard.py`)."""
