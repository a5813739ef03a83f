#ifndef PPM_DIRECT_LIGHT_H
#define PPM_DIRECT_LIGHT_H
#include "rng.h"
#include "light/light_types.h"
#include "light/light_mesh.h"
#include "light/world.h"
#include "closure/shader.h"
#include "integrator/shadow_rays.h"

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

/* The scene lights rays see (camera, glossy, transmission and diffuse rays; Cycles shows area
 * lights from the front, point lights as disks or spheres, suns with an angle as discs to rays
 * that escape).  As in Cycles (shade_light), lights do not block rays: a ray that meets one
 * adds its emission and goes on past it to the lights and the surface behind; each light met is
 * a transparent bounce, and the path ends at the one that brings its count to the Light Paths'
 * transparent limit.  Shadow rays meet none.  Counting only the nearest light, a grid of 1 cm
 * lights overlapping each other 5 cm under a ceiling lost half the ceiling's direct light (the
 * sample's side of MIS, tests/test_light_tree.py). */

/* A ray looking for lights: o + t d, 0 < t < tmax, of visibility ray_type (VIS_CAMERA,
 * VIS_DIFFUSE, VIS_GLOSSY or VIS_TRANSMISSION; a light hidden from it is not met), sampled with
 * density prev_pdf (INFINITY: a camera ray or a singular lobe) at the vertex pv of normal nv;
 * each light it meets adds beta x its radiance x the MIS weight of that sample against
 * next-event estimation's density of that light from pv (the light tree's pick included),
 * clamped to `limit` (clamp_sample). */
typedef struct {
    float3 o, d, pv, nv, beta;
    float tmax, prev_pdf, limit;
    uint ray_type;
#if PPM_VOLUME
    /* the extinction of the media it is in: a light at t seen through exp(-sigma_t t), and
     * through the field's among them + 1 (geom/medium_field.h; 0: none) */
    float3 sigma_t;
    int field;
#endif
} LightRay;

inline LightRay light_ray(float3 o, float3 d, float tmax, uint ray_type, float3 pv, float3 nv,
                          float prev_pdf, float3 beta, float limit) {
    LightRay r = {o, d, pv, nv, beta, tmax, prev_pdf, limit, ray_type}; /* (sigma_t: 0) */
    return r;
}
#if PPM_VOLUME
/* ray r in the media m: the lights it meets are seen through them (media_mix) */
inline void light_ray_in(LightRay *r, const Scene *scene, const Media *m) {
    Mix x = media_mix(m, scene->materials);
    r->sigma_t = x.sigma_a + x.sigma_s;
    r->field = x.field + 1;
}
#endif

/* one light a ray meets: its distance and index (lights are met in the order of (t, i)), and
 * what it adds */
typedef struct {
    float t;
    int i;
    float3 c;
} LightMet;

/* Whether ray r meets light i after (t0, i0); *m the meeting.  Suns are suns_seen's. */
inline bool light_met(const Scene *scene, int i, const LightRay *r, float t0, int i0, LightMet *m) {
    Light l = scene->lights[i];
    if (l.flags & (r->ray_type << LIGHT_HIDDEN_SHIFT)) return false;
    float t = 0.0f, pdf = 0.0f;
    float3 Le = (float3)(0.0f);
    bool hit = false;
    if (PPM_LIGHT_AREA && (l.type == LIGHT_AREA_RECT || l.type == LIGHT_AREA_ELLIPSE))
        hit = area_seen(&l, r->o, r->d, r->tmax, &t, &Le, &pdf);
    else if (PPM_LIGHT_POINT && l.type == LIGHT_POINT)
        hit = point_seen(&l, r->o, r->d, r->tmax, &t, &Le, &pdf);
    if (!hit || !(t > t0 || (t == t0 && i > i0))) return false;
    m->t = t;
    m->i = i;
    float w = 1.0f;
    if (!isinf(r->prev_pdf) && max3(r->beta) > 0.0f) {
        w = mis_power(r->prev_pdf, pdf * emitter_pmf_at(scene, i, r->pv, r->nv));
    }
#if PPM_VOLUME
    if (r->field > 0) { /* (ratio tracking to the light) */
        uint rng = ray_hash(r->o, r->d);
        float3 T = (float3)(1.0f);
        Mix x = mix_extinction(scene, r->field - 1, r->sigma_t);
        medium_ratio(scene, &x, r->o, r->d, t, ratio_rate(t), &rng, &T);
        Le *= T;
    } else {
        Le *= exp(-r->sigma_t * t);
    }
#endif
    m->c = clamp_sample(r->beta * Le * w, r->limit);
    return true;
}

