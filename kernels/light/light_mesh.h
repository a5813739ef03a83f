#ifndef PPM_LIGHT_MESH_H
#define PPM_LIGHT_MESH_H
#include "light/light_tree.h"
#include "light/light_types.h"
#include "svm/shader_inputs.h"
/* --- emissive triangles (mesh lights) ------------------------------------------------------
 * Both sides emit.  Seen by rays as the surfaces they are (the passes add their emission). */

/* The index of emissive BVH leaf k among the emissive triangles (-1 when it is not one):
 * emissive[] holds the emissive leaves in ascending order (ppm_engine/scene/emitters.py). */
inline int emissive_index(const Scene *scene, int leaf) {
    int lo = 0, hi = scene->emitter_info->n_emissive - 1;
    while (lo <= hi) {
        int mid = (lo + hi) >> 1, v = scene->emissive[mid];
        if (v == leaf) return mid;
        if (v < leaf) lo = mid + 1;
        else hi = mid - 1;
    }
    return -1;
}

/* --- the pick among few emissive triangles -----------------------------------------------
 * The emitter table picks an emitter by its power, the same from every shading point.  A
 * scene lit by one emissive quad (two triangles) then picks the far triangle half the time
 * at a ceiling a centimetre from the lamp, where the near one gives nearly all the light: the
 * brightest pixels beside a lamp carried 1.3x Cycles' variance (Cycles' light tree picks by
 * importance at the shading point).  With at most LOCAL_PICK_MAX emissive triangles,
 * next-event estimation from a point near them (within LOCAL_PICK_NEAR times their bounding
 * ball, emitters.py) picks among them (the group keeps its probability in the table) by the
 * irradiance each gives the point, unoccluded: its mean radiance times its projected solid
 * angle (Lambert's formula for a polygon), mixed with the power pick (LOCAL_PICK_DEFENSIVE of
 * it: a transmitting closure lit from behind, or an occluded triangle, keeps a share).
 * Farther away the triangles' light is in proportion to their power already, and the power
 * pick costs nothing (evaluated everywhere, the Cornell box's eye pass took 40 % longer).
 * The MIS of an emitter a sampled ray hits evaluates the same pmf from the same vertex
 * (mesh_seen), so the estimate stays unbiased. */
#define LOCAL_PICK_NEAR 2.0f
#define LOCAL_PICK_DEFENSIVE 0.25f

inline bool local_pick_at(const Scene *scene, float3 p) {
    __global const EmitterInfo *info = scene->emitter_info;
    float r = info->local_radius * LOCAL_PICK_NEAR;
    if (!(r > 0.0f) || info->n_emissive > LOCAL_PICK_MAX) return false;
    float3 v = p - F3(info->local_center);
    return dot(v, v) < r * r;
}

/* atan2(y, x) for y >= 0 to 2e-6 rad (a minimax polynomial on [0, 1] folded to [0, pi]): an
 * importance needs no more; evaluated at every vertex of the Cornell box the library's took
 * the eye pass 42 ms against this one's 38 (29 without the local pick) */
inline float atan2_fast(float y, float x) {
    float ax = fabs(x), mx = fmax(ax, y), mn = fmin(ax, y);
    float t = mx > 0.0f ? mn / mx : 0.0f, t2 = t * t;
    float r = t
              * (0.99997726f
                 + t2
                       * (-0.33262347f
                          + t2
                                * (0.19354346f
                                   + t2 * (-0.11643287f + t2 * (0.05265332f - t2 * 0.01172120f)))));
    if (y > ax) r = 0.5f * PPM_PI - r;
    return x < 0.0f ? PPM_PI - r : r;
}

/* the projected solid angle of the triangle (p0, p1, p2) from p with normal n: the integral
 * of cos over the directions it subtends (below the horizon cos counts negative; clamped at 0) */
inline float projected_solid_angle(float3 p, float3 n, float3 p0, float3 p1, float3 p2) {
    float3 a = p0 - p, b = p1 - p, c = p2 - p;
    float la = length(a), lb = length(b), lc = length(c);
    if (!(la > 0.0f && lb > 0.0f && lc > 0.0f)) return 0.0f;
    a /= la;
    b /= lb;
    c /= lc;
    float3 nab = cross(a, b), nbc = cross(b, c), nca = cross(c, a);
    float lab = length(nab), lbc = length(nbc), lca = length(nca), s = 0.0f;
    /* (the angle between two unit vectors from their cross and dot products) */
    if (lab > 0.0f) s += atan2_fast(lab, dot(a, b)) * dot(n, nab) / lab;
    if (lbc > 0.0f) s += atan2_fast(lbc, dot(b, c)) * dot(n, nbc) / lbc;
    if (lca > 0.0f) s += atan2_fast(lca, dot(c, a)) * dot(n, nca) / lca;
    s *= dot(a, nbc) < 0.0f ? -0.5f : 0.5f;
    return isfinite(s) ? fmax(s, 0.0f) : 0.0f;
}

