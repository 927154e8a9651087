"""Ray-shape intersection and ray-origin offsets (Warp functions shared by every kernel variant)."""
import warp as wp

# Quad parameters within this of [0, 1] count as inside, so rays through a shared edge of two quads
# (a box's edges and corners) hit at least one of them despite rounding.
EDGE_TOLERANCE = wp.constant(1.0e-6)


@wp.struct
class Hit:
    t: float
    p: wp.vec3
    n: wp.vec3          # unit geometric normal: outward for spheres, edge_u x edge_v for quads,
                        # (b - a) x (c - a) for a mesh triangle (a, b, c)
    ns: wp.vec3         # unit shading normal (Features.meshes only): n, or a mesh's interpolated
                        # vertex normal turned to n's side
    uv: wp.vec2
    material: int
    light: int          # index into the area-light list, -1 if the shape does not emit
    kind: int           # 0 sphere, 1 quad, 2 mesh triangle, -1 no hit
    index: int          # index within its kind (a triangle: in the per-face arrays), -1 no hit


@wp.struct
class QuadGeom:
    """What a ray test reads of a quad, in one record (kernels/intersection/quad_records.py fills it at upload)."""
    origin: wp.vec3     # at shutter open
    edge_u: wp.vec3
    edge_v: wp.vec3
    cross: wp.vec3      # edge_u x edge_v, unnormalised
    basis: wp.vec3      # quad_basis(cross)


@wp.func
def hit_sphere(o: wp.vec3, d: wp.vec3, c: wp.vec3, r: float, tmax: float) -> float:
    """Nearest t in (0, tmax) where the unit-direction ray meets the sphere, else tmax.

    Uses the form of Haines et al. (Ray Tracing Gems ch. 7): the discriminant from the distance of
    the centre to the ray, and the smaller root from the product of the roots, which stays accurate
    for small spheres far away and for rays starting on or inside the sphere.
    """
    f = o - c
    b = -wp.dot(f, d)
    l = f + d * b
    disc = r * r - wp.dot(l, l)
    if disc < 0.0:
        return tmax
    sq = wp.sqrt(disc)
    q = b + sq
    if b < 0.0:
        q = b - sq
    if q == 0.0:
        return tmax
    c2 = wp.dot(f, f) - r * r
    t0 = c2 / q
    t1 = q
    if t0 > t1:
        tmp = t0
        t0 = t1
        t1 = tmp
    if t0 > 0.0 and t0 < tmax:
        return t0
    if t1 > 0.0 and t1 < tmax:
        return t1
    return tmax


@wp.func
def sphere_uv(local: wp.vec3) -> wp.vec2:
    """Mitsuba 3's uv of a sphere (src/shapes/sphere.cpp) at the unit direction `local` in its own
    frame: u = atan2(y, x) / 2 pi in [0, 1) (u = 0 towards +x, turning towards +y), v = acos(z) / pi
    (v = 0 at the +z pole)."""
    phi = wp.atan2(local[1], local[0])
    if phi < 0.0:
        phi += 2.0 * wp.pi
    return wp.vec2(phi * (0.5 / wp.pi), wp.acos(wp.clamp(local[2], -1.0, 1.0)) * (1.0 / wp.pi))


@wp.func
def quad_basis(n: wp.vec3) -> wp.vec3:
    """w = n / |n|^2 for n = edge_u x edge_v: (s, t) = (w . (rel x edge_v), w . (edge_u x rel))."""
    return n / wp.dot(n, n)


@wp.func
def param_s(rel: wp.vec3, ev: wp.vec3, w: wp.vec3) -> float:
    """s of rel = s * eu + t * ev for a point in the quad's plane, w = quad_basis(eu x ev)."""
    return wp.dot(w, wp.cross(rel, ev))


@wp.func
def param_t(rel: wp.vec3, eu: wp.vec3, w: wp.vec3) -> float:
    """t of rel = s * eu + t * ev (see param_s)."""
    return wp.dot(w, wp.cross(eu, rel))


