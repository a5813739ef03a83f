#ifndef PPM_DIRECT_LIGHT_H
#define PPM_DIRECT_LIGHT_H
#include "light_types.h"

/* Direct light at a diffuse point: next-event estimation (one emitter picked by power) and a
 * BSDF sample, combined by multiple importance sampling for mesh lights; and the radiance of
 * the lights camera and specular rays see.  The emitter types a program has are the feature
 * flags of features.h (0/1): a type without its flag is never dispatched to. */

/* Radiance of the scene lights seen directly along o + t d, t < tmax (camera rays and their
 * specular chains; Cycles shows area lights from the front and point lights as spheres).
 * Lights do not block rays: only the nearest one in front of the surface hit counts.
 * ray_type: VIS_CAMERA, VIS_GLOSSY or VIS_TRANSMISSION; lights hidden from it are skipped. */
inline float3 lights_seen(float3 o, float3 d, float tmax, __global const Light *lights,
                          int n_lights, uint ray_type) {
    float3 L = (float3)(0.0f);
    float best = tmax;
    for (int i = 0; i < n_lights; i++) {
        Light l = lights[i];
        if (l.flags & (ray_type << LIGHT_HIDDEN_SHIFT)) continue;
        if (PPM_LIGHT_AREA && (l.type == LIGHT_AREA_RECT || l.type == LIGHT_AREA_ELLIPSE))
            area_seen(&l, o, d, &best, &L);
        else if (PPM_LIGHT_POINT)
            point_seen(&l, o, d, &best, &L);
    }
    return L;
}

/* power heuristic weight of strategy a against b */
inline float mis_power(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Next-event estimation at a diffuse point p (shading normal n and geometric normal ngf both on
 * the side the light must come from).  Returns E with the pixel contribution = beta * f * E,
 * f the Lambert BSDF; one emitter sample, shadow ray through the BVH.  With mis, an emissive
 * triangle's sample is weighted against the BSDF sample of direct_bsdf (power heuristic). */
inline float3 sample_direct(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng, bool mis) {
    EmitterInfo info = *emitter_info;
    if (info.n_emitters == 0) return (float3)(0.0f);
    float pmf;
    int e = pick_emitter(emitter_cdf, info.n_emitters, rnd(rng), &pmf);
    if (!(pmf > 0.0f)) return (float3)(0.0f);
    float u1 = rnd(rng), u2 = rnd(rng);
    /* All geometry from the shadow ray's own origin: a direction computed from p but traced
     * from the offset origin would meet a planar emitter's own plane early at grazing angles
     * (the offset over cos) and the light would shadow itself. */
    float3 o = offset_ray(p, ngf);
    LightSample s;
    s.dist = PPM_INF;
    s.pdf_light = 0.0f;
    s.cosine_included = false;
    if (e < info.n_lights) {
        Light L = lights[e];
        if (PPM_LIGHT_SUN && L.type == LIGHT_SUN) sun_direct(&L, u1, u2, &s);
        else if (PPM_LIGHT_POINT && (L.type == LIGHT_POINT || L.type == LIGHT_SPOT)) {
            if (!point_direct(&L, o, u1, u2, &s)) return (float3)(0.0f);
        } else if (PPM_LIGHT_AREA && (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE)) {
            if (!area_direct(&L, o, u1, u2, &s)) return (float3)(0.0f);
        } else return (float3)(0.0f);
    } else if (PPM_EMISSIVE && e < info.n_lights + info.n_emissive) {
        if (!mesh_direct(emissive[e - info.n_lights], pmf, o, u1, u2, SCENE_PASS, &s))
            return (float3)(0.0f);
    } else if (PPM_WORLD && info.has_world) {
        world_direct(F3(info.world), n, u1, u2, &s);
    } else return (float3)(0.0f);
    float cos_s = dot(s.wi, n);
    if (cos_s <= 0.0f || dot(s.wi, ngf) <= 0.0f) return (float3)(0.0f);
    /* planar emitters: the ray ends just in front of the emitter, so it never reaches it */
    Hit h = bvh_intersect(o, s.wi, s.dist, VIS_SHADOW, true, BVH_PASS);
    if (h.leaf >= 0) return (float3)(0.0f);
    float w = mis && s.pdf_light > 0.0f ? mis_power(s.pdf_light, cos_s * (1.0f / PPM_PI)) : 1.0f;
    return s.E * (w * (s.cosine_included ? 1.0f : cos_s) / pmf);
}

/* The BSDF half of direct light at a diffuse point: one cosine-distributed ray; when it meets
 * an emissive triangle first, its emission weighted against sample_direct's pdf for it (power
 * heuristic).  Near a large emitter (a ceiling 1 cm above a lamp, a filament inside its
 * bulb) next-event estimation alone has unbounded variance (1/d^2); the BSDF sample covers
 * it.  Returns E as sample_direct does (pixel contribution = beta * f * E). */
inline float3 direct_bsdf(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng) {
    float u1 = rnd(rng), u2 = rnd(rng);
#if !PPM_EMISSIVE
    return (float3)(0.0f);           /* no emissive triangle: nothing for this sample to find */
#else
    if (emitter_info->n_emissive == 0) return (float3)(0.0f);
    float3 wi = sample_cosine_hemisphere(n, u1, u2);
    float cos_s = dot(wi, n);
    if (cos_s <= 0.0f || dot(wi, ngf) <= 0.0f) return (float3)(0.0f);
    float3 o = offset_ray(p, ngf);
    /* a diffuse bounce's ray (it must find emitters that cast no shadow, which next-event
     * estimation samples too) */
    Hit h = bvh_intersect(o, wi, PPM_INF, VIS_DIFFUSE, false, BVH_PASS);
    if (h.leaf < 0) return (float3)(0.0f);
    float4 e1 = tri_e1[h.leaf], e2 = tri_e2[h.leaf];
    __global const Material *m = materials + as_int(e2.w);
    if (!(m->flags & MAT_EMISSIVE)) return (float3)(0.0f);
    float pmf = emissive_leaf_pmf(h.leaf, SCENE_PASS);
    float3 c = cross(e1.xyz, e2.xyz);
    float area2 = length(c);
    float cos_l = area2 > 0.0f ? fabs(dot(wi, c)) / area2 : 0.0f;
    if (!(pmf > 0.0f && cos_l > 0.0f)) return (float3)(0.0f);   /* NEE never picks it: 0 power */
    /* the pdf of the strategy sample_direct uses for this triangle from this origin */
    float4 v0 = tri_v0[h.leaf];
    SphTri st = spherical_triangle(o, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz);
    float pdf_light = st.area > 0.0f ? pmf / st.area : pmf * h.t * h.t / (cos_l * 0.5f * area2);
    /* f Le cos / pdf_bsdf = (rho/pi) Le pi: in E units (times f) that is Le pi */
    return F3(m->emission)
        * texture_tint(m->emission_tex, as_uint(v0.w), h.u, h.v, TEXTURE_PASS)
        * (PPM_PI * mis_power(cos_s * (1.0f / PPM_PI), pdf_light));
#endif
}

/* Direct light at a diffuse point: next-event estimation and the BSDF sample, combined. */
inline float3 direct_lighting(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng) {
    return sample_direct(p, n, ngf, SCENE_PASS, rng, true) + direct_bsdf(p, n, ngf, SCENE_PASS, rng);
}
#endif
