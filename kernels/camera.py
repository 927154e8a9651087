"""Primary rays: the camera's thin lens and shutter per kernel variant, and Whitted's sub-pixel grid.

`make_camera(features, pointset)` returns the Warp function
sample_ray(sd, seed, pix, idx, spp, px, py) -> CameraRay (pixel, lens and time from the point set);
`grid_ray_dir(sd, px, py, sub, nx, ny)` is the pinhole direction through the centre of sub-pixel
`sub` of an nx x ny grid.
"""
import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.domain_maps import square_to_disk
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import Features


@wp.struct
class CameraRay:
    o: wp.vec3
    d: wp.vec3
    dt: float           # shutter offset (time since shutter open)


@wp.func
def camera_ray_dir(sd: SceneData, px: int, py: int, u: wp.vec2, lens: wp.vec2) -> wp.vec3:
    sx = (2.0 * (float(px) + u[0]) / float(sd.width) - 1.0) * sd.camera.half_width
    sy = (1.0 - 2.0 * (float(py) + u[1]) / float(sd.height)) * sd.camera.half_height
    # Thin lens: aim from the lens point at the point the pinhole ray meets the focal plane;
    # written as (x, y, 1) - lens / focus so that a zero aperture reproduces the pinhole exactly.
    cx = sx - lens[0] / sd.camera.focus_distance
    cy = sy - lens[1] / sd.camera.focus_distance
    return wp.normalize(sd.camera.right * cx + sd.camera.up * cy + sd.camera.forward)


@wp.func
def grid_ray_dir(sd: SceneData, px: int, py: int, sub: int, nx: int, ny: int) -> wp.vec3:
    # Regular sub-pixel grid at stratum centres, lens centre (shutter-open time is the caller's).
    u = wp.vec2((float(sub % nx) + 0.5) / float(nx), (float(sub / nx) + 0.5) / float(ny))
    return camera_ray_dir(sd, px, py, u, wp.vec2(0.0, 0.0))


def make_camera(f: Features, pointset: PointSet) -> wp.Function:
    get1d = pointset.get1d
    get2d = pointset.get2d

    @wp.func
    def sample_ray(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32,
                   spp: wp.uint32, px: int, py: int) -> CameraRay:
        u = get2d(seed, pix, idx, wp.uint32(wp.static(dims.PIXEL)), spp)
        lens = wp.vec2(0.0, 0.0)
        o = sd.camera.position
        # A runtime switch (one branch per sample): scenes with and without a lens share a variant.
        if sd.camera.aperture > 0.0:
            lens = square_to_disk(get2d(seed, pix, idx, wp.uint32(wp.static(dims.LENS)),
                                        spp)) * sd.camera.aperture
            o = o + sd.camera.right * lens[0] + sd.camera.up * lens[1]
        ray = CameraRay()
        ray.o = o
        ray.d = camera_ray_dir(sd, px, py, u, lens)
        ray.dt = float(0.0)
        if sd.moving == 1:
            ray.dt = (sd.camera.shutter_close - sd.camera.shutter_open) * get1d(
                seed, pix, idx, wp.uint32(wp.static(dims.TIME)), spp)
        return ray

    return sample_ray
