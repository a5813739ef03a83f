#ifndef PPM_LIGHT_PATH_H
#define PPM_LIGHT_PATH_H
#include "closure/closure_types.h"
#include "shared.h"

/* The ray that reached a shading point, as the Light Path node sees it (kernels/svm/svm.h), packed
 * into one uint: its type (PATH_*, 7 bits) and the bounces before it, 5 bits each (saturating
 * at 31): all, transparent, diffuse, glossy, transmission.  Bounces follow Cycles'
 * path_state_next: a reflection counts as diffuse or glossy, a transmission as transmission,
 * a singular lobe is glossy and singular; a transparent crossing keeps the type. */
/* (the type bits are in the order of the Light Path node's outputs, LIGHT_PATH_*) */
#define PATH_CAMERA (1u << LIGHT_PATH_CAMERA)
#define PATH_SHADOW (1u << LIGHT_PATH_SHADOW)
#define PATH_DIFFUSE (1u << LIGHT_PATH_DIFFUSE)
#define PATH_GLOSSY (1u << LIGHT_PATH_GLOSSY)
#define PATH_SINGULAR (1u << LIGHT_PATH_SINGULAR)
#define PATH_REFLECT (1u << LIGHT_PATH_REFLECTION)
#define PATH_TRANSMIT (1u << LIGHT_PATH_TRANSMISSION)
#define PATH_DEPTH 0          /* path_count fields */
#define PATH_TRANSPARENT_DEPTH 1
#define PATH_DIFFUSE_DEPTH 2
#define PATH_GLOSSY_DEPTH 3
#define PATH_TRANSMISSION_DEPTH 4

inline uint path_count(uint p, int k) { return (p >> (7 + 5 * k)) & 31u; }
inline uint path_add(uint p, int k) { return path_count(p, k) < 31u ? p + (1u << (7 + 5 * k)) : p; }

/* the type bits of the ray a bounce with sample label `label` makes */
inline uint path_kind(int label) {
    uint f = (label & LABEL_DIFFUSE)  ? PATH_DIFFUSE
             : (label & LABEL_GLOSSY) ? PATH_GLOSSY
                                      : (PATH_GLOSSY | PATH_SINGULAR);
    return f | ((label & LABEL_TRANSMIT) ? PATH_TRANSMIT : PATH_REFLECT);
}

/* the bounce count (path_count field) a bounce of type bits f adds to */
inline int path_kind_field(uint f) {
    return (f & PATH_TRANSMIT)  ? PATH_TRANSMISSION_DEPTH
           : (f & PATH_DIFFUSE) ? PATH_DIFFUSE_DEPTH
                                : PATH_GLOSSY_DEPTH;
}

/* the state after a bounce with sample label `label` */
inline uint path_bounce(uint p, int label) {
    uint f = path_kind(label);
    p = path_add(path_add(p, PATH_DEPTH), path_kind_field(f));
    return (p & ~127u) | f;
}

/* the state after a transparent crossing (the type kept) */
inline uint path_transparent(uint p) { return path_add(p, PATH_TRANSPARENT_DEPTH); }

/* the state after n transparent crossings (the lights a ray met: direct_light.h lights_seen) */
inline uint path_transparent_n(uint p, int n) {
    for (int k = 0; k < min(n, 31); k++) p = path_transparent(p);
    return p;
}

/* --- Cycles' Light Paths limits (ppm_engine/scene/light_paths.py; docs/SHADING.md, "Light Paths").
 * Cycles counts a path's bounces from the camera: each scattering but the one that reaches the
 * light (next-event estimation's vertex, or the sample that finds an emitter) counts, by kind
 * (a reflection diffuse or glossy, a transmission), and a transparent crossing counts apart.
 * A path past a limit ends as Cycles' PATH_RAY_TERMINATE_* do: */
#define TERM_NONE 0
#define TERM_AFTER_TRANSPARENT \
    1 /* past a bounce limit: the path crosses transparent surfaces
                                    and adds the emission of the surface it meets, no more */
