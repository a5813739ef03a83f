/* Photon pass: photons emitted from the emitters in proportion to power, scattered by sampling
 * the closures of every surface they meet (Russian roulette keeps their power about constant),
 * and stored where the gather can evaluate a closure (kernels/closure/shader.h: diffuse, sheen,
 * translucent and rough lobes), after the first scattering (direct light is next-event
 * estimation's).  Photons outside this pass's grid (visible points' bounds) cannot be gathered
 * and are only counted.  With caustics_only (eye paths bring the rest of the indirect light,
 * indirect_paths.h) a photon lives on only if its first scattering is by a followed closure;
 * with capacity 0 (a pilot) photons are only classified at their first scattering and counted
 * (CNT_CAUSTIC, CNT_DIFFUSE_FIRST).  ``mode``'s bits (ppm_engine/render/passes/photons.py):
 * PHOTONS_CAUSTIC, caustics only; PHOTONS_AIMED, emitted toward the casters
 * (photon_emission.h); CNT_CASTER counts the caustic photons whose first scattering is a
 * caster's.  PHOTONS_GUIDED: the guided lights' directions from their learned bins
 * (light/guide.h), guide_stats counting the stores per bin.  In scattering media (PPM_VOLUME)
 * photons scatter and are stored as volume photons, the first vcapacity of them
 * (volume_photons.h). */
#include "builtins.h"
#include "rng.h"
#include "integrator/photon_emission.h"
#include "geom/camera.h"
#include "closure/shader.h"
#include "integrator/hash.h"
#include "integrator/direct_light.h"
#include "integrator/camera_connect.h"
#include "integrator/pass_state.h"

#include "shared.h"
#include "geom/medium.h"
#include "integrator/volume_photons.h"

/* the photon pass's mode bits (ppm_engine/render/passes/photons.py PhotonMode) */
#define PHOTONS_CAUSTIC 1u
#define PHOTONS_AIMED 2u
#define PHOTONS_GUIDED 4u

/* A stored photon as the camera connection needs it: its flux (before shading, its cos_N /
 * cos_Ng factor), path and clamp ratio as stored; a Lambert surface's colour and normals
 * (facing where the photon came from; the others' are in the ShaderData). */
typedef struct {
    float3 flux, color, N, Ng;
    float shading, rs;
    uint ppath;
    bool lambert;
#if PPM_VOLUME
    const Media *media; /* those it arrived through */
#endif
} PhotonHit;

/* Light tracing, the photons' second strategy (VCM's camera connection, Georgiev et al. 2012):
 * a photon stored at s (arriving along d) is connected to the pinhole camera through the
 * closures the gather evaluates, as the camera sees them, and splatted with the pixel filter,
 * each pixel weighted by the balance heuristic against the merge of the same path at a visible
 * point the camera sees directly (camera_connect.h merge_factor; the eye pass gives the merge
 * the other side).  Returns whether sd was set up again (as the camera sees it). */
