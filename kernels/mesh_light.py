"""Emitting triangle meshes (light_sample.py's interface; compiled in by `features.meshes`): a face
picked with probability proportional to its area (MeshData.tri_cdf), then a uniform point on it
(area sampling: the density is 1 / (the mesh's area) everywhere on it) or, where the strategy
samples by solid angle and `triangle_ok`, uniform in its spherical triangle (Arvo 1995). The fault
features.MESH_PDF_HIGH_10PCT claims a density 10% too high."""
import warp as wp

from drtlab.estimators.spherical_maps import triangle_solid_angle
from drtlab.kernels.device_scene import MESH, SceneData
from drtlab.kernels.features import LIGHT_JACOBIAN, MESH_PDF_HIGH_10PCT
from drtlab.kernels.light_sample import LightKind, LightSample, make_toward, spherical_ok


@wp.struct
class TrianglePoint:
    y: wp.vec3
    n: wp.vec3          # the face's unit normal (b - a) x (c - a): the side it emits to
    face: int
    pdf: float          # solid-angle density of y given the mesh (spherical triangle); 0: by area


@wp.struct
class Corners:
    a: wp.vec3
    b: wp.vec3
    c: wp.vec3


@wp.func
def triangle_ok(x: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3, omega: float) -> int:
    n = wp.cross(b - a, c - a)
    h = wp.dot(a - x, n)
    reach2 = wp.max(wp.length_sq(a - x), wp.max(wp.length_sq(b - x), wp.length_sq(c - x)))
    return spherical_ok(omega, h * h, reach2 * wp.dot(n, n))


def make(f, strategy, motion, spherical) -> LightKind:
    mesh_shift = motion.mesh_shift
    SOLID_ANGLE = strategy.solid_angle
    WRONG = LIGHT_JACOBIAN in f.faults
    MIS_AREA = spherical.mis_area
    to_triangle = spherical.maps.square_to_spherical_triangle
    toward = make_toward(WRONG)
    FAULT = MESH_PDF_HIGH_10PCT in f.faults
    # features.MESH_PDF_HIGH_10PCT: the area a mesh light's density is taken from is 10% short.
    MESH_AREA_SCALE = 1.0 / 1.1 if FAULT else 1.0

    @wp.func
    def face_probability(sd: SceneData, s: int, f: int) -> float:
        """The probability sample_triangle picks face f of mesh s."""
        c0 = float(0.0)
        if f > sd.meshes.face0[s]:
            c0 = sd.meshes.tri_cdf[f - 1]
        return sd.meshes.tri_cdf[f] - c0

    @wp.func
    def face_corners(sd: SceneData, f: int, shift: wp.vec3) -> Corners:
        idx = sd.meshes.tri_index[f]
        p = Corners()
        p.a = sd.meshes.points[idx[0]] + shift
        p.b = sd.meshes.points[idx[1]] + shift
        p.c = sd.meshes.points[idx[2]] + shift
        return p

    @wp.func
    def face_solid_angle_pdf(sd: SceneData, s: int, f: int, x: wp.vec3, dt: float) -> float:
        """Solid-angle sampling's density of face f's points given mesh s (the face's probability
        over its solid angle from x), or 0 where the face is area-sampled from x."""
        p = face_corners(sd, f, mesh_shift(sd, s, dt))
        omega = triangle_solid_angle(x, p.a, p.b, p.c)
        if triangle_ok(x, p.a, p.b, p.c, omega) == 1:
            return face_probability(sd, s, f) / (omega * wp.static(MESH_AREA_SCALE))
        return 0.0

    @wp.func
    def sample_triangle(sd: SceneData, s: int, x: wp.vec3, u: wp.vec2, dt: float) -> TrianglePoint:
        """A point on mesh s: the face whose cdf interval holds u[0] (binary search), then u[0]
        rescaled to that interval and u[1] make a uniform point on it (the square-root warp) or,
        solid angle sampling, one uniform in its solid angle from x. The rescaled u[0] keeps
        24 - log2(1 / the face's probability) bits of resolution."""
        lo = sd.meshes.face0[s]
        hi = sd.meshes.face0[s + 1] - 1
        while lo < hi:
            mid = (lo + hi) / 2
            if u[0] < sd.meshes.tri_cdf[mid]:
                hi = mid
            else:
                lo = mid + 1
        c0 = float(0.0)
        if lo > sd.meshes.face0[s]:
            c0 = sd.meshes.tri_cdf[lo - 1]
        u0 = wp.clamp((u[0] - c0) / (sd.meshes.tri_cdf[lo] - c0), 0.0, 1.0)
        p = face_corners(sd, lo, mesh_shift(sd, s, dt))
        a = p.a
        b = p.b
        c = p.c
        tp = TrianglePoint()
        tp.n = wp.normalize(wp.cross(b - a, c - a))
        tp.face = lo
        tp.pdf = 0.0
        if wp.static(SOLID_ANGLE):
            omega = triangle_solid_angle(x, a, b, c)
            if triangle_ok(x, a, b, c, omega) == 1:
                tp.y = to_triangle(x, a, b, c, omega, wp.vec2(u0, u[1]))
                tp.pdf = (sd.meshes.tri_cdf[lo] - c0) / (omega * wp.static(MESH_AREA_SCALE))
                return tp
        su = wp.sqrt(u0)
        b1 = (1.0 - u[1]) * su
        b2 = u[1] * su
        tp.y = a + (b - a) * b1 + (c - a) * b2
        return tp

    @wp.func
    def sample(sd: SceneData, s: int, x: wp.vec3, u: wp.vec2, bounce: int, dt: float) -> LightSample:
        tp = sample_triangle(sd, s, x, u, dt)
        ls = toward(sd, sd.meshes.material[s], x, tp.y, tp.n, tp.pdf,
                    sd.meshes.area[s] * wp.static(MESH_AREA_SCALE))
        ls.prim = tp.face
        return ls

    @wp.func
    def pdf(sd: SceneData, s: int, x: wp.vec3, y: wp.vec3, ny: wp.vec3, prim: int, bounce: int,
            dt: float) -> float:
        d = y - x
        dist2 = wp.dot(d, d)
        cos_l = wp.abs(wp.dot(ny, d)) / wp.sqrt(dist2)
        p = float(0.0)
        if cos_l > 0.0:
            p = dist2 / (cos_l * (sd.meshes.area[s] * wp.static(MESH_AREA_SCALE)))
        if wp.static(SOLID_ANGLE and not MIS_AREA):
            sa = face_solid_angle_pdf(sd, s, prim, x, dt)
            if sa > 0.0:
                p = sa
        return p

    return LightKind(MESH, sample, pdf, ("mesh", SOLID_ANGLE, WRONG, FAULT, MIS_AREA, spherical.linear))
