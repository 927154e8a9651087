"""`python -m drtlab.experiments.bench`: runs drtlab.experiments.bench.scenes.main."""
from drtlab.experiments.bench.scenes import main

raise SystemExit(main())
