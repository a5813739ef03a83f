/* Progressive radius update per pixel (Hachisuka & Jensen 2009, SPPM):
 *   N' = N + alpha M,  R' = R sqrt(N' / (N + M)),  tau' = (tau + Phi) R'^2 / R^2
 * and the film: radiance = direct / samples + tau / (pi R^2 N_emitted).
 *
 * The film keeps S = tau / R^2 instead of tau: S' = tau' / R'^2 = (tau + Phi) / R^2 = S + Phi /
 * R^2, a plain sum (the same estimate, without the per-pass ratio whose float rounding, applied
 * differently to tau and to R, drifts ~3e-4 of the image in 10,000 passes).  The per-pixel sums
 * (direct: rgb and sample count; S) are accumulated in double where the device has cl_khr_fp64
 * (PPM_FP64), otherwise as float sums with Neumaier compensation: 32 bytes per pixel either
 * way (docs/STABILITY.md: a float32 sum of a constant loses ~1e-5 in 2,000 passes, 1e-4 in
 * 10,000, and stops growing at 2^24 samples). */
#include "builtins.h"
#include "geom/geometry.h"
#include "shared.h"
#include "integrator/pass_state.h"

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
                                 __global float *nstat, __global float4 *tau, float alpha, uint n) {
    uint id = WORK_ITEM();
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

/* The radius schedules (RenderOptions.radius_schedule): */
#define RADIUS_PIXEL 0u  /* the paper's: each pixel's radius from its own photon statistics */
#define RADIUS_GLOBAL 1u /* Knaus & Zwicker 2011 (VCM's): a fixed sequence of the pass count */

/* The renderer's update: S += Phi / R^2 (this pass's R) into the accumulator, then the radius
 * for the next pass.  Either schedule keeps S a plain sum of each pass's estimate at its own
 * radius (the film divides it by the photons emitted); they differ in how R shrinks:
 * - RADIUS_PIXEL: N and R as above, from the photons this pixel gathered (its radius stays
 *   where none arrive).  The statistics follow where the pixel's visible points fell.
 * - RADIUS_GLOBAL: the eye pass set this pass's R, its visible point's footprint times the
 *   pass's factor of the sequence R_{k+1}^2 = R_k^2 (k + alpha) / (k + 1) (k the pass's index
 *   from 1; options.py global_radius_scale): the radius of a pass depends on no other
 *   pass, so each pass's estimate is the radius' blur of the light wherever the sampler placed
 *   the visible point, the blur vanishes as k^((alpha - 1) / 2), and passes rendered apart
 *   (pass ranges, other devices) sum to the same film.  N counts the photons gathered
 *   (adaptive sampling, the "PPM Photons" pass).
 * A radius whose square underflows (or a contribution that overflows) adds nothing: nothing
 * non-finite ever enters the sums.  gathered[id] is overwritten with this pass's photon term
 * (Phi / R^2, 0 when none) for film_add_sample, which counts the pass in moments after this. */
__kernel void film_update(FILM_PARAMS VP_PARAMS float alpha, uint schedule, uint n) {
    FILM_LOAD(film);
    VP_LOAD(vps);
    uint id = WORK_ITEM();
    if (id >= n) return;
    float4 g = vps->gathered[id];
    vps->gathered[id] = (float4)(0.0f);
    float R = film->radius[id];
    if (vps->pos[id].w <= 0.0f || !(g.w > 0.0f)) return;
    float3 phi = vps->beta[id].xyz * g.xyz;
#ifdef PPM_FP64
    double3 s = convert_double3(phi) / ((double)R * (double)R);
    float3 add = convert_float3(s);
#else
    float inv_r = 1.0f / R;
    float3 add = phi * inv_r * inv_r;
#endif
    if (!(R > 0.0f && isfinite(add.x) && isfinite(add.y) && isfinite(add.z))) return;
    if (schedule == RADIUS_GLOBAL) {
        film->nstat[id] += g.w;
    } else {
        float N = film->nstat[id];
        float3 t = (float3)(0.0f);
        ppm_update(alpha, g.w, phi, &N, &R, &t);
        film->nstat[id] = N;
        film->radius[id] = R;
    }
    acc_add(film->photon_sum, id, (float4)(add, 0.0f));
    vps->gathered[id] = (float4)(add, 0.0f);
}

/* End of a pass, per active pixel: direct += this pass's (L, 1) (the eye pass writes (0, 0)
 * for a dropped NaN/Inf sample), lt_sum += this pass's light tracing (photon_pass.cl
 * connect_camera: lt_pass, rgb per pixel, cleared here for the next pass, active or not) and
 * moments += (y, y^2, photons, 1), y the luminance of this pass's sample of the pixel
 * (direct + (photon term / pi + light tracing) / photons): the pixel's own photon count (for
 * film_resolve) and its noise (film_error).  photons: emitted this pass (0: no photon pass,
 * gathered and lt_pass are not read). */
__kernel void film_add_sample(FILM_PARAMS VP_PARAMS uint photons, uint lt, uint n) {
    FILM_LOAD(film);
    VP_LOAD(vps);
    uint id = WORK_ITEM();
    if (id >= n) return;
    float3 l = (float3)(0.0f);
    if (lt && photons) {
        l = vload3(id, film->lt_pass);
        vstore3((float3)(0.0f), id, film->lt_pass);
        if (!(isfinite(l.x) && isfinite(l.y) && isfinite(l.z))) l = (float3)(0.0f);
    }
    if (!film->active[id]) return;
    float4 v = film->direct_pass[id];
    if (v.w > 0.0f) acc_add(film->direct, id, v);
    if (lt && photons) acc_add(film->lt_sum, id, (float4)(l, 0.0f));
    float y = luminance(v.xyz);
    if (photons)
        y += (luminance(vps->gathered[id].xyz) * (1.0f / PPM_PI) + luminance(l))
             * (1.0f / (float)photons);
    acc_add(film->moments, id, (float4)(y, y * y, (float)photons, 1.0f));
}

/* The per-pixel image: (direct mean + (S / pi + the light tracing's sum, lt: there is one) /
 * the photons emitted while the pixel was active, in moments.z: a pixel that converged keeps
 * its value) x the film's exposure; alpha 1 - the mean transparency of its passes (transparent
 * film, eye_pass.cl). */
__kernel void film_resolve(FILM_PARAMS uint lt, float exposure, uint n) {
    FILM_LOAD(film);
    uint id = WORK_ITEM();
    if (id >= n) return;
    acc4 d = acc_get(film->direct, id);
    acc4 c = d.w > 0 ? d / d.w : (acc4)(0);
    acc4 m = acc_get(film->moments, id);
    if (m.z > 0) {
        acc4 s = acc_get(film->photon_sum, id) / PPM_PI;
        if (lt) s += acc_get(film->lt_sum, id);
        c += s / m.z;
    }
    float alpha = m.w > 0 ? 1.0f - clamp(film->transparency[id] / (float)m.w, 0.0f, 1.0f) : 1.0f;
    film->image[id] = (float4)(convert_float3(c.xyz) * exposure, alpha);
}

/* Adaptive sampling, step 1: each pixel's estimated error, the standard error of its mean
 * over passes relative to the square root of its brightness (as Cycles' adaptive sampling:
 * dark pixels need less absolute precision); infinite before min_passes, and while a pixel
 * that gathers photons still has a radius above max_radius x its initial one (passes/update.py
 * ProgressiveUpdate.ADAPTIVE_MAX_RADIUS: the spread does not show the radius' bias). */
__kernel void film_error(FILM_PARAMS float max_radius, uint min_passes, uint n) {
    FILM_LOAD(film);
    uint id = WORK_ITEM();
    if (id >= n) return;
    acc4 m = acc_get(film->moments, id);
    float k = (float)m.w;
    if (k < (float)max(min_passes, 2u)
        || (film->nstat[id] > 0.0f && film->radius[id] > max_radius * film->radius0[id])) {
        film->error[id] = INFINITY;
        return;
    }
    float mean = (float)(m.x / m.w);
    float var = fmax((float)((m.y - m.x * m.x / m.w) / (m.w - 1)), 0.0f);
    film->error[id] = sqrt(var / k) / sqrt(fmax(mean, 1e-4f));
}

/* Step 2: a pixel stays active while any pixel of its 3x3 neighbourhood is above the threshold
 * (an isolated lucky pixel does not stop early); counts the active pixels. */
__kernel void film_converge(FILM_PARAMS int width, int height, float threshold,
                            __global uint *counters) {
    FILM_LOAD(film);
    int id = WORK_ITEM();
    if (id >= width * height) return;
    if (!film->active[id]) return;
    int x = id % width, y = id / width;
    float e = 0.0f;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int xx = clamp(x + dx, 0, width - 1), yy = clamp(y + dy, 0, height - 1);
            e = fmax(e, film->error[yy * width + xx]);
        }
    if (e > threshold) atomic_inc(&counters[CNT_ACTIVE]);
    else film->active[id] = 0u;
}
