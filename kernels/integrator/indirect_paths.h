#ifndef PPM_INDIRECT_PATHS_H
#define PPM_INDIRECT_PATHS_H
#include "rng.h"
#include "integrator/direct_light.h"
#include "integrator/volume_light.h"
#include "geom/camera.h"
#include "geom/medium.h"

/* Indirect light at a visible point by path tracing (RenderOptions.indirect = "paths"): the eye
 * path goes on from the visible point through a sample of the gather's closures, with
 * next-event estimation at every vertex, and the photon map keeps only the light paths that
 * path tracing cannot sample well: those whose first scattering from the emitter is by a mirror,
 * glass or a glossy reflection smoother than LightPaths.caustic_roughness (caustics,
 * kernels/integrator/photon_pass.cl).  Followed glossy reflections at least that rough (by default
 * none: it is the gather's roughness, RenderOptions.caustic_roughness) are the eye path's:
 * next-event estimation through them, as Cycles does.
 *
 * The two estimators split the light paths without overlap by that one vertex, the light's
 * first scattering: at every vertex the path chooses the gather's closures, the glossy followed
 * ones or the other followed ones in proportion to their sample weights.  Light counts here
 * only when the vertex before it chose the gather's or the glossy closures (next-event
 * estimation of those closures and emitters their sample finds, combined by MIS); light
 * reached through another followed closure, or whose shadow ray meets glass, is the caustic
 * photons' (a photon whose first scattering chose the gather's or glossy closures is ended
 * there: next-event estimation and these paths have it).  Transparent surfaces are no
 * scattering for either.
 *
 * Russian roulette (survival: the square root of the path's throughput relative to the visible
 * point's, below), decided by one number for the whole path; bounces counted from the camera
 * as in the eye pass, and a path past a Light Paths limit only adds the emitters its last
 * sample found (through transparent surfaces after its last bounce; path_state.h).  The numbers of
 * the first twelve vertices are low-discrepancy over the passes (Owen-scrambled Sobol sets, as
 * Cycles' default sampler; rng.h ld_set).  In a closed emissive sphere (the benchmark's furnace)
 * both estimators, next-event estimation and the cosine sample, are constant: all of its noise is
 * Russian roulette's, and the roulette's one number stratifies it over the passes. */

/* Filter Glossy (path_state.h): a vertex whose path's smallest density is below the setting
 * has its lobes blurred, and every light path whose light scatters first there is these
 * paths' (the photons carry none of them: photon_pass.cl, gather.cl).  At such a vertex the
 * path estimates the light through all the closures (next-event estimation of all, and a sample
 * of all), as Cycles does.  mode: which light is these paths' past the visible point:
 * INDIRECT_ALL, that of the eye paths' split above (RenderOptions.indirect "paths");
 * INDIRECT_BLURRED, only the light that scatters first at a blurred vertex (indirect light by
 * photons, "photons": the rest is theirs); INDIRECT_EVERY, all of it (a visible point that
 * gathers no photon, eye_pass.cl), each vertex sampling all its closures. */
#define INDIRECT_ALL 0
#define INDIRECT_BLURRED 1
#define INDIRECT_EVERY 2

/* Path space filtering (Keller et al. 2016, "Path Space Filtering"; kernels/integrator/
 * path_filter.cl): the light a path brings past its second vertex x2 (the tail: what its sample
 * there finds) is averaged with that of the other pixels' paths whose x2 share a grid cell,
 * surface orientation and path state.  x2 must be Lambert and sample only the gather's closures:
 * the tail is then the albedo times (1 / pi) x the irradiance it estimates, the same for every
 * path that reaches x2 in that state.  The eye pass records the tail over its weight (v) and
 * the weight (the throughput at x2 times the albedo) and adds the average later. */
typedef struct {
    bool want;   /* filtering on (in) */
    bool on;     /* this path recorded its x2 (out) */
    uint key;    /* the path state at x2 (path_state.h bits) */
    float3 p, ng; /* x2 and its geometric normal */
    float3 mark; /* L before the tail */
    float3 w;    /* the tail's weight */
} PathRecord;

/* Whether x2's closures (sd, the set its sample takes) make a recordable tail: its albedo, else
 * zero */
inline float3 record_albedo(const ShaderData *sd, int set) {
    if (set != MASK_GATHER && !(set == MASK_ALL && !(sd->sw_continue > 0.0f)))
        return (float3)(0.0f);
    bool lambert;
    float3 a = gather_albedo(sd, &lambert);
    return lambert ? a : (float3)(0.0f);
}

