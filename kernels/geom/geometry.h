#ifndef PPM_GEOMETRY_H
#define PPM_GEOMETRY_H
#include "types.h"

#define PPM_PI 3.14159265358979323846f
#define PPM_INF INFINITY
/* a 4-wide BVH node's float4s (geom/bvh.h's layout, written by bvh_build.cl pack_nodes4;
 * ppm_engine/render/bvh.py BVH_NODE_BYTES) */
#define BVH_NODE 7

inline float max3(float3 v) { return fmax(v.x, fmax(v.y, v.z)); }
inline float luminance(float3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* Offset a ray origin off a surface along n (pointing to the side the ray leaves to), by a
 * number of ULPs that scales with |p| (Waechter & Binder, Ray Tracing Gems ch. 6), and near
 * the axis planes by an absolute amount that scales with the scene: robust at any scale and
 * distance from the origin, unlike one fixed epsilon.  scale: the scene's size, a power of two
 * (ppm_engine/scene/prep.py offset_scale, EmitterInfo.offset_scale): the absolute part is
 * tuned for scenes of size ~1; a 2 mm scene would be offset by 1 % of its size and a 10 km one
 * too little near its axis planes. */
inline float3 offset_ray(float3 p, float3 n, float scale) {
    const float origin = scale / 32.0f, float_scale = scale / 65536.0f, int_scale = 256.0f;
    int3 oi = convert_int3(int_scale * n);
    float3 pi = (float3)(as_float(as_int(p.x) + (p.x < 0.0f ? -oi.x : oi.x)),
                         as_float(as_int(p.y) + (p.y < 0.0f ? -oi.y : oi.y)),
                         as_float(as_int(p.z) + (p.z < 0.0f ? -oi.z : oi.z)));
    return (float3)(fabs(p.x) < origin ? p.x + float_scale * n.x : pi.x,
                    fabs(p.y) < origin ? p.y + float_scale * n.y : pi.y,
                    fabs(p.z) < origin ? p.z + float_scale * n.z : pi.z);
}

/* orthonormal basis around unit n (Duff et al. 2017) */
inline void make_frame(float3 n, float3 *t, float3 *b) {
    float sign = copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = (float3)(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = (float3)(bb, sign + n.y * n.y * a, -n.y);
}

inline float3 to_world_frame(float3 v, float3 n) {
    float3 t, b;
    make_frame(n, &t, &b);
    return v.x * t + v.y * b + v.z * n;
}

/* (sin, cos) of the angle 2 pi u, u in turns (u >= -1/8; the samplers' u in [0, 1]): reduced
 * exactly in turns (4u and its nearest integer are floats) to a quarter turn's multiple and
 * |r| <= pi / 4, then Taylor polynomials (truncation under 2e-9, below float's rounding).  The
 * library's sin and cos reduce any argument (Payne-Hanek): on PoCL they were 8 % of a pass
 * (docs/BENCHMARKS.md, "The builtins inlined"). */
inline float2 sincos_turns(float u) {
    float t = 4.0f * u;
    int q = (int)(t + 0.5f);
    float r = (t - (float)q) * (0.5f * PPM_PI), r2 = r * r;
    /* the Taylor series of sin r and cos r by Horner's rule in r^2 */
    float ps = 1.0f / 120.0f + r2 * (-1.0f / 5040.0f + r2 * (1.0f / 362880.0f));
    float pc = 1.0f / 24.0f + r2 * (-1.0f / 720.0f + r2 * (1.0f / 40320.0f - r2 / 3628800.0f));
    float s = r + r * r2 * (-1.0f / 6.0f + r2 * ps);
    float c = 1.0f + r2 * (-0.5f + r2 * pc);
    /* a quarter turn more: (sin, cos) -> (cos, -sin); a half turn: both negated */
    float2 sc = (q & 1) ? (float2)(c, -s) : (float2)(s, c);
    return (q & 2) ? -sc : sc;
}

inline float3 sample_cosine_hemisphere(float3 n, float u1, float u2) {
    float r = sqrt(u1);
    float2 sc = sincos_turns(u2);
    float3 v = (float3)(r * sc.y, r * sc.x, sqrt(fmax(0.0f, 1.0f - u1)));
    return normalize(to_world_frame(v, n));
}

inline float3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.0f - 2.0f * u1, r = sqrt(fmax(0.0f, 1.0f - z * z));
    float2 sc = sincos_turns(u2);
    return (float3)(r * sc.y, r * sc.x, z);
}

/* uniform direction in the cone of half-angle acos(cos_max) around n */
/* uniform direction in the cone around n with 1 - cos(half angle) = omc: the cone is given by
 * omc, not cos, so that tiny cones (a 1e-6 m light 1 m away, a sun of 0.01 degrees) keep their
 * size in float32 (1 - cos rounds to 0 below ~3e-8) */
inline float3 sample_cone(float3 n, float omc, float u1, float u2) {
    float c = 1.0f - u1 * omc, s = sqrt(fmax(0.0f, u1 * omc * (2.0f - u1 * omc)));
    float2 sc = sincos_turns(u2);
    return normalize(to_world_frame((float3)(s * sc.y, s * sc.x, c), n));
}

/* concentric map of the unit square to the unit disk (Shirley & Chiu) */
inline float2 sample_disk(float u1, float u2) {
    float a = 2.0f * u1 - 1.0f, b = 2.0f * u2 - 1.0f;
    if (a == 0.0f && b == 0.0f) return (float2)(0.0f, 0.0f);
    float r, turns;
    if (fabs(a) > fabs(b)) {
        r = a;
        turns = 0.125f * (b / a);
    } else {
        r = b;
        turns = 0.25f - 0.125f * (a / b);
    }
    float2 sc = sincos_turns(turns);
    return (float2)(r * sc.y, r * sc.x);
}

inline float2 sample_triangle(float u1, float u2) {
    float su = sqrt(u1);
    return (float2)(1.0f - su, u2 * su);   /* barycentrics (b1, b2) of v1, v2 */
}

/* Octahedral unit-vector packing into 2 x 16 bits (for photon records). */
inline uint pack_unit(float3 n) {
    n /= (fabs(n.x) + fabs(n.y) + fabs(n.z));
    float2 e = n.z >= 0.0f ? n.xy
                           : (float2)((1.0f - fabs(n.y)) * copysign(1.0f, n.x),
                                      (1.0f - fabs(n.x)) * copysign(1.0f, n.y));
    uint2 q = convert_uint2_sat_rte((e * 0.5f + 0.5f) * 65535.0f);
    return q.x | (q.y << 16);
}
inline float3 unpack_unit(uint v) {
    float2 e = (float2)((float)(v & 0xffffu), (float)(v >> 16)) * (2.0f / 65535.0f) - 1.0f;
    float3 n = (float3)(e.x, e.y, 1.0f - fabs(e.x) - fabs(e.y));
    float t = fmax(-n.z, 0.0f);
    n.x += n.x >= 0.0f ? -t : t;
    n.y += n.y >= 0.0f ? -t : t;
    return normalize(n);
}
#endif