/* the power pick's probabilities g[j] of the emissive triangles and their sum, and their
 * importance at p (normal n) imp[j] and its sum (local_pick_at only) */
inline void local_weights(const Scene *scene, float3 p, float3 n, float *g, float *imp,
                          float *g_sum, float *imp_sum) {
    int first = scene->emitter_info->n_lights, m = scene->emitter_info->n_emissive;
    float gs = 0.0f, is = 0.0f;
    for (int j = 0; j < m && j < LOCAL_PICK_MAX; j++) {
        int e = first + j, leaf = scene->emissive[j];
        g[j] = emitter_pmf(scene->local_cdf, e);
        float4 v0 = scene->tri_v0[leaf], e1 = scene->tri_e1[leaf], e2 = scene->tri_e2[leaf];
        float area2 = length(cross(e1.xyz, e2.xyz));
        /* g / area: the triangle's mean radiance (its power over its area), up to a constant */
        float w = area2 > 0.0f
                      ? g[j] / area2
                            * projected_solid_angle(p, n, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz)
                      : 0.0f;
        imp[j] = isfinite(w) ? w : 0.0f;
        gs += g[j];
        is += imp[j];
    }
    *g_sum = gs;
    *imp_sum = is;
}

/* the pick's probability of emissive triangle j given the group (local_pick_at), from the
 * weights of local_weights */
inline float local_share(int j, const float *g, const float *imp, float g_sum, float imp_sum) {
    if (!(g_sum > 0.0f)) return 0.0f;
    if (!(imp_sum > 0.0f && isfinite(imp_sum))) return g[j] / g_sum;
    return (1.0f - LOCAL_PICK_DEFENSIVE) * imp[j] / imp_sum + LOCAL_PICK_DEFENSIVE * g[j] / g_sum;
}

/* Next-event estimation's choice between the local emitters (lights but suns, emissive
 * triangles) and the far ones (suns, the world) at p (normal n): the local ones' share, as
 * Cycles' light tree chooses between its local lights and its distant ones (the mean of two
 * shares, by their upper and by their lower bounds on importance): by importance, the bound of
 * them all (local_bound: light_tree_importance) against the far ones' (EmitterInfo
 * far_energy), and with a world (whose lower bound is 0) all of it where the local ones surely
 * light p, half where they may not (from within their box, or where some face away).  By
 * power, a dim world around a large scene took half of the samples from a lamp beside the
 * point: rough glass cubes before a lamp-lit wall under a grey world had 1.17x and 1.09x
 * Cycles' noise per sample on the glass of roughness 0.2 and on the wall, 1.00x and 0.77x with
 * this (docs/BENCHMARKS.md, "Rough glass").  With a light tree (many local emitters) their
 * share stays their power's: the bound of a whole city seen from within it says little (the
 * benchmark's city at night gave its sky 9 % of the samples by power, 25 % by this and 0.2 % by
 * the upper bounds alone, with 1.13x and 1.15x the noise at equal passes). */
inline float emitter_local_share(const Scene *scene, float3 p, float3 n) {
    __global const EmitterInfo *info = scene->emitter_info;
    float far = info->far_energy;
    if (!(far > 0.0f)) return 1.0f;
    if (info->n_tree > 0) return info->tree_share;
    float loc = light_tree_importance(scene->local_bound, p, n);
    if (!(loc > 0.0f)) return 0.0f;
    float s = isfinite(loc + far) ? loc / (loc + far) : 1.0f;
    if (!info->has_world) return s;  /* (suns only: their lower bound taken as their upper) */
    return 0.5f * s + (light_tree_surely_lights(scene->local_bound, p, n) ? 0.5f : 0.25f);
}

/* whether emitter e is a local one (not a sun, not the world) */
inline bool emitter_is_local(const Scene *scene, int e) {
    __global const EmitterInfo *info = scene->emitter_info;
    return e < info->n_lights ? scene->lights[e].type != LIGHT_SUN
                              : e < info->n_lights + info->n_emissive;
}

