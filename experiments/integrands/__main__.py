"""`python -m drtlab.experiments.integrands`: runs drtlab.experiments.integrands.study.main."""
from drtlab.experiments.integrands.study import main

raise SystemExit(main())
