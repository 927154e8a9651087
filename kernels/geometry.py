"""Ray-shape intersection and ray-origin offsets (Warp functions shared by every kernel variant)."""
import warp as wp

# Quad parameters within this of [0, 1] count as inside, so rays through a shared edge of two quads
# (a box's edges and corners) hit at least one of them despite rounding.
EDGE_TOLERANCE = wp.constant(1.0e-6)


@wp.struct
class Hit:
    t: float
    p: wp.vec3
    n: wp.vec3          # unit geometric normal: outward for spheres, edge_u x edge_v for quads
    uv: wp.vec2
    material: int
    light: int          # index into the area-light list, -1 if the shape does not emit
    kind: int           # 0 sphere, 1 quad, -1 no hit
    index: int          # index within its kind, -1 no hit


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
def quad_params(rel: wp.vec3, eu: wp.vec3, ev: wp.vec3) -> wp.vec2:
    """(s, t) with rel = s * eu + t * ev for a point in the quad's plane (any parallelogram)."""
    n = wp.cross(eu, ev)
    w = n / wp.dot(n, n)
    return wp.vec2(wp.dot(w, wp.cross(rel, ev)), wp.dot(w, wp.cross(eu, rel)))


@wp.func
def hit_quad(o: wp.vec3, d: wp.vec3, q0: wp.vec3, eu: wp.vec3, ev: wp.vec3, tmax: float) -> float:
    n = wp.cross(eu, ev)
    denom = wp.dot(n, d)
    if denom == 0.0:
        return tmax
    t = wp.dot(n, q0 - o) / denom
    if not (t > 0.0 and t < tmax):
        return tmax
    st = quad_params(o + d * t - q0, eu, ev)
    if st[0] < -EDGE_TOLERANCE or st[0] > 1.0 + EDGE_TOLERANCE:
        return tmax
    if st[1] < -EDGE_TOLERANCE or st[1] > 1.0 + EDGE_TOLERANCE:
        return tmax
    return t


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