/* The probability, among the local emitters, that next-event estimation from p (normal n)
 * picks emissive triangle j (the emitter table's n_lights + j) */
inline float emissive_local_pmf(const Scene *scene, int j, float3 p, float3 n) {
    __global const EmitterInfo *info = scene->emitter_info;
    if (info->n_tree > 0) return light_tree_pmf(scene, info->n_lights + j, p, n);
    if (local_pick_at(scene, p)) {
        float g[LOCAL_PICK_MAX], imp[LOCAL_PICK_MAX], g_sum, imp_sum;
        local_weights(scene, p, n, g, imp, &g_sum, &imp_sum);
        return g_sum * local_share(j, g, imp, g_sum, imp_sum);
    }
    return emitter_pmf(scene->local_cdf, info->n_lights + j);
}

/* The probability that next-event estimation from p (normal n, as sample_emitter is given
 * them) picks emissive BVH leaf k as the emitter (0 when it is not one). */
inline float emissive_leaf_pmf(const Scene *scene, int leaf, float3 p, float3 n) {
    int j = emissive_index(scene, leaf);
    if (j < 0) return 0.0f;
    return emitter_local_share(scene, p, n) * emissive_local_pmf(scene, j, p, n);
}

/* The probability next-event estimation from p (normal n) picks emitter e (a light, an
 * emissive triangle, the world: the emitter table's order) */
inline float emitter_pmf_at(const Scene *scene, int e, float3 p, float3 n) {
    __global const EmitterInfo *info = scene->emitter_info;
    float share = emitter_local_share(scene, p, n);
    if (!emitter_is_local(scene, e)) return (1.0f - share) * emitter_pmf(scene->far_cdf, e);
    if (e >= info->n_lights) return share * emissive_local_pmf(scene, e - info->n_lights, p, n);
    if (info->n_tree > 0) return share * light_tree_pmf(scene, e, p, n);
    return share * emitter_pmf(scene->local_cdf, e);
}

/* Next-event estimation's pick from p (normal n) with the number u: local or far emitters
 * (emitter_local_share), then the far ones by power, the local ones by the light tree, or by
 * power with the local pick among few emissive triangles (its number: where u fell in the
 * group's range of the local power table, rescaled). */
inline int pick_emitter_at(const Scene *scene, float3 p, float3 n, float u, float *pmf) {
    __global const EmitterInfo *info = scene->emitter_info;
    float share = emitter_local_share(scene, p, n);
    if (!(u < share)) {
        int e = pick_emitter(scene->far_cdf, info->n_emitters,
                             clamp((u - share) / (1.0f - share), 0.0f, 0.99999994f), pmf);
        *pmf *= 1.0f - share;
        return e;
    }
    u = share < 1.0f ? clamp(u / share, 0.0f, 0.99999994f) : u;
    if (info->n_tree > 0) {
        int e = light_tree_sample(scene, p, n, u, pmf);
        *pmf *= share;
        return e;
    }
    int e = pick_emitter(scene->local_cdf, info->n_emitters, u, pmf);
    *pmf *= share;
    int first = info->n_lights;
    if (!(PPM_EMISSIVE && e >= first && local_pick_at(scene, p) && e < first + info->n_emissive))
        return e;
    float g[LOCAL_PICK_MAX], imp[LOCAL_PICK_MAX], g_sum, imp_sum;
    local_weights(scene, p, n, g, imp, &g_sum, &imp_sum);
    float c0 = first > 0 ? scene->local_cdf[first - 1] : 0.0f;
    float v = clamp((u - c0) / g_sum, 0.0f, 1.0f), acc = 0.0f;
    int m = info->n_emissive, j = 0;
    for (; j < m - 1; j++) {
        float q = local_share(j, g, imp, g_sum, imp_sum);
        if (v < acc + q && q > 0.0f) break;
        acc += q;
    }
    /* (the last: what rounding leaves; skipped back to a triangle with a share) */
    while (j > 0 && !(local_share(j, g, imp, g_sum, imp_sum) > 0.0f)) j--;
    *pmf = share * g_sum * local_share(j, g, imp, g_sum, imp_sum);
    return first + j;
}

