#ifndef PPM_SHADOW_RAYS_H
#define PPM_SHADOW_RAYS_H
#include "geom/bvh.h"
#include "geom/medium.h"
#include "geom/medium_field.h"
#include "closure/shader.h"

/* What shadow rays (and the photons' connections to the camera) let through: partly
 * transparent surfaces, and with PPM_VOLUME the homogeneous media (geom/medium.h) they cross;
 * the media a ray leaving a shading point starts in, and the media holding a point (a camera, a
 * light). */

/* The fraction of light a ray from o along d lets through over dist, meeting the objects of
 * visibility `mask`: 0 at an opaque surface; partly transparent surfaces (alpha, Transparent
 * BSDF) attenuate it, at most `crossings` of them (as Blender 5.0's Cycles renders: the Light
 * Paths' transparent limit less the path's crossings, ShaderData.crossings); with PPM_VOLUME and
 * media m (the ray's: entered and left at the transparent boundaries it crosses; NULL: none
 * counted), each segment's extinction (Beer-Lambert) too. */
inline float3 transmittance_through(const Scene *scene, float3 o, float3 d, float dist,
                                    int crossings, uint mask, Media *m) {
    float3 T = (float3)(1.0f);
    for (int i = 0; i <= crossings; i++) {
        Hit h = bvh_intersect(scene, o, d, dist, mask, false);
#if PPM_VOLUME
        if (m) T *= media_transmittance_ray(scene, m, o, d, h.leaf < 0 ? dist : h.t);
#endif
        if (h.leaf < 0) return T;
        Surface s = surface_at(scene, h);
        if (i == crossings || !(scene->materials[s.material].flags & MAT_TRANSPARENT))
            return (float3)(0.0f);
        T *= material_transparency(scene, s.material, s.tri, h.u, h.v, s.p);
        if (!(max3(T) > 0.0f)) return (float3)(0.0f);
#if PPM_VOLUME
        if (m) media_cross_transparent(m, scene->materials, s.material, dot(d, s.ng) < 0.0f);
#endif
        float3 o2 = offset_ray(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng,
                               scene->emitter_info->offset_scale);
        dist -= dot(o2 - o, d);
        o = o2;
        if (!(dist > 0.0f)) return T;
    }
    return (float3)(0.0f);
}

/* transmittance_through without media.  A shadow ray's (shadow_transmittance) meets what casts
 * shadows; a camera connection's (photon_pass.cl connect_camera) what the camera sees; without
 * transparent surfaces one ray that stops at any hit. */
inline float3 ray_transmittance(const Scene *scene, float3 o, float3 d, float dist, int crossings,
                                uint mask) {
#if PPM_TRANSPARENT
    return transmittance_through(scene, o, d, dist, crossings, mask, 0);
#else
    Hit h = bvh_intersect(scene, o, d, dist, mask, true);
    return (float3)(h.leaf < 0 ? 1.0f : 0.0f);
#endif
}

inline float3 shadow_transmittance(const Scene *scene, float3 o, float3 d, float dist,
                                   int crossings) {
    return ray_transmittance(scene, o, d, dist, crossings, VIS_SHADOW);
}

#if PPM_VOLUME
/* ray_transmittance through media: m0 the media at o (0: none) */
inline float3 ray_transmittance_media(const Scene *scene, float3 o, float3 d, float dist,
                                      int crossings, uint mask, const Media *m0) {
    Media m = media_copy(m0);
    return transmittance_through(scene, o, d, dist, crossings, mask, &m);
}

/* The world's medium (its Volume output, EmitterInfo.world_medium), -1 where there is none:
 * it fills the space outside every object, the bottom of every volume stack (Cycles'), and a
 * ray that leaves the scene in it goes on forever (no background, no sun through it). */
inline int world_medium(const Scene *scene) {
    return scene->emitter_info->n_media > 0 ? scene->emitter_info->world_medium : -1;
}

/* The media that hold point p (camera rays' and photons' start, Cycles' volume stack
 * initialisation): the world's, then a ray from p through every surface (at most
 * MEDIA_PROBE_HITS); a medium whose boundaries it leaves more often than it enters (several
 * meshes may share a material) holds p.  Outermost first, as paths push them: the order in
 * which the ray first leaves them, reversed. */
#define MEDIA_PROBE_HITS 32
inline void media_at(const Scene *scene, float3 p, Media *m) {
    media_init(m);
    if (scene->emitter_info->n_media == 0) return; /* (a program of every feature, no media) */
    int w = world_medium(scene);
    if (w >= 0) {
        media_cross(m, w, true);
        if (scene->emitter_info->n_media == 1) return; /* (no mesh has a medium) */
    }
    float3 d = (float3)(0.26726124f, 0.53452248f, 0.80178373f); /* (1, 2, 3) / sqrt(14) */
    int seen[2 * MEDIUM_DEPTH], depth[2 * MEDIUM_DEPTH], n_seen = 0;
    float3 o = p;
    for (int k = 0; k < MEDIA_PROBE_HITS; k++) {
        Hit h = bvh_intersect(scene, o, d, PPM_INF, 0xffffffffu, false);
        if (h.leaf < 0) break;
        Surface s = surface_at(scene, h);
        bool leaving = dot(d, s.ng) > 0.0f;
        o = offset_ray(s.p, leaving ? s.ng : -s.ng, scene->emitter_info->offset_scale);
        if (!(scene->materials[s.material].flags & MAT_VOLUME)) continue;
        int j = 0;
        while (j < n_seen && seen[j] != s.material) j++;
        if (j == n_seen) {
            if (n_seen == 2 * MEDIUM_DEPTH) continue; /* (more media than it keeps) */
            seen[n_seen] = s.material;
            depth[n_seen++] = 0;
        }
        depth[j] += leaving ? 1 : -1;
    }
    for (int j = n_seen - 1; j >= 0; j--)
        if (depth[j] > 0 && m->n < MEDIUM_DEPTH) m->mat[m->n++] = seen[j];
}
#endif

#if PPM_VOLUME
/* The media a ray leaving shading point sd starts in: the point's (the pass's, sd->media; none
 * when 0), or, through the surface (`transmit`), those its crossing leads into. */
inline Media shading_media(const Scene *scene, const ShaderData *sd, bool transmit) {
    Media m = media_copy(sd->media);
    if (transmit && sd->leaf >= 0)
        media_cross_transparent(&m, scene->materials, as_int(scene->tri_e2[sd->leaf].w),
                                !sd->backfacing);
    return m;
}
#endif
#endif
