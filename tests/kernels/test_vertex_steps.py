"""The API's composed vertex steps (kernels/integrators/vertex.py) call the functions the API hands
out after the negative controls and probes wrap them, so a fault acts inside direct_light and
scatter as it does in an integrator that calls sample_bsdf, next_event or get2d itself."""
import dataclasses
import inspect

import pytest

from drtlab.estimators.registry import parse_sampler
from drtlab.kernels.features import (DROP_COSINE, PDF_HIGH_10PCT, REPEAT_DRAW, REPEAT_NEXT_EVENT,
                                     REPEAT_SAMPLE_BSDF)
from drtlab.kernels.integrators.api import make_api
from drtlab.kernels.plugin_compile import small_features

# fault -> the API functions it replaces that a vertex step calls
WRAPS = {DROP_COSINE: ("sample_bsdf",), PDF_HIGH_10PCT: ("sample_bsdf",),
         REPEAT_SAMPLE_BSDF: ("sample_bsdf",), REPEAT_NEXT_EVENT: ("next_event",),
         REPEAT_DRAW: ("get2d",)}
STEPS = {"sample_bsdf": "scatter", "next_event": "direct_light", "get2d": "scatter"}


def _api(faults=()):
    spec = parse_sampler("independent+importance")
    f = dataclasses.replace(small_features("path"), meshes=True, point_lights=True,
                            faults=frozenset(faults))
    return make_api(f, spec.pointset, spec.strategy)


def _calls(step) -> dict:
    return inspect.getclosurevars(step.func).nonlocals


@pytest.mark.parametrize("fault", list(WRAPS))
def test_a_fault_reaches_the_vertex_steps(fault):
    plain, faulty = _api(), _api((fault,))
    for name in WRAPS[fault]:
        # negative control: the fault does replace the function (else this test could not fail)
        assert getattr(faulty, name) is not getattr(plain, name)
        step = getattr(faulty, STEPS[name])
        assert _calls(step)[name] is getattr(faulty, name), f"{STEPS[name]} calls the unwrapped {name}"


def test_the_steps_use_the_api_functions_without_faults():
    api = _api()
    for step, names in (("direct_light", ("get1d", "get2d", "next_event", "direct_delta_lights")),
                        ("scatter", ("get1d", "get2d", "sample_bsdf", "shading_consistent"))):
        calls = _calls(getattr(api, step))
        assert all(calls[n] is getattr(api, n) for n in names), step
