#ifndef PPM_PHOTON_EMISSION_H
#define PPM_PHOTON_EMISSION_H
#include "rng.h"
#include "light/light_types.h"
#include "light/light_mesh.h"
#include "light/world.h"

/* Emit one photon: an emitter picked in proportion to its power, then its origin, direction
 * and flux (already divided by all sampling pdfs).  When the Light Paths clamp indirect light
 * (else 0; kernels/integrator/gather.cl clamps a photon as the camera path that finds the same
 * light would be clamped): *rs the radiance along its first ray over its flux (one number: both are
 * the emitter's colour times a number), 0 from a point, spot or sun of no size, which no camera
 * path can hit; *nee the density next-event estimation would give the photon's origin from
 * where it lands, t away: nee.x t^2 + nee.y (per steradian, the emitter's pick included).  The
 * emitter types a program has are the feature flags of shared.h (0/1). */
inline bool emit_photon(const Scene *scene, uint *rng, float3 *o, float3 *d, float3 *flux,
                        float *rs, float2 *nee) {
    *rs = 0.0f;
    *nee = (float2)(0.0f);
    bool clamped = scene->light_paths->clamp_indirect > 0.0f;
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
        float r = L.radius;
        if (PPM_LIGHT_SUN && L.type == LIGHT_SUN) {
            sun_emit(&L, c, R, pmf, u1, u2, u3, u4, o, d, flux);
            /* sun_seen's radiance over the flux; next-event estimation samples its cone */
            if (clamped && r > 0.0f) {
                *rs = pmf / (PPM_PI * PPM_PI * R * R * sin(r) * sin(r));
                nee->y = pmf / (2.0f * PPM_PI * (1.0f - cos(r)));
            }
        } else if (PPM_LIGHT_POINT && (L.type == LIGHT_POINT || L.type == LIGHT_SPOT)) {
            point_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
            /* a sphere (a disc for a spot) of radius r: intensity / (pi r^2) over the flux */
            if (clamped && r > 0.0f) {
                *rs = L.type == LIGHT_SPOT
                          ? pmf / (2.0f * PPM_PI * PPM_PI * r * r * (1.0f - spot_sample_cos(&L)))
                          : pmf / (4.0f * PPM_PI * PPM_PI * r * r);
                nee->x = pmf / (PPM_PI * r * r);
            }
        } else if (PPM_LIGHT_AREA && (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE)) {
            area_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
            if (clamped) {
                *rs = pmf / (PPM_PI * area_light_area(&L));
                nee->x = pmf / (area_light_area(&L) * fmax(dot(F3(L.direction), *d), 1e-6f));
            }
        } else return false;
    } else if (PPM_EMISSIVE && e < info.n_lights + info.n_emissive) {
        int k = scene->emissive[e - info.n_lights];
        if (!mesh_emit(scene, k, pmf, u1, u2, u3, u4, o, d, flux)) return false;
        if (clamped) {
            float3 cr = cross(scene->tri_e1[k].xyz, scene->tri_e2[k].xyz);
            float area = 0.5f * length(cr);
            *rs = pmf / (PPM_PI * area);
            nee->x = pmf / (area * fmax(fabs(dot(normalize(cr), *d)), 1e-6f));
        }
    } else if (PPM_WORLD && info.has_world) {
        if (!world_emit(scene, pmf, u1, u2, u3, u4, o, d, flux)) return false;
        if (clamped) {
            *rs = avg3(world_le(scene, -*d)) / avg3(*flux);
            nee->y = *rs * PPM_PI * R * R; /* the direction's density times the pick */
        }
    } else return false;
    if (!isfinite(*rs) || !isfinite(nee->x) || !isfinite(nee->y)) *rs = 0.0f;
    return max3(*flux) > 0.0f && isfinite(max3(*flux));
}
#endif
