/* Progressive radius update per pixel (Hachisuka & Jensen 2009, SPPM):
 *   N' = N + alpha M,  R' = R sqrt(N' / (N + M)),  tau' = (tau + Phi) R'^2 / R^2
 * and the film: radiance = direct / samples + tau / (pi R^2 N_emitted).
 *
 * The film keeps S = tau / R^2 instead of tau: S' = tau' / R'^2 = (tau + Phi) / R^2 = S + Phi / R^2,
 * a plain sum (the same estimate, without the per-pass ratio whose float rounding, applied
 * differently to tau and to R, drifts ~3e-4 of the image in 10,000 passes).  The per-pixel sums
 * (direct: rgb and sample count; S) are accumulated in double where the device has cl_khr_fp64
 * (PPM_FP64), otherwise as float sums with Neumaier compensation: 32 bytes per pixel either
 * way (docs/STABILITY.md: a float32 sum of a constant loses ~1e-5 in 2,000 passes, 1e-4 in
 * 10,000, and stops growing at 2^24 samples). */
#include "geometry.h"

#ifdef PPM_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double4 acc4;
inline void acc_add(__global float4 *acc, uint id, float4 v) {
    __global double4 *a = (__global double4 *)acc;
    a[id] += convert_double4(v);
}
inline acc4 acc_get(__global const float4 *acc, uint id) {
    return ((__global const double4 *)acc)[id];
}
#else
typedef float4 acc4;
/* Neumaier's compensated sum: acc[2 id] = running sum, acc[2 id + 1] = lost low-order part */
inline void acc_add(__global float4 *acc, uint id, float4 v) {
    float4 s = acc[2 * id], c = acc[2 * id + 1];
    float4 t = s + v;
    c += select((v - t) + s, (s - t) + v, isgreaterequal(fabs(s), fabs(v)));
    acc[2 * id] = t;
    acc[2 * id + 1] = c;
}
inline acc4 acc_get(__global const float4 *acc, uint id) { return acc[2 * id] + acc[2 * id + 1]; }
#endif

inline void ppm_update(float alpha, float M, float3 phi, float *N, float *R, float3 *tau) {
    float n_new = *N + alpha * M;
    float ratio = n_new / (*N + M);      /* = R'^2 / R^2 */
    *R = *R * sqrt(ratio);
    *tau = (*tau + phi) * ratio;
    *N = n_new;
}

/* The closed form on (N, R, tau) buffers (tests/test_kernels.py); the renderer uses film_update. */
__kernel void progressive_update(__global const float4 *vp_pos, __global const float4 *vp_beta,
                                 __global const float4 *gathered, __global float *radius,
                                 __global float *nstat, __global float4 *tau, float alpha,
                                 uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 g = gathered[id];
    if (vp_pos[id].w <= 0.0f || !(g.w > 0.0f)) return;
    float3 phi = vp_beta[id].xyz * g.xyz;
    if (!(isfinite(phi.x) && isfinite(phi.y) && isfinite(phi.z))) return;
    float N = nstat[id], R = radius[id];
    float3 t = tau[id].xyz;
    ppm_update(alpha, g.w, phi, &N, &R, &t);
    nstat[id] = N;
    radius[id] = R;
    tau[id] = (float4)(t, 0.0f);
}

/* The renderer's update: N and R as above, S += Phi / R^2 (old R) into the accumulator.
 * A radius whose square underflows (or a contribution that overflows) leaves the pixel as it
 * is: nothing non-finite ever enters the sums. */
__kernel void film_update(__global const float4 *vp_pos, __global const float4 *vp_beta,
                          __global const float4 *gathered, __global float *radius,
                          __global float *nstat, __global float4 *photon_sum, float alpha,
                          uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 g = gathered[id];
    if (vp_pos[id].w <= 0.0f || !(g.w > 0.0f)) return;
    float3 phi = vp_beta[id].xyz * g.xyz;
    float N = nstat[id], R = radius[id];
#ifdef PPM_FP64
    double3 s = convert_double3(phi) / ((double)R * (double)R);
    float3 add = convert_float3(s);
#else
    float inv_r = 1.0f / R;
    float3 add = phi * inv_r * inv_r;
#endif
    if (!(R > 0.0f && isfinite(add.x) && isfinite(add.y) && isfinite(add.z))) return;
    float3 t = (float3)(0.0f);
    ppm_update(alpha, g.w, phi, &N, &R, &t);
    nstat[id] = N;
    radius[id] = R;
    acc_add(photon_sum, id, (float4)(add, 0.0f));
}

/* direct += this pass's (L, 1) (the eye pass writes (0, 0) for a dropped NaN/Inf sample) */
__kernel void film_add_direct(__global const float4 *direct_pass, __global float4 *direct,
                              uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 v = direct_pass[id];
    if (v.w > 0.0f) acc_add(direct, id, v);
}

/* inv_pi_emitted = 1 / (pi * photons emitted so far), computed in double on the host */
__kernel void film_resolve(__global const float4 *direct, __global const float4 *photon_sum,
                           float inv_pi_emitted, __global float4 *image, uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    acc4 d = acc_get(direct, id);
    acc4 c = d.w > 0 ? d / d.w : (acc4)(0);
    if (inv_pi_emitted > 0.0f) c += acc_get(photon_sum, id) * inv_pi_emitted;
    image[id] = (float4)(convert_float3(c.xyz), 1.0f);
}
