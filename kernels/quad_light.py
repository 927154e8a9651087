"""Quad lights (light_sample.py's interface): a rectangle by its spherical rectangle (Urena et al.
2013) where the strategy samples by solid angle and it pays (`rect_to_sample`, lights.py's rules),
else, and for quads that are not rectangles, points uniform on its area."""
import warp as wp

from drtlab.estimators.spherical_maps import SphericalRect, spherical_rect
from drtlab.kernels.device_scene import QUAD, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN
from drtlab.kernels.light_sample import RECTANGLE_COS, LightKind, LightSample, make_toward, spherical_ok


@wp.func
def rect_ok(r: SphericalRect) -> int:
    reach2 = wp.max(r.x0 * r.x0, r.x1 * r.x1) + wp.max(r.y0 * r.y0, r.y1 * r.y1) + r.z0 * r.z0
    return spherical_ok(r.solid_angle, r.z0 * r.z0, reach2)


@wp.func
def is_rectangle(u: wp.vec3, v: wp.vec3) -> int:
    uv = wp.dot(u, v)
    if uv * uv <= wp.static(RECTANGLE_COS * RECTANGLE_COS) * wp.dot(u, u) * wp.dot(v, v):
        return 1
    return 0


def make(f, strategy, motion, spherical) -> LightKind:
    quad_origin = motion.quad_origin
    SOLID_ANGLE = strategy.solid_angle
    WRONG = LIGHT_JACOBIAN in f.faults
    PAYS = spherical.pays
    MAX_BOUNCE = spherical.max_bounce
    MIS_AREA = spherical.mis_area
    MIS_FIRST_VERTEX = spherical.mis_first_vertex
    to_rect = spherical.maps.square_to_spherical_rect
    toward = make_toward(WRONG)

    @wp.func
    def rect_pays(x: wp.vec3, q0: wp.vec3, u: wp.vec3, v: wp.vec3, n: wp.vec3, area: float,
                  bounce: int) -> int:
        """Whether the rectangle q0 + s u + t v (unit normal n, area A) is worth solid-angle
        sampling from x, a vertex of bounce index `bounce`: bounce <= SPHERICAL_MAX_BOUNCE and
        A cos_l / d^2 at its centre reaches SPHERICAL_PAYS. Tested before, and deciding whether,
        the spherical rectangle is built."""
        if bounce > wp.static(MAX_BOUNCE):
            return 0
        c = q0 + (u + v) * 0.5 - x
        d2 = wp.dot(c, c)
        if area * wp.abs(wp.dot(c, n)) >= wp.static(PAYS) * d2 * wp.sqrt(d2):
            return 1
        return 0

    @wp.func
    def rect_to_sample(sd: SceneData, s: int, x: wp.vec3, q0: wp.vec3, bounce: int) -> SphericalRect:
        """The spherical rectangle by which quad s (origin q0 now) is sampled from x, a vertex of
        bounce index `bounce`, or one of solid angle 0: sampled by area. The one place that decides:
        sample draws by it and pdf gives its density, and MIS is unbiased only while the two agree."""
        uu = sd.quads.u[s]
        vv = sd.quads.v[s]
        out = SphericalRect()
        if is_rectangle(uu, vv) == 1 and rect_pays(x, q0, uu, vv, sd.quads.normal[s], sd.quads.area[s],
                                                   bounce) == 1:
            rect = spherical_rect(x, q0, uu, vv)
            if rect_ok(rect) == 1:
                out = rect
        return out

    @wp.func
    def sample(sd: SceneData, s: int, x: wp.vec3, u: wp.vec2, bounce: int, dt: float) -> LightSample:
        q0 = quad_origin(sd, s, dt)
        y = wp.vec3(0.0)
        sa = float(0.0)             # the solid-angle density, 0: area-sampled
        if wp.static(SOLID_ANGLE):
            rect = rect_to_sample(sd, s, x, q0, bounce)
            if rect.solid_angle > 0.0:
                y = to_rect(rect, x, u)
                sa = 1.0 / rect.solid_angle
        if sa == 0.0:
            y = q0 + sd.quads.u[s] * u[0] + sd.quads.v[s] * u[1]
        return toward(sd, sd.quads.material[s], x, y, sd.quads.normal[s], sa, sd.quads.area[s])

    @wp.func
    def pdf(sd: SceneData, s: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, prim: int, bounce: int,
            dt: float) -> float:
        d = y - x
        dist2 = wp.dot(d, d)
        cos_l = wp.abs(wp.dot(ny, d)) / wp.sqrt(dist2)
        p = float(0.0)
        if cos_l > 0.0:
            p = dist2 / (cos_l * sd.quads.area[s])
        if wp.static(SOLID_ANGLE and not MIS_AREA):
            b = bounce
            if wp.static(MIS_FIRST_VERTEX):
                b = 0
            rect = rect_to_sample(sd, s, x, quad_origin(sd, s, dt), b)
            if rect.solid_angle > 0.0:
                p = 1.0 / rect.solid_angle
        return p

    return LightKind(QUAD, sample, pdf, ("quad", SOLID_ANGLE, WRONG, PAYS, MAX_BOUNCE, MIS_AREA,
                                         MIS_FIRST_VERTEX, spherical.linear))
