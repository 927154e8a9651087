"""Multiple importance sampling weights (Veach 1995, ch. 9): w(p_this, p_other), the weight of a sample
drawn by one technique of density p_this where the other would have drawn it with p_other. A
strategy names its heuristic (`LightSampling.heuristic`); both techniques use the same one, and
w(a, b) + w(b, a) = 1 wherever either density is positive, so the combination stays unbiased.

    power    a^2 / (a^2 + b^2): Veach's recommendation (exponent 2), the built-in strategies' choice
    balance  a / (a + b): provably within a factor of the best combination's variance; a study can
             set one against the other (`drtlab.register_strategy(..., heuristic="balance")`)
"""
import warp as wp


@wp.func
def power_heuristic(a: float, b: float) -> float:
    return a * a / (a * a + b * b)


@wp.func
def balance_heuristic(a: float, b: float) -> float:
    return a / (a + b)


HEURISTICS = {"power": power_heuristic, "balance": balance_heuristic}


def heuristic_of(strategy) -> wp.Function:
    """The weight function of a strategy that combines by MIS (power where it names none)."""
    return HEURISTICS[strategy.light.heuristic if strategy.light is not None else "power"]
