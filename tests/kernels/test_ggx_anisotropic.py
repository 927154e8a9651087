"""`ggx_anisotropic` (kernels/materials/ggx_anisotropic.py): Mitsuba 3's GGX roughconductor with
alpha_u != alpha_v in the hit's tangent frame.

* Exact values: eval against a float64 transcription of Mitsuba's formulas (D, separable G1, F = 1)
  at random directions with a tilted tangent; negative control: the same reference with alpha_u and
  alpha_v swapped (the tangent frame turned 90 degrees) must be rejected by the same comparison.
* The isotropic limit: alpha_u = alpha_v gives ggx_conductor's eval and pdf.
* Sampling: the chi-square harness of sample_bsdf against pdf_bsdf; the directional albedo (mean
  sample weight) against eval's own integral over the sphere, and at most 1 (a white furnace).
Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS statistical tests.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from scipy import stats

from drtlab.estimators.strategies import LightSampling, Strategy
from drtlab.experiments.stats import chi2 as C
from drtlab.experiments.stats.chi2.adapters import uniform
from drtlab.kernels.features import Features
from drtlab.kernels.materials import make_bsdf
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.scene_model.material_kinds import MATERIAL_CODE

from stats_util import ALPHA

NORMAL = np.array([0.0, 0.0, 1.0])
TANGENT = np.array([math.cos(0.4), math.sin(0.4), 0.0])
CASES = [(0.25, 0.05, 30.0, 0.0), (0.05, 0.4, 60.0, 1.2), (0.3, 0.1, 75.0, 2.5)]   # au, av, theta, phi
M_TESTS = 2 * len(CASES)
LEVEL = C.sidak(ALPHA, M_TESTS)
N = 400_000
_KERNEL = {}


def kernel():
    if "k" in _KERNEL:
        return _KERNEL["k"]
    f = Features(integrator="path", lens=False, motion=False, spheres=True, quads=False,
                 kinds=frozenset({"ggx_anisotropic", "ggx_conductor"}), checker=False,
                 area_lights=True, point_lights=False, dir_lights=False, roulette=False,
                 background=False)
    b = make_bsdf(f, Strategy("t", "test", "lobe", LightSampling("area", "uniform")))
    sample_bsdf, pdf_bsdf, eval_bsdf = b.sample_bsdf, b.pdf_bsdf, b.eval_bsdf

    @wp.kernel(enable_backward=False, module="unique")
    def k(mode: int, mat: MaterialAt, n: wp.vec3, wo: wp.vec3, seed: wp.uint32, pts: wp.array(dtype=wp.vec3),
          out_wi: wp.array(dtype=wp.vec3), out_w: wp.array(dtype=wp.vec3), out_valid: wp.array(dtype=int),
          out_pdf: wp.array(dtype=float), out_f: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        i = wp.uint32(tid)
        if mode == 0:
            s = sample_bsdf(mat, n, wo, 0.0, wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2)))
            out_wi[tid] = s.wi
            out_w[tid] = s.weight
            out_valid[tid] = s.valid
            # a uniform sphere direction: eval's own estimate of the albedo (4 pi f|cos|)
            z = 1.0 - 2.0 * uniform(seed, i, 3)
            r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
            phi = 6.283185307179586 * uniform(seed, i, 4)
            out_f[tid] = eval_bsdf(mat, n, wo, wp.vec3(r * wp.cos(phi), r * wp.sin(phi), z)) * 12.566370614359172
        else:
            out_pdf[tid] = pdf_bsdf(mat, n, wo, pts[tid])
            out_f[tid] = eval_bsdf(mat, n, wo, pts[tid])
    _KERNEL["k"] = k
    return k


def material(kind, au, av):
    mat = MaterialAt()
    mat.kind = MATERIAL_CODE[kind]
    mat.albedo = wp.vec3(1.0, 1.0, 1.0)
    mat.shape, mat.shape_v, mat.tangent = float(au), float(av), wp.vec3(*(TANGENT + 0.3 * NORMAL))
    mat.eta, mat.k = wp.vec3(0.0, 0.0, 0.0), wp.vec3(1.0, 1.0, 1.0)      # F = 1
    mat.table, mat.row = wp.zeros(1, dtype=float, device="cpu"), 0
    return mat


def wo_at(theta, phi):
    t, p = math.radians(theta), phi
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def launch(mode, mat, wo, n=0, seed=0, pts=None):
    n = len(pts) if pts is not None else n
    pts = wp.array(np.asarray(pts if pts is not None else np.zeros((1, 3)), np.float32), dtype=wp.vec3,
                   device="cpu")
    outs = [wp.zeros(n, dtype=t, device="cpu") for t in (wp.vec3, wp.vec3, int, float, wp.vec3)]
    wp.launch(kernel(), dim=n, device="cpu",
              inputs=[mode, mat, wp.vec3(*NORMAL), wp.vec3(*wo), wp.uint32(seed), pts, *outs])
    return [o.numpy() for o in outs]


def reference_f(au, av, wo, wi):
    """Mitsuba's f|cos_i| (F = 1) in float64, in the frame s = TANGENT, t = n x s."""
    s, t = TANGENT, np.cross(NORMAL, TANGENT)
    to = lambda w: np.stack([w @ s, w @ t, w @ NORMAL], axis=-1)    # noqa: E731
    ol, il = to(wo), to(wi)
    m = ol + il
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    d = 1.0 / (np.pi * au * av * ((m[..., 0] / au) ** 2 + (m[..., 1] / av) ** 2 + m[..., 2] ** 2) ** 2)

    def g1(v):
        lam = (np.sqrt(1.0 + (au ** 2 * v[..., 0] ** 2 + av ** 2 * v[..., 1] ** 2) / v[..., 2] ** 2) - 1.0) / 2.0
        return np.where((v * m).sum(-1) * v[..., 2] > 0, 1.0 / (1.0 + lam), 0.0)
    f = d * g1(ol) * g1(il) / (4.0 * ol[..., 2])
    return np.where(il[..., 2] > 0, f, 0.0)


