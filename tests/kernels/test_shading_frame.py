"""Normal and bump maps (kernels/materials/shading_frame.py): the perturbed frame in exact values
against hand-worked cases and Mitsuba 3's formulas, and the wrapped BSDF's energy.

Statistics: level ALPHA = 0.01, Sidak-corrected over the module's M_TESTS albedo tests (two-sided z
of the mean sample weight against a float64 quadrature of eval). Negative controls: a normal map
read without the 2 rgb - 1 decode, a tangent frame with t flipped (s x n for n x s), and the wrapped
BSDF without its shadowing term, each checked to be rejected by the same comparison.
"""
from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
import warp as wp
from scipy import stats

from drtlab.estimators.strategies import LightSampling, Strategy
from drtlab.experiments.stats.chi2 import sidak
from drtlab.experiments.stats.chi2.adapters import uniform
from drtlab.kernels.features import Features
from drtlab.kernels.materials import make_bsdf
from drtlab.kernels.materials.material_at import MaterialAt
from drtlab.kernels.intersection.tangent import tangent_s, triangle_tangents
from drtlab.kernels.materials.shading_frame import (bump_map_local, mapped_bsdf, normal_map_local, shadowing, with_local_normal)
from drtlab.kernels.scene_model.material_kinds import MATERIAL_CODE

from stats_util import ALPHA

ALBEDO_CASES = [("diffuse", (0.9, 0.5, 0.9), 30.0), ("diffuse", (1.0, 0.5, 0.6), 80.0),
                ("ggx_conductor", (0.75, 0.5, 1.0), 40.0)]
M_TESTS = len(ALBEDO_CASES)
LEVEL = sidak(ALPHA, M_TESTS)
N = 200_000


@wp.kernel(enable_backward=False, module="unique")
def frame_kernel(rgb: wp.array(dtype=wp.vec3), ns: wp.array(dtype=wp.vec3), dpdu: wp.array(dtype=wp.vec3),
                 wo: wp.array(dtype=wp.vec3), out_local: wp.array(dtype=wp.vec3),
                 out_nm: wp.array(dtype=wp.vec3), out_a2: wp.array(dtype=float)):
    i = wp.tid()
    s = tangent_s(ns[i], dpdu[i])
    local = normal_map_local(rgb[i], s, ns[i], wo[i])
    m = with_local_normal(MaterialAt(), local, s, ns[i])
    out_local[i] = local
    out_nm[i] = m.nm
    out_a2[i] = m.nm_alpha2


@wp.kernel(enable_backward=False, module="unique")
def bump_kernel(grad: wp.array(dtype=wp.vec2), dpdu: wp.array(dtype=wp.vec3), dpdv: wp.array(dtype=wp.vec3),
                ng: wp.array(dtype=wp.vec3), ns: wp.array(dtype=wp.vec3), wo: wp.array(dtype=wp.vec3),
                out_local: wp.array(dtype=wp.vec3)):
    i = wp.tid()
    tg = triangle_tangents(wp.vec3(0.0), dpdu[i], dpdv[i], wp.vec2(0.0), wp.vec2(1.0, 0.0),
                           wp.vec2(0.0, 1.0), ng[i])
    out_local[i] = bump_map_local(grad[i], tg, ng[i], tangent_s(ns[i], tg.dpdu), ns[i], wo[i])


@wp.kernel(enable_backward=False, module="unique")
def tangents_kernel(p: wp.array(dtype=wp.vec3), uv: wp.array(dtype=wp.vec2), ng: wp.vec3,
                    out: wp.array(dtype=wp.vec3)):
    t = triangle_tangents(p[0], p[1], p[2], uv[0], uv[1], uv[2], ng)
    out[0] = t.dpdu
    out[1] = t.dpdv


