"""Sphere lights (light_sample.py's interface): from outside the sphere, directions uniform in the
cone it subtends where the strategy samples by solid angle (`Strategy.solid_angle`), else points
uniform on its area (and from inside it always)."""
import warp as wp

from drtlab.estimators.domain_maps import PI, cone_pdf, frame_to_world, square_to_cone, square_to_uniform_sphere
from drtlab.kernels.device_scene import SPHERE, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN
from drtlab.kernels.light_sample import LightKind, LightSample, make_toward


@wp.func
def sphere_cone(sd: SceneData, c: wp.vec3, r: float, x: wp.vec3) -> wp.vec2:
    """(1 - cos theta_max, distance to centre); first component <= 0 when x is inside."""
    dc = wp.length(c - x)
    if dc <= r * (1.0 + 1.0e-4):
        return wp.vec2(-1.0, dc)
    sin2 = (r / dc) * (r / dc)
    cos_max = wp.sqrt(wp.max(0.0, 1.0 - sin2))
    return wp.vec2(sin2 / (1.0 + cos_max), dc)


def make(f, strategy, motion, spherical) -> LightKind:
    sphere_center = motion.sphere_center
    SOLID_ANGLE = strategy.solid_angle
    WRONG = LIGHT_JACOBIAN in f.faults
    toward = make_toward(WRONG)

    @wp.func
    def sample(sd: SceneData, s: int, x: wp.vec3, u: wp.vec2, bounce: int, dt: float) -> LightSample:
        c = sphere_center(sd, s, dt)
        r = sd.spheres.radius[s]
        m = sd.spheres.material[s]
        cone = wp.vec2(-1.0, 0.0)
        if wp.static(SOLID_ANGLE):
            cone = sphere_cone(sd, c, r, x)
        if cone[0] > 0.0:
            ls = LightSample()
            ls.valid = 0
            axis = (c - x) / cone[1]
            w = frame_to_world(square_to_cone(u, cone[0]), axis)
            # Nearest intersection of the cone direction with the sphere.
            b = wp.dot(c - x, w)
            perp = (c - x) - w * b
            disc = r * r - wp.dot(perp, perp)
            t = b - wp.sqrt(wp.max(0.0, disc))
            y = x + w * t
            ny = wp.normalize(y - c)
            ls.wi = w
            ls.dist = t
            if wp.dot(ny, ls.wi) >= 0.0:
                return ls
            ls.radiance = sd.materials.emission[m]
            ls.pdf = cone_pdf(cone[0])
            ls.valid = 1
            return ls
        ny = square_to_uniform_sphere(u)
        return toward(sd, m, x, c + ny * r, ny, 0.0, 4.0 * PI * sd.spheres.radius[s] * sd.spheres.radius[s])

    @wp.func
    def pdf(sd: SceneData, s: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, prim: int, bounce: int,
            dt: float) -> float:
        d = y - x
        dist2 = wp.dot(d, d)
        cos_l = wp.abs(wp.dot(ny, d)) / wp.sqrt(dist2)
        p = float(0.0)
        c = sphere_center(sd, s, dt)
        r = sd.spheres.radius[s]
        cone = wp.vec2(-1.0, 0.0)
        if wp.static(SOLID_ANGLE):
            cone = sphere_cone(sd, c, r, x)
        if cone[0] > 0.0:
            p = cone_pdf(cone[0])
        elif cos_l > 0.0:
            p = dist2 / (cos_l * 4.0 * PI * r * r)
        return p

    return LightKind(SPHERE, sample, pdf, ("sphere", SOLID_ANGLE, WRONG))
