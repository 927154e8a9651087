"""What a render uses when it is told nothing, in a module without Warp: the command line builds its
parser from these before any kernel code is imported."""

# The sampler of every render that names none (drtlab.render, `drtlab render`, `make bench`): the
# lowest-variance preview, MIS over jittered strata.
DEFAULT_SAMPLER = "stratified+importance"
# A point set named alone takes this strategy, as the preset `stratified` does: `sobol` and
# `stratified` then differ in their points only.
POINTSET_STRATEGY = "uniform"
