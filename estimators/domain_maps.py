"""Warps from [0, 1)^2 to directions and points, each with the density it claims.

Local frames are z-up; `frame_to_world` rotates a local vector into the frame of a unit axis. Every
`*_pdf` is the density (per unit solid angle or area) of the matching `square_to_*` warp, so the
chi-square tests and MIS can call it on its own.
"""
import warp as wp

PI = wp.constant(3.14159265358979323846)
INV_PI = wp.constant(0.31830988618379067154)
INV_2PI = wp.constant(0.15915494309189533577)
INV_4PI = wp.constant(0.07957747154594766788)


@wp.func
def facing(n: wp.vec3, w: wp.vec3) -> wp.vec3:
    """The normal n turned to w's side (n itself where w lies in the plane)."""
    if wp.dot(n, w) < 0.0:
        return -n
    return n


@wp.func
def mirror_dir(n: wp.vec3, w: wp.vec3) -> wp.vec3:
    """w reflected about the line of n (either side of the surface)."""
    return 2.0 * wp.dot(n, w) * n - w


@wp.func
def cosine_pdf(n: wp.vec3, wo: wp.vec3, wi: wp.vec3) -> float:
    """Density of the cosine lobe about n on wo's side at wi (0 on the other side)."""
    cos_i = wp.dot(n, wi)
    p = float(0.0)
    if wp.dot(n, wo) * cos_i > 0.0:
        p = wp.abs(cos_i) * INV_PI
    return p


@wp.func
def frame_to_world(v: wp.vec3, n: wp.vec3) -> wp.vec3:
    # Duff et al. 2017: branch-free orthonormal basis, continuous except on the -z pole.
    s = 1.0
    if n[2] < 0.0:
        s = -1.0
    a = -1.0 / (s + n[2])
    b = n[0] * n[1] * a
    t = wp.vec3(1.0 + s * n[0] * n[0] * a, s * b, -s * n[0])
    bt = wp.vec3(b, s + n[1] * n[1] * a, -n[1])
    return t * v[0] + bt * v[1] + n * v[2]


# Sines and cosines of the maps below come from polynomials on [-pi/4, pi/4] (Cephes' sinf/cosf
# minimax coefficients, ~1 ulp there), not from libm: the maps know their angle in that range or
# in turns (2 pi u), so no costly range reduction is needed, and libm's sincosf call was 6% of a
# diffuse path-traced render (perf, Cornell box).
@wp.func
def sincos_octant(x: float) -> wp.vec2:
    """(cos x, sin x) for |x| <= pi / 4."""
    z = x * x
    s = ((-1.9515295891e-4 * z + 8.3321608736e-3) * z - 1.6666654611e-1) * z * x + x
    c = ((2.443315711809948e-5 * z - 1.388731625493765e-3) * z + 4.166664568298827e-2) * z * z \
        - 0.5 * z + 1.0
    return wp.vec2(c, s)


@wp.func
def sincos_turns(u: float) -> wp.vec2:
    """(cos 2 pi u, sin 2 pi u) for u in [0, 1]: u's octant is exact in turns, the angle within
    it goes to sincos_octant, and the octant's symmetry maps the result back."""
    t = u * 8.0
    k = int(wp.floor(t))
    f = t - float(k)
    # Octants 2j and 2j + 1 share the quarter turn j: angle j pi/2 + y, y in [0, pi/2), with y
    # = f pi/4 (even) or pi/2 - (1 - f) pi/4 (odd; the polynomial's argument stays in range).
    cs = wp.vec2()
    if k % 2 == 0:
        cs = sincos_octant(f * (PI * 0.25))
    else:
        r = sincos_octant((1.0 - f) * (PI * 0.25))
        cs = wp.vec2(r[1], r[0])
    j = (k / 2) % 4
    if j == 1:
        cs = wp.vec2(-cs[1], cs[0])
    elif j == 2:
        cs = wp.vec2(-cs[0], -cs[1])
    elif j == 3:
        cs = wp.vec2(cs[1], -cs[0])
    return cs