#define TERM_ON_NEXT_SURFACE 2   /* past the transparent limit: the next surface's emission */

/* How a path whose state after a bounce is p (depth: its true bounce count) ends: past a
 * bounce limit or not.  The counts in p saturate at 31, so a limit of 31 or more of one kind
 * is kept by the total alone. */
inline int path_limit(uint p, int depth, __global const LightPaths *lp) {
    return depth > lp->max_bounces || (int)path_count(p, PATH_DIFFUSE_DEPTH) > lp->diffuse_bounces
                   || (int)path_count(p, PATH_GLOSSY_DEPTH) > lp->glossy_bounces
                   || (int)path_count(p, PATH_TRANSMISSION_DEPTH) > lp->transmission_bounces
               ? TERM_AFTER_TRANSPARENT
               : TERM_NONE;
}

/* A scattering in a medium (eye paths: eye_pass.cl, indirect_paths.h): the path's state after
 * it (a bounce of no surface kind, its type cleared), its bounce and volume-bounce counts one
 * up, and how it ends: past Volume bounces or max bounces, as Cycles' volume scattering. */
inline int path_volume_bounce(uint *p, int *depth, int *vbounce, __global const LightPaths *lp) {
    *p = path_add(*p, PATH_DEPTH) & ~127u;
    *depth += 1;
    *vbounce += 1;
    return *vbounce > lp->volume_bounces || *depth > lp->max_bounces ? TERM_AFTER_TRANSPARENT
                                                                     : TERM_NONE;
}

/* How a path ends after a transparent crossing that brought its count to n */
inline int path_limit_transparent(int n, __global const LightPaths *lp) {
    return n >= lp->transparent_max_bounces ? TERM_ON_NEXT_SURFACE : TERM_NONE;
}

/* A photon's light path joined to a visible point's eye path: the kinds of the visible point's
 * own bounce (JOIN_*) through which the whole path keeps the limits.  e: the ray that reached
 * the visible point; p: the photon's state (the bounces after the light's first scattering,
 * which Cycles would reach by next-event estimation and so not count).  The transparent
 * crossings of both parts count together. */
#define JOIN_DIFFUSE 1u          /* a diffuse reflection at the visible point */
#define JOIN_GLOSSY 2u           /* a glossy reflection */
#define JOIN_DIFFUSE_TRANSMIT 4u /* a diffuse transmission */
#define JOIN_GLOSSY_TRANSMIT 8u  /* a glossy transmission */
#define JOIN_ALL 15u

/* Reflective / Refractive Caustics off (Cycles' caustics toggles): a glossy reflection / a
 * glossy transmission right after a diffuse bounce, from the camera, is not made.  Whether a
 * bounce of type bits f (glossy or singular) is such a one, were the next bounce towards the
 * camera diffuse. */
inline bool path_caustic_off(uint f, __global const LightPaths *lp) {
    if (!(f & PATH_GLOSSY)) return false;
    return (f & PATH_TRANSMIT) ? !(lp->flags & LP_CAUSTICS_REFRACTIVE)
                               : !(lp->flags & LP_CAUSTICS_REFLECTIVE);
}
/* the scatterings in media a state p counts (PPM_VOLUME: a medium's scattering adds to the depth
 * alone, so they are what the depth holds past the bounces of each kind) */
inline int path_volume(uint p) {
    return max((int)path_count(p, PATH_DEPTH) - (int)path_count(p, PATH_DIFFUSE_DEPTH)
                   - (int)path_count(p, PATH_GLOSSY_DEPTH)
                   - (int)path_count(p, PATH_TRANSMISSION_DEPTH),
               0);
}

/* Volume bounces, as Cycles': a path goes on past a scattering in a medium (other than through
 * transparent surfaces) only while its scatterings in media so far are at most the setting, so
 * those of the joined path (the light's first scattering is next-event estimation's and
 * counts for nothing, as in p) must be; v: the joining vertex's own (1 in a medium, 0 on a
 * surface).  Scenes without media count none. */
