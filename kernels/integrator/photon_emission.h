#ifndef PPM_PHOTON_EMISSION_H
#define PPM_PHOTON_EMISSION_H
#include "rng.h"
#include "light/light_types.h"
#include "light/light_mesh.h"
#include "light/world.h"
#include "light/aim.h"
#include "light/guide.h"

/* The share of a sun's or the world's light that reaches the scene through the world's
 * medium (EmitterInfo.world_medium) from infinitely far: none in a channel where it has
 * extinction (Cycles'; shadow_rays.h world_medium) */
inline float3 far_transmittance(const Scene *scene) {
    EmitterInfo info = *scene->emitter_info;
    if (!PPM_VOLUME || info.n_media == 0 || info.world_medium < 0) return (float3)(1.0f);
    __global const Material *m = scene->materials + info.world_medium;
    return select((float3)(0.0f), (float3)(1.0f),
                  isequal(F3(m->absorption) + F3(m->scattering), (float3)(0.0f)));
}

/* Emit one photon: an emitter picked in proportion to its power, then its origin, direction
 * and flux (already divided by all sampling pdfs).  ``aim`` (caustic photons: only those whose
 * first scattering is by a caster live on): the emitter picked by its power toward the casters
 * (scene->caustic_cdf) and the photon aimed at them (light/aim.h), its flux divided by that
 * density instead.  When the Light Paths clamp indirect light (else 0;
 * kernels/integrator/gather.cl clamps a photon as the camera path that finds the same light
 * would be clamped): *rs the radiance along its first ray over its flux (one number: both are
 * the emitter's colour times a number); *nee the density next-event estimation would give the
 * photon's origin from where it lands, t away: nee.x t^2 + nee.y (per steradian, next-event
 * estimation's pick of the emitter included).  A point, spot or sun of no size (*delta) has
 * both infinite: no camera path hits it, and next-event estimation alone finds it, with
 * rs / (nee.x t^2 + nee.y) of the flux per unit of f cos (its sample: I / (t^2 pick) of a point
 * light); for those *rs and *nee are the same light's with a radius of 1 (a sun's cone of pi
 * sr), whose ratio is the same (photon_pass.cl takes it at the light's first scattering).
 * *caster the caster it was aimed at (-1: none).  ``guided`` (not aimed): a guided light's
 * direction from its learned bins too (light/guide.h), the flux divided by the mixture's
 * density, *gbin its bin among all guides' (-1: none).  The emitter types a program has are the
 * feature flags of shared.h (0/1). */