/* Emissive triangles seen under a large solid angle are sampled by solid angle.  Area sampling
 * gives a sample at distance d the weight d^2 / cos: next to a large emitter (a ceiling 1 cm
 * above a lamp, a filament's glass) that weight varies by orders of magnitude.  Arvo's (1995)
 * sampling of the spherical triangle is uniform in solid angle instead; it is used when the
 * triangle subtends more than SPHERICAL_MIN_SOLID_ANGLE (area sampling is as good below and
 * keeps full precision for far, small triangles).  The choice depends only on the point and the
 * triangle, so mesh_direct and direct_bsdf (its MIS pdf) always agree. */
#define SPHERICAL_MIN_SOLID_ANGLE 0.02f

/* angle between unit vectors, accurate near 0 and pi */
inline float angle_between(float3 u, float3 v) {
    return dot(u, v) < 0.0f ? PPM_PI - 2.0f * asin(fmin(length(u + v) * 0.5f, 1.0f))
                            : 2.0f * asin(fmin(length(v - u) * 0.5f, 1.0f));
}

typedef struct {
    float3 a, b, c;          /* unit directions to the corners */
    float alpha;             /* the spherical triangle's angle at a */
    float area;              /* its solid angle; 0: use area sampling */
} SphTri;

inline SphTri spherical_triangle(float3 o, float3 p0, float3 p1, float3 p2) {
    SphTri t;
    t.area = 0.0f;
    /* a triangle inside a ball that subtends less than the threshold does too: area sampling,
     * decided without the three angles (most triangles of a large emissive mesh, seen from
     * most points: a furnace's pass took 111 ms with them, 128x128) */
    float3 cen = (p0 + p1 + p2) * (1.0f / 3.0f);
    float3 q0 = p0 - cen, q1 = p1 - cen, q2 = p2 - cen, oc = cen - o;
    float r2 = fmax(dot(q0, q0), fmax(dot(q1, q1), dot(q2, q2))), d2 = dot(oc, oc);
    if (d2 > r2 && 2.0f * PPM_PI * (1.0f - sqrt(1.0f - r2 / d2)) <= SPHERICAL_MIN_SOLID_ANGLE) {
        t.a = t.b = t.c = (float3)(0.0f);
        t.alpha = 0.0f;
        return t;
    }
    t.a = normalize(p0 - o);
    t.b = normalize(p1 - o);
    t.c = normalize(p2 - o);
    float3 n_ab = cross(t.a, t.b), n_bc = cross(t.b, t.c), n_ca = cross(t.c, t.a);
    float l_ab = length(n_ab), l_bc = length(n_bc), l_ca = length(n_ca);
    if (!(l_ab > 1e-7f && l_bc > 1e-7f && l_ca > 1e-7f)) return t;
    n_ab /= l_ab;
    n_bc /= l_bc;
    n_ca /= l_ca;
    t.alpha = angle_between(n_ab, -n_ca);
    float A = t.alpha + angle_between(n_bc, -n_ab) + angle_between(n_ca, -n_bc) - PPM_PI;
    t.area = (A > SPHERICAL_MIN_SOLID_ANGLE && A < 2.0f * PPM_PI && isfinite(A)) ? A : 0.0f;
    return t;
}

/* a direction uniform over the spherical triangle t (t.area > 0), Arvo 1995 */
inline float3 sample_spherical_triangle(const SphTri *t, float u0, float u1) {
    float x = u0 * t->area;                          /* solid angle of the sub-triangle */
    float ca = cos(t->alpha), sa = sin(t->alpha);
    /* phi = Ap_pi - alpha with Ap_pi = pi + x: sin and cos of pi + x - alpha */
    float sin_phi = -sin(x) * ca + cos(x) * sa;
    float cos_phi = -cos(x) * ca - sin(x) * sa;
    float k1 = cos_phi + ca, k2 = sin_phi - sa * dot(t->a, t->b);
    float cos_bp = (k2 + (k2 * cos_phi - k1 * sin_phi) * ca) / ((k2 * sin_phi + k1 * cos_phi) * sa);
    cos_bp = isfinite(cos_bp) ? clamp(cos_bp, -1.0f, 1.0f) : 1.0f;
    float sin_bp = sqrt(fmax(0.0f, 1.0f - cos_bp * cos_bp));
    float3 ca_perp = t->c - dot(t->c, t->a) * t->a;
    float3 cp = cos_bp * t->a + sin_bp * normalize(ca_perp);
    float cos_t = 1.0f - u1 * (1.0f - dot(cp, t->b));
    float sin_t = sqrt(fmax(0.0f, 1.0f - cos_t * cos_t));
    float3 cb_perp = cp - dot(cp, t->b) * t->b;
    float lb = length(cb_perp);
    return normalize(cos_t * t->b + (lb > 0.0f ? sin_t / lb : 0.0f) * cb_perp);
}