def frame(rgb, ns, dpdu, wo):
    n = len(rgb)
    arrs = [wp.array(np.asarray(a, dtype=np.float32).reshape(n, 3), dtype=wp.vec3, device="cpu")
            for a in (rgb, ns, dpdu, wo)]
    out = [wp.zeros(n, dtype=wp.vec3, device="cpu"), wp.zeros(n, dtype=wp.vec3, device="cpu"),
           wp.zeros(n, dtype=float, device="cpu")]
    wp.launch(frame_kernel, dim=n, inputs=[*arrs, *out], device="cpu")
    return [a.numpy() for a in out]


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def mitsuba_frame(rgb, ns, dpdu, wo, decode=True, flip_t=False):
    """normalmap.cpp's frame in float64: the reference, and its negative controls."""
    s = unit(dpdu - ns * (ns @ dpdu))
    t = np.cross(ns, s) if not flip_t else np.cross(s, ns)
    c = 2.0 * np.asarray(rgb) - 1.0 if decode else np.asarray(rgb, dtype=np.float64)
    wl = np.array([wo @ s, wo @ t, wo @ ns])
    if wl[2] * (wl @ c) <= 0.0:
        c = np.array([-c[0], -c[1], c[2]])
    c = unit(c)
    return c, s * c[0] + t * c[1] + ns * c[2]


def test_identity_normal_map_changes_nothing_exactly():
    rng = np.random.default_rng(1)
    ns = unit(rng.normal(size=(64, 3)))
    dpdu = rng.normal(size=(64, 3))
    wo = unit(rng.normal(size=(64, 3)))
    wo *= np.sign(np.sum(wo * ns, axis=1))[:, None]
    local, nm, a2 = frame(np.tile([0.5, 0.5, 1.0], (64, 1)), ns, dpdu, wo)
    assert np.array_equal(local, np.tile(np.float32([0, 0, 1]), (64, 1)))
    assert np.array_equal(nm, ns.astype(np.float32))          # bit for bit: the same normal
    assert np.all(a2 == 0.0)                                  # and no shadowing


def test_perturbed_normal_by_hand():
    # ns = z, dp_du = (2, 0, 0.5) -> s = x, t = y; rgb (1, 0.5, 1) -> c = (1, 0, 1)
    ns, dpdu = [0.0, 0.0, 1.0], [2.0, 0.0, 0.5]
    h = math.sqrt(0.5)
    wo_up, wo_grazing = [0.0, 0.0, 1.0], unit([-1.0, 0.0, 0.1])
    local, nm, a2 = frame([[1.0, 0.5, 1.0]] * 2, [ns] * 2, [dpdu] * 2, [wo_up, wo_grazing])
    np.testing.assert_allclose(nm[0], [h, 0.0, h], atol=1e-7)
    # wo below the tilted normal but above ns: c mirrored about ns (flip_invalid_normals)
    np.testing.assert_allclose(nm[1], [-h, 0.0, h], atol=1e-7)
    np.testing.assert_allclose(a2, [0.125, 0.125], rtol=1e-6)     # tan^2 45 deg / 8
    # Estevez et al.'s term at wi 45 deg from ns: 2 / (1 + sqrt(1 + a2 tan^2))
    assert np.isclose(shadowing_at(0.125, ns, unit([1.0, 0.0, 1.0])), 2.0 / (1.0 + math.sqrt(1.125)), rtol=1e-6)


@wp.kernel(enable_backward=False, module="unique")
def shadowing_kernel(a2: float, ns: wp.vec3, wi: wp.vec3, out: wp.array(dtype=float)):
    out[0] = shadowing(a2, ns, wi)


def shadowing_at(a2, ns, wi):
    out = wp.zeros(1, dtype=float, device="cpu")
    wp.launch(shadowing_kernel, dim=1, inputs=[float(a2), wp.vec3(*ns), wp.vec3(*wi), out], device="cpu")
    return float(out.numpy()[0])


def test_frame_is_mitsubas_and_the_controls_are_rejected():
    rng = np.random.default_rng(2)
    n = 256
    ns = unit(rng.normal(size=(n, 3)))
    dpdu = rng.normal(size=(n, 3))
    rgb = rng.uniform(0.05, 1.0, size=(n, 3))
    wo = unit(rng.normal(size=(n, 3)))
    _, nm, _ = frame(rgb, ns, dpdu, wo)
    ref = np.array([mitsuba_frame(*a)[1] for a in zip(rgb, ns, dpdu, wo)])

    def agrees(x):
        return np.max(np.abs(nm - x)) < 1e-4
    assert agrees(ref)
    assert not agrees(np.array([mitsuba_frame(*a, decode=False)[1] for a in zip(rgb, ns, dpdu, wo)]))
    assert not agrees(np.array([mitsuba_frame(*a, flip_t=True)[1] for a in zip(rgb, ns, dpdu, wo)]))