inline bool connect_camera(const Scene *scene, ShaderData *sd, const Surface *s, Hit h, float3 d,
                           const PhotonHit *ph, const Splat *sp, __global uint *counters) {
    __global const Camera *cam = scene->camera;
    float px, py, dist, we;
    float3 wc;
    if (!(ph->shading > 0.0f) || !camera_project(cam, s->p, sp->reach, &px, &py, &wc, &dist, &we))
        return false;
    float cos_c = dot(wc, ph->Ng); /* Ng faces where the photon came from */
    if (ph->lambert && !(cos_c > 0.0f && dot(wc, ph->N) > 0.0f)) return false;
    uint kinds = path_join(PATH_CAMERA, ph->ppath, scene->light_paths);
    if (kinds == 0u || (ph->lambert && !(kinds & JOIN_DIFFUSE))) return false;
    /* the photon's flux times f (the gather's photon_term, gather.cl), ratio: the camera
     * path's sample weight f cos / pdf for the photon's direction (Clamp Indirect) */
    float3 f, ratio;
    bool setup = false;
    if (ph->lambert) {
        /* Filter Glossy: the camera path's density towards where the photon came from */
        if (!filter_glossy_keeps(-dot(d, ph->N) * (1.0f / PPM_PI), scene->light_paths))
            return false;
        f = ph->color * (1.0f / PPM_PI);
        ratio = ph->color;
    } else {
        shader_setup(scene, sd, s, h.u, h.v, PATH_CAMERA, dist, wc,
                     footprint_at(scene, s->tri, h.leaf, h.u, h.v,
                                  SVM_FOOTPRINT ? camera_footprint_at(cam, s->p) : 0.0f));
        setup = true;
        float pdf, cs = fabs(dot(d, sd->N));
        float3 fc = shader_eval_kinds(sd, -d, MASK_GATHER, kinds, &pdf);
        if (!(cs > 1e-6f) || !(max3(fc) > 0.0f)) return true;
        if (scene->light_paths->filter_glossy > 0.0f) {
            float p_all;     /* Filter Glossy: the density of all the camera's closures */
            shader_eval(sd, -d, MASK_ALL, &p_all);
            if (!filter_glossy_keeps(p_all, scene->light_paths)) return true;
        }
        f = fc * (1.0f / cs);
        ratio = pdf > 0.0f ? fc * (1.0f / pdf) : (float3)(0.0f);
    }
    float3 org = offset_ray(s->p, cos_c > 0.0f ? ph->Ng : -ph->Ng,
                            scene->emitter_info->offset_scale);
    /* the segment as a camera ray sees it: through objects hidden from the camera, as the
     * eye pass's rays that make the merge's visible points; through the media the photon
     * arrived in (a camera on the other side of a medium's surface: not connected) */
#if PPM_VOLUME
    if (media_top(ph->media) != world_medium(scene) && !(cos_c > 0.0f)) return setup;
    float3 T = ray_transmittance_media(scene, org, wc, dist * 0.9999f,
                                       scene->light_paths->transparent_max_bounces, VIS_CAMERA,
                                       ph->media);
#else
    float3 T = ray_transmittance(scene, org, wc, dist * 0.9999f,
                                 scene->light_paths->transparent_max_bounces, VIS_CAMERA);
#endif
    if (!(max3(T) > 0.0f)) return setup;
    float3 c = ph->flux * ph->shading * f * T * (fabs(cos_c) * we);
    float limit = scene->light_paths->clamp_indirect;
    if (limit > 0.0f && ph->rs > 0.0f) {
        float3 x = ratio * ph->flux * ph->rs;
        float sum = fabs(x.x) + fabs(x.y) + fabs(x.z);
        if (sum > limit) c *= limit / sum;
    }
    if (isfinite(c.x) && isfinite(c.y) && isfinite(c.z) && max3(c) > 0.0f) {
        splat(cam, sp, px, py, c, merge_density(sp->kappa, cos_c, we));
        atomic_inc(&counters[CNT_USED]);
    }
    return setup;
}