/* whether o + t d meets the box [lo, hi] for some t in [0, tmax] */
inline bool ray_box(float3 o, float3 inv_d, float3 lo, float3 hi, float tmax) {
    float3 t0 = (lo - o) * inv_d, t1 = (hi - o) * inv_d;
    float3 a = fmin(t0, t1), b = fmax(t0, t1);
    float near = fmax(fmax(a.x, a.y), fmax(a.z, 0.0f)), far = fmin(fmin(b.x, b.y), fmin(b.z, tmax));
    return near <= far;
}

/* The lights ray r meets after (t0, i0): their number, the sum of what they add (*sum) and the
 * first of them (*first; t PPM_INF: none).  Many lights: the light tree's boxes (which hold the
 * lights whole) as a BVH. */
inline int lights_met(const Scene *scene, const LightRay *r, float t0, int i0, float3 *sum,
                      LightMet *first) {
    int n = 0, n_lights = scene->emitter_info->n_lights;
    *sum = (float3)(0.0f);
    first->t = PPM_INF;
    first->i = -1;
    first->c = (float3)(0.0f);
    LightMet m;
    if (scene->emitter_info->n_tree > 0) {
        __global const LightTreeNode *tree = scene->light_tree;
        float3 inv_d = 1.0f / r->d;
        int stack[LIGHT_TREE_STACK], top = 0;
        stack[top++] = 0;
        while (top > 0) {
            int k = stack[--top];
            if (!ray_box(r->o, inv_d, F3(tree[k].bmin), F3(tree[k].bmax), r->tmax)) continue;
            int c = tree[k].child;
            if (c < 0) {
                if (-1 - c < n_lights && light_met(scene, -1 - c, r, t0, i0, &m)) {
                    n++;
                    *sum += m.c;
                    if (m.t < first->t || (m.t == first->t && m.i < first->i)) *first = m;
                }
            } else if (top + 2 <= LIGHT_TREE_STACK) {
                stack[top++] = c + 1;
                stack[top++] = c;
            }
        }
    } else {
        for (int i = 0; i < n_lights; i++)
            if (light_met(scene, i, r, t0, i0, &m)) {
                n++;
                *sum += m.c;
                if (m.t < first->t) *first = m; /* (met in the order of i) */
            }
    }
    return n;
}

/* The radiance of the suns (with an angle) a ray that escapes the scene along d sees, those not
 * hidden from ray_type.  Next-event estimation samples a sun without MIS (sun_direct: pdf_dir
 * 0), so a sun a sampled direction finds counts only after a singular bounce or the camera. */
inline float3 suns_seen(const Scene *scene, float3 d, uint ray_type) {
    float3 L = (float3)(0.0f);
    if (!PPM_LIGHT_SUN || scene->emitter_info->n_suns == 0) return L;
    for (int i = 0; i < scene->emitter_info->n_lights; i++) {
        Light l = scene->lights[i];
        if (l.type == LIGHT_SUN && !(l.flags & (ray_type << LIGHT_HIDDEN_SHIFT)))
            L += sun_seen(&l, d);
    }
    return L;
}

/* What the lights ray r meets add to its path, and the suns' light when it `escaped` the scene.
 * `budget`: the transparent bounces the path has left, at least 1 (Cycles ends a path at the
 * light that brings its count to the limit); *met: the lights met, at most budget; the path
 * ends when it is budget (then only the nearest budget lights count, and nothing behind
 * them). */
inline float3 lights_seen(const Scene *scene, const LightRay *r, bool escaped, int budget,
                          int *met) {
    float3 L, s;
    LightMet m;
    int n = lights_met(scene, r, -1.0f, -1, &L, &m);
    if (n >= budget) {
        /* the path ends at the budget-th light: the lights met one by one, nearest first */
        L = m.c;
        for (int k = 1; k < budget; k++) {
            lights_met(scene, r, m.t, m.i, &s, &m);
            L += m.c;
        }
        *met = budget;
        return L;
    }
    *met = n;
#if PPM_VOLUME
    /* (through the world's medium, from infinitely far: none where it has extinction) */
    if (escaped && isinf(r->prev_pdf))
        L += clamp_sample(r->beta * suns_seen(scene, r->d, r->ray_type)
                              * medium_tr(r->sigma_t, PPM_INF),
                          r->limit);
#else
    if (escaped && isinf(r->prev_pdf))
        L += clamp_sample(r->beta * suns_seen(scene, r->d, r->ray_type), r->limit);
#endif
    return L;
}

/* The transparent bounces a path whose count is `transparent` has left for the lights its next
 * ray meets (lights_seen's budget): at least one, as Cycles counts the light before it ends the
 * path. */
