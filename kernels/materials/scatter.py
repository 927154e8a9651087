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