__kernel void photon_pass(SCENE_PARAMS FILM_PARAMS PHOTON_PARAMS uint pass_index, uint seed,
                          uint n_photons, uint capacity, __global uint *counters, uint mode,
                          __global uint *guide_stats, __global const float *lt_filter,
                          float lt_reach, float lt_kappa, uint vcapacity) {
    SCENE_LOAD(scene);
    FILM_LOAD(film);
    PHOTON_LOAD(photons);
    uint id = WORK_ITEM();
    if (id >= n_photons) return;
    Grid g = *photons->grid;
    if (g.valid == 0u && capacity > 0u && vcapacity == 0u) return; /* (none to store) */
    uint rng = rng_seed(seed, pass_index, id, 2u);
    Splat sp = {film->lt_pass, lt_filter, film->radius, FILTER_SAMPLES, lt_reach, lt_kappa};
    float3 o, d, flux;
    float rs; /* the radiance its light path carries over its flux (the clamp, gather.cl) */
    float2 nee;
    bool delta; /* from a light of no size (photon_emission.h) */
    bool caustics_only = (mode & PHOTONS_CAUSTIC) != 0u;
    int caster; /* the caster it is aimed at (-1: none) */
    int gbin; /* its guide's bin (-1: none; light/guide.h) */
    if (!emit_photon(scene, &rng, (mode & PHOTONS_AIMED) != 0u, (mode & PHOTONS_GUIDED) != 0u, &o,
                     &d, &flux, &rs, &nee, &delta, &caster, &gbin))
        return;
    /* per guide bin: the photons it stored (Renderer.learn_guides; GUIDE_BINS per light) */
    __global uint *guide_count = gbin >= 0 && capacity > 0u ? guide_stats + gbin
                                                            : (__global uint *)0;
    /* per caster: the photons aimed at it and those they store (Renderer.learn_caster_weights) */
    __global uint *aimed = caster >= 0 && capacity > 0u ? counters + CNT_CASTER_STATS + 2 * caster
                                                        : (__global uint *)0;
    if (aimed) atomic_inc(aimed);
    uint mask = VIS_SHADOW; /* the light's own segment: objects that cast no shadow let it by */
#if PPM_ABSORPTION
    Media media;
    media_init(&media);
#endif
#if PPM_VOLUME
    media_at(scene, o, &media); /* a light inside fog */
    int bounds = 0;             /* the media's boundaries it crossed (media_boundary) */
    bool chain = true;          /* every scattering so far singular (a volume photon's L S+ M) */
#endif
    ShaderData sd;
    bool direct = true; /* nothing but transparent surfaces crossed yet */
    uint path = 0u; /* the Light Path node's view: light's rays are no camera rays */
    /* the bounces the Light Paths limits count (path_state.h path_join): all after the light's
     * first scattering, which a camera path reaches by next-event estimation; the type bits
     * those of the last scattering */
    uint ppath = 0u;
    __global const LightPaths *lp = scene->light_paths;
    int max_bounces = lp->max_bounces;
    float reach = 0.0f; /* from the emitter to the light's first scattering */
    for (int bounce = 0, transparent = 0; bounce <= max_bounces;) {
        Hit h = bvh_intersect(scene, o, d, PPM_INF, mask, false);
#if PPM_VOLUME
        /* in the world's medium a photon that meets nothing still scatters on its way out */
        bool open = h.leaf < 0 && media_top(&media) >= 0
                    && media_top(&media) == world_medium(scene);
        if (h.leaf < 0 && !open) break;
#else
        if (h.leaf < 0) break;
#endif
        float3 before = flux; /* Russian roulette below: this bounce's albedo */
        if (direct && h.leaf >= 0) reach += h.t;
#if PPM_VOLUME
        /* a scattering medium: a free-flight distance (volume_photons.h photon_medium) */
        float3 vp;
        float vg;
        int vm = photon_medium(scene, &media, o, d, open ? PPM_INF : h.t, &rng, &flux, &vp, &vg);
        if (vm < 0 && open) break;
        if (vm >= 0 && capacity == 0u) { /* a pilot: a medium's light is the eye paths' */
            if (direct) atomic_inc(&counters[CNT_DIFFUSE_FIRST]);
            break;
        }
        if (vm >= 0) {
            if (!direct && (chain || !caustics_only) && lp->volume_bounces > 0
                && store_volume_photon(photons, vp, d, flux, ppath, vcapacity, counters)) {
                if (aimed) atomic_inc(aimed + 1); /* (what casters and guides learn from) */
                if (guide_count) atomic_inc(guide_count);
            }
            /* with eye paths for the indirect light a photon's light past the medium is
             * theirs (the volume photon has the caustic's, L S+ M); with photons on along
             * the phase function's sample, where a camera path can still join it */
            if (caustics_only || bounce == max_bounces) break;
            ppath = direct ? ppath & ~127u : path_add(ppath, PATH_DEPTH) & ~127u;
            if (path_volume(ppath) > lp->volume_bounces) break;
            float pdf;
            float3 wo = hg_sample(d, vg, rnd(&rng), rnd(&rng), &pdf);
            bounce++;
            direct = chain = false;
            rs = 0.0f; /* (no clamp past a medium) */
            mask = VIS_DIFFUSE;
            o = vp;
            d = wo;
            float q = fmin(1.0f, max3(flux) / max3(before));
            if (!(q > 0.0f) || rnd(&rng) >= q) break;
            flux /= q;
            continue;
        }
#elif PPM_ABSORPTION
        flux *= media_transmittance(&media, scene->materials, h.t); /* the segment's medium */
#endif
        Surface s = surface_at(scene, h);
        Material mt = scene->materials[s.material];
        /* a Lambert material's one closure without the closure list (shader.h's short path:
         * the same closure, sampled the same way) */
#if PPM_SHADER
        bool lambert = (mt.flags & MAT_LAMBERT) != 0;
#else
        bool lambert = true;              /* every material is one Lambert closure */
#endif
        float3 color = (float3)(0.0f), N, Ng;
        bool gather;
        if (lambert) {
            color = lambert_weight(scene, scene->shader_nodes + mt.node_first, s.tri, h.u, h.v);
            bool back = dot(d, s.ng) > 0.0f;
            N = back ? -s.ns : s.ns;
            Ng = back ? -s.ng : s.ng;
            gather = fabs(avg3(color)) >= CLOSURE_WEIGHT_CUTOFF;
        } else {
            shader_setup(scene, &sd, &s, h.u, h.v, path, h.t, -d,
                         footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                      SVM_FOOTPRINT ? camera_footprint_at(scene->camera, s.p)
                                                    : 0.0f));
            N = sd.N;
            Ng = sd.Ng;
            gather = sd.sw_gather > 0.0f;
        }
        /* Shading normals for light (Veach's thesis, 5.3): photons land with the density of
         * their cosine to the surface as it is (Ng), where a camera path weighs the light it
         * finds by the cosine to the shading normal (N), as Cycles does (none from below N).
         * So a stored photon counts cos_N / cos_Ng of its arrival, and a scattered one also
         * cos_Ng / cos_N of its departure (the adjoint of a BSDF with shading normals).  Its
         * normal is the geometric one: the gather's disc lies in the surface as it is
         * (gather.cl). */
        float c_ng = fabs(dot(d, Ng)), c_n = -dot(d, N);
        float shading = c_ng > 0.0f ? fmax(c_n, 0.0f) / c_ng : 0.0f;
        /* Filter Glossy above 1 / pi: no camera path leaves a diffuse surface with the density
         * it asks, so the light after it is the eye paths' (path_state.h) */
        if (!direct && lambert && filter_glossy_blurs(FILTER_GLOSSY_DIFFUSE_PDF, lp)) break;
        if (!direct && gather) {
            if (!(isfinite(flux.x) && isfinite(flux.y) && isfinite(flux.z))) {
                atomic_inc(&counters[CNT_NAN]);
                break;
            }
            if (in_grid(s.p, &g)) {
                uint k = atomic_inc(&counters[CNT_STORED]);
                if (aimed) atomic_inc(aimed + 1);
                if (guide_count) atomic_inc(guide_count);
                if (k < capacity) {
                    photons->pos[k] = (float4)(s.p, as_float(pack_unit(Ng)));
                    photons->flux[k] = (float4)(flux * shading, as_float(pack_unit(-d)));
                    /* (the camera path's sample has no such factor: gather.cl's clamp) */
                    photons->path[k] = (uint2)(ppath, as_uint(shading > 0.0f ? rs / shading : rs));
                } else {
                    atomic_inc(&counters[CNT_OVERFLOW]);
                }
            } else {
                atomic_inc(&counters[CNT_OUTSIDE]);
            }
            PhotonHit ph = {flux, color, N, Ng, shading, rs, ppath, lambert};
#if PPM_VOLUME
            ph.media = &media;
#endif
            if (lt_kappa > 0.0f && capacity > 0u
                && connect_camera(scene, &sd, &s, h, d, &ph, &sp, counters)
                && !lambert) /* sd was the camera's: the light's again for its scattering */
                shader_setup(scene, &sd, &s, h.u, h.v, path, h.t, -d,
                             footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                          SVM_FOOTPRINT ? camera_footprint_at(scene->camera, s.p)
                                                        : 0.0f));
        }
        int set = MASK_ALL;
        if (caustics_only && direct) {
            /* The light's first scattering, with eye paths for the indirect light
             * (indirect_paths.h): the gather's closures and the glossy followed ones, or the
             * other followed ones (mirrors, glass), in proportion to their sample weights; the
             * first ends the photon (next-event estimation and the eye paths count that
             * light), the second makes a caustic photon. */
            float sg = lambert ? (gather ? 1.0f : 0.0f) : sd.sw_gather + sd.sw_glossy;
            float sc = lambert ? 0.0f : shader_sw_specular(&sd);
            if (sc > 0.0f && capacity > 0u) atomic_inc(&counters[CNT_CASTER]);
            if (!(sc > 0.0f) || rnd(&rng) * (sg + sc) < sg) {
                /* a pilot counts the light the gather's closures scatter first (not what
                 * meets a black surface: a filament's inside) */
                if (capacity == 0u && sg > 0.0f) atomic_inc(&counters[CNT_DIFFUSE_FIRST]);
                break;
            }
            flux *= (sg + sc) / sc;
            rs *= sc / (sg + sc);
            set = MASK_SPECULAR;
        }
        if (bounce == max_bounces) break;
        BsdfSample b;
        float3 rand = (float3)(rnd(&rng), rnd(&rng), rnd(&rng));
        if (lambert) {
            if (!gather) break;
            b.wo = sample_cosine_hemisphere(N, rand.x, rand.y);
            if (dot(b.wo, Ng) <= 0.0f) break;
            b.weight = color;
            b.label = LABEL_REFLECT | LABEL_DIFFUSE;
            b.eta = 1.0f;
        } else if (!shader_sample_light(&sd, set, rand, &b, scene->shading_tables)) {
            break;
        }
        if (!direct && lp->filter_glossy > 0.0f
            && !(b.label & (LABEL_SINGULAR | LABEL_TRANSPARENT))) {
            /* Filter Glossy: a camera path that comes the other way bounces here with the
             * density of all the closures as it sees them; below the setting the vertices
             * behind (towards the light) are blurred and the light the eye paths' */
            float p_cam = fabs(dot(d, N)) * (1.0f / PPM_PI);
            if (!lambert) {
                shader_setup(scene, &sd, &s, h.u, h.v, path, h.t, b.wo,
                             footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                          SVM_FOOTPRINT ? camera_footprint_at(scene->camera, s.p)
                                                        : 0.0f));
                shader_eval(&sd, -d, MASK_ALL, &p_cam);
            }
            if (!filter_glossy_keeps(p_cam, lp)) break;
        }
        if (capacity == 0u && set == MASK_SPECULAR && !(b.label & LABEL_TRANSPARENT)) {
            atomic_inc(&counters[CNT_CAUSTIC]); /* a pilot (Renderer.caustic_fraction_pilot) */
            return;
        }
        flux *= b.weight;
        if (!(b.label & LABEL_TRANSPARENT)) {
            float adj = shading_adjoint(d, b.wo, N, Ng);
            if (!(adj > 0.0f)) break;
            flux *= adj;
            rs /= adj;
        }
        bool transmit = (b.label & LABEL_TRANSMIT) != 0;
        /* refraction's (eta_i / eta_t)^2 on the flux (kernels/closure/closure.h: camera paths carry
         * none, as Cycles; photons the matching factor, so both agree) */
        float measure = 1.0f;
        if (transmit && b.eta != 1.0f) {
            measure = 1.0f / (b.eta * b.eta);
            flux *= measure;
            rs /= measure; /* camera paths carry no such factor */
        }
        if (b.label & LABEL_TRANSPARENT) { /* not a bounce (Cycles' transparent bounces) */
#if PPM_VOLUME
            /* a medium's boundary: photons go on through it with its transmittance (they
             * neither scatter nor are stored in media yet: what scatters out is lost); no
             * transparent bounce */
            media_cross_transparent(&media, scene->materials, s.material, dot(d, s.ng) < 0.0f);
            if (media_boundary(scene->materials, s.material)) {
                if (++bounds > VOLUME_BOUNDS_MAX) break;
            } else
#endif
            {
                if (++transparent > lp->transparent_max_bounces) break;
                path = path_transparent(path);
                ppath = path_transparent(ppath);
            }
        } else {
            if (direct && rs > 0.0f && (b.label & LABEL_SINGULAR)) {
                if (delta) rs = 0.0f; /* no camera path finds a light of no size so */
            } else if (direct && rs > 0.0f) {
                /* A camera path reaches the light from this first scattering by next-event
                 * estimation as much as by its sample (MIS): its sample is about f cos_l (the
                 * cosine on the light's side) over the larger of the two densities, p_l and
                 * p_c, its sample's density of the light's direction, where the chain above
                 * (the flux) has f cos_o over the photon's density of its direction.  p_c is
                 * the photon's density times cos_l / cos_o (exact for a Lambert closure, and
                 * for a microfacet reflection sampled by its visible normals but for the ratio
                 * of its two G1).  A light of no size only next-event estimation finds: f cos_l
                 * times its rs / p_l, exactly (emit_photon). */
                float p_c = lambert ? fabs(dot(N, d)) * (1.0f / PPM_PI)
                                    : b.pdf * fabs(dot(d, N)) / fabs(dot(b.wo, N));
                float p_l = nee.x * reach * reach + nee.y;
                rs *= p_c / (delta ? p_l : fmax(p_l, p_c));
            }
            /* a caustic bounce that is off (Reflective / Refractive Caustics) before this diffuse
             * one: light no camera path carries (path_state.h path_caustic_off) */
            if (!direct && (b.label & LABEL_DIFFUSE) && path_caustic_off(ppath & 127u, lp)) break;
            ppath = direct ? (ppath & ~127u) | path_kind(b.label) : path_bounce(ppath, b.label);
            /* past a limit of its kind: no visible point's path can take it */
            if (path_limit(ppath, bounce, lp) != TERM_NONE) break;
            bounce++;
            path = path_bounce(path, b.label);
            direct = false;
#if PPM_VOLUME
            chain = chain && (b.label & LABEL_SINGULAR);
#endif
            mask = bounce_visibility(b.label);
#if PPM_ABSORPTION
            if (transmit) media_cross(&media, s.material, dot(d, s.ng) < 0.0f);
#endif
        }
        o = offset_ray(s.p, transmit ? -Ng : Ng, scene->emitter_info->offset_scale);
        d = b.wo;
        /* Russian roulette keeps photon power roughly constant: survival is the scattering's
         * albedo (times the medium's transmittance).  The change of measure of refraction is
         * left out of it: a photon entering glass (flux x 1/eta^2) survived with probability
         * 1/eta^2 = 0.44, and one leaving it got x eta^2 back, so behind n panes 0.44^n of the
         * photons carried 2.25^n of the flux: the same mean, and no photon at all behind 20
         * panes in a pass. */
        float q = fmin(1.0f, max3(flux) / (max3(before) * measure));
        if (!(q > 0.0f) || rnd(&rng) >= q) break;
        flux /= q;
        rs *= q;
    }
}
