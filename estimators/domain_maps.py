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


@wp.func
def square_to_disk(u: wp.vec2) -> wp.vec2:
    # Shirley-Chiu concentric map: area-preserving and continuous, keeps strata compact on the disk.
    a = 2.0 * u[0] - 1.0
    b = 2.0 * u[1] - 1.0
    if a == 0.0 and b == 0.0:
        return wp.vec2(0.0, 0.0)
    r = float(0.0)
    phi = float(0.0)
    if wp.abs(a) > wp.abs(b):
        r = a
        phi = (PI * 0.25) * (b / a)
    else:
        r = b
        phi = PI * 0.5 - (PI * 0.25) * (a / b)
    return wp.vec2(r * wp.cos(phi), r * wp.sin(phi))


@wp.func
def square_to_uniform_hemisphere(u: wp.vec2) -> wp.vec3:
    z = u[0]
    r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
    phi = 2.0 * PI * u[1]
    return wp.vec3(r * wp.cos(phi), r * wp.sin(phi), z)


@wp.func
def uniform_hemisphere_pdf(cos_theta: float) -> float:
    if cos_theta < 0.0:
        return 0.0
    return INV_2PI


@wp.func
def square_to_uniform_sphere(u: wp.vec2) -> wp.vec3:
    z = 1.0 - 2.0 * u[0]
    r = wp.sqrt(wp.max(0.0, 1.0 - z * z))
    phi = 2.0 * PI * u[1]
    return wp.vec3(r * wp.cos(phi), r * wp.sin(phi), z)


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
    phi = 2.0 * PI * u[1]
    return wp.vec3(sin_a * wp.cos(phi), sin_a * wp.sin(phi), cos_a)


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
    phi = 2.0 * PI * u[1]
    return wp.vec3(sin_t * wp.cos(phi), sin_t * wp.sin(phi), cos_t)


@wp.func
def cone_pdf(one_minus_cos_max: float) -> float:
    return INV_2PI / one_minus_cos_max
