"""What a BSDF's `sample` returns (the one interface of kernels/materials/__init__.py): one scattered
direction and its weight. A kind's model module (or a lobe sampler) builds it with one of two
functions: `delta_scatter(wi, weight)` for a delta lobe (its weight is the lobe's, no density), or
`proposal(wi)` for a direction drawn with the density its `pdf` gives, which the composed BSDF
(bsdf.py) weighs by eval / pdf."""
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


@wp.func
def proposal(wi: wp.vec3) -> Scatter:
    """A direction drawn with the sampler's density (`pdf`): the composed BSDF fills its pdf and
    weight, and drops it where either eval or pdf is 0 (a zero vector is such a direction)."""
    s = Scatter()
    s.wi = wi
    s.delta = 0
    s.valid = 1
    return s