inline bool emit_photon(const Scene *scene, uint *rng, bool aim, bool guided, float3 *o, float3 *d,
                        float3 *flux, float *rs, float2 *nee, bool *delta, int *caster, int *gbin) {
    *rs = 0.0f;
    *caster = -1;
    *gbin = -1;
    *nee = (float2)(0.0f);
    *delta = false;
    bool clamped = scene->light_paths->clamp_indirect > 0.0f;
    EmitterInfo info = *scene->emitter_info;
    if (info.n_emitters == 0) return false;
    aim = aim && info.n_casters > 0;
    float pmf;
    int e = pick_emitter(aim ? scene->caustic_cdf : scene->emitter_cdf, info.n_emitters, rnd(rng),
                         &pmf);
    if (!(pmf > 0.0f)) return false;
    /* next-event estimation's pick of the emitter (the clamp's MIS, below) */
    float pn = aim ? emitter_pmf(scene->emitter_cdf, e) : pmf;
    float u1 = rnd(rng), u2 = rnd(rng), u3 = rnd(rng), u4 = rnd(rng);
    float3 c = F3(info.scene_center);
    float R = info.scene_radius;
    /* the aim's three numbers (drawn only when aimed: a photon not aimed is as before) */
    float a0 = aim ? rnd(rng) : 0.0f, a1 = aim ? rnd(rng) : 0.0f, a2 = aim ? rnd(rng) : 0.0f;
    /* where aimed, the density of the native direction (or origin) over the aimed one's */
    float ratio = 1.0f;
    if (e < info.n_lights) {
        Light L = scene->lights[e];
        float r = L.radius;
        if (PPM_LIGHT_SUN && L.type == LIGHT_SUN) {
            sun_emit(&L, c, R, pmf, u1, u2, u3, u4, o, d, flux);
            *flux *= far_transmittance(scene);
            float pa;
            if (aim && !aim_origin(scene, *d, c, R, a0, a1, a2, o, &pa, caster)) return false;
            if (aim) ratio = 1.0f / (PPM_PI * R * R * pa);
            /* sun_seen's radiance over the flux; next-event estimation samples its cone (of no
             * size: the ratio of the two, pmf / (pi R^2 pn), as for the cone of pi sr) */
            *delta = clamped && !(r > 0.0f);
            if (clamped && r > 0.0f) {
                *rs = pmf / (PPM_PI * PPM_PI * R * R * sin(r) * sin(r));
                nee->y = pn / (2.0f * PPM_PI * (1.0f - cos(r)));
            } else if (clamped) {
                *rs = pmf / (PPM_PI * PPM_PI * R * R);
                nee->y = pn / PPM_PI;
            }
        } else if (PPM_LIGHT_POINT && (L.type == LIGHT_POINT || L.type == LIGHT_SPOT)) {
            point_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
            bool sphere = r > 0.0f && L.type == LIGHT_POINT;
            float3 ns = sphere ? normalize(*o - F3(L.position)) : (float3)(0.0f);
            __global const float *g = guided && !aim ? guide_of(scene, e) : 0;
            if (g) {
                /* guided (light/guide.h): the direction from the mixture of the light's own
                 * density (uniform over its sphere or its spot's cone) and the learned bins */
                float cm = L.type == LIGHT_SPOT ? spot_sample_cos(&L) : -1.0f;
                float3 axis = L.type == LIGHT_SPOT ? F3(L.direction) : (float3)(0.0f, 0.0f, 1.0f);
                float pn = 1.0f / (2.0f * PPM_PI * (1.0f - cm));
                if (g[1] < 1.0f) {
                    if (rnd(rng) >= g[1]) *d = guide_sample(g, axis, rnd(rng), rnd(rng), rnd(rng));
                    else if (sphere) *d = sample_uniform_sphere(rnd(rng), rnd(rng));
                    if (sphere) {
                        /* a sphere's origin given its direction: uniform over the disc facing
                         * it, onto the sphere (its own density cos / pi r^2: the pair's is the
                         * native one, 1 / 4 pi r^2 times cos / pi) */
                        float3 t, b;
                        make_frame(*d, &t, &b);
                        float2 q = sample_disk(rnd(rng), rnd(rng));
                        ns = q.x * t + q.y * b + sqrt(fmax(0.0f, 1.0f - dot(q, q))) * *d;
                        *o = offset_ray(F3(L.position) + r * ns, ns, info.offset_scale);
                    } else if (L.type == LIGHT_SPOT) {
                        *flux = F3(L.emit) * (spot_attenuation(&L, *d) / (pn * pmf));
                    }
                }
                ratio = pn / guide_mixture(g, axis, *d, pn, gbin);
                if (*gbin >= 0) *gbin += scene->guide_slot[e] * GUIDE_BINS;
            }
            if (aim) {
                float pa, cm = L.type == LIGHT_SPOT ? spot_sample_cos(&L) : -1.0f;
                if (!aim_direction(scene, *o, ns, sphere, F3(L.direction), 1.0f - cm, a0, a1, a2, d,
                                   &pa, caster))
                    return false;
                float pd; /* point_emit's density of *d */
                if (sphere) {
                    pd = fmax(dot(ns, *d), 0.0f) * (1.0f / PPM_PI);
                } else if (L.type == LIGHT_SPOT) {
                    pd = 1.0f / (2.0f * PPM_PI * (1.0f - cm));
                    *flux = F3(L.emit) * (spot_attenuation(&L, *d) / (pd * pmf));
                } else {
                    pd = 1.0f / (4.0f * PPM_PI);
                }
                ratio = pd / pa;
            }
            /* a sphere (a disc for a spot) of radius r: intensity / (pi r^2) over the flux; of no
             * size, radius 1's: the ratio pmf pdf / pn (pdf: point_emit's of the direction) */
            if (clamped) {
                float rr = r > 0.0f ? r : 1.0f;
                *delta = !(r > 0.0f);
                *rs = L.type == LIGHT_SPOT
                          ? pmf / (2.0f * PPM_PI * PPM_PI * rr * rr * (1.0f - spot_sample_cos(&L)))
                          : pmf / (4.0f * PPM_PI * PPM_PI * rr * rr);
                nee->x = pn / (PPM_PI * rr * rr);
            }
        } else if (PPM_LIGHT_AREA && (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE)) {
            area_emit(&L, pmf, u1, u2, u3, u4, info.offset_scale, o, d, flux);
            float3 nl = F3(L.direction);
            __global const float *g = guided && !aim ? guide_of(scene, e) : 0;
            if (g) { /* guided: the cosine's density mixed with the learned bins' */
                if (g[1] < 1.0f && rnd(rng) >= g[1])
                    *d = guide_sample(g, nl, rnd(rng), rnd(rng), rnd(rng));
                float pn = fmax(dot(nl, *d), 0.0f) * (1.0f / PPM_PI);
                ratio = pn / guide_mixture(g, nl, *d, pn, gbin);
                if (*gbin >= 0) *gbin += scene->guide_slot[e] * GUIDE_BINS;
            }
            if (aim) {
                float pa;
                if (!aim_direction(scene, *o, nl, true, nl, 2.0f, a0, a1, a2, d, &pa, caster))
                    return false;
                ratio = fmax(dot(nl, *d), 0.0f) * (1.0f / PPM_PI) / pa;
            }
            if (clamped) {
                *rs = pmf / (PPM_PI * area_light_area(&L));
                nee->x = pn / (area_light_area(&L) * fmax(dot(nl, *d), 1e-6f));
            }
        } else return false;
    } else if (PPM_EMISSIVE && e < info.n_lights + info.n_emissive) {
        int k = scene->emissive[e - info.n_lights];
        float3 q, nt;
        if (!mesh_emit(scene, k, pmf, u1, u2, u3, u4, o, d, flux, &q, &nt)) return false;
        if (aim) {
            float pa;
            if (!aim_direction(scene, *o, nt, false, nt, 2.0f, a0, a1, a2, d, &pa, caster))
                return false;
            /* either side, as mesh_emit picks one; the origin off the side it leaves */
            float cs = dot(nt, *d);
            ratio = 0.5f * fabs(cs) * (1.0f / PPM_PI) / pa;
            *o = offset_ray(q, cs < 0.0f ? -nt : nt, info.offset_scale);
        }
        if (clamped) {
            float area = 0.5f * length(cross(scene->tri_e1[k].xyz, scene->tri_e2[k].xyz));
            *rs = pmf / (PPM_PI * area);
            nee->x = pn / (area * fmax(fabs(dot(nt, *d)), 1e-6f));
        }
    } else if (PPM_WORLD && info.has_world) {
        if (!world_emit(scene, pmf, u1, u2, u3, u4, o, d, flux)) return false;
        if (clamped) {
            *rs = avg3(world_le(scene, -*d)) / avg3(*flux);
            nee->y = *rs * PPM_PI * R * R * (pn / pmf); /* the direction's density times the pick */
        }
        *flux *= far_transmittance(scene); /* (and so the radiance: rs the same) */
        float pa;
        if (aim && !aim_origin(scene, *d, c, R, a0, a1, a2, o, &pa, caster)) return false;
        if (aim) ratio = 1.0f / (PPM_PI * R * R * pa);
    } else return false;
    if (ratio != 1.0f) { /* aimed: the same radiance over a flux times ratio */
        *flux *= ratio;
        *rs /= ratio;
    }
    if (!isfinite(*rs) || !isfinite(nee->x) || !isfinite(nee->y)) *rs = 0.0f;
    return max3(*flux) > 0.0f && isfinite(max3(*flux));
}
#endif
