"""Every area-light kind is one module behind one interface (kernels/light_sample.py), composed by
make_lights: each builds a LightKind of its own shape code whose `sample` and `pdf` take the same
arguments, a variant has exactly the kinds its features compile in, and closures of one source built
for another strategy or fault carry another cache tag. (Their densities against their samples:
tests/estimators/test_chi2.py and test_chi2_solid_angle.py.)"""
import pytest
import warp as wp

from drtlab.estimators.strategies import STRATEGIES
from drtlab.kernels import lights
from drtlab.kernels.device_scene import MESH, QUAD, SPHERE, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN, Features
from drtlab.kernels.intersection.motion import make_motion
from drtlab.kernels.light_sample import LightKind, LightSample

AS32 = {float: wp.float32, int: wp.int32}
SAMPLE = tuple(AS32.get(t, t) for t in (SceneData, int, wp.vec3, wp.vec2, int, float))
PDF = tuple(AS32.get(t, t) for t in (SceneData, int, wp.vec3, wp.vec3, wp.vec3, int, int, float))


def _kinds(meshes: bool, strategy: str = "importance", faults: frozenset = frozenset()):
    features = Features(integrator="path", lens=False, motion=False, spheres=True, quads=True,
                        kinds=frozenset({"diffuse", "emitter"}), checker=False, area_lights=True,
                        point_lights=False, dir_lights=False, roulette=False, background=False,
                        faults=faults, meshes=meshes)
    return lights.light_kinds(features, STRATEGIES[strategy], motion=make_motion())


def _types(fn) -> tuple:
    return tuple(AS32.get(t, t) for t in fn.input_types.values())


@pytest.mark.parametrize("meshes", [False, True])
def test_each_kind_has_the_one_interface(meshes):
    kinds = _kinds(meshes)
    assert all(isinstance(k, LightKind) for k in kinds)
    assert [k.code for k in kinds] == [SPHERE, QUAD] + ([MESH] if meshes else [])
    for k in kinds:
        assert _types(k.sample) == SAMPLE and _types(k.pdf) == PDF, k.tag
        assert k.sample.func.__annotations__["return"] is LightSample


def test_the_cache_tags_tell_variants_apart():
    solid = _kinds(True)
    for other in (_kinds(True, "importance-area"), _kinds(True, faults=frozenset({LIGHT_JACOBIAN}))):
        assert all(a.tag != b.tag for a, b in zip(other, solid))
