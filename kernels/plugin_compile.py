"""Compile a plugin's Warp code once when it is registered, so that an error in it is one line then
(drtlab/registration.py words it at the user's file and line) and never a traceback at first use.

    compile_light_selection(sel)   a kernel calling pick and pmf on a scene's device data
    compile_lobe_sampler(ls)       a kernel calling sample and pdf
    compile_integrator(name)       the render kernel of a small variant (spheres and quads, diffuse
                                   and emitting, area lights) around the integrator's trace: the
                                   one a first render of such a scene then reuses
Each raises what Warp raised.
"""
import warp as wp

from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.materials.material_at import MaterialAt


def _load(kernel) -> None:
    wp.load_module(kernel.module, device="cpu")


def compile_light_selection(sel) -> None:
    pick, pmf = sel.pick, sel.pmf

    @wp.kernel(enable_backward=False, module="unique")
    def probe(sd: SceneData, out: wp.array(dtype=float)):
        x = wp.vec3(0.1, 0.2, 0.3)
        li = pick(sd, x, 0.5)
        out[0] = pmf(sd, x, li) + float(li)

    _load(probe)


def compile_lobe_sampler(ls) -> None:
    sample, pdf = ls.sample, ls.pdf

    @wp.kernel(enable_backward=False, module="unique")
    def probe(out: wp.array(dtype=float)):
        n = wp.vec3(0.0, 0.0, 1.0)
        wo = wp.normalize(wp.vec3(0.3, 0.1, 1.0))
        mat = MaterialAt()
        mat.albedo = wp.vec3(0.5)
        mat.shape = 10.0
        mat.ior = 1.5
        s = sample(mat, n, wo, 0.5, wp.vec2(0.3, 0.7))
        out[0] = pdf(mat, n, wo, s.wi) + s.wi[0]

    _load(probe)


def small_features(integrator: str) -> Features:
    """The variant a registered integrator is compiled for at once."""
    return Features(integrator=integrator, lens=False, motion=False, spheres=True, quads=True,
                    kinds=frozenset({"diffuse", "emitter"}), checker=False, area_lights=True,
                    point_lights=False, dir_lights=False, roulette=False, background=False)


def compile_integrator(name: str) -> None:
    from drtlab.estimators.registry import parse_sampler
    from drtlab.kernels.variants import get_kernel
    get_kernel(small_features(name), parse_sampler("independent+importance"), "cpu")