inline int lights_budget(int transparent, __global const LightPaths *lp) {
    return max(lp->transparent_max_bounces - transparent, 1);
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

/* The density next-event estimation gives the world in direction d from a point p whose normal
 * (the one the world is sampled around) is n, its pick included. */
inline float world_light_pdf(const Scene *scene, float3 d, float3 p, float3 n) {
    return world_pdf(scene, d, n)
           * emitter_pmf_at(scene, scene->emitter_info->n_emitters - 1, p, n);
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
    float3 f = shader_eval_as(sd, s.wi, mask, true, &pdf_b);
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
#if PPM_VOLUME
    Media m = shading_media(scene, sd, transmit); /* the point's, or those behind the surface */
    float3 T = ray_transmittance_media(scene, o, wi, dist, sd->crossings, VIS_SHADOW, &m);
#else
    float3 T = shadow_transmittance(scene, o, wi, dist, sd->crossings);
#endif
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

/* What a ray from o along d finds of the emitters (ray_type: VIS_*), weighted against
 * next-event estimation by the power heuristic (the ray's sample of density pdf_b; p and n: the
 * vertex the ray left and the normal next-event estimation was given there, around which the
 * world is sampled): the lights it meets on its way (lights_seen) and the first emitting surface
 * or the world, through at most `crossings` partly transparent surfaces (attenuated), with the
 * lights met among the transparent bounces. */
inline float3 emitter_along(const Scene *scene, float3 o, float3 d, uint ray_type, float3 p,
                            float3 n, int crossings, float pdf_b, const Media *media) {
    float3 T = (float3)(1.0f), L = (float3)(0.0f);
#if PPM_VOLUME
    Media m = media_copy(media); /* the ray's (0: none), changed at the boundaries it crosses */
#endif
    for (;;) {
        Hit h = bvh_intersect(scene, o, d, PPM_INF, ray_type, false);
#if PPM_LIGHTS_SEEN
        LightRay r = light_ray(o, d, h.leaf < 0 ? PPM_INF : h.t, ray_type, p, n, pdf_b, T, 0.0f);
#if PPM_VOLUME
        light_ray_in(&r, scene, &m);
#endif
        int met, budget = max(crossings, 1);
        L += lights_seen(scene, &r, h.leaf < 0, budget, &met);
        if (met == budget) return L; /* the path ends at the last light it may cross */
        crossings -= met;
#endif
#if PPM_VOLUME
        T *= media_transmittance_ray(scene, &m, o, d, h.leaf < 0 ? PPM_INF : h.t);
        if (!(max3(T) > 0.0f)) return L;
#endif
        if (h.leaf < 0) {
            if (!(PPM_WORLD && scene->emitter_info->has_world)) return L;
            return L + T * world_le(scene, d) * mis_power(pdf_b, world_light_pdf(scene, d, p, n));
        }
        int mat = as_int(scene->tri_e2[h.leaf].w);
        if (PPM_EMISSIVE && (scene->materials[mat].flags & MAT_EMISSIVE)) {
            float pdf_l;
            float3 Le = mesh_seen(scene, h.leaf, o, d, h.t, h.u, h.v, p, n, &pdf_l);
            return L + T * Le * mis_power(pdf_b, pdf_l);
        }
#if !PPM_TRANSPARENT
        return L;          /* an opaque surface: no emitter behind it counts */
#endif
        if (crossings <= 0 || !(scene->materials[mat].flags & MAT_TRANSPARENT)) return L;
        crossings--;
        Surface s = surface_at(scene, h);
        T *= material_transparency(scene, mat, s.tri, h.u, h.v, s.p);
        if (!(max3(T) > 0.0f)) return L;
#if PPM_VOLUME
        media_cross_transparent(&m, scene->materials, mat, dot(d, s.ng) < 0.0f);
#endif
        o = offset_ray(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng, scene->emitter_info->offset_scale);
    }
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
    float pdf_b = b.pdf;      /* next-event estimation's density for its closures (mis_mask) */
    if (mis_mask != mask && !isinf(pdf_b)) pdf_b = shader_mis_pdf(sd, b.wo, mask, mis_mask, pdf_b);
#if PPM_VOLUME
    Media m = shading_media(scene, sd, transmit), *mp = &m;
#else
    const Media *mp = 0;
#endif
    return b.weight
           * emitter_along(scene,
                           offset_ray(p, transmit ? -sd->Ng : sd->Ng,
                                      scene->emitter_info->offset_scale),
                           b.wo, ray, p, sd->N, sd->crossings, pdf_b, mp);
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
