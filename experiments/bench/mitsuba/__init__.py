"""drtlab against Mitsuba 3 (`make bench-compare`; `python -m drtlab.experiments.bench.mitsuba`): the
scene translation, renders, matched sampler pairs, statistics and report. May import stats/ and
study/manifest (the machine and package versions a result records)."""
