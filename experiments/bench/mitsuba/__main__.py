"""`python -m drtlab.experiments.bench.mitsuba`: runs drtlab.experiments.bench.mitsuba.compare.main."""
from drtlab.experiments.bench.mitsuba.compare import main

raise SystemExit(main())