@wp.func
def square_to_disk(u: wp.vec2) -> wp.vec2:
    # Shirley-Chiu concentric map: area-preserving and continuous, keeps strata compact on the disk.
    a = 2.0 * u[0] - 1.0
    b = 2.0 * u[1] - 1.0
    if a == 0.0 and b == 0.0:
        return wp.vec2(0.0, 0.0)
    # phi = pi/4 (b / a) when |a| > |b|, else pi/2 - pi/4 (a / b): (cos, sin) swap for the latter.
    if wp.abs(a) > wp.abs(b):
        cs = sincos_octant((PI * 0.25) * (b / a))
        return wp.vec2(a * cs[0], a * cs[1])
    cs = sincos_octant((PI * 0.25) * (a / b))
    return wp.vec2(b * cs[1], b * cs[0])


@wp.func
def square_to_uniform_hemisphere(u: wp.vec2) -> wp.vec3:
    z = u[0]
    r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
    cs = sincos_turns(u[1])
    return wp.vec3(r * cs[0], r * cs[1], z)


@wp.func
def uniform_hemisphere_pdf(cos_theta: float) -> float:
    if cos_theta < 0.0:
        return 0.0
    return INV_2PI


@wp.func
def square_to_uniform_sphere(u: wp.vec2) -> wp.vec3:
    z = 1.0 - 2.0 * u[0]
    r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
    cs = sincos_turns(u[1])
    return wp.vec3(r * cs[0], r * cs[1], z)


@wp.func
def square_to_cosine_hemisphere(u: wp.vec2) -> wp.vec3:
    d = square_to_disk(u)
    z = wp.sqrt(wp.max(0.0, 1.0 - d[0] * d[0] - d[1] * d[1]))
    return wp.vec3(d[0], d[1], z)


@wp.func
def cosine_hemisphere_pdf(cos_theta: float) -> float:
    return wp.max(cos_theta, 0.0) * INV_PI


@wp.func
def one_minus_exp(t: float) -> float:
    # 1 - exp(t) for t <= 0 without cancellation near 0 (a Phong exponent of 1e6 gives t ~ -1e-6).
    if t > -1.0e-3:
        return -t * (1.0 + t * (0.5 + t * (1.0 / 6.0)))
    return 1.0 - wp.exp(t)


@wp.func
def square_to_phong_lobe(u: wp.vec2, exponent: float) -> wp.vec3:
    # cos(alpha) = (1 - u)^(1 / (n + 1)); 1 - u lies in (0, 1] so the log is finite.
    t = wp.log(1.0 - u[0]) / (exponent + 1.0)
    cos_a = wp.exp(t)
    one_minus_cos = one_minus_exp(t)
    sin_a = wp.sqrt(wp.max(0.0, one_minus_cos * (1.0 + cos_a)))
    cs = sincos_turns(u[1])
    return wp.vec3(sin_a * cs[0], sin_a * cs[1], cos_a)


@wp.func
def phong_lobe_pdf(cos_a: float, exponent: float) -> float:
    if cos_a <= 0.0:
        return 0.0
    return (exponent + 1.0) * INV_2PI * wp.pow(cos_a, exponent)


@wp.func
def square_to_cone(u: wp.vec2, one_minus_cos_max: float) -> wp.vec3:
    # Uniform in the cone; 1 - cos(theta) is carried directly so tiny cones keep their spread.
    omc = u[0] * one_minus_cos_max
    cos_t = 1.0 - omc
    sin_t = wp.sqrt(wp.max(0.0, omc * (2.0 - omc)))
    cs = sincos_turns(u[1])
    return wp.vec3(sin_t * cs[0], sin_t * cs[1], cos_t)


@wp.func
def cone_pdf(one_minus_cos_max: float) -> float:
    return INV_2PI / one_minus_cos_max
