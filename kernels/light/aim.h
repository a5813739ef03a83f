#ifndef PPM_AIM_H
#define PPM_AIM_H
#include "geom/geometry.h"
#include "scene.h"

/* Aimed emission for caustic photons (photon_emission.h): with indirect light by eye paths, a
 * photon lives on only when the first surface it scatters from is a caster (a mirror, glass, a
 * smooth glossy lobe: ppm_engine/scene/casters.py), so only directions toward the casters
 * matter.  The casters are bounding spheres (scene->casters: centre, radius), each with a
 * weight (scene->caster_weight: how much of what reaches it goes on as a caustic).
 *
 * From an emitter's point o, caster i is picked with probability w_i Omega_i / W (Omega_i the
 * solid angle of its cone, W the sum), then a direction uniform in its cone: the direction's
 * density is sum_i w_i [d in cone i] / W over every cone it lies in, since w_i Omega_i / W
 * over Omega_i is w_i / W.  Every direction whose ray meets a caster lies in that caster's
 * cone, so every caustic path keeps a density > 0 and the photon's flux (divided by it) keeps
 * the estimate unbiased.  From a sun or the world, directions stay as they are and the origin
 * moves: onto the casters' discs in the plane the photons start from, by the same rule with
 * the discs' areas. */

/* 1 - cos of the half angle of the cone from o around sphere s (xyz centre, w radius), its
 * axis in *axis; 2 (every direction) when o is inside it */
inline float caster_cone(float3 o, float4 s, float3 *axis) {
    float3 to = s.xyz - o;
    float d2 = dot(to, to), r2 = s.w * s.w;
    if (!(d2 > r2)) {
        *axis = (float3)(0.0f, 0.0f, 1.0f);
        return 2.0f;
    }
    float x = r2 / d2; /* sin^2: 1 - cos = x / (1 + cos), no cancellation */
    *axis = to * rsqrt(d2);
    return x / (1.0f + sqrt(1.0f - x));
}

/* whether the ray o + t d (t > 0) meets sphere s, or o is inside it: d is in its cone */
inline bool in_caster_cone(float3 o, float3 d, float4 s) {
    float3 to = s.xyz - o;
    float b = dot(to, d), c = dot(to, to) - s.w * s.w;
    return c <= 0.0f || (b > 0.0f && b * b >= c);
}

/* Caster i's part of the aim from o: returns its weight times its cone's 1 - cos (the cone's
 * solid angle over 2 pi), the cone sampled (*axis, *omc) and whether that is the limit cone.
 * 0 (out of reach) when the emitter emits only to the side n faces (one_sided) and the caster
 * lies wholly behind that plane, or only into the limit cone (a spot's: lim_axis, lim_omc < 2)
 * and the caster's cone lies wholly outside it.  Where the limit cone is the smaller, it is
 * sampled instead of the caster's: every direction both emitted and toward the caster is in
 * it. */
inline float aim_part(const Scene *scene, int i, float3 o, float3 n, bool one_sided,
                      float3 lim_axis, float lim_omc, float3 *axis, float *omc, bool *limited) {
    float4 s = scene->casters[i];
    float w = scene->caster_weight[i];
    *limited = false;
    *omc = caster_cone(o, s, axis);
    if (!(w > 0.0f) || (one_sided && dot(s.xyz - o, n) < -s.w)) return 0.0f;
    if (lim_omc < 2.0f && *omc < 2.0f) {
        float gap = acos(clamp(dot(*axis, lim_axis), -1.0f, 1.0f));
        if (gap > acos(1.0f - *omc) + acos(1.0f - lim_omc)) return 0.0f;
    }
    if (lim_omc < *omc) {
        *axis = lim_axis;
        *omc = lim_omc;
        *limited = true;
    }
    return w * *omc;
}

/* A direction d from o toward the casters and its density (per steradian), *caster the one
 * picked; false when no caster is in reach.  lim_omc = 2: no limit cone (aim_part). */
inline bool aim_direction(const Scene *scene, float3 o, float3 n, bool one_sided, float3 lim_axis,
                          float lim_omc, float u0, float u1, float u2, float3 *d, float *pdf,
                          int *caster) {
    int m = scene->emitter_info->n_casters;
    float total = 0.0f, omc;
    float3 axis;
    bool limited;
    for (int i = 0; i < m; i++)
        total += aim_part(scene, i, o, n, one_sided, lim_axis, lim_omc, &axis, &omc, &limited);
    if (!(total > 0.0f)) return false;
    float target = u0 * total;
    int pick = -1;
    for (int i = 0; i < m && pick < 0; i++) {
        float wi = aim_part(scene, i, o, n, one_sided, lim_axis, lim_omc, &axis, &omc, &limited);
        if (!(wi > 0.0f)) continue;
        if (target < wi || i == m - 1) pick = i;
        else target -= wi;
    }
    if (pick < 0) return false;
    *caster = pick;
    *d = sample_cone(axis, omc, u1, u2);
    /* the density: sum over the parts whose cone holds d of weight / (2 pi omc) x its share,
     * weight x omc / total: sum of weights / (2 pi total); the picked part always counts (its
     * edge may round either way) */
    float sum = 0.0f;
    for (int i = 0; i < m; i++) {
        float wi = aim_part(scene, i, o, n, one_sided, lim_axis, lim_omc, &axis, &omc, &limited);
        if (!(wi > 0.0f)) continue;
        bool in = i == pick
                  || (limited ? 1.0f - dot(*d, axis) <= omc
                              : in_caster_cone(o, *d, scene->casters[i]));
        if (in) sum += wi / omc;
    }
    *pdf = sum / (total * 2.0f * PPM_PI);
    return *pdf > 0.0f && isfinite(*pdf);
}

/* An origin for a photon travelling along d from a sun or the world: on the plane through
 * c - R d facing d (where sun_emit and world_emit start theirs), within the casters' discs
 * (their spheres seen along d), with its density per unit area and the caster picked; false
 * when no caster has weight. */
inline bool aim_origin(const Scene *scene, float3 d, float3 c, float R, float u0, float u1,
                       float u2, float3 *o, float *pdf, int *caster) {
    int m = scene->emitter_info->n_casters;
    float3 t, b;
    make_frame(d, &t, &b);
    float total = 0.0f;
    for (int i = 0; i < m; i++) {
        float r = scene->casters[i].w;
        total += scene->caster_weight[i] * r * r;
    }
    if (!(total > 0.0f)) return false;
    float target = u0 * total;
    int pick = m - 1;
    for (int i = 0; i < m; i++) {
        float r = scene->casters[i].w, wi = scene->caster_weight[i] * r * r;
        if (wi > 0.0f && target < wi) {
            pick = i;
            break;
        }
        target -= wi;
    }
    *caster = pick;
    float4 s = scene->casters[pick];
    float2 q = (float2)(dot(s.xyz - c, t), dot(s.xyz - c, b)) + sample_disk(u1, u2) * s.w;
    *o = c - R * d + q.x * t + q.y * b;
    float sum = 0.0f;
    for (int i = 0; i < m; i++) {
        float4 si = scene->casters[i];
        float2 e = q - (float2)(dot(si.xyz - c, t), dot(si.xyz - c, b));
        float w = scene->caster_weight[i];
        if (w > 0.0f && (i == pick || dot(e, e) <= si.w * si.w)) sum += w;
    }
    *pdf = sum / (total * PPM_PI);
    return *pdf > 0.0f && isfinite(*pdf);
}
#endif