inline bool path_join_volume(uint e, uint p, int v, __global const LightPaths *lp) {
    return path_volume(e) + path_volume(p) + v <= lp->volume_bounces;
}

inline uint path_join(uint e, uint p, __global const LightPaths *lp) {
    if (!path_join_volume(e, p, 0, lp)) return 0u;
    int total = (int)(path_count(e, PATH_DEPTH) + path_count(p, PATH_DEPTH)) + 1;
    int tr = (int)(path_count(e, PATH_TRANSPARENT_DEPTH) + path_count(p, PATH_TRANSPARENT_DEPTH));
    int d = (int)(path_count(e, PATH_DIFFUSE_DEPTH) + path_count(p, PATH_DIFFUSE_DEPTH));
    int g = (int)(path_count(e, PATH_GLOSSY_DEPTH) + path_count(p, PATH_GLOSSY_DEPTH));
    int t = (int)(path_count(e, PATH_TRANSMISSION_DEPTH) + path_count(p, PATH_TRANSMISSION_DEPTH));
    if (total > lp->max_bounces || tr > lp->transparent_max_bounces || d > lp->diffuse_bounces
        || g > lp->glossy_bounces || t > lp->transmission_bounces)
        return 0u;
    uint k = (d < lp->diffuse_bounces ? JOIN_DIFFUSE : 0u)
             | (g < lp->glossy_bounces ? JOIN_GLOSSY : 0u)
             | (t < lp->transmission_bounces ? JOIN_DIFFUSE_TRANSMIT | JOIN_GLOSSY_TRANSMIT : 0u);
    /* the photon's last bounce, a caustic one that is off: not after a diffuse bounce here */
    if (path_caustic_off(p & 127u, lp)) k &= ~(JOIN_DIFFUSE | JOIN_DIFFUSE_TRANSMIT);
    return k;
}

/* A volume photon's light path (p) joined to a camera path (e) that scatters it in a medium
 * (volume_gather.cl): whether the whole path keeps the limits, that scattering a volume bounce */
inline bool path_join_medium(uint e, uint p, __global const LightPaths *lp) {
    int total = (int)(path_count(e, PATH_DEPTH) + path_count(p, PATH_DEPTH)) + 1;
    int tr = (int)(path_count(e, PATH_TRANSPARENT_DEPTH) + path_count(p, PATH_TRANSPARENT_DEPTH));
    int d = (int)(path_count(e, PATH_DIFFUSE_DEPTH) + path_count(p, PATH_DIFFUSE_DEPTH));
    int g = (int)(path_count(e, PATH_GLOSSY_DEPTH) + path_count(p, PATH_GLOSSY_DEPTH));
    int t = (int)(path_count(e, PATH_TRANSMISSION_DEPTH) + path_count(p, PATH_TRANSMISSION_DEPTH));
    return path_join_volume(e, p, 1, lp) && total <= lp->max_bounces
           && tr <= lp->transparent_max_bounces && d <= lp->diffuse_bounces
           && g <= lp->glossy_bounces && t <= lp->transmission_bounces;
}

/* Cycles' Clamp Direct and Clamp Indirect: a sample's contribution (its path weight times what
 * it found) whose r + g + b exceeds the limit (3 x the setting; 0: off) is scaled down to it.
 * Direct: the light path has no bounce Cycles counts (an emitter the camera or a vertex's
 * sample finds after at most one bounce, next-event estimation at the first vertex). */
inline float clamp_limit(int bounces, __global const LightPaths *lp) {
    return bounces <= 0 ? lp->clamp_direct : lp->clamp_indirect;
}

inline float3 clamp_sample(float3 L, float limit) {
    float s = fabs(L.x) + fabs(L.y) + fabs(L.z);
    return limit > 0.0f && s > limit ? L * (limit / s) : L;
}

