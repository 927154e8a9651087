"""Speed: `make bench` (per-scene table, scaling; `python -m drtlab.experiments.bench`), primitive-count
scaling, kernel microbenchmarks, and the Mitsuba 3 comparison (mitsuba/). May import study/ and stats/."""
