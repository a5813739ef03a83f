#ifndef PPM_DIRECT_LIGHT_H
#define PPM_DIRECT_LIGHT_H
#include "rng.h"
#include "light/light_types.h"
#include "light/light_mesh.h"
#include "light/world.h"
#include "closure/shader.h"

/* Direct light at a shading point: next-event estimation (one emitter picked by power, among
 * few emissive triangles by their light at the point: light_mesh.h pick_emitter_at; a shadow
 * ray) and a sample of the closures, combined by multiple importance sampling (power
 * heuristic); and what rays see of the emitters, with the MIS weight of the sample that found
 * them.  The emitter types a program has are the feature flags of shared.h (0/1): a type
 * without its flag is never dispatched to. */

/* power heuristic weight of strategy a against b */
inline float mis_power(float a, float b) {
    if (isinf(a)) return 1.0f;
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Radiance of the scene lights seen along o + t d, t < tmax (camera, glossy and transmission
 * rays; Cycles shows area lights from the front, point lights as disks or spheres, suns with
 * an angle as discs to rays that escape, ``escaped``).  Lights do not block rays: only the
 * nearest one in front of the surface hit counts.  ray_type:
 * VIS_CAMERA, VIS_DIFFUSE, VIS_GLOSSY or VIS_TRANSMISSION; lights hidden from it are skipped.
 * *pdf_light: the density next-event estimation gives d from o for that light (pmf
 * included: from the vertex pv of normal nv the ray left, the light tree's), for MIS. */
/* light i seen along o + t d (lights_seen): the nearest so far in *best, its radiance and
 * density, *seen its index; a sun's radiance summed in *Lsun when the ray escaped */
inline void light_seen(const Scene *scene, int i, float3 o, float3 d, bool escaped, uint ray_type,
                       float *best, float3 *L, float *pdf, int *seen, float3 *Lsun) {
    Light l = scene->lights[i];
    if (l.flags & (ray_type << LIGHT_HIDDEN_SHIFT)) return;
    float before = *best;
    if (PPM_LIGHT_AREA && (l.type == LIGHT_AREA_RECT || l.type == LIGHT_AREA_ELLIPSE))
        area_seen(&l, o, d, best, L, pdf);
    else if (PPM_LIGHT_SUN && l.type == LIGHT_SUN) {
        if (escaped) *Lsun += sun_seen(&l, d);
    } else if (PPM_LIGHT_POINT) point_seen(&l, o, d, best, L, pdf);
    if (*best != before) *seen = i;
}

/* whether o + t d meets the box [lo, hi] for some t in [0, tmax] */
inline bool ray_box(float3 o, float3 inv_d, float3 lo, float3 hi, float tmax) {
    float3 t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
    float3 a = fmin(t0, t1), b = fmax(t0, t1);
    float near = fmax(fmax(a.x, a.y), fmax(a.z, 0.0f)), far = fmin(fmin(b.x, b.y), fmin(b.z, tmax));
    return near <= far;
}

inline float3 lights_seen(const Scene *scene, float3 o, float3 d, float tmax, bool escaped,
                          uint ray_type, float3 pv, float3 nv, float *pdf_light) {
    float3 L = (float3)(0.0f), Lsun = (float3)(0.0f);
    float best = tmax, pdf = 0.0f;
    int seen = -1, n_lights = scene->emitter_info->n_lights;
    if (scene->emitter_info->n_tree > 0) {
        /* many lights: the light tree's boxes (which hold the lights whole) as a BVH, then the
         * suns when the ray escaped */
        __global const LightTreeNode *tree = scene->light_tree;
        float3 inv_d = 1.0f / d;
        int stack[LIGHT_TREE_STACK], top = 0;
        stack[top++] = 0;
        while (top > 0) {
            int k = stack[--top];
            if (!ray_box(o, inv_d, F3(tree[k].bmin), F3(tree[k].bmax), best)) continue;
            int c = tree[k].child;
            if (c < 0) {
                if (-1 - c < n_lights)
                    light_seen(scene, -1 - c, o, d, escaped, ray_type, &best, &L, &pdf, &seen,
                               &Lsun);
            } else if (top + 2 <= LIGHT_TREE_STACK) {
                stack[top++] = c + 1;
                stack[top++] = c;
            }
        }
        if (escaped && scene->emitter_info->n_suns > 0)
            for (int i = 0; i < n_lights; i++)
                if (scene->lights[i].type == LIGHT_SUN)
                    light_seen(scene, i, o, d, escaped, ray_type, &best, &L, &pdf, &seen, &Lsun);
    } else {
        for (int i = 0; i < n_lights; i++)
            light_seen(scene, i, o, d, escaped, ray_type, &best, &L, &pdf, &seen, &Lsun);
    }
    __global const EmitterInfo *info = scene->emitter_info;
    *pdf_light = seen < 0 ? 0.0f
                 : scene->emitter_leaf[seen] >= 0 && info->n_tree > 0
                     ? pdf * info->tree_share * light_tree_pmf(scene, seen, pv, nv)
                     : pdf * emitter_pmf_far(scene, seen);
    /* suns, behind everything: a ray that escapes the scene and meets no other light.
     * Next-event estimation samples a sun without MIS (sun_direct: pdf_dir 0), so a sun a
     * sampled direction finds counts only after a singular bounce or the camera (density
     * INFINITY: mis_power weighs it 0 after any other). */
    if (seen < 0 && max3(Lsun) > 0.0f) {
        L = Lsun;
        *pdf_light = INFINITY;
    }
    return L;
}

/* The emission of emissive BVH leaf `leaf` hit at (u, v) from o along d at distance t, and the
 * density next-event estimation from the vertex pv (normal nv: the point and normal it was
 * given there) gives that direction (pmf included).  The density is the vertex's, not the
 * ray origin's: past a transparent surface o lies on it, and the solid angle from there made
 * light through a Transparent BSDF or alpha 26 % bright (tests/test_direct_light.py). */
inline float3 mesh_seen(const Scene *scene, int leaf, float3 o, float3 d, float t, float u, float v,
                        float3 pv, float3 nv, float *pdf_light) {
    *pdf_light = 0.0f;
    float3 q = o + t * d;                                   /* the point hit */
    float4 v0 = scene->tri_v0[leaf], e1 = scene->tri_e1[leaf], e2 = scene->tri_e2[leaf];
    __global const Material *m = scene->materials + as_int(e2.w);
    if (!(m->flags & MAT_EMISSIVE)) return (float3)(0.0f);
#if PPM_EMISSIVE
    float pmf = emissive_leaf_pmf(scene, leaf, pv, nv);
    float3 c = cross(e1.xyz, e2.xyz);
    float area2 = length(c), cos_l = area2 > 0.0f ? fabs(dot(d, c)) / area2 : 0.0f;
    if (pmf > 0.0f && cos_l > 0.0f) {
        SphTri st = spherical_triangle(pv, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz);
        float3 to = q - pv;
        *pdf_light = st.area > 0.0f ? pmf / st.area : pmf * dot(to, to) / (cos_l * 0.5f * area2);
    }
#endif
    return material_emission(scene, m, as_uint(v0.w), u, v, q);
}

/* The density next-event estimation gives the world in direction d from a point whose normal
 * (the one the world is sampled around) is n, its pick included. */
inline float world_light_pdf(const Scene *scene, float3 d, float3 n) {
    return world_pdf(scene, d, n) * emitter_pmf_far(scene, scene->emitter_info->n_emitters - 1);
}

/* The MIS weight of the emission of the surface hit h, found from o along d by a sample of
 * density prev_pdf (INFINITY: a camera ray or a singular lobe, weight 1) taken at vertex pv
 * with normal nv. */
inline float mesh_hit_mis(const Scene *scene, const Hit *h, float3 o, float3 d, float prev_pdf,
                          float3 pv, float3 nv) {
    float pdf_l = 0.0f;
    if (PPM_EMISSIVE && !isinf(prev_pdf))
        mesh_seen(scene, h->leaf, o, d, h->t, h->u, h->v, pv, nv, &pdf_l);
    return mis_power(prev_pdf, pdf_l);
}

/* The fraction of light a ray from o along d lets through over dist, meeting the objects of
 * visibility `mask`: 0 at an opaque surface; partly transparent surfaces (alpha, Transparent
 * BSDF) attenuate it, at most `crossings` of them (as Blender 5.0's Cycles renders: the Light
 * Paths' transparent limit less the path's crossings, ShaderData.crossings).  A shadow ray's
 * (shadow_transmittance) meets what casts shadows; a camera connection's
 * (photon_pass.cl connect_camera) what the camera sees. */
inline float3 ray_transmittance(const Scene *scene, float3 o, float3 d, float dist, int crossings,
                                uint mask) {
#if PPM_TRANSPARENT
    float3 T = (float3)(1.0f);
    for (int i = 0; i <= crossings; i++) {
        Hit h = bvh_intersect(scene, o, d, dist, mask, false);
        if (h.leaf < 0) return T;
        Surface s = surface_at(scene, h);
        if (i == crossings || !(scene->materials[s.material].flags & MAT_TRANSPARENT))
            return (float3)(0.0f);
        T *= material_transparency(scene, s.material, s.tri, h.u, h.v, s.p);
        if (!(max3(T) > 0.0f)) return (float3)(0.0f);
        float3 o2 = offset_ray(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng,
                               scene->emitter_info->offset_scale);
        dist -= dot(o2 - o, d);
        o = o2;
        if (!(dist > 0.0f)) return T;
    }
    return (float3)(0.0f);
#else
    Hit h = bvh_intersect(scene, o, d, dist, mask, true);
    return (float3)(h.leaf < 0 ? 1.0f : 0.0f);
#endif
}

inline float3 shadow_transmittance(const Scene *scene, float3 o, float3 d, float dist,
                                   int crossings) {
    return ray_transmittance(scene, o, d, dist, crossings, VIS_SHADOW);
}

/* One next-event sample from p (n: the shading normal the world is sampled around, ngf the
 * geometric normal on the side the light must come from); false when there is none. */
inline bool sample_emitter(const Scene *scene, float3 p, float3 n, float3 ngf, float3 u,
                           LightSample *s, float *pmf) {
    EmitterInfo info = *scene->emitter_info;
    if (info.n_emitters == 0) return false;
    int e = pick_emitter_at(scene, p, n, u.x, pmf);
    if (!(*pmf > 0.0f)) return false;
    float u1 = u.y, u2 = u.z;
    /* All geometry from the shadow ray's own origin: a direction computed from p but traced
     * from the offset origin would meet a planar emitter's own plane early at grazing angles
     * (the offset over cos) and the light would shadow itself. */
    float3 o = offset_ray(p, ngf, info.offset_scale);
    s->dist = PPM_INF;
    s->pdf_dir = 0.0f;
    if (e < info.n_lights) {
        Light L = scene->lights[e];
        if (PPM_LIGHT_SUN && L.type == LIGHT_SUN) sun_direct(&L, u1, u2, s);
        else if (PPM_LIGHT_POINT && (L.type == LIGHT_POINT || L.type == LIGHT_SPOT)) {
            if (!point_direct(&L, o, u1, u2, s)) return false;
        } else if (PPM_LIGHT_AREA && (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE)) {
            if (!area_direct(&L, o, u1, u2, info.offset_scale, s)) return false;
        } else return false;
    } else if (PPM_EMISSIVE && e < info.n_lights + info.n_emissive) {
        if (!mesh_direct(scene, scene->emissive[e - info.n_lights], o, u1, u2, s)) return false;
    } else if (PPM_WORLD && info.has_world) {
        if (!world_direct(scene, n, u1, u2, s)) return false;
    } else return false;
    return true;
}

/* Whether a BSDF-sampled ray can find an emitter next-event estimation also samples: emissive
 * triangles, lights rays see, the world. */
#define EMITTERS_HITTABLE (PPM_EMISSIVE || PPM_LIGHTS_SEEN || PPM_WORLD)

/* Next-event estimation at shading point p for the closures in mask, weighted against their
 * sample (power heuristic; mis false: alone, when no sample of the closures looks for
 * emitters), from the uniform numbers u (the emitter's pick, a point on it).  Returns the
 * radiance reflected towards sd->wi. */
inline float3 direct_nee_u(const Scene *scene, const ShaderData *sd, float3 p, int mask, bool mis,
                           float3 u) {
    LightSample s;
    float pmf;
    if (!sample_emitter(scene, p, sd->N, sd->Ng, u, &s, &pmf)) return (float3)(0.0f);
    float pdf_b;
    float3 f = shader_eval(sd, s.wi, mask, &pdf_b);
    if (!(max3(f) > 0.0f)) return (float3)(0.0f);
    /* the side the light is on as the shading normal sees it (as Cycles decides): a light
     * below the face but above the shading normal's horizon is reflected light, and its
     * shadow ray leaves from the face's front; it meets the face itself where the face is
     * in the way */
    bool transmit = dot(s.wi, sd->N) < 0.0f;
    float3 side = transmit ? -sd->Ng : sd->Ng;
    float3 o = offset_ray(p, side, scene->emitter_info->offset_scale);
    float3 wi = s.wi;
    float dist = s.dist;
    /* near the terminator of a smooth-shaded mesh the shadow ray leaves from the smooth
     * surface (bvh.h terminator_lift), all the way where the light grazes the face or the
     * shading normal's horizon and not at all from `cut` above both (the object's Shadow
     * Terminator > Geometry Offset; Cycles' ramp) */
    float cut = sd->leaf >= 0 ? scene->terminator[sd->tri] : 0.0f;
    float nl = fabs(dot(sd->N, wi)), ngl = dot(side, wi);
    float amount = cut > 0.0f ? clamp((nl < cut ? 2.0f - nl / cut : 1.0f) - ngl / cut, 0.0f, 1.0f)
                              : 0.0f;
    if (amount > 0.0f && !transmit) {
        float3 lift = amount * terminator_lift(scene, sd->leaf, sd->tri, sd->u, sd->v, sd->Ng);
        if (isfinite(dist)) {             /* towards the same point on the light */
            float3 to = wi * dist - lift;
            dist = length(to);
            wi = to / dist;
        }
        o += lift;
    }
    float3 T = shadow_transmittance(scene, o, wi, dist, sd->crossings);
    float w = mis && s.pdf_dir > 0.0f ? mis_power(pmf * s.pdf_dir, pdf_b) : 1.0f;
    return f * T * s.E * (w / pmf);
}

inline float3 direct_nee(const Scene *scene, const ShaderData *sd, float3 p, int mask, bool mis,
                         uint *rng) {
    float3 u;
    u.x = rnd(rng);
    u.y = rnd(rng);
    u.z = rnd(rng);
    return direct_nee_u(scene, sd, p, mask, mis, u);
}

/* What a ray from o along d finds of the emitters (ray_type: VIS_*): the radiance of the
 * first emitter (through at most `crossings` partly transparent surfaces, attenuated) and the
 * density next-event estimation gives d for it; p and n: the vertex the ray left and the
 * normal next-event estimation was given there (the world is sampled around it). */
inline float3 emitter_along(const Scene *scene, float3 o, float3 d, uint ray_type, float3 p,
                            float3 n, int crossings, float *pdf_l) {
    float3 T = (float3)(1.0f);
    *pdf_l = 0.0f;
    for (int i = 0; i <= crossings; i++) {
        Hit h = bvh_intersect(scene, o, d, PPM_INF, ray_type, false);
#if PPM_LIGHTS_SEEN
        float3 Le = lights_seen(scene, o, d, h.leaf < 0 ? PPM_INF : h.t, h.leaf < 0, ray_type, p, n,
                                pdf_l);
        if (max3(Le) > 0.0f) return T * Le;
#endif
        if (h.leaf < 0) {
            if (!(PPM_WORLD && scene->emitter_info->has_world)) return (float3)(0.0f);
            *pdf_l = world_light_pdf(scene, d, n);
            return T * world_le(scene, d);
        }
        int mat = as_int(scene->tri_e2[h.leaf].w);
        if (PPM_EMISSIVE && (scene->materials[mat].flags & MAT_EMISSIVE))
            return T * mesh_seen(scene, h.leaf, o, d, h.t, h.u, h.v, p, n, pdf_l);
#if !PPM_TRANSPARENT
        return (float3)(0.0f);          /* an opaque surface: no emitter behind it counts */
#endif
        if (i == crossings || !(scene->materials[mat].flags & MAT_TRANSPARENT))
            return (float3)(0.0f);
        Surface s = surface_at(scene, h);
        T *= material_transparency(scene, mat, s.tri, h.u, h.v, s.p);
        if (!(max3(T) > 0.0f)) return (float3)(0.0f);
        o = offset_ray(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng, scene->emitter_info->offset_scale);
    }
    return (float3)(0.0f);
}

/* The sample half of direct light at p: one direction from the closures in mask, its emitter
 * weighted against next-event estimation's density (power heuristic; a singular lobe's fully).
 * Near a large emitter (a ceiling 1 cm above a lamp, a filament inside its bulb) and for glossy
 * lobes next-event estimation alone has large variance; this sample covers it. */
inline float3 direct_bsdf(const Scene *scene, const ShaderData *sd, float3 p, int mask,
                          int mis_mask, uint *rng) {
    float3 rand = (float3)(rnd(rng), rnd(rng), rnd(rng));
#if EMITTERS_HITTABLE
    BsdfSample b;
    if (!shader_sample(sd, mask, rand, &b)) return (float3)(0.0f);
    bool transmit = (b.label & LABEL_TRANSMIT) != 0;
    uint ray = (b.label & LABEL_DIFFUSE) ? VIS_DIFFUSE : transmit ? VIS_TRANSMISSION : VIS_GLOSSY;
    float pdf_l;
    float3 Le = emitter_along(scene,
                              offset_ray(p, transmit ? -sd->Ng : sd->Ng,
                                         scene->emitter_info->offset_scale),
                              b.wo, ray, p, sd->N, sd->crossings, &pdf_l);
    float pdf_b = b.pdf;      /* next-event estimation's density for its closures (mis_mask) */
    if (mis_mask != mask && !isinf(pdf_b)) pdf_b = shader_mis_pdf(sd, b.wo, mask, mis_mask, pdf_b);
    return b.weight * Le * mis_power(pdf_b, pdf_l);
#else
    return (float3)(0.0f);       /* nothing for the sample to find but what NEE samples */
#endif
}

/* Direct light at shading point p for the closures in mask, times the path weight beta:
 * next-event estimation and one sample of those closures, combined by MIS, each clamped to
 * `limit` (path_state.h clamp_sample; 0: not).  For Lambert closures the sample only pays where
 * next-event estimation is poor, next to large emissive meshes (a ceiling 1 cm above a lamp);
 * with lights and the world alone next-event estimation works alone (the sample's ray would
 * mostly find nothing).  Returns the radiance towards sd->wi. */
inline float3 direct_light(const Scene *scene, const ShaderData *sd, float3 p, int mask,
                           float3 beta, float limit, uint *rng) {
    bool lambert = true;
    for (int k = 0; k < sd->n; k++)
        lambert &= !closure_in(&sd->c[k], mask) || sd->c[k].type == CLOSURE_DIFFUSE;
    bool sample = !lambert || WORLD_PROGRAM(scene->emitter_info);
#if PPM_EMISSIVE
    sample = sample || scene->emitter_info->n_emissive > 0;
#endif
    float3 L = clamp_sample(beta * direct_nee(scene, sd, p, mask, sample, rng), limit);
    return sample ? L + clamp_sample(beta * direct_bsdf(scene, sd, p, mask, mask, rng), limit) : L;
}
#endif