def random_upper(rng, k):
    w = rng.normal(size=(k, 3))
    w[:, 2] = np.abs(w[:, 2]) + 0.05
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def test_eval_is_mitsubas_and_swapped_alphas_are_rejected():
    rng = np.random.default_rng(7)
    for au, av, theta, phi in CASES:
        wo = wo_at(theta, phi)
        wi = random_upper(rng, 500)
        f = launch(1, material("ggx_anisotropic", au, av), wo, pts=wi)[4][:, 0].astype(np.float64)
        ref = reference_f(au, av, wo, wi)
        close = lambda r: np.allclose(f, r, rtol=2e-3, atol=1e-5 * r.max())      # noqa: E731
        assert close(ref)
        assert not close(reference_f(av, au, wo, wi))            # the frame turned 90 degrees


def test_isotropic_limit_is_ggx_conductor():
    rng = np.random.default_rng(8)
    wo = wo_at(50.0, 0.7)
    wi = random_upper(rng, 500)
    a = launch(1, material("ggx_anisotropic", 0.3, 0.3), wo, pts=wi)
    b = launch(1, material("ggx_conductor", 0.3, 0.0), wo, pts=wi)
    np.testing.assert_allclose(a[3], b[3], rtol=2e-4, atol=1e-6)
    np.testing.assert_allclose(a[4], b[4], rtol=2e-4, atol=1e-6)


@pytest.mark.parametrize("au,av,theta,phi", CASES)
def test_sampling_chi2_and_albedo(au, av, theta, phi):
    mat, wo = material("ggx_anisotropic", au, av), wo_at(theta, phi)
    seed = int(1000 * au + 100 * av + theta)
    wi, w, valid, _, fest = launch(0, mat, wo, n=N, seed=seed)
    r = C.run_chi2(C.SphericalDomain(NORMAL), lambda k, sd: (wi, valid == 1),
                   lambda pts: launch(1, mat, wo, pts=pts)[3].astype(np.float64),
                   name=f"ggx_anisotropic {au} {av} {theta}", sample_count=N, res=(101, 202),
                   seed=seed + 1, test_count=M_TESTS)
    assert r.passed, r.summary()
    ws = np.where(valid == 1, w[:, 0].astype(np.float64), 0.0)
    fs = fest[:, 0].astype(np.float64)
    mw, sw = ws.mean(), ws.std(ddof=1) / math.sqrt(N)
    mf, sf = fs.mean(), fs.std(ddof=1) / math.sqrt(N)
    z = stats.norm.isf(LEVEL / 2)
    assert abs(mw - mf) / math.hypot(sw, sf) < z, (mw, sw, mf, sf)
    assert mw <= 1.0 + z * sw                                      # a white furnace keeps at most 1
