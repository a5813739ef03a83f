#ifndef PPM_VOLUME_LIGHT_H
#define PPM_VOLUME_LIGHT_H
#include "integrator/direct_light.h"

/* Direct light in homogeneous media (PPM_VOLUME; geom/medium.h): next-event estimation at a
 * scattering point, and equiangular sampling of the lights of no size along a segment,
 * combined by MIS (eye_pass.cl). */
#if PPM_VOLUME
/* A medium segment (o + s d, 0 <= s < t) whose light next-event estimation gathers: where its
 * scattering point came from (the free-flight density's channels pc, see medium_channels), and
 * the point from which equiangular sampling picks its light (the segment's middle). */
typedef struct {
    float3 o, d, pc, mid;
    float t;
    float s, pdf; /* where the path scatters on it (INFINITY: it crosses), the density of s */
    /* how its lights of no size are sampled: EQUI_MIS by equiangular distances and free-flight
     * ones under MIS (a homogeneous medium), EQUI_ONLY by equiangular distances alone (a field,
     * whose free-flight density is not known), EQUI_NONE by free-flight distances alone */
    int equi;
    float g; /* the media's Henyey-Greenstein anisotropy (media_mix) */
} Segment;
#define EQUI_NONE 0
#define EQUI_MIS 1
#define EQUI_ONLY 2

inline Segment segment(float3 o, float3 d, float t, float3 pc) {
    Segment g = {o, d, pc, isfinite(t) ? o + (0.5f * t) * d : o, t, INFINITY, 0.0f, EQUI_MIS, 0.0f};
    return g;
}

/* whether emitter e is a light of no size at a point (a point or spot light of radius 0): its
 * light in a medium is also sampled by equiangular distances (volume_equiangular) */
inline bool equiangular_light(const Scene *scene, int e) {
    if (!PPM_LIGHT_POINT || e < 0 || e >= scene->emitter_info->n_lights) return false;
    __global const Light *l = scene->lights + e;
    return (l->type == LIGHT_POINT || l->type == LIGHT_SPOT) && !(l->radius > 0.0f);
}

/* The part [*s0, *s1] of the segment o + s d (0 <= s <= t) inside light l's spot cone (a point
 * light: all of it), where its equiangular samples go, as Cycles clips them to a spot's cone;
 * false when the segment misses the cone.  The cone in the light's frame (spot_attenuation's,
 * a linear map of the segment) is convex: one interval, between roots of a quadratic. */
inline bool light_segment(const Light *l, float3 o, float3 d, float t, float *s0, float *s1) {
    *s0 = 0.0f;
    *s1 = t;
    float3 ax = F3(l->axis_x), ay = F3(l->axis_y), dir = F3(l->direction);
    float sx = dot(ax, ax), sy = dot(ay, ay), cs = l->spot_cos_half;
    if (l->type != LIGHT_SPOT || !isfinite(t) || !(sx > 0.0f && sy > 0.0f) || !(cs > 0.0f))
        return true;
    float3 w = o - F3(l->position);
    float3 wl = (float3)(dot(w, ax) / sx, dot(w, ay) / sy, dot(w, dir) * l->spot_scale_z);
    float3 dl = (float3)(dot(d, ax) / sx, dot(d, ay) / sy, dot(d, dir) * l->spot_scale_z);
    float c2 = cs * cs;
    float a = dl.z * dl.z - c2 * dot(dl, dl), b = 2.0f * (wl.z * dl.z - c2 * dot(wl, dl)),
          c = wl.z * wl.z - c2 * dot(wl, wl);
    float cand[4] = {0.0f, t, 0.0f, 0.0f};
    int n = 2;
    float disc = b * b - 4.0f * a * c;
    if (fabs(a) > 1e-12f && disc >= 0.0f) {
        float q = sqrt(disc);
        cand[n++] = clamp((-b - q) / (2.0f * a), 0.0f, t);
        cand[n++] = clamp((-b + q) / (2.0f * a), 0.0f, t);
    } else if (fabs(a) <= 1e-12f && fabs(b) > 0.0f) {
        cand[n++] = clamp(-c / b, 0.0f, t);
    }
    for (int i = 1; i < n; i++) /* (sorted) */
        for (int j = i; j > 0 && cand[j] < cand[j - 1]; j--) {
            float x = cand[j];
            cand[j] = cand[j - 1];
            cand[j - 1] = x;
        }
    float lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k + 1 < n; k++) {
        float3 v = wl + (0.5f * (cand[k] + cand[k + 1])) * dl;
        if (v.z > 0.0f && v.z * v.z >= c2 * dot(v, v)) {
            lo = fmin(lo, cand[k]);
            hi = fmax(hi, cand[k + 1]);
        }
    }
    *s0 = lo;
    *s1 = hi;
    return hi > lo;
}

