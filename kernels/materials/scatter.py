"""What sample_bsdf returns: one scattered direction and its weight (bsdf.py composes it; a delta
kind's module returns it from sample_delta)."""
import warp as wp


@wp.struct
class Scatter:
    wi: wp.vec3
    weight: wp.vec3     # f * |cos| / pdf, or the delta lobe's weight
    pdf: float          # solid-angle pdf; 0 for delta lobes
    delta: int
    valid: int


@wp.func
def delta_scatter(wi: wp.vec3, weight: wp.vec3) -> Scatter:
    """A delta lobe's scatter: its one direction and weight."""
    s = Scatter()
    s.wi = wi
    s.weight = weight
    s.delta = 1
    s.valid = 1
    return s
