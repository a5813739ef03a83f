/* Progressive radius update per pixel (Hachisuka & Jensen 2009, SPPM):
 *   N' = N + alpha M,  R' = R sqrt(N' / (N + M)),  tau' = (tau + Phi) R'^2 / R^2
 * and the film: radiance = direct / samples + tau / (pi R^2 N_emitted). */
#include "geometry.h"

inline void ppm_update(float alpha, float M, float3 phi, float *N, float *R, float3 *tau) {
    float n_new = *N + alpha * M;
    float ratio = n_new / (*N + M);      /* = R'^2 / R^2 */
    *R = *R * sqrt(ratio);
    *tau = (*tau + phi) * ratio;
    *N = n_new;
}

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

/* inv_pi_emitted = 1 / (pi * photons emitted so far), computed in double on the host */
__kernel void film_resolve(__global const float4 *direct, __global const float4 *tau,
                           __global const float *radius, float inv_pi_emitted,
                           __global float4 *image, uint n) {
    uint id = get_global_id(0);
    if (id >= n) return;
    float4 dsum = direct[id];
    float3 c = dsum.w > 0.0f ? dsum.xyz / dsum.w : (float3)(0.0f);
    float R = radius[id];
    if (R > 0.0f && inv_pi_emitted > 0.0f) c += tau[id].xyz * (inv_pi_emitted / (R * R));
    image[id] = (float4)(c, 1.0f);
}
