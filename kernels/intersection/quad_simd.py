"""One ray against many quads, four per vector instruction (the CPU's ray test of lone quads).

Warp's CPU backend compiles scalar code (its JIT does not auto-vectorise), but clang's vector
extensions inside a `wp.func_native` snippet compile to SSE/AVX instructions. The quads the vector
test holds (quad_records.vector_lanes: lone quads and the faces of open boxes) are packed at upload
(`quad_pack`) in blocks of LANES, as structure-of-arrays rows of LANES floats: corner at shutter
open, normal n = edge_u x edge_v, the parameter rows a_u = edge_v x w and a_v = w x edge_u (w = n /
|n|^2, so s = a_u . (p - corner) and t = a_v . (p - corner) are the hit's coordinates along the
edges), the velocity and the quad's index. Every lane is a plane test (t = n . (corner - o) /
n . d, kept when 0 < t < the lane's best so far and s, t lie in [0, 1] within EDGE_TOLERANCE);
each lane keeps its own nearest across the blocks, so the blocks are independent work, and one
reduction at the end picks the nearest t and, among equal ones, the lowest quad index: what a scan
of the quads in index order returns. Padding lanes have n = 0 (0 / 0 is NaN, which no comparison
keeps) and index -1.

Why four lanes: a path's rays form one long chain of dependent work per sample, so what counts is
the test's latency, not its throughput, and the horizontal reductions at the end grow with the
width. Against the scalar tests (`python -m drtlab.experiments.bench.profile_kernels rays`), the
Cornell box's quads took 26-31 ns a ray instead of 50-57 ns; in whole renders (stratified+importance,
1 thread, best of 6 interleaved) 8 lanes made 6 of 13 built-in scenes 3-6% slower, 4 lanes none
(1.00-1.08x; veach-mis 1.20x, aa-edges 1.65x). The scalar grouped tests
(kernels/intersection/scene_rays.py) remain the CUDA path and that of scenes outside
`features.QUAD_SIMD_MIN`..`QUAD_SIMD_MAX` lanes; `#if defined(__CUDA_ARCH__)` keeps a scalar loop
of the same test for a device compile.
"""
import numpy as np
import warp as wp

from drtlab.kernels.intersection.primitives import EDGE_TOLERANCE

LANES = 4
# Rows of a block, in this order (each LANES floats).
FIELDS = ("corner_x", "corner_y", "corner_z", "n_x", "n_y", "n_z", "au_x", "au_y", "au_z",
          "av_x", "av_y", "av_z", "vel_x", "vel_y", "vel_z", "quad")
_BLOCK = len(FIELDS) * LANES