@wp.func
def quad_params_w(rel: wp.vec3, eu: wp.vec3, ev: wp.vec3, w: wp.vec3) -> wp.vec2:
    """(s, t) with rel = s * eu + t * ev in the quad's plane, w = quad_basis(eu x ev)."""
    return wp.vec2(param_s(rel, ev, w), param_t(rel, eu, w))


@wp.func
def quad_params(rel: wp.vec3, eu: wp.vec3, ev: wp.vec3) -> wp.vec2:
    """(s, t) with rel = s * eu + t * ev for a point in the quad's plane (any parallelogram)."""
    return quad_params_w(rel, eu, ev, quad_basis(wp.cross(eu, ev)))


@wp.func
def hit_quad_nw(o: wp.vec3, d: wp.vec3, q0: wp.vec3, eu: wp.vec3, ev: wp.vec3, n: wp.vec3,
                w: wp.vec3, tmax: float) -> float:
    """hit_quad with the quad's n = eu x ev and w = quad_basis(n) given (precomputed at upload)."""
    denom = wp.dot(n, d)
    if denom == 0.0:
        return tmax
    num = wp.dot(n, q0 - o)
    # t = num / denom <= 0 (behind the origin) without the division: exactly when this is true.
    if num == 0.0 or (num > 0.0) != (denom > 0.0):
        return tmax
    t = num / denom
    if not (t > 0.0 and t < tmax):
        return tmax
    rel = o + d * t - q0
    s = param_s(rel, ev, w)
    if s < -EDGE_TOLERANCE or s > 1.0 + EDGE_TOLERANCE:
        return tmax
    v = param_t(rel, eu, w)
    if v < -EDGE_TOLERANCE or v > 1.0 + EDGE_TOLERANCE:
        return tmax
    return t


@wp.func
def hit_quad(o: wp.vec3, d: wp.vec3, q0: wp.vec3, eu: wp.vec3, ev: wp.vec3, tmax: float) -> float:
    """Nearest t in (0, tmax) where the ray meets the parallelogram q0 + [0, 1] eu + [0, 1] ev."""
    n = wp.cross(eu, ev)
    return hit_quad_nw(o, d, q0, eu, ev, n, quad_basis(n), tmax)


@wp.func
def may_hit_ball(o: wp.vec3, d: wp.vec3, ball: wp.vec4, tmax: float) -> int:
    """0 only when the unit-direction ray surely misses the ball (center xyz, radius w) within
    (0, tmax): a cheap test before a costlier one of what the ball bounds. The slack (1e-5 of the
    distances involved) is far above the rounding of these few operations, so a ray that could hit
    is never turned away."""
    oc = wp.vec3(ball[0], ball[1], ball[2]) - o
    r = ball[3]
    b = wp.dot(oc, d)
    oc2 = wp.dot(oc, oc)
    if oc2 - b * b > r * r + 1.0e-5 * oc2:
        return 0                    # the line passes outside the ball
    slack = r + 2.0e-5 * (wp.abs(oc[0]) + wp.abs(oc[1]) + wp.abs(oc[2]))
    if b + slack < 0.0 or b - slack > tmax:
        return 0                    # the ball lies behind the origin or beyond tmax
    return 1


# hit_box's rank of a face slot without a face.
BOX_NO_FACE = wp.constant(7)


@wp.struct
class BoxHit:
    t: float
    slot: int           # the face met: 2 * axis + side (side 1 at local coordinate 1), -1 none


@wp.func
def box_face(bounds: wp.vec3, t: float, flip: wp.vec3i, leaving: int, rank: int) -> int:
    """The slot of the face where a slab bound equals t, the first in quad order on a tie (a ray
    through an edge); -1 when that face does not exist."""
    slot = int(-1)
    best = int(BOX_NO_FACE)
    for k in range(3):
        if bounds[k] == t:
            s = 2 * k + (flip[k] ^ leaving)
            r = (rank >> (3 * s)) & 7
            if r < best:
                best = r
                slot = s
    return slot


