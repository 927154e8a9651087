"""Multiple importance sampling weights (Veach 1995, ch. 9): w(p_this, p_other), the weight of a sample
drawn by one technique of density p_this where the other would have drawn it with p_other. A
strategy names its heuristic (`LightSampling.heuristic`); both techniques use the same one, and
w(a, b) + w(b, a) = 1 wherever either density is positive, so the combination stays unbiased.

    power    a^2 / (a^2 + b^2): Veach's recommendation (exponent 2), the built-in strategies' choice
    balance  a / (a + b): provably within a factor of the best combination's variance; a study can
             set one against the other (`drtlab.register_strategy(..., heuristic="balance")`)

The fault features.MIS_SWAPPED (a test's negative control, compiled into that variant only) gives
each technique the other's weight, w(b, a): the weights still sum to 1 and the image stays unbiased,
but each technique keeps its samples where it is the worse one, and the variance grows by orders of
magnitude (tests/kernels/test_mis_variance.py).
"""
import warp as wp

from drtlab.kernels.features import MIS_SWAPPED


@wp.func
def power_heuristic(a: float, b: float) -> float:
    return a * a / (a * a + b * b)


@wp.func
def balance_heuristic(a: float, b: float) -> float:
    return a / (a + b)


HEURISTICS = {"power": power_heuristic, "balance": balance_heuristic}


def swapped(weight: wp.Function) -> wp.Function:
    """`weight` with its techniques exchanged: w(b, a) for w(a, b) (MIS_SWAPPED)."""
    @wp.func
    def other_weight(a: float, b: float) -> float:
        return weight(b, a)
    return other_weight


def heuristic_of(strategy, faults=frozenset()) -> wp.Function:
    """The weight function of a strategy that combines by MIS (power where it names none); with the
    fault MIS_SWAPPED among `faults`, its swapped twin."""
    weight = HEURISTICS[strategy.light.heuristic if strategy.light is not None else "power"]
    return swapped(weight) if MIS_SWAPPED in faults else weight