/* Next-event sample of emissive BVH leaf k from origin o. */
inline bool mesh_direct(const Scene *scene, int k, float3 o, float u1, float u2, LightSample *s) {
    float4 v0 = scene->tri_v0[k], e1 = scene->tri_e1[k], e2 = scene->tri_e2[k];
    float3 c = cross(e1.xyz, e2.xyz);
    float area2 = length(c);
    if (!(area2 > 0.0f)) return false;
    float3 nt = c / area2;
    __global const Material *me = scene->materials + as_int(e2.w);
    SphTri st = spherical_triangle(o, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz);
    float2 b;
    float3 q;
    if (st.area > 0.0f) {              /* uniform in solid angle: weight = solid angle */
        s->wi = sample_spherical_triangle(&st, u1, u2);
        float denom = dot(s->wi, nt);
        float t = dot(v0.xyz - o, nt) / denom;
        if (!(t > 0.0f && isfinite(t))) return false;
        q = o + t * s->wi;
        /* barycentrics of q for the emission texture */
        float3 dq = q - v0.xyz;
        float d00 = dot(e1.xyz, e1.xyz), d01 = dot(e1.xyz, e2.xyz), d11 = dot(e2.xyz, e2.xyz);
        float d20 = dot(dq, e1.xyz), d21 = dot(dq, e2.xyz), den = d00 * d11 - d01 * d01;
        b = (float2)((d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den);
        s->E = st.area;
        s->pdf_dir = 1.0f / st.area;
    } else {                           /* uniform in area: weight = cos area / d^2 */
        b = sample_triangle(u1, u2);
        q = v0.xyz + b.x * e1.xyz + b.y * e2.xyz;
    }
    q = offset_ray(q, dot(o - q, nt) >= 0.0f ? nt : -nt,
                   scene->emitter_info->offset_scale);                 /* on our side of it */
    float3 tq = q - o;
    float dq2 = dot(tq, tq);
    s->dist = st.area > 0.0f ? dot(tq, s->wi) : sqrt(dq2);   /* along wi: short of the emitter */
    if (!(s->dist > 0.0f)) return false;
    if (!(st.area > 0.0f)) {          /* (solid angle: wi stays the sampled direction,
                                          q only ends the shadow ray) */
        s->wi = tq / s->dist;
        float cos_l = fabs(dot(s->wi, nt));                   /* mesh lights: both sides */
        s->E = cos_l * 0.5f * area2 / dq2;
        s->pdf_dir = cos_l > 0.0f ? dq2 / (cos_l * 0.5f * area2) : 0.0f;
    }
    s->E = s->E * material_emission(scene, me, as_uint(v0.w), b.x, b.y, q);
    return true;
}

/* A photon from emissive BVH leaf k: a uniform point, a side with probability 1/2 each, a
 * cosine-weighted direction; *q the point on the triangle, *n its normal (either side). */
inline bool mesh_emit(const Scene *scene, int k, float pmf, float u1, float u2, float u3, float u4,
                      float3 *o, float3 *d, float3 *flux, float3 *q_out, float3 *n_out) {
    float4 v0 = scene->tri_v0[k], e1 = scene->tri_e1[k], e2 = scene->tri_e2[k];
    float2 b = sample_triangle(u1, u2);
    float3 q = v0.xyz + b.x * e1.xyz + b.y * e2.xyz;
    float3 cr = cross(e1.xyz, e2.xyz);
    float area2 = length(cr);
    if (!(area2 > 0.0f)) return false;
    float3 nt = cr / area2;
    *q_out = q;
    *n_out = nt;
    float side = u3 < 0.5f ? 1.0f : -1.0f;
    float uu = u3 < 0.5f ? 2.0f * u3 : 2.0f * u3 - 1.0f;
    nt *= side;
    *d = sample_cosine_hemisphere(nt, uu, u4);
    *o = offset_ray(q, nt, scene->emitter_info->offset_scale);
    __global const Material *me = scene->materials + as_int(e2.w);
    *flux = material_emission(scene, me, as_uint(v0.w), b.x, b.y, q)
            * (2.0f * PPM_PI * 0.5f * area2 / pmf);
    return true;
}
#endif
