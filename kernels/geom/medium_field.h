#ifndef PPM_MEDIUM_FIELD_H
#define PPM_MEDIUM_FIELD_H
#include "rng.h"
#include "svm/svm.h"
#include "geom/medium.h"
#include "geom/volume_grid.h"
#include "integrator/path_state.h"

/* Heterogeneous media (PPM_VOLUME with PPM_SVM; docs/VOLUMES.md): a medium whose Density is
 * driven by nodes (export/material_volume.py) has a density program, evaluated at a point in
 * the space of the object it is bound to (its Object and Generated coordinates, a Volume
 * object's grids as its attributes: geom/volume_grid.h), that scales its absorption and
 * scattering there (its emission is not scaled, as Cycles' Principled Volume's).  Its majorant
 * (Material.majorant, a bound of the density over the object's box found on the device by
 * render/medium_bound.py, or a grid's largest voxel) sets the rate of tentative collisions: null
 * scattering (Woodcock tracking), with weights (Kutz et al. 2017, "Spectral and Decomposition
 * Tracking") so that chromatic coefficients and a density above the majorant stay unbiased.
 * A homogeneous medium takes none of this (geom/medium.h's closed forms). */
#if PPM_VOLUME
/* the most tentative collisions one segment tracks (a denser one is cut there: its weight 0) */
#define MEDIUM_TRACK_MAX 4096
/* the fewest tentative collisions ratio tracking takes over a segment: the rate is raised to
 * that where the majorant's is lower (any rate keeps it unbiased; more collisions, less noise:
 * the density ramp's columns of tests/test_volume_fields.py over 16 passes, their optical depth
 * within 10 % at the majorant's rate, 3 % at 16; a quarter of the smoke bench scene's pass) */
#define MEDIUM_RATIO_STEPS 16.0f

/* whether medium mat's density is a field */
inline bool medium_field(const Scene *scene, int mat) {
#if PPM_SVM
    return mat >= 0 && scene->materials[mat].density_program > 0;
#else
    return false;
#endif
}

/* the density of medium mat's field at P (>= 0; NaN and negative ones 0, as Cycles clamps; 0
 * where mat is none) */
__attribute__((noinline)) float medium_density(const Scene *scene, int mat, float3 P) {
#if PPM_SVM
    if (mat < 0) return 0.0f;
    __global const Material *mt = scene->materials + mat;
    int p = mt->density_program;
    if (p <= 0) return 1.0f;
    float3 z = (float3)(0.0f);
    SvmContext cx = svm_context_base((float2)(0.0f), P, 0u, 0.0f, z, z, z, false);
    if (mt->volume_object >= 0) {
        __global const float4 *o = scene->objects + OBJECT_ROWS * (size_t)mt->volume_object;
        float4 h = (float4)(P, 1.0f);
        cx.P_object = (float3)(dot(o[0], h), dot(o[1], h), dot(o[2], h));
        cx.generated = cx.P_object * o[9].xyz + o[10].xyz;
        /* a Volume object's grids: the attributes its program reads (geom/volume_grid.h) */
        if (o[5].z > 0.0f) grid_attributes(scene, o, cx.P_object, cx.attr);
        for (int r = 0; r < 3; r++) {
            cx.object[r] = o[3 + r];
#if SVM_OBJECT_MATRICES
            cx.to_object[r] = o[r];
            cx.to_world[r] = o[6 + r];
#endif
        }
    }
    float stack[PPM_SVM_STACK];
    svm_eval(scene, p, stack, &cx);
    float d = stack[scene->svm[p + 1].w];
    return d > 0.0f ? fmin(d, 1e30f) : 0.0f;
#else
    return 1.0f;
#endif
}

/* numbers for a ray's tracking where its path has none (shadow rays): hashed from the ray */
inline uint ray_hash(float3 o, float3 d) {
    return pcg_hash(
        as_uint(o.x)
        ^ pcg_hash(as_uint(o.y) ^ pcg_hash(as_uint(o.z) ^ pcg_hash(as_uint(d.x) ^ as_uint(d.y)))));
}

/* the mix's majorant: a bound of its extinction's largest channel (its field at its bound) */
inline float mix_majorant(const Scene *scene, const Mix *x) {
    float3 c = x->sigma_a + x->sigma_s;
    if (x->field < 0) return max3(c);
    return max3(c + (x->unit_a + x->unit_s) * scene->materials[x->field].majorant);
}

