"""Two wrappers around any kind's BSDF, read from the material at the hit (`MaterialAt.opacity`,
`MaterialAt.one_sided`), compiled only into variants of scenes that have them (Features.masks,
Features.one_sided):

* Mitsuba 3's `mask` (src/bsdfs/mask.cpp): with probability `opacity` a hit scatters by the
  material's kind, else the ray passes straight on with weight 1, a delta event (Mitsuba's Null
  component, which its Delta flag includes, so an emitter seen through it counts at full weight):
      eval = opacity x f|cos|,  pdf = opacity x p,
      sample: u_lobe < opacity -> the kind's sample with u_lobe / opacity, its pdf x opacity (its
              weight unchanged); else wi = -wo, weight 1.
  The path integrators count the pass-through as a bounce (Mitsuba's path.cpp increments the
  depth), and shadow rays see the surface as opaque (Mitsuba's ray_test): neither needs code here.
* One-sided: Mitsuba's diffuse, conductors and plastics outside `twosided` are black from behind:
  eval and pdf 0 unless wo and wi both lie on the shading normal's side, no sample from behind.

The mask is outside the side test, as in Mitsuba's mask around a bare diffuse: from behind, the
share 1 - opacity still passes through.
"""
import warp as wp

from drtlab.kernels.features import MASK_DIVIDES_BY_CHOICE
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.materials.scatter import Scatter, delta_scatter
from drtlab.kernels.static_tag import variant_tag


def wrap(eval_bsdf, pdf_bsdf, sample_bsdf, masks: bool, one_sided: bool, tag,
         faults: frozenset = frozenset()) -> tuple:
    """(eval, pdf, sample) of the kinds' composed BSDF with the wrappers the variant has; `tag`
    names the composed functions for the kernel cache (static_tag.py); `faults` a test's negative
    control (features.MASK_FAULTS)."""
    MASKS, ONE_SIDED = masks, one_sided
    DIVIDES = MASK_DIVIDES_BY_CHOICE in faults
    TAG = (tag, MASKS, ONE_SIDED, DIVIDES)

    @wp.func
    def front(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        # 1 where the material is two-sided or both directions lie in front of it
        if wp.static(ONE_SIDED):
            if mat.one_sided != 0:
                if wp.dot(n, wo) <= 0.0 or wp.dot(n, wi) <= 0.0:
                    return 0.0
        return 1.0

    @wp.func
    def opacity(mat: MaterialAt) -> float:
        if wp.static(MASKS):
            return mat.opacity
        return 1.0

    @wp.func
    def eval_wrapped(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> wp.vec3:
        _variant = wp.static(variant_tag(TAG))  # noqa: F841 (static_tag.py)
        return eval_bsdf(mat, n, wo, wi) * (opacity(mat) * front(mat, n, wo, wi))

    @wp.func
    def pdf_wrapped(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
        _variant = wp.static(variant_tag(TAG))  # noqa: F841 (static_tag.py)
        return pdf_bsdf(mat, n, wo, wi) * (opacity(mat) * front(mat, n, wo, wi))

    @wp.func
    def sample_wrapped(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, u_lobe: float, u: wp.vec2) -> Scatter:
        _variant = wp.static(variant_tag(TAG))  # noqa: F841 (static_tag.py)
        a = opacity(mat)
        ul = u_lobe
        if wp.static(MASKS):
            if u_lobe >= a:
                if wp.static(DIVIDES):
                    return delta_scatter(-wo, wp.vec3(1.0 / (1.0 - a)))
                return delta_scatter(-wo, wp.vec3(1.0))
            ul = u_lobe / a
        s = Scatter()
        s.valid = 0
        s.delta = 0
        if wp.static(ONE_SIDED):
            if mat.one_sided != 0 and wp.dot(n, wo) <= 0.0:
                return s
        s = sample_bsdf(mat, n, wo, ul, u)
        if s.valid == 1:
            if front(mat, n, wo, s.wi) == 0.0:
                s.valid = 0
            elif s.delta == 0:
                s.pdf = s.pdf * a
        return s

    return eval_wrapped, pdf_wrapped, sample_wrapped