/* --- Filter Glossy (Cycles' blur of glossy lobes, Light Paths > Caustics; docs/SHADING.md).
 * A camera path keeps the smallest density of its bounces so far (the mixture's, of all the
 * closures at each vertex; singular and transparent bounces do not lower it: INFINITY), as
 * Cycles' min_ray_pdf.  Where it is below the setting (filter_glossy = Cycles' blur_glossy; 0:
 * off) the vertex is blurred: every microfacet lobe there is at least as rough as
 * filter_glossy_alpha says (shader.h shader_blur), before anything is shaded.  Light paths
 * split between the eye paths and the photons by it: a light path whose light scatters first at
 * a blurred vertex is the eye paths' (they meet blurred lobes and estimate the light through
 * all of them); the photons carry only light paths no vertex of which is blurred, seen from
 * the camera (photon_pass.cl, gather.cl: filter_glossy_keeps). */
#define FILTER_GLOSSY_DIFFUSE_PDF \
    0.31830988618f /* 1 / pi: the most a diffuse closure's density is */
inline bool filter_glossy_blurs(float min_pdf, __global const LightPaths *lp) {
    return lp->filter_glossy > 0.0f && min_pdf < lp->filter_glossy;
}

/* the alpha a blurred vertex's microfacet lobes are raised to (0: not blurred): Cycles'
 * sqrt(1 - min_pdf / filter_glossy) / 2 */
inline float filter_glossy_alpha(float min_pdf, __global const LightPaths *lp) {
    if (!filter_glossy_blurs(min_pdf, lp)) return 0.0f;
    return 0.5f * sqrt(1.0f - min_pdf / lp->filter_glossy);
}

/* The roughness from which a followed glossy reflection is the eye paths' light, not the
 * caustic photons' (shader.h shader_classify; RenderOptions.caustic_roughness, in the
 * Light Paths record).  With Filter Glossy above 1 / pi every one that is not singular: a
 * photon scattered first by it would be merged only where a camera path's bounce towards it
 * has more than that density, which no diffuse point's has, so only near the peaks of glossy
 * lobes, where a merge is at its noisiest; next-event estimation through the lobe is Cycles'
 * estimator of that light (the sun-lit cone's noise x sqrt(time) 0.0103 -> 0.0089).  The host
 * finds the casters by the same rule (ppm_engine/scene/casters.py caustic_roughness). */
inline float filter_glossy_caustic_roughness(__global const LightPaths *lp) {
    return filter_glossy_blurs(FILTER_GLOSSY_DIFFUSE_PDF, lp) ? 0.0f : lp->caustic_roughness;
}

/* whether a camera path that bounced with density pdf (the mixture's, INFINITY: singular) leaves
 * the vertex it reaches unblurred, that is whether a photon's light that came along the reverse
 * of that bounce is the photons' */
inline bool filter_glossy_keeps(float pdf, __global const LightPaths *lp) {
    return !filter_glossy_blurs(pdf, lp);
}

/* output k of the Light Path node (LIGHT_PATH_*) for state p and the length of the ray's last
 * segment */
inline float path_output(uint p, float length, int k) {
    if (k < LIGHT_PATH_VOLUME_SCATTER) return (p >> k) & 1u ? 1.0f : 0.0f;   /* a type bit */
    if (k == LIGHT_PATH_VOLUME_SCATTER) return 0.0f;
    if (k == LIGHT_PATH_RAY_LENGTH) return length;
    if (k == LIGHT_PATH_PORTAL_DEPTH) return 0.0f;
    /* the depths, from LIGHT_PATH_RAY_DEPTH on */
    const int field[5] = {PATH_DEPTH, PATH_DIFFUSE_DEPTH, PATH_GLOSSY_DEPTH, PATH_TRANSPARENT_DEPTH,
                          PATH_TRANSMISSION_DEPTH};
    return (float)path_count(p, field[clamp(k - LIGHT_PATH_RAY_DEPTH, 0, 4)]);
}
#endif