/* the density of equiangular sampling's distance s towards light e on segment sg (its pick from
 * the segment's middle included) */
inline float equiangular_density(const Scene *scene, const Segment *sg, int e, float s) {
    Light l = scene->lights[e];
    float s0, s1;
    if (!light_segment(&l, sg->o, sg->d, sg->t, &s0, &s1)) return 0.0f;
    return emitter_pmf_at(scene, e, sg->mid, (float3)(0.0f))
           * equiangular_pdf(sg->o, sg->d, s0, s1, F3(l.position), s);
}

/* Light scattered at point p = g->o + s g->d inside a medium of phase anisotropy g towards -d,
 * per unit of the scattering coefficient: next-event estimation (one emitter, its shadow ray
 * through the media m and the transparent boundaries, at most `crossings`).  A light with size
 * is weighted against the phase function's sample (power heuristic: the path's phase sample
 * finds it, eye_pass.cl), a light of no size against the segment's equiangular sample
 * (volume_equiangular; pdf_d the density of the distance s).  The point has no normal: the pick
 * and the world's sample are given the zero vector (the light tree then weighs no cosine at p;
 * a constant world is left to the phase sample, which finds it with full weight). */
inline float3 volume_nee(const Scene *scene, const Segment *sg, float s_dist, float pdf_d, float g,
                         const Media *m, int crossings, float3 u) {
    LightSample s;
    float pmf;
    float3 none = (float3)(0.0f), p = sg->o + s_dist * sg->d;
    EmitterInfo info = *scene->emitter_info;
    if (info.n_emitters == 0) return none;
    int e = pick_emitter_at(scene, p, none, u.x, &pmf);
    if (!sample_emitter(scene, p, none, none, u, &s, &pmf)) return none;
    float ph = hg_phase(dot(sg->d, s.wi), g);
    float3 T = ray_transmittance_media(scene, p, s.wi, s.dist, crossings, VIS_SHADOW, m);
    float w = 1.0f;
    if (s.pdf_dir > 0.0f) {
        w = mis_power(pmf * s.pdf_dir, ph);
    } else if (sg->equi != EQUI_NONE && equiangular_light(scene, e)) {
        w = sg->equi == EQUI_ONLY
                ? 0.0f
                : mis_power(pmf * pdf_d, equiangular_density(scene, sg, e, s_dist));
    }
    return ph * T * s.E * (w / pmf);
}

/* The light of no size a medium segment scatters towards its start, by an equiangular distance
 * towards the light next-event estimation picks from the segment's middle (u.x; u.y the
 * distance, u.z the spot's), weighted against the free-flight sample's next-event estimation
 * (volume_nee) by the power heuristic; per the path weight at the segment's start (the
 * scattering coefficient and the transmittance to the point included).  Near a spot light in
 * fog, free-flight distances rarely fall where its light is: this is Kulla and Fajardo's cure,
 * as Cycles'. */
inline float3 volume_equiangular(const Scene *scene, const Segment *sg, const Mix *x,
                                 const Media *m, int crossings, float3 u) {
    float3 sigma_t = x->sigma_a + x->sigma_s, sigma_s = x->sigma_s;
    float g = x->g;
    float3 none = (float3)(0.0f);
    if (scene->emitter_info->n_emitters == 0) return none;
    float pmf_e;
    int e = pick_emitter_at(scene, sg->mid, none, u.x, &pmf_e);
    if (!(pmf_e > 0.0f) || !equiangular_light(scene, e)) return none;
    Light l = scene->lights[e];
    float pdf_e, s0, s1;
    if (!light_segment(&l, sg->o, sg->d, sg->t, &s0, &s1)) return none; /* (outside its cone) */
    float s_dist = equiangular_sample(sg->o, sg->d, s0, s1, F3(l.position), u.y, &pdf_e);
    if (!(pdf_e > 0.0f) || !(s_dist < sg->t)) return none;
    float3 p = sg->o + s_dist * sg->d;
    LightSample ls;
    if (!point_direct(&l, p, u.z, 0.5f, &ls)) return none;
    float ph = hg_phase(dot(sg->d, ls.wi), g);
    float3 T = ray_transmittance_media(scene, p, ls.wi, ls.dist, crossings, VIS_SHADOW, m);
    if (!(max3(T) > 0.0f)) return none;
    if (sg->equi == EQUI_ONLY) {
        /* a field (geom/medium_field.h): its scattering at p, the transmittance to p by ratio
         * tracking (numbers hashed from the sample), no MIS (free-flight distances leave
         * these lights to this) */
        float3 tr = (float3)(1.0f);
        uint rng = ray_hash(p, sg->d) ^ as_uint(u.y);
        medium_ratio(scene, x, sg->o, sg->d, s_dist, ratio_rate(s_dist), &rng, &tr);
        float3 tn = (float3)(1.0f);
        float dens = medium_point(scene, x->field, p, 0, &tn, 0);
        float3 ss = sigma_s + x->unit_s * tn * dens;
        return ss * tr * (ph / (pmf_e * pdf_e)) * T * ls.E;
    }
    float3 tr = exp(-sigma_t * s_dist);
    float a = pmf_e * pdf_e;
    float b = emitter_pmf_at(scene, e, p, none) * medium_pdf(sigma_t, sg->pc, s_dist);
    return sigma_s * tr * (ph * mis_power(a, b) / a) * T * ls.E;
}