def test_triangle_tangents_are_the_uv_derivatives():
    # p(u, v) = p0 + A u + B v on a triangle with arbitrary uvs: dp/du = A, dp/dv = B
    a, b, p0 = np.array([1.0, 2.0, -0.5]), np.array([0.3, -1.0, 2.0]), np.array([0.2, 0.1, 0.4])
    uv = np.array([[0.1, 0.2], [0.7, 0.25], [0.3, 0.9]])
    p = p0 + uv[:, :1] * a + uv[:, 1:] * b
    out = wp.zeros(2, dtype=wp.vec3, device="cpu")
    wp.launch(tangents_kernel, dim=1, device="cpu",
              inputs=[wp.array(p.astype(np.float32), dtype=wp.vec3, device="cpu"),
                      wp.array(uv.astype(np.float32), dtype=wp.vec2, device="cpu"),
                      wp.vec3(0.0, 0.0, 1.0), out])
    np.testing.assert_allclose(out.numpy(), [a, b], rtol=1e-4, atol=1e-5)
    # A degenerate uv triangle: the geometric normal's coordinate system (orthogonal to it)
    wp.launch(tangents_kernel, dim=1, device="cpu",
              inputs=[wp.array(p.astype(np.float32), dtype=wp.vec3, device="cpu"),
                      wp.array(np.zeros((3, 2), np.float32), dtype=wp.vec2, device="cpu"),
                      wp.vec3(0.0, 0.6, 0.8), out])
    t = out.numpy()
    assert np.allclose(t @ [0.0, 0.6, 0.8], 0.0, atol=1e-6) and np.allclose(np.linalg.norm(t, axis=1), 1.0)


def bump(grad, dpdu, dpdv, ng, ns, wo):
    n = len(grad)
    arrs = [wp.array(np.asarray(grad, np.float32).reshape(n, 2), dtype=wp.vec2, device="cpu")]
    arrs += [wp.array(np.asarray(a, np.float32).reshape(n, 3), dtype=wp.vec3, device="cpu")
             for a in (dpdu, dpdv, ng, ns, wo)]
    out = wp.zeros(n, dtype=wp.vec3, device="cpu")
    wp.launch(bump_kernel, dim=n, inputs=[*arrs, out], device="cpu")
    return out.numpy()


def test_bump_normal_by_hand():
    # The plane z = 0, dp_du = x, dp_dv = y: a height gradient g along u tilts n to (-g, 0, 1).
    x, y, z = np.eye(3)
    g = 0.75
    local = bump([[0.0, 0.0], [g, 0.0], [0.0, -g]], [x] * 3, [y] * 3, [z] * 3, [z] * 3, [z] * 3)
    np.testing.assert_allclose(local[0], [0.0, 0.0, 1.0], atol=1e-7)
    np.testing.assert_allclose(local[1], unit([-g, 0.0, 1.0]), atol=1e-6)
    np.testing.assert_allclose(local[2], unit([0.0, g, 1.0]), atol=1e-6)
    # The gradient's scale: dp_du's component along ns is replaced, not added to
    local2 = bump([[g, 0.0]], [x + 3.0 * z], [y], [z], [z], [z])
    np.testing.assert_allclose(local2[0], unit([-g, 0.0, 1.0]), atol=1e-6)


# --- The wrapped BSDF's directional albedo ---------------------------------------------------------

