"""Warp adapters of the chi-square harness: samplers and claimed densities of the project's Warp
functions (estimators/domain_maps.py, kernels/materials/bsdf.py `make_bsdf`) in CPU kernels built by
factories, and the helpers the other adapters share (lights: light_adapter.py; see the package
docstring, drtlab.experiments.stats.chi2)."""

from dataclasses import dataclass

import numpy as np
import warp as wp

from drtlab.estimators.hashing import hash_key, unit_float
from drtlab.estimators.strategies import LightSampling, Strategy
from drtlab.experiments.stats.chi2.harness import PdfFunc, SampleFunc
from drtlab.kernels.features import Features
from drtlab.kernels.scene_model.material_kinds import MATERIAL_CODE, MATERIAL_KINDS
from drtlab.warp_runtime import warp as _wp


@wp.func
def uniform(seed: wp.uint32, thread: wp.uint32, dim: int) -> float:
    """The harness's random number `dim` of sample `thread`: unit_float(hash_key(seed, thread, dim,
    0)). The dimension goes in hash_key's `index` slot, which two mixing rounds follow; in its own
    `dim` slot, which only one round follows, consecutive dimensions are not jointly uniform (see
    tests/estimators/test_pointset_uniformity.py), and that would be blamed on the warps under test."""
    return unit_float(hash_key(seed, thread, wp.uint32(dim), wp.uint32(0)))


def _vec3_array(pts: np.ndarray):
    wp = _wp()
    a = np.ascontiguousarray(np.asarray(pts, dtype=np.float32).reshape(-1, 3))
    return wp.array(a, dtype=wp.vec3, device="cpu")


def as_vec3(v):
    wp = _wp()
    v = np.asarray(v, dtype=np.float64).reshape(3)
    return wp.vec3(float(v[0]), float(v[1]), float(v[2]))


def input_points(pts, n: int):
    """(points, launch size): the given points and their count (evaluation), or a one-point
    placeholder and n (sampling, pts None)."""
    wp = _wp()
    if pts is None:
        return wp.zeros(1, dtype=wp.vec3, device="cpu"), int(n)
    inp = _vec3_array(pts)
    return inp, int(inp.shape[0])


def outputs(n: int, *dtypes) -> list:
    """Zeroed CPU output arrays of length n, one per dtype."""
    wp = _wp()
    return [wp.zeros(n, dtype=d, device="cpu") for d in dtypes]


# Which warp `WarpsAdapter` runs (a runtime switch of one kernel).
UNIFORM_HEMISPHERE, UNIFORM_SPHERE, COSINE_HEMISPHERE, PHONG, CONE, DISK, SQUARE = range(7)


class WarpsAdapter:
    """estimators/domain_maps.py in the local z-up frame: `sampler(which, param)` and `pdf(which, param)`.

    param: the Phong exponent, or 1 - cos(theta_max) of the cone. The disk's points are returned as
    (x, y) in [-1, 1]^2 and its claimed density is 1/pi inside the unit disk (the concentric map is
    area-preserving; domain_maps.py has no disk pdf). SQUARE returns the random input (u0, u1) itself, to
    test the harness's generator. The cone's support is t <= 1 - cos(theta_max), t
    computed from the perpendicular components (see CapDomain) so tiny cones keep their edge."""

    _kernel = None

    @classmethod
    def kernel(cls):
        if cls._kernel is None:
            cls._kernel = _make_warps_kernel()
        return cls._kernel

    @classmethod
    def launch(cls, mode: int, which: int, param: float, n: int, seed: int = 0, pts=None):
        wp = _wp()
        k = cls.kernel()
        inp, n = input_points(pts, n)
        out_v = wp.zeros(n if mode == 0 else 1, dtype=wp.vec3, device="cpu")
        out_p = wp.zeros(n, dtype=float, device="cpu")
        wp.launch(k, dim=n, device="cpu", inputs=[int(mode), int(which), float(param),
                                                  wp.uint32(seed), inp, out_v, out_p])
        return out_v.numpy(), out_p.numpy()

    @classmethod
    def sampler(cls, which: int, param: float = 0.0) -> SampleFunc:
        def sample(n, seed):
            v, _ = cls.launch(0, which, param, n, seed)
            return v[:, :2] if which in (DISK, SQUARE) else v
        return sample

    @classmethod
    def pdf(cls, which: int, param: float = 0.0) -> PdfFunc:
        def pdf(pts):
            pts = np.asarray(pts, dtype=np.float64)
            if which in (DISK, SQUARE):
                pts = np.concatenate([pts[:, :2], np.zeros((pts.shape[0], 1))], axis=1)
            return cls.launch(1, which, param, 0, 0, pts)[1].astype(np.float64)
        return pdf


