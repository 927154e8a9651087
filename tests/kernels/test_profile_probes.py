"""The profile's probes (kernels/features.py REPEATS, `profile_kernels components`): a variant that
does one part of a sample twice must render the plain variant's image (the second call enters at
1e-30, below float32 rounding of any pixel), so its extra time is the part's cost and nothing else."""
import numpy as np
import pytest

from drtlab.errors import InputError
from drtlab.kernels.features import REPEATS
from drtlab.kernels.render import render

# One diffuse path-traced scene with an area light reaches every probe (camera, nearest hit, light
# sample, shadow ray, BSDF sample, draws).
SCENE, RES, SPP = "cornell-box", (12, 10), 4


@pytest.fixture(scope="module")
def plain():
    return render(SCENE, spp=SPP, res=RES, sampler="independent+importance-area")


@pytest.mark.parametrize("probe", REPEATS)
def test_probe_leaves_the_image(plain, probe):
    img = render(SCENE, spp=SPP, res=RES, sampler="independent+importance-area", faults=(probe,))
    assert img.shape == plain.shape
    # Equal to float32 rounding: the probe adds 1e-30 times an O(1) value to radiance of O(0.01-10).
    np.testing.assert_allclose(img, plain, rtol=1e-6, atol=1e-20)
    assert plain.max() > 0.0


def test_unknown_probe_is_refused():
    with pytest.raises(InputError, match="faults"):
        render(SCENE, spp=1, res=RES, faults=("repeat_everything",))