/* Tracks the segment o + s d (0 <= s < t) through the media x, with a field: tentative
 * collisions at exponential distances of the majorant's rate; at each the media's emission per
 * metre over the majorant times the weight there is added to *L (where L is given: the
 * collision estimator, clamped at `limit`); where `scatter` it is a scattering with a
 * probability in proportion to |beta sigma_s| against |beta sigma_n| (sigma_n = majorant -
 * sigma_t, negative where the density exceeds its bound), else a null collision, *beta times
 * the coefficient over the majorant and that probability; without `scatter` every one is null
 * (ratio tracking: *beta times the transmittance, in expectation), the collisions' rate at
 * least `rate` where the media attenuate at all.  Russian roulette below a hundredth of the
 * weight at the start.  Returns where it scattered (INFINITY: it crossed). */
inline float medium_track(const Scene *scene, const Mix *x, float3 o, float3 d, float t,
                          bool scatter, float rate, float limit, uint *rng, float3 *beta,
                          float3 *L) {
    float3 ct = x->sigma_a + x->sigma_s, ut = x->unit_a + x->unit_s, ue = x->emission;
    float mu = mix_majorant(scene, x);
    bool glow = L && max3(ue) > 0.0f;
    if (!scatter && mu > 0.0f) mu = fmax(mu, rate);
    if (!(mu > 0.0f)) { /* nothing attenuates: the emission along it in closed form */
        if (glow && isfinite(t)) *L += clamp_sample(*beta * ue * t, limit);
        return INFINITY;
    }
    float b0 = 0.01f * max3(fabs(*beta)), s = 0.0f;
    for (int k = 0; k < MEDIUM_TRACK_MAX; k++) {
        s -= log(1.0f - rnd(rng)) / mu;
        if (!(s < t)) return INFINITY;
        float dens = medium_density(scene, x->field, o + s * d);
        float3 ss = x->sigma_s + x->unit_s * dens, sn = mu - (ct + ut * dens);
        if (glow) *L += clamp_sample(*beta * ue / mu, limit);
        if (scatter) {
            float ps = dot(fabs(*beta * ss), (float3)(1.0f)),
                  pn = dot(fabs(*beta * sn), (float3)(1.0f));
            if (!(ps + pn > 0.0f)) break;
            float q = ps / (ps + pn);
            if (rnd(rng) < q) {
                *beta *= ss / (mu * q);
                return s;
            }
            *beta *= sn / (mu * (1.0f - q));
        } else {
            *beta *= sn / mu;
        }
        float b = max3(fabs(*beta));
        if (!(b > 0.0f)) break;
        if (b < b0) { /* Russian roulette */
            if (rnd(rng) * b0 >= b) break;
            *beta *= b0 / b;
        }
    }
    *beta = (float3)(0.0f);
    return INFINITY;
}

/* the least rate of ratio tracking's collisions over a segment of length t (0: unbounded) */
inline float ratio_rate(float t) { return isfinite(t) && t > 0.0f ? MEDIUM_RATIO_STEPS / t : 0.0f; }

/* Ratio tracking alone over the segment o + s d (0 <= s < t) of the media x, with a field: *T
 * times the transmittance (in expectation), tentative collisions at the majorant's rate or at
 * least `rate` (medium_track without scattering or emission). */
inline void medium_ratio(const Scene *scene, const Mix *x, float3 o, float3 d, float t, float rate,
                         uint *rng, float3 *T) {
    medium_track(scene, x, o, d, t, false, rate, 0.0f, rng, T, 0);
}

/* the media x of a field with constant extinction c (the others') where only the extinction
 * matters (ratio tracking: shadow rays, the lights a ray meets, the volume photons' gather) */
inline Mix mix_extinction(const Scene *scene, int field, float3 c) {
    Mix x;
    __global const Material *mt = scene->materials + field;
    x.sigma_a = c;
    x.sigma_s = x.emission = (float3)(0.0f);
    x.unit_a = F3(mt->absorption);
    x.unit_s = F3(mt->scattering);
    x.g = 0.0f;
    x.field = field;
    x.top = field;
    return x;
}

/* the fraction of light left after the segment o + s d (0 <= s < t) in the media m (geom/
 * medium.h media_transmittance; with a field by ratio tracking, numbers hashed from the ray) */
inline float3 media_transmittance_ray(const Scene *scene, const Media *m, float3 o, float3 d,
                                      float t) {
    Mix x = media_mix(m, scene->materials);
    if (x.field < 0) return media_transmittance(m, scene->materials, t);
    uint rng = ray_hash(o, d);
    float3 T = (float3)(1.0f);
    medium_ratio(scene, &x, o, d, t, ratio_rate(t), &rng, &T);
    return T;
}
#endif
#endif