/* The light L of a path that made a record, less its tail, which the record keeps over its
 * weight (v) for path_filter.cl to add its group's mean of; L whole where that is not finite
 * (the eye pass drops such a sample) */
inline float3 record_tail(const PathRecord *rec, float3 L, __global float4 *pos, __global float4 *v,
                          __global float4 *w) {
    if (!rec->on) return L;
    float3 t = L - rec->mark, a = rec->w;
    float3 r = (float3)(a.x > 0.0f ? t.x / a.x : 0.0f, a.y > 0.0f ? t.y / a.y : 0.0f,
                        a.z > 0.0f ? t.z / a.z : 0.0f);
    if (!(isfinite(r.x) && isfinite(r.y) && isfinite(r.z) && isfinite(max3(a)))) return L;
    *pos = (float4)(rec->p, as_float(rec->key));
    *v = (float4)(r, as_float(pack_unit(rec->ng)));
    *w = (float4)(a, 1.0f);
    return rec->mark;
}

/* How the eye pass hands its visible point to indirect_paths */
typedef struct {
    float min_pdf; /* the smallest density of the eye path's bounces before it (Filter Glossy) */
    int set;       /* the closures it samples: MASK_GATHER, or MASK_ALL */
    int mode;      /* which light is the paths' past it: INDIRECT_* */
    /* the eye pass has done next-event estimation there for all the closures (a vertex with
     * gathered and followed ones): none in the paths, and their first sample is weighted
     * against that one's density */
    bool nee_all;
    bool own; /* its own direct light is the paths' (else the eye pass's) */
    PathRecord *rec; /* the path space filter's record of the path (rec->want: on) */
} IndirectStart;

/* Russian roulette spares the hit of the visible point's own sample: measured at equal time
 * (docs/BENCHMARKS.md) the furnace's error fell from 0.023 to 0.013 and the Cornell box's
 * stayed (0.0127, 0.0125); sparing two hits was worse on both */
#define INDIRECT_RR_FIRST 1
/* the most a bounce's survival is raised to (the roulette below): 3/4, a tail of three more
 * bounces on average after a survival */
#define INDIRECT_RR_Q 0.75f

/* the path's vertices draw their numbers from the pixel's low-discrepancy stream over the
 * passes (rng.h ld_set), two sets of four each: set one (the point on the emitter as the set's
 * (0, 2)-sequence pair, the emitter's pick, the closure set), set two (the sampled direction as
 * the pair, the closure's pick, and at the first vertex the path's one Russian-roulette
 * number); vertices past LD_SETS / 2 from the generator */
inline float4 indirect_set(int vertex, uint which, uint pass, uint key, uint *rng) {
    return ld_set_or_rnd(pass, key, 2u * (uint)vertex + which, rng);
}

/* Light reaching the visible point p (material mat, closures sd, weight beta towards the pixel,
 * reached after depth bounces by the ray `path`) by next-event estimation there and paths that
 * continue from it; pass and key: the pixel's low-discrepancy stream; start: how the eye pass
 * hands p over (IndirectStart).  sd is overwritten. */
