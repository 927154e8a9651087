"""The chi-square harness's adapter of the environment light's samplers (kernels/environment.py
`make_environment`): one CPU kernel per sampler ("uniform", "cosine", "image") on the device tables
of an EnvironmentMap, sampling env_sample(env, n, u) with the harness's `uniform` random numbers
and evaluating env_pdf(env, n, d) and env_radiance(env, d) (`radiance`: the lookup). `tables` replaces the image sampler's tables (a SamplingTables
of kernels/scene_model/environment_map.py, e.g. built without the sin(theta) weight: the negative control) while
the claimed density stays the exact one (environment_map.direction_pdf)."""

from dataclasses import dataclass

import numpy as np

from drtlab.experiments.stats.chi2.adapters import (as_vec3, input_points, outputs,
                                                    uniform)
from drtlab.warp_runtime import warp as _wp
from drtlab.experiments.stats.chi2.harness import PdfFunc, SampleFunc


@dataclass
class EnvSamples:
    wi: np.ndarray          # (n, 3)
    pdf: np.ndarray         # the pdf each sample carries
    valid: np.ndarray       # bool
    radiance: np.ndarray    # (n, 3)


def _cpu_array(values, dtype, empty_shape):
    wp = _wp()
    a = np.asarray(values, dtype=np.float32)
    return wp.array(a if a.size else np.zeros(empty_shape, np.float32), dtype=dtype, device="cpu")


def device_tables(env_map, tables=None):
    """EnvironmentData of `env_map` on the CPU (no area lights), its image-sampling tables
    replaced by `tables` when given."""
    from drtlab.kernels.environment import environment_data
    arr = _cpu_array
    e = environment_data(env_map, np.zeros(0), 1.0, arr)
    if tables is not None:
        e.texel_pdf = arr(tables.texel_pdf.ravel(), float, (1,))
        e.marginal = arr(tables.marginal, float, (1,))
        e.conditional = arr(tables.conditional.ravel(), float, (1,))
    return e


class EnvironmentAdapter:
    _kernels: dict = {}

    def __init__(self, sampler: str):
        if sampler not in EnvironmentAdapter._kernels:
            EnvironmentAdapter._kernels[sampler] = _make_env_kernel(sampler)
        self.kernel = EnvironmentAdapter._kernels[sampler]

    def _launch(self, mode, env, n_axis, n, seed, pts=None):
        wp = _wp()
        inp, n = input_points(pts, n)
        arrays = outputs(n, wp.vec3, float, int, wp.vec3)
        wp.launch(self.kernel, dim=n, device="cpu",
                  inputs=[int(mode), env, as_vec3(n_axis), wp.uint32(seed), inp, *arrays])
        return [a.numpy() for a in arrays]

    def sample(self, env, n_axis, n: int, seed: int = 0) -> EnvSamples:
        wi, pdf, valid, rad = self._launch(0, env, n_axis, n, seed)
        return EnvSamples(wi=wi, pdf=pdf.astype(np.float64), valid=valid == 1, radiance=rad)

    def sampler(self, env, n_axis) -> SampleFunc:
        def sample(n, seed):
            s = self.sample(env, n_axis, n, seed)
            return s.wi, s.valid
        return sample

    def pdf(self, env, n_axis) -> PdfFunc:
        """env_pdf as the Warp code evaluates it (MIS's density at an escape)."""
        def pdf(pts):
            return self._launch(1, env, n_axis, 0, 0, pts)[1].astype(np.float64)
        return pdf

    def radiance(self, env, dirs) -> np.ndarray:
        """env_radiance at `dirs` (n, 3): what a ray leaving the scene along each sees."""
        return self._launch(1, env, (0.0, 1.0, 0.0), 0, 0, dirs)[3].astype(np.float64)


def _make_env_kernel(sampler: str):
    wp = _wp()
    from drtlab.estimators.strategies import LightSampling, Strategy
    from drtlab.kernels.device_scene import EnvironmentData
    from drtlab.kernels.environment import make_environment

    env_fns = make_environment(Strategy("chi2", "the environment adapter's sampler", "lobe",
                                        LightSampling("solid_angle", "power", environment=sampler)))
    env_sample, env_pdf, env_radiance = env_fns.env_sample, env_fns.env_pdf, env_fns.env_radiance

    @wp.kernel(enable_backward=False, module="unique")
    def env_kernel(mode: int, env: EnvironmentData, n: wp.vec3, seed: wp.uint32,
                   pts: wp.array(dtype=wp.vec3), out_wi: wp.array(dtype=wp.vec3),
                   out_pdf: wp.array(dtype=float), out_valid: wp.array(dtype=int),
                   out_rad: wp.array(dtype=wp.vec3)):
        tid = wp.tid()
        if mode == 0:
            i = wp.uint32(tid)
            es = env_sample(env, n, wp.vec2(uniform(seed, i, 0), uniform(seed, i, 1)))
            out_wi[tid] = es.wi
            out_pdf[tid] = es.pdf
            out_valid[tid] = es.valid
            out_rad[tid] = es.radiance
        else:
            d = wp.normalize(pts[tid])
            out_pdf[tid] = env_pdf(env, n, d)
            out_rad[tid] = env_radiance(env, d)

    return env_kernel