/* A path's segment o + s d (0 <= s < t) in its media (every one on the stack, summed: geom/
 * medium.h media_mix), the same for the eye pass and indirect_paths.h: the light it adds
 * towards its start per the path weight *beta at its start (the media's emission, clamped at
 * limits.x; with `nee` the light of points and
 * spots along it by equiangular distances, clamped at limits.y), and, where `scatter` (the
 * path may still scatter) and the medium scatters, a free-flight distance (numbers u: the
 * channel, the distance, equiangular sampling's pick and distance): *sg the segment with
 * where it scattered (sg->s, INFINITY: it crossed), *beta times the transmittance (and the
 * scattering coefficient there) over the density.  crossings: the transparent surfaces its
 * shadow rays may cross. */
inline float3 medium_segment(const Scene *scene, const Media *media, float3 o, float3 d, float t,
                             bool scatter, float4 u, int crossings, float2 limits, bool nee,
                             float3 *beta, Segment *sg) {
    float3 L = (float3)(0.0f), pc;
    *sg = segment(o, d, t, (float3)(0.0f));
    if (media_top(media) < 0) return L;
    Mix x = media_mix(media, scene->materials);
    sg->g = x.g;
    if (x.field >= 0) {
        /* a heterogeneous medium (geom/medium_field.h): tracked, its emission by collisions;
         * its lights of no size by an equiangular distance alone (EQUI_ONLY), the others by
         * next-event estimation where it scatters (the numbers u are 0 where the path does
         * not scatter: the ray's own too) */
        uint rng = ray_hash(o, d) ^ pcg_hash(as_uint(u.x) ^ pcg_hash(as_uint(u.y)));
        bool scat = scatter && mix_scatters(&x);
        sg->equi = EQUI_NONE;
        if (PPM_LIGHT_POINT && scat && nee) { /* (with the weight at the segment's start) */
            sg->equi = EQUI_ONLY;
            L += clamp_sample(*beta
                                  * volume_equiangular(scene, sg, &x, media, crossings,
                                                       (float3)(u.z, u.w, 0.5f)),
                              limits.y);
        }
        sg->s = medium_track(scene, &x, o, d, t, scat, ratio_rate(t), limits.x, &rng, beta, &L);
        return L;
    }
    float3 sigma_t = x.sigma_a + x.sigma_s, sigma_s = x.sigma_s;
    if (max3(x.emission) > 0.0f)
        L += clamp_sample(*beta * medium_emission(x.emission, sigma_t, t), limits.x);
    if (!scatter || !(max3(sigma_s) > 0.0f)) {
        *beta *= medium_tr(sigma_t, t);
        return L;
    }
    bool scatters = medium_channels(sigma_t, sigma_s, *beta, &pc);
    *sg = segment(o, d, t, scatters ? pc : (float3)(0.0f));
    sg->g = x.g;
    /* (the same numbers with and without point lights: a program of every feature renders the
     * image of the scene's own) */
    if (PPM_LIGHT_POINT && scatters && nee)
        L += clamp_sample(*beta
                              * volume_equiangular(scene, sg, &x, media, crossings,
                                                   (float3)(u.z, u.w, 0.5f)),
                          limits.y);
    sg->s = medium_sample(sigma_t, sigma_s, t, u.x, u.y, beta, &sg->pdf);
    return L;
}
#endif
#endif