@wp.func
def hit_box(o: wp.vec3, d: wp.vec3, corner: wp.vec3, inverse: wp.mat33, rank: int,
            tmax: float) -> BoxHit:
    """First t in (0, tmax) where the ray meets an existing face of the parallelepiped
    {corner + M [0, 1]^3} (inverse = M^-1). `rank` holds 3 bits per face slot k (at bit 3 k): the
    face's place in the scene's quad order, BOX_NO_FACE where the face does not exist."""
    return slab_hit(inverse * (o - corner), inverse * d, rank, tmax)


@wp.func
def slab_hit(lo: wp.vec3, ld: wp.vec3, rank: int, tmax: float) -> BoxHit:
    """hit_box in the box's coordinates, where it is [0, 1]^3: the ray lo + t ld.

    Slab test (t is unchanged by the linear map to these coordinates): a ray meets a convex solid's
    boundary where it enters and where it leaves, so the first existing face is the entry face if
    it exists and lies ahead, else the exit face. No gaps at edges and corners; a ray through an
    edge meets both faces at one t and gets the one first in quad order, as a scan of the quads
    would. A ray parallel to a slab gives infinite bounds; a NaN bound (a ray exactly in a face's
    plane) constrains nothing."""
    t_near = float(-1.0e30)
    t_far = float(1.0e30)
    enter = wp.vec3()
    leave = wp.vec3()
    flip = wp.vec3i()
    for k in range(3):
        inv = 1.0 / ld[k]
        ta = -lo[k] * inv
        tb = (1.0 - lo[k]) * inv
        if ta > tb:
            tmp = ta
            ta = tb
            tb = tmp
            flip[k] = 1
        enter[k] = ta
        leave[k] = tb
        if ta > t_near:
            t_near = ta
        if tb < t_far:
            t_far = tb
    h = BoxHit()
    h.t = tmax
    h.slot = -1
    if t_near <= t_far:
        if t_near > 0.0 and t_near < tmax:
            h.slot = box_face(enter, t_near, flip, 0, rank)
            if h.slot >= 0:
                h.t = t_near
        if h.slot < 0 and t_far > 0.0 and t_far < tmax:
            h.slot = box_face(leave, t_far, flip, 1, rank)
            if h.slot >= 0:
                h.t = t_far
    return h


@wp.func
def shading_consistent(ng: wp.vec3, ns: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    """1 when the shading normal ns and the geometric normal ng agree on whether wo -> wi is a
    reflection or a transmission, else 0. A BSDF evaluated about an interpolated normal otherwise
    reflects light through the geometric surface (a leak) or transmits it back out at grazing
    angles; f is zero there instead, in evaluation (light samples) and in sampling alike, so the
    density a sample carries stays that of the proposal and MIS stays consistent."""
    shading = wp.dot(ns, wo) * wp.dot(ns, wi) > 0.0
    geometric = wp.dot(ng, wo) * wp.dot(ng, wi) > 0.0
    if shading == geometric:
        return 1.0
    return 0.0


@wp.func
def offset_origin(p: wp.vec3, n: wp.vec3, wi: wp.vec3, eps: float) -> wp.vec3:
    """Move a new ray's origin off the surface, to the side wi leaves on.

    The offset scales with the scene (eps, set from its extent) and with |p| (float32 rounding of a
    hit point grows with its magnitude), so scenes at 1e-3 and 1e4 scale behave alike.
    """
    m = wp.max(wp.abs(p[0]), wp.max(wp.abs(p[1]), wp.abs(p[2])))
    off = eps + 2.0e-6 * m
    if wp.dot(n, wi) < 0.0:
        off = -off
    return p + n * off