def _bsdf_kernel(kinds):
    f = Features(integrator="path", lens=False, motion=False, spheres=True, quads=False,
                 kinds=frozenset(kinds), checker=False, area_lights=True, point_lights=False,
                 dir_lights=False, roulette=False, background=False)
    b = mapped_bsdf(make_bsdf(f, Strategy("t", "test", "lobe", LightSampling("area", "uniform"))))
    sample_bsdf, eval_bsdf = b.sample_bsdf, b.eval_bsdf

    @wp.kernel(enable_backward=False, module="unique")
    def k(mat: MaterialAt, n: wp.vec3, wo: wp.vec3, seed: wp.uint32, out_w: wp.array(dtype=wp.vec3),
          out_f: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        i = wp.uint32(tid)
        s = sample_bsdf(mat, n, wo, uniform(seed, i, 0), wp.vec2(uniform(seed, i, 1), uniform(seed, i, 2)))
        if s.valid == 1:
            out_w[tid] = s.weight
        # uniform sphere directions: eval's own estimate of the albedo (4 pi f|cos|)
        z = 1.0 - 2.0 * uniform(seed, i, 3)
        r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
        phi = 6.283185307179586 * uniform(seed, i, 4)
        out_f[tid] = eval_bsdf(mat, n, wo, wp.vec3(r * wp.cos(phi), r * wp.sin(phi), z)) * 12.566370614359172
    return k


_KERNEL = {}


def albedo_samples(kind, rgb, theta, seed):
    if "k" not in _KERNEL:
        _KERNEL["k"] = _bsdf_kernel({"diffuse", "ggx_conductor"})
    ns = np.array([0.0, 0.0, 1.0])
    local, nm, a2 = frame([rgb], [ns], [[1.0, 0.0, 0.0]], [[math.sin(math.radians(theta)), 0.0,
                                                            math.cos(math.radians(theta))]])
    mat = MaterialAt()
    mat.kind = MATERIAL_CODE[kind]
    mat.albedo = wp.vec3(1.0, 1.0, 1.0)
    mat.shape = 0.3
    mat.eta, mat.k = wp.vec3(0.0, 0.0, 0.0), wp.vec3(1.0, 1.0, 1.0)     # F = 1: a white metal
    mat.table, mat.row = wp.zeros(1, dtype=float, device="cpu"), 0
    mat.mapped, mat.nm, mat.nm_alpha2 = 1, wp.vec3(*nm[0]), float(a2[0])
    wo = np.array([math.sin(math.radians(theta)), 0.0, math.cos(math.radians(theta))])
    out_w, out_f = wp.zeros(N, dtype=wp.vec3, device="cpu"), wp.zeros(N, dtype=wp.vec3, device="cpu")
    wp.launch(_KERNEL["k"], dim=N, device="cpu",
              inputs=[mat, wp.vec3(*ns), wp.vec3(*wo), wp.uint32(seed), out_w, out_f])
    return out_w.numpy()[:, 0].astype(np.float64), out_f.numpy()[:, 0].astype(np.float64), nm[0], a2[0], wo


def quadrature_diffuse(nm, a2, wo, shadow=True, k=400):
    """The wrapped white diffuse's albedo in float64: the integral over wi above both ns and nm of
    (nm . wi) / pi times the shadowing term (midpoint rule in (cos theta, phi) about ns)."""
    c = (np.arange(k) + 0.5) / k
    phi = (np.arange(2 * k) + 0.5) / (2 * k) * 2 * np.pi
    C, P = np.meshgrid(c, phi, indexing="ij")
    S = np.sqrt(1 - C * C)
    wi = np.stack([S * np.cos(P), S * np.sin(P), C], axis=-1)
    cn = wi @ nm
    tan2 = (1 - C * C) / (C * C)
    g = 2.0 / (1.0 + np.sqrt(1.0 + a2 * tan2)) if shadow else 1.0
    f = np.where(cn > 0, cn / np.pi * g, 0.0)
    return f.mean() * 2 * np.pi


@pytest.mark.parametrize("kind,rgb,theta", ALBEDO_CASES)
def test_wrapped_albedo_at_most_one_and_sampling_matches_eval(kind, rgb, theta):
    w, f, nm, a2, wo = albedo_samples(kind, rgb, theta, seed=zlib.crc32(f"{kind}-{theta}".encode()))
    z = stats.norm.isf(LEVEL / 2)
    mw, sw = w.mean(), w.std(ddof=1) / math.sqrt(N)
    mf, sf = f.mean(), f.std(ddof=1) / math.sqrt(N)
    assert mw + z * sw <= 1.0 + 1e-9 or mw <= 1.0, (mw, sw)       # a furnace under the tilted frame
    assert abs(mw - mf) / math.hypot(sw, sf) < z, (mw, sw, mf, sf)    # sample's weights = eval's integral
    if kind == "diffuse":
        ref = quadrature_diffuse(nm, a2, wo)
        assert abs(mw - ref) / sw < z, (mw, sw, ref)
        wrong = quadrature_diffuse(nm, a2, wo, shadow=False)       # the control: no shadowing term
        assert abs(wrong - ref) / sw >= z + stats.norm.isf(0.01)   # detectable at this N ...
        assert abs(mw - wrong) / sw >= z                           # ... and rejected
