#ifndef PPM_PHOTON_EMISSION_H
#define PPM_PHOTON_EMISSION_H
#include "rng.h"
#include "light_types.h"
#include "light_mesh.h"
#include "world.h"

/* Emit one photon: an emitter picked in proportion to its power, then its origin, direction
 * and flux (already divided by all sampling pdfs).  The emitter types a program has are the
 * feature flags of shared.h (0/1). */
inline bool emit_photon(const Scene *scene, uint *rng, float3 *o, float3 *d, float3 *flux) {
    EmitterInfo info = *scene->emitter_info;
    if (info.n_emitters == 0) return false;
    float pmf;
    int e = pick_emitter(scene->emitter_cdf, info.n_emitters, rnd(rng), &pmf);
    if (!(pmf > 0.0f)) return false;
    float u1 = rnd(rng), u2 = rnd(rng), u3 = rnd(rng), u4 = rnd(rng);
    float3 c = F3(info.scene_center);
    float R = info.scene_radius;
    if (e < info.n_lights) {
        Light L = scene->lights[e];
        if (PPM_LIGHT_SUN && L.type == LIGHT_SUN)
            sun_emit(&L, c, R, pmf, u1, u2, u3, u4, o, d, flux);
        else if (PPM_LIGHT_POINT && (L.type == LIGHT_POINT || L.type == LIGHT_SPOT))
            point_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
        else if (PPM_LIGHT_AREA && (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE))
            area_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
        else return false;
    } else if (PPM_EMISSIVE && e < info.n_lights + info.n_emissive) {
        if (!mesh_emit(scene, scene->emissive[e - info.n_lights], pmf, u1, u2, u3, u4, o, d, flux))
            return false;
    } else if (PPM_WORLD && info.has_world) {
        if (!world_emit(scene, pmf, u1, u2, u3, u4, o, d, flux)) return false;
    } else return false;
    return max3(*flux) > 0.0f && isfinite(max3(*flux));
}
#endif
