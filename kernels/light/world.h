#ifndef PPM_WORLD_H
#define PPM_WORLD_H
/* The world: a constant colour all around, or (PPM_WORLD_MAP) the radiance of its shader
 * program (export/world.py) importance-sampled by a lat-long map of it baked on the device
 * (ppm_engine/render/world_map.py; Cycles' background map).  world_map holds the map's marginal CDF
 * over rows (map_h + 1 floats, v upwards), each row's CDF over columns (map_h x (map_w + 1))
 * and the map's values f (map_h x map_w: mean radiance x sin(theta) at the texel centres);
 * the density of a direction in (u, v) is f / mean(f), over solid angle / (2 pi^2 sin(theta)). */
#include "light/light_types.h"
#include "svm/svm.h"
#include "light/world_map.h"

/* whether this build and scene evaluate the world's program */
#define WORLD_PROGRAM(info) (PPM_WORLD_MAP && PPM_SVM && (info)->world_program > 0)

/* the world's radiance along direction d */
inline float3 world_le(const Scene *scene, float3 d) {
#if PPM_WORLD_MAP && PPM_SVM
    if (scene->emitter_info->world_program > 0)
        return svm_world(scene, scene->emitter_info->world_program, d);
#endif
    return F3(scene->emitter_info->world);
}

/* density next-event estimation gives direction d of the world (pmf not included); n: the
 * normal a constant world is sampled around */
inline float world_pdf(const Scene *scene, float3 d, float3 n) {
    if (WORLD_PROGRAM(scene->emitter_info)) {
        EmitterInfo info = *scene->emitter_info;
        return world_map_pdf(d, info.map_w, info.map_h, info.map_mean, scene->world_map);
    }
    return fmax(dot(d, n), 0.0f) * (1.0f / PPM_PI);
}

/* next-event estimation of the world from a point with shading normal n */
inline bool world_direct(const Scene *scene, float3 n, float u1, float u2, LightSample *s) {
    if (WORLD_PROGRAM(scene->emitter_info)) {
        EmitterInfo info = *scene->emitter_info;
        if (!world_map_sample(info.map_w, info.map_h, info.map_mean, scene->world_map, u1, u2,
                              &s->wi, &s->pdf_dir))
            return false;
        s->E = world_le(scene, s->wi) / s->pdf_dir;
        return true;
    }
    s->wi = sample_cosine_hemisphere(n, u1, u2);       /* density cos / pi */
    s->pdf_dir = fmax(dot(s->wi, n), 0.0f) * (1.0f / PPM_PI);
    s->E = F3(scene->emitter_info->world) / s->pdf_dir;
    return s->pdf_dir > 0.0f;
}

/* photons from a disc of the scene's bounding radius R across the direction they travel: a
 * uniform direction for a constant world, else one from the map */
inline bool world_emit(const Scene *scene, float pmf, float u1, float u2, float u3, float u4,
                       float3 *o, float3 *d, float3 *flux) {
    float3 c = F3(scene->emitter_info->scene_center);
    float R = scene->emitter_info->scene_radius;
    float3 dir, scale;
    if (WORLD_PROGRAM(scene->emitter_info)) {
        EmitterInfo info = *scene->emitter_info;
        float3 wi;
        float pdf;
        if (!world_map_sample(info.map_w, info.map_h, info.map_mean, scene->world_map, u3, u4, &wi,
                              &pdf))
            return false;
        dir = -wi;
        scale = world_le(scene, wi) * (PPM_PI * R * R / (pdf * pmf));
    } else {
        dir = sample_uniform_sphere(u3, u4);
        scale = F3(scene->emitter_info->world) * (4.0f * PPM_PI * PPM_PI * R * R / pmf);
    }
    float2 q = sample_disk(u1, u2) * R;
    float3 t, b;
    make_frame(dir, &t, &b);
    *d = dir;
    *o = c - R * dir + q.x * t + q.y * b;
    *flux = scale;
    return true;
}
#endif