_SNIPPET = r"""
    const float* base = pack.data;
    const float lo = -(float)(TOL), hi = 1.0f + (float)(TOL);
    const float ox = o[0], oy = o[1], oz = o[2];
    const float dx = d[0], dy = d[1], dz = d[2];
#if defined(__CUDA_ARCH__)
    float best_t = tmax;
    int best_i = -1;
    for (int b = 0; b < blocks; ++b) {
        const float* p = base + b * BLOCK;
        for (int l = 0; l < LANES; ++l) {
            float qx = p[l], qy = p[LANES + l], qz = p[2 * LANES + l];
            if (moving) {
                qx += p[12 * LANES + l] * dt; qy += p[13 * LANES + l] * dt; qz += p[14 * LANES + l] * dt;
            }
            const float rx = qx - ox, ry = qy - oy, rz = qz - oz;
            const float nx = p[3 * LANES + l], ny = p[4 * LANES + l], nz = p[5 * LANES + l];
            const float t = (nx * rx + ny * ry + nz * rz) / (nx * dx + ny * dy + nz * dz);
            const float px = t * dx - rx, py = t * dy - ry, pz = t * dz - rz;
            const float s = p[6 * LANES + l] * px + p[7 * LANES + l] * py + p[8 * LANES + l] * pz;
            const float v = p[9 * LANES + l] * px + p[10 * LANES + l] * py + p[11 * LANES + l] * pz;
            if (t > 0.0f && t < best_t && s >= lo && s <= hi && v >= lo && v <= hi) {
                best_t = t;
                best_i = (int)p[15 * LANES + l];
            }
        }
    }
    return wp::vec2(best_t, (float)best_i);
#else
    typedef float vf __attribute__((ext_vector_type(LANES)));
    typedef int vi __attribute__((ext_vector_type(LANES)));
    vf best = (vf)(tmax);
    vf index = (vf)(-1.0f);
    for (int b = 0; b < blocks; ++b) {
        const float* p = base + b * BLOCK;
        vf row[15];
        for (int k = 0; k < 12; ++k) __builtin_memcpy(&row[k], p + k * LANES, sizeof(vf));
        vf qx = row[0], qy = row[1], qz = row[2];
        if (moving) {
            for (int k = 12; k < 15; ++k) __builtin_memcpy(&row[k], p + k * LANES, sizeof(vf));
            qx += row[12] * dt; qy += row[13] * dt; qz += row[14] * dt;
        }
        const vf rx = qx - ox, ry = qy - oy, rz = qz - oz;
        const vf t = (row[3] * rx + row[4] * ry + row[5] * rz) / (row[3] * dx + row[4] * dy + row[5] * dz);
        const vf px = t * dx - rx, py = t * dy - ry, pz = t * dz - rz;
        const vf s = row[6] * px + row[7] * py + row[8] * pz;
        const vf v = row[9] * px + row[10] * py + row[11] * pz;
        const vi keep = (t > 0.0f) & (t < best) & (s >= lo) & (s <= hi) & (v >= lo) & (v <= hi);
        best = keep ? t : best;
        vf quad;
        __builtin_memcpy(&quad, p + 15 * LANES, sizeof(vf));
        index = keep ? quad : index;
    }
    const float best_t = __builtin_reduce_min(best);
    int best_i = -1;
    if (best_t < tmax) {
        // The lanes at the nearest t as a bit mask (a bool vector's bits): one lane is the common
        // case; several (a tie) take the lowest quad index, as a scan in index order would.
        typedef bool vb __attribute__((ext_vector_type(LANES)));
        const vb at_best = __builtin_convertvector(best == best_t, vb);
        unsigned int bits = 0;
        __builtin_memcpy(&bits, &at_best, sizeof(vb));
        bits &= (1u << LANES) - 1u;
        if ((bits & (bits - 1u)) == 0u)
            best_i = (int)index[__builtin_ctz(bits)];
        else
            best_i = (int)__builtin_reduce_min(best == best_t ? index : (vf)(INFINITY));
    }
    return wp::vec2(best_t, (float)best_i);
#endif
"""


def _snippet() -> str:
    return (_SNIPPET.replace("BLOCK", str(_BLOCK)).replace("LANES", str(LANES))
            .replace("TOL", repr(float(EDGE_TOLERANCE))))


@wp.func_native(_snippet())
def quads_nearest(pack: wp.array(dtype=float), blocks: int, o: wp.vec3, d: wp.vec3, tmax: float,
                  moving: int, dt: float) -> wp.vec2:
    """(t, quad index) of the nearest quad hit in (0, tmax), (tmax, -1) if none; quads at their
    position dt after shutter open when `moving`."""
    ...


def quad_pack(index: list, origin: np.ndarray, edge_u: np.ndarray, edge_v: np.ndarray,
              velocity: np.ndarray) -> tuple[np.ndarray, int]:
    """(the float32 blocks, their count) of the quads `index` (ascending), each given by a row of
    the (N, 3) arrays at shutter open; the rows are computed in float64 and rounded once."""
    origin, edge_u, edge_v, velocity = (np.asarray(a, np.float64).reshape(-1, 3)[index]
                                        for a in (origin, edge_u, edge_v, velocity))
    count = len(index)
    blocks = (count + LANES - 1) // LANES
    n = np.cross(edge_u, edge_v)
    w = n / np.maximum((n * n).sum(axis=1), np.finfo(np.float64).tiny)[:, None]
    rows = np.concatenate([origin, n, np.cross(edge_v, w), np.cross(w, edge_u), velocity,
                           np.asarray(index, np.float64)[:, None]], axis=1)
    padded = np.zeros((blocks * LANES, len(FIELDS)))
    padded[:, -1] = -1.0
    padded[:count] = rows
    pack = padded.reshape(blocks, LANES, len(FIELDS)).transpose(0, 2, 1)
    return np.ascontiguousarray(pack, dtype=np.float32).ravel(), blocks