inline float3 indirect_paths(const Scene *scene, ShaderData *sd, float3 p, int mat, float3 beta,
                             int depth, uint path, uint pass, uint key, IndirectStart start,
#if PPM_ABSORPTION
                             Media *media,
#endif
                             uint *rng) {
    float3 L = (float3)(0.0f);
    PathRecord *rec = start.rec;
    float beta0 = max3(beta);
    if (!(beta0 > 0.0f)) return L;
    int set = start.set;             /* the closures this vertex samples */
    bool own = start.own; /* whether the light that scatters first at this vertex is these paths' */
    float min_pdf = start.min_pdf;
    bool nee_all = start.nee_all;
    int mode = start.mode;
    bool counts = own; /* whether emitters the next ray finds are these paths' */
    float prev_pdf = INFINITY;
    float3 prev_n = sd->N, prev_p = p;
    uint mask = VIS_DIFFUSE;
    /* Russian roulette by one number for the whole path: it survives its k-th roulette while
     * u_rr < q_1 ... q_k (each survival given the last has probability q_k, as with a number per
     * roulette), so over the passes a pixel's path lengths are stratified as that one
     * dimension is: measured, the furnace's error at 256 passes fell from 0.0065 to 0.0031
     * (0.0010 with the Sobol numbers) and the Cornell box's stayed */
    float u_rr = 0.0f, survive = 1.0f;
    float4 ua = indirect_set(0, 0u, pass, key, rng);
    __global const LightPaths *lp = scene->light_paths;
    int term = TERM_NONE; /* past a Light Paths limit: how the path ends (path_state.h) */
    float3 o = p, d = (float3)(0.0f, 0.0f, 1.0f); /* the ray to the next vertex */
#if PPM_VOLUME
    bool in_medium = false; /* the vertex is a scattering in a medium: its ray is drawn */
    int vbounce = 0; /* the path's scatterings in media (Light Paths > Volume bounces) */
    int bounds = 0; /* the media's boundaries it crossed (media_boundary) */
#endif
    for (int vertex = 0, transparent = (int)path_count(path, PATH_TRANSPARENT_DEPTH);; vertex++) {
#if PPM_VOLUME
        if (!in_medium)
#endif
        {
            if (own && !(vertex == 0 && nee_all)) {
                float3 u = (float3)(ua.z, ua.x, ua.y);
                L += clamp_sample(beta * direct_nee_u(scene, sd, p, set, EMITTERS_HITTABLE, u),
                                  clamp_limit(depth, lp));
            }
            /* x2 (path space filtering): the tail starts here, after its next-event estimation
             * (with Filter Glossy only at a blurred x2: every vertex past it is blurred too) */
            if (vertex == 1 && rec->want && own
                && (!(lp->filter_glossy > 0.0f) || filter_glossy_blurs(min_pdf, lp))) {
                float3 a = record_albedo(sd, set);
                if (max3(a) > 0.0f) {
                    rec->on = true;
                    rec->key = path;
                    rec->p = p;
                    rec->ng = sd->Ng;
                    rec->mark = L;
                    rec->w = beta * a;
                }
            }
            float4 ub = indirect_set(vertex, 1u, pass, key, rng);
            if (vertex == 0) u_rr = ub.w;
            BsdfSample b;
            float3 rand = ub.xyz;
            if (!shader_sample(sd, set, rand, &b)) break;
            beta *= b.weight;
            bool transmit = (b.label & LABEL_TRANSMIT) != 0;
            o = offset_ray(p, transmit ? -sd->Ng : sd->Ng, scene->emitter_info->offset_scale);
            d = b.wo;
            if (b.label & LABEL_TRANSPARENT) {
                /* straight through: no scattering, the ray keeps its type and MIS state */
#if PPM_VOLUME
                media_cross_transparent(media, scene->materials, mat, !sd->backfacing);
                if (media_boundary(scene->materials, mat)) {
                    if (++bounds > VOLUME_BOUNDS_MAX) break;
                } else
#endif
                {
                    path = path_transparent(path);
                    term = path_limit_transparent(++transparent, lp);
                }
            } else {
                depth++;
                path = path_bounce(path, b.label);
                term = path_limit(path, depth, lp);
                counts = own;
                prev_pdf = b.pdf;
                if (vertex == 0 && nee_all && !isinf(b.pdf)) /* the eye pass's NEE's density */
                    prev_pdf = shader_mis_pdf(sd, b.wo, set, MASK_ALL, b.pdf);
                if (lp->filter_glossy > 0.0f && !isinf(b.pdf)
                    && !filter_glossy_blurs(min_pdf, lp)) {
                    /* the smallest density, the mixture's over all the closures (once below the
                 * setting it stays there), evaluated as the gather and the photons evaluate
                 * it (gather.cl photon_term, photon_pass.cl) */
                    float p_all = b.pdf;
                    if (set != MASK_ALL) shader_eval(sd, b.wo, MASK_ALL, &p_all);
                    min_pdf = fmin(min_pdf, p_all);
                }
                prev_n = sd->N;
                prev_p = p;
                mask = bounce_visibility(b.label);
#if PPM_ABSORPTION
                if (transmit) media_cross(media, mat, !sd->backfacing);
#endif
            }
        }
#if PPM_VOLUME
        in_medium = false;
#endif
        if (!(max3(beta) > 0.0f)) break;
        Hit h = bvh_intersect(scene, o, d, PPM_INF, mask, false);
#if PPM_VOLUME
        /* a segment in a medium, as the eye pass's (volume_light.h medium_segment): its
         * emission is these paths' whatever the mode; the light its scattering brings
         * (next-event estimation, equiangular sampling, emitters its phase sample finds) is
         * the photons' with indirect light by photons (they scatter in media,
         * photon_pass.cl), else these paths' */
        float3 beta_in = beta;
        int vm = media_top(media);
        bool vnee = mode != INDIRECT_BLURRED;
        Segment sg = segment(o, d, 0.0f, (float3)(0.0f));
        if (vm >= 0) {
            float4 u = (float4)(rnd(rng), rnd(rng), rnd(rng), rnd(rng));
            L += medium_segment(scene, media, o, d, h.leaf < 0 ? PPM_INF : h.t, term == TERM_NONE,
                                u, max(lp->transparent_max_bounces - transparent, 0),
                                (float2)(clamp_limit(depth - 1, lp), clamp_limit(depth, lp)), vnee,
                                &beta, &sg);
        }
#elif PPM_ABSORPTION
        if (h.leaf >= 0) beta *= media_transmittance(media, scene->materials, h.t);
#endif
        float pdf_l = 0.0f;
#if PPM_LIGHTS_SEEN
        /* the lights the ray meets (theirs to add when it counts), each a transparent bounce;
         * the path ends at the one that reaches the limit */
        {
#if PPM_VOLUME
            LightRay r = light_ray(o, d, h.leaf < 0 ? PPM_INF : h.t, mask, prev_p, prev_n, prev_pdf,
                                   counts ? beta_in : (float3)(0.0f), clamp_limit(depth - 1, lp));
            light_ray_in(&r, scene, media);
#else
            LightRay r = light_ray(o, d, h.leaf < 0 ? PPM_INF : h.t, mask, prev_p, prev_n, prev_pdf,
                                   counts ? beta : (float3)(0.0f), clamp_limit(depth - 1, lp));
#endif
            int met, budget = lights_budget(transparent, lp);
            L += lights_seen(scene, &r, h.leaf < 0, budget, &met);
            if (met == budget) break;
            transparent += met;
            path = path_transparent_n(path, met);
        }
#endif
#if PPM_VOLUME
        if (sg.s < INFINITY) {
            /* scattered at q: next-event estimation, then the phase function's sample, which
             * finds the emitters with size under MIS and goes on while Volume bounces allow */
            float3 q = o + sg.s * d;
            float g = sg.g;
            float3 un = (float3)(rnd(rng), rnd(rng), rnd(rng));
            if (vnee)
                L += clamp_sample(beta
                                      * volume_nee(scene, &sg, sg.s, sg.pdf, g, media,
                                                   max(lp->transparent_max_bounces - transparent,
                                                       0),
                                                   un),
                                  clamp_limit(depth, lp));
            float u1 = rnd(rng), u2 = rnd(rng);
            float3 wo = hg_sample(d, g, u1, u2, &prev_pdf); /* (its weight: phase / pdf = 1) */
            term = path_volume_bounce(&path, &depth, &vbounce, lp);
            counts = vnee;
            prev_n = (float3)(0.0f);
            prev_p = q;
            mask = VIS_DIFFUSE;
            o = q;
            d = wo;
            in_medium = true;
            if (!(max3(beta) > 0.0f)) break;
            continue;
        }
#endif
        while (h.leaf >= 0 && term == TERM_AFTER_TRANSPARENT) {
            /* past a bounce limit: on through transparent surfaces to an emitter (Cycles'
             * TERMINATE_AFTER_TRANSPARENT), whose emission counts below */
            Surface s = surface_at(scene, h);
            if (!(scene->materials[s.material].flags & MAT_TRANSPARENT)) break;
            if (counts && (scene->materials[s.material].flags & MAT_EMISSIVE)) break;
            beta *= material_transparency(scene, s.material, s.tri, h.u, h.v, s.p);
            if (!(max3(beta) > 0.0f)) return L;
#if PPM_VOLUME
            media_cross_transparent(media, scene->materials, s.material, dot(d, s.ng) < 0.0f);
#endif
            o = offset_ray(s.p, dot(d, s.ng) > 0.0f ? s.ng : -s.ng,
                           scene->emitter_info->offset_scale);
#if PPM_VOLUME
            if (media_boundary(scene->materials, s.material)) {
                if (++bounds > VOLUME_BOUNDS_MAX) return L;
            } else
#endif
            {
                path = path_transparent(path);
                term = max(term, path_limit_transparent(++transparent, lp));
            }
            h = bvh_intersect(scene, o, d, PPM_INF, mask, false);
#if PPM_VOLUME
            if (h.leaf >= 0) beta *= media_transmittance_ray(scene, media, o, d, h.t);
#elif PPM_ABSORPTION
            if (h.leaf >= 0) beta *= media_transmittance(media, scene->materials, h.t);
#endif
#if PPM_LIGHTS_SEEN
            {
                LightRay r = light_ray(o, d, h.leaf < 0 ? PPM_INF : h.t, mask, prev_p, prev_n,
                                       prev_pdf, counts ? beta : (float3)(0.0f),
                                       clamp_limit(depth - 1, lp));
                int met, budget = lights_budget(transparent, lp);
                L += lights_seen(scene, &r, h.leaf < 0, budget, &met);
                if (met == budget) return L;
                transparent += met;
                path = path_transparent_n(path, met);
            }
#endif
        }
        if (h.leaf < 0) {
            if (counts && PPM_WORLD && scene->emitter_info->has_world) {
                pdf_l = !isinf(prev_pdf) ? world_light_pdf(scene, d, prev_p, prev_n) : 0.0f;
                L += clamp_sample(beta * world_le(scene, d) * mis_power(prev_pdf, pdf_l),
                                  clamp_limit(depth - 1, lp));
            }
            break;
        }
        Surface s = surface_at(scene, h);
        shader_setup(scene, sd, &s, h.u, h.v, path, h.t, -d,
                     footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                  SVM_FOOTPRINT ? camera_footprint_at(scene->camera, s.p) : 0.0f));
        shader_blur(sd, filter_glossy_alpha(min_pdf, lp));
        if (path & PATH_DIFFUSE) shader_caustics_off(sd, lp); /* the caustics toggles */
        if (counts && max3(sd->emission) > 0.0f)
            L += clamp_sample(beta * sd->emission
                                  * mesh_hit_mis(scene, &h, o, d, prev_pdf, prev_p, prev_n),
                              clamp_limit(depth - 1, lp));
        if (term != TERM_NONE) break; /* past a limit: that emission only */
        float sw = sd->sw_gather + sd->sw_continue;
        if (!(sw > 0.0f)) break;
        /* Russian roulette after the hit's emission, before its next-event estimation and
         * sample (moved here from before the ray, the furnace's error fell from 0.034 to 0.023
         * at 8 s).  Cycles' survival, the square root of the throughput relative to the
         * visible point's (t, after the roulettes' 1 / q), settles at q = the albedo per bounce;
         * here a bounce survives with at least that and up to sqrt(albedo), at most
         * INDIRECT_RR_Q: the path survives to a vertex with probability min(sqrt of its
         * throughput before the roulettes, Q per bounce).  Low albedos are where the roulette's
         * noise is all there is (the furnace, albedo 0.5: error at 4 s 0.0060 -> 0.0037, at
         * 16 s 0.0019 -> 0.0013), and with the cap longer paths cost high albedos nothing
         * (the Cornell box 0.0084 -> 0.0083; docs/BENCHMARKS.md) */
        float q = 1.0f;
        if (vertex >= INDIRECT_RR_FIRST) {
            float t = max3(beta) / beta0;
            float cycles = survive * fmin(1.0f, sqrt(t));
            /* both terms are at most survive: the survival never rises */
            float keep = fmax(cycles, fmin(sqrt(survive * t), survive * INDIRECT_RR_Q));
            q = keep / survive;
            survive = keep;
        }
        if (!(survive > 0.0f) || u_rr >= survive) break;
        beta /= q;
        p = s.p;
        mat = s.material;
        ua = indirect_set(vertex + 1, 0u, pass, key, rng);
        /* the vertex's closures: at a blurred vertex all of them, the light theirs (Filter
         * Glossy); with INDIRECT_BLURRED elsewhere all of them, the light the photons'; else the
         * gather's, the glossy followed ones or the others (the caustic photons' light), in
         * proportion to their sample weights */
        float sw_specular = shader_sw_specular(sd);
        bool blurred = filter_glossy_blurs(min_pdf, lp);
        own = blurred || mode != INDIRECT_BLURRED;
        sw = sd->sw_gather + sd->sw_glossy + sw_specular;
        float pick = ua.w * sw;
        if (blurred || mode != INDIRECT_ALL) {
            set = MASK_ALL;
        } else if (pick < sd->sw_gather) {
            set = MASK_GATHER;
            beta *= sw / sd->sw_gather;
        } else if (pick < sd->sw_gather + sd->sw_glossy) {
            set = MASK_GLOSSY;
            beta *= sw / sd->sw_glossy;
        } else {
            set = MASK_SPECULAR;
            beta *= sw / sw_specular;
            own = false;
        }
    }
    return L;
}
#endif
