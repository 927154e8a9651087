"""Primary rays: the camera's thin lens and shutter per kernel variant (or an orthographic camera's
parallel rays, compiled in only for scenes with one), and Whitted's sub-pixel grid.

`make_camera(features, pointset)` returns the Warp function
sample_ray(sd, seed, pix, idx, spp, px, py) -> CameraRay (pixel, lens and time from the point set;
with filter importance sampling the pixel position is drawn from the filter and weighted, `w`);
`grid_ray_dir(sd, px, py, sub, nx, ny)` is the pinhole direction through the centre of sub-pixel
`sub` of an nx x ny grid.
"""
import warp as wp

from drtlab.estimators import dimensions as dims
from drtlab.estimators.pointsets.base import PointSet
from drtlab.estimators.domain_maps import square_to_disk
from drtlab.kernels.device_scene import SceneData
from drtlab.kernels.features import Features
from drtlab.kernels.filter_sampling import PixelFilter


@wp.struct
class CameraRay:
    o: wp.vec3
    d: wp.vec3
    dt: float           # shutter offset (time since shutter open)
    w: float            # the pixel filter's sample weight (filter importance sampling; else unused)


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
def film_offset(sd: SceneData, px: int, py: int, u: wp.vec2) -> wp.vec3:
    """An orthographic film's point of pixel (px, py) at offset u, from the film's centre (its half
    extents are lengths there)."""
    sx = (2.0 * (float(px) + u[0]) / float(sd.width) - 1.0) * sd.camera.half_width
    sy = (1.0 - 2.0 * (float(py) + u[1]) / float(sd.height)) * sd.camera.half_height
    return sd.camera.right * sx + sd.camera.up * sy


@wp.func
def grid_ray_dir(sd: SceneData, px: int, py: int, sub: int, nx: int, ny: int) -> wp.vec3:
    # Regular sub-pixel grid at stratum centres, lens centre (shutter-open time is the caller's).
    u = wp.vec2((float(sub % nx) + 0.5) / float(nx), (float(sub / nx) + 0.5) / float(ny))
    return camera_ray_dir(sd, px, py, u, wp.vec2(0.0, 0.0))


def make_camera(f: Features, pointset: PointSet, pixel_filter: PixelFilter | None = None) -> wp.Function:
    get1d = pointset.get1d
    get2d = pointset.get2d
    # Filter importance sampling: the pixel dimensions drawn from the filter around the pixel centre.
    FIS = pixel_filter is not None and not f.splat
    filter_sample = pixel_filter.sample if FIS else None
    ORTHO = f.orthographic

    @wp.func
    def sample_ray(sd: SceneData, seed: wp.uint32, pix: wp.uint32, idx: wp.uint32,
                   spp: wp.uint32, px: int, py: int) -> CameraRay:
        u = get2d(seed, pix, idx, wp.uint32(wp.static(dims.PIXEL)), spp)
        w = float(1.0)
        if wp.static(FIS):
            s = filter_sample(sd, u, px, py)
            u = wp.vec2(0.5 + s[0], 0.5 + s[1])
            w = s[2]
        lens = wp.vec2(0.0, 0.0)
        o = sd.camera.position
        # A runtime switch (one branch per sample): scenes with and without a lens share a variant.
        if sd.camera.aperture_radius > 0.0:
            lens = square_to_disk(get2d(seed, pix, idx, wp.uint32(wp.static(dims.LENS)),
                                        spp)) * sd.camera.aperture_radius
            o = o + sd.camera.right * lens[0] + sd.camera.up * lens[1]
        ray = CameraRay()
        ray.o = o
        if wp.static(ORTHO):
            # Parallel rays along the view axis from the film point (half extents are lengths here).
            ray.o = o + film_offset(sd, px, py, u)
            ray.d = sd.camera.forward
        else:
            ray.d = camera_ray_dir(sd, px, py, u, lens)
        ray.dt = float(0.0)
        ray.w = w
        if sd.moving == 1:
            ray.dt = (sd.camera.shutter_close - sd.camera.shutter_open) * get1d(
                seed, pix, idx, wp.uint32(wp.static(dims.TIME)), spp)
        return ray

    return sample_ray
