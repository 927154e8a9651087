"""drtlab against Mitsuba 3 (`make bench-compare`; `python -m drtlab.experiments.bench.mitsuba`): the
scene translation, renders, matched sampler pairs, statistics and report. May import stats/ and bench/."""