def _make_warps_kernel():
    wp = _wp()
    from drtlab.estimators import domain_maps as W

    @wp.func
    def cap_t(v: wp.vec3) -> float:
        s2 = (v[0] * v[0] + v[1] * v[1]) / wp.dot(v, v)
        if v[2] > 0.0:
            return s2 / (1.0 + wp.sqrt(wp.max(0.0, 1.0 - s2)))
        return 1.0 - v[2] / wp.length(v)

    @wp.kernel(enable_backward=False, module="unique")
    def warps_kernel(mode: int, which: int, param: float, seed: wp.uint32,
                     pts: wp.array(dtype=wp.vec3), out_v: wp.array(dtype=wp.vec3),
                     out_p: wp.array(dtype=float)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            u = wp.vec2(uniform(seed, i, 0), uniform(seed, i, 1))
            v = wp.vec3(0.0)
            if which == 0:
                v = W.square_to_uniform_hemisphere(u)
            elif which == 1:
                v = W.square_to_uniform_sphere(u)
            elif which == 2:
                v = W.square_to_cosine_hemisphere(u)
            elif which == 3:
                v = W.square_to_phong_lobe(u, param)
            elif which == 4:
                v = W.square_to_cone(u, param)
            elif which == 5:
                d = W.square_to_disk(u)
                v = wp.vec3(d[0], d[1], 0.0)
            else:
                v = wp.vec3(u[0], u[1], 0.0)
            out_v[tid] = v
        else:
            v = pts[tid]
            p = float(0.0)
            if which == 0:
                p = W.uniform_hemisphere_pdf(v[2])
            elif which == 1:
                p = W.INV_4PI
            elif which == 2:
                p = W.cosine_hemisphere_pdf(v[2])
            elif which == 3:
                p = W.phong_lobe_pdf(v[2], param)
            elif which == 4:
                if cap_t(v) <= param:
                    p = W.cone_pdf(param)
            elif which == 5:
                if v[0] * v[0] + v[1] * v[1] <= 1.0:
                    p = W.INV_PI
            else:
                if v[0] >= 0.0 and v[0] < 1.0 and v[1] >= 0.0 and v[1] < 1.0:
                    p = 1.0
            out_p[tid] = p

    return warps_kernel


# The kernels' integer material kind of each kind name (one definition: kernels/scene_model/material_kinds.py).
KIND_INDEX = MATERIAL_CODE
ALL_KINDS = frozenset(MATERIAL_KINDS)


def routine_variant(lobe: bool = True, solid_angle: bool = False, power_pick=False,
                    meshes: bool = False, faults: frozenset = frozenset(),
                    microfacet: str = "vndf", lobes: tuple = (), masks: bool = False) -> tuple:
    """(features, strategy) to build one sampling routine from, as the kernel factories take them:
    every material kind, spheres and quads (and meshes), the given strategy (with registered lobe
    samplers `lobes`) and faults; `masks`: with opacity and one-sidedness (kernels/materials/mask.py)."""
    features = Features(integrator="path", lens=False, motion=False, spheres=True, quads=True,
                        kinds=ALL_KINDS, checker=False, area_lights=True, point_lights=False,
                        dir_lights=False, roulette=False, background=False,
                        faults=frozenset(faults), meshes=meshes, masks=masks, one_sided=masks)
    pick = power_pick if isinstance(power_pick, str) else ("power" if power_pick else "uniform")
    light = LightSampling("solid_angle" if solid_angle else "area", pick)
    return features, Strategy("chi2", "a chi-square adapter's routine",
                              "lobe" if lobe else "uniform", light, microfacet=microfacet, lobes=tuple(lobes))


@dataclass
class BSDFSamples:
    wi: np.ndarray          # (n, 3)
    pdf: np.ndarray         # the pdf the sample carries
    weight: np.ndarray      # (n, 3)
    valid: np.ndarray       # bool
    delta: np.ndarray       # bool
    pdf_eval: np.ndarray    # pdf_bsdf(wi) evaluated separately (valid non-delta samples)
    f_eval: np.ndarray      # eval_bsdf(wi) = f|cos| evaluated separately


class BSDFAdapter:
    """`make_bsdf` of ALL_KINDS wrapped in one kernel per `lobe` (mode 0 samples, mode 1
    evaluates pdf_bsdf and eval_bsdf at given directions). A case is (kind, albedo, shape, ior,
    n, wo) or, for a conductor kind, (..., n, wo, eta, k), for an anisotropic kind (..., eta, k,
    shape_v, tangent) (MaterialAt.shape_v, .tangent), or for a `params` kind (..., n, wo,
    {name: value}) (principled_params.py), `shape` the lobe's (MaterialAt.shape); a
    rough plastic kind's table row is built from the case (rough_plastic_table.py); u_lobe, u.x, u.y of thread i are
    `uniform(seed, i, 0|1|2)`. `microfacet`: how the lobe strategy draws GGX normals
    (Strategy.microfacet); `lobes`: registered lobe samplers replacing the built-in lobe sampling of
    their kinds (Strategy.lobes). `opacity` / `one_sided`: the material's mask and sides
    (kernels/materials/mask.py), compiled in only where either is given."""

    _kernels: dict = {}

    def __init__(self, lobe: bool, microfacet: str = "vndf", lobes: tuple = (),
                 opacity: float | None = None, one_sided: bool = False):
        from drtlab.kernels.lobe_samplers import LOBE_SAMPLERS
        self.lobe = bool(lobe)
        self.masks = opacity is not None or bool(one_sided)
        self.opacity, self.one_sided = 1.0 if opacity is None else float(opacity), int(bool(one_sided))
        # An edited plugin re-registers under its name: its fingerprint keys a new kernel.
        key = (self.lobe, microfacet, tuple(lobes), tuple(LOBE_SAMPLERS[n].fingerprint for n in lobes),
               self.masks)
        if key not in BSDFAdapter._kernels:
            BSDFAdapter._kernels[key] = _make_bsdf_kernel(self.lobe, microfacet, tuple(lobes), self.masks)
        self.kernel = BSDFAdapter._kernels[key]

    def _launch(self, mode, case, n, seed, pts=None):
        wp = _wp()
        kind, albedo, shape, ior, nrm, wo, *metal = case
        params = metal.pop() if metal and isinstance(metal[-1], dict) else None
        eta, k = metal[:2] or ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
        shape_v, tangent = metal[2:] or (shape, (0.0, 0.0, 0.0))
        inp, n = input_points(pts, n)
        arrays = outputs(n, wp.vec3, float, wp.vec3, int, float, wp.vec3)
        from drtlab.kernels.materials.material_at import MaterialAt
        mat = MaterialAt()
        mat.kind = KIND_INDEX[kind] if isinstance(kind, str) else int(kind)
        mat.albedo, mat.shape, mat.ior = as_vec3(albedo), float(shape), float(ior)
        mat.eta, mat.k = as_vec3(eta), as_vec3(k)
        mat.shape_v, mat.tangent = float(shape_v), as_vec3(tangent)
        mat.table, mat.row = _table(mat.kind, albedo, shape, ior, params), 0
        mat.opacity, mat.one_sided = self.opacity, self.one_sided
        from drtlab.kernels.scene_model.material_kinds import KINDS
        if KINDS[mat.kind].params:
            from drtlab.kernels.materials.material_at import ParamVector
            mat.param = ParamVector(*mat.table.numpy()[:len(ParamVector())].tolist())
        wp.launch(self.kernel, dim=n, device="cpu",
                  inputs=[int(mode), mat, as_vec3(nrm), as_vec3(wo), wp.uint32(seed), inp, *arrays])
        return [a.numpy() for a in arrays]

    def sample(self, case, n: int, seed: int = 0) -> BSDFSamples:
        wi, pdf, weight, flags, pdf_eval, f_eval = self._launch(0, case, n, seed)
        return BSDFSamples(wi=wi, pdf=pdf.astype(np.float64), weight=weight,
                           valid=(flags & 1) == 1, delta=(flags & 2) == 2,
                           pdf_eval=pdf_eval.astype(np.float64), f_eval=f_eval)

    def evaluate(self, case, wi) -> tuple[np.ndarray, np.ndarray]:
        """(pdf_bsdf, eval_bsdf) at directions wi."""
        _, _, _, _, pdf, f = self._launch(1, case, 0, 0, wi)
        return pdf.astype(np.float64), f

    def sampler(self, case) -> SampleFunc:
        def sample(n, seed):
            s = self.sample(case, n, seed)
            return s.wi, s.valid
        return sample

    def pdf(self, case, masked: bool = True) -> PdfFunc:
        """The density of *valid* samples: pdf_bsdf where f|cos| > 0 (sample_bsdf drops a proposal
        whose f is zero, e.g. a uniform proposal outside a Phong lobe); masked=False: pdf_bsdf."""
        def pdf(pts):
            p, f = self.evaluate(case, pts)
            if masked:
                p = np.where(np.any(f > 0.0, axis=1), p, 0.0)
            return p
        return pdf


def _table(kind: int, albedo, shape: float, ior: float, params: dict | None = None):
    """The case's row of MaterialData.table (a kind whose model reads one, MaterialKind.table),
    else one zero; a `params` kind's (principled_params.py) from the case's trailing dict."""
    from drtlab.kernels.materials.kinds import model_module
    from drtlab.kernels.scene_model.material_kinds import KINDS
    spec = KINDS[kind]
    row = np.zeros(1, dtype=np.float32)
    if spec.table:
        row = model_module(spec).table_row(spec.name, albedo, shape, ior,
                                           **({"params": params} if spec.params else {}))
    return _wp().array(row, dtype=float, device="cpu")


def _make_bsdf_kernel(lobe: bool, microfacet: str = "vndf", lobes: tuple = (), masks: bool = False):
    wp = _wp()
    from drtlab.kernels.materials import make_bsdf
    from drtlab.kernels.materials.material_at import MaterialAt

    b = make_bsdf(*routine_variant(lobe=lobe, microfacet=microfacet, lobes=lobes, masks=masks))
    sample_bsdf, pdf_bsdf, eval_bsdf = b.sample_bsdf, b.pdf_bsdf, b.eval_bsdf

    @wp.kernel(enable_backward=False, module="unique")
    def bsdf_kernel(mode: int, mat: MaterialAt, n: wp.vec3, wo: wp.vec3, seed: wp.uint32, pts: wp.array(dtype=wp.vec3),
                    out_wi: wp.array(dtype=wp.vec3), out_pdf: wp.array(dtype=float),
                    out_weight: wp.array(dtype=wp.vec3), out_flags: wp.array(dtype=int),
                    out_pdf_eval: wp.array(dtype=float), out_f_eval: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            u_lobe = uniform(seed, i, 0)
            u = wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2))
            s = sample_bsdf(mat, n, wo, u_lobe, u)
            out_wi[tid] = s.wi
            out_pdf[tid] = s.pdf
            out_weight[tid] = s.weight
            out_flags[tid] = s.valid + 2 * s.delta
            if s.valid == 1 and s.delta == 0:
                out_pdf_eval[tid] = pdf_bsdf(mat, n, wo, s.wi)
                out_f_eval[tid] = eval_bsdf(mat, n, wo, s.wi)
        else:
            wi = pts[tid]
            out_pdf_eval[tid] = pdf_bsdf(mat, n, wo, wi)
            out_f_eval[tid] = eval_bsdf(mat, n, wo, wi)

    return bsdf_kernel
