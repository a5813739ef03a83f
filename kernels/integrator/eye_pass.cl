/* Eye pass (the paper's first phase): one jittered camera ray per pixel, through the closures
 * paths follow (mirrors, glass, smooth glossy lobes, transparency) to a hit whose closures the
 * gather evaluates, where it stores a visible point and adds direct light by next-event
 * estimation and a sample of those closures (MIS).  At each vertex one of the two is chosen in
 * proportion to the closures' sample weights.  Emission and background seen along the way go
 * to the pixel's direct sum.  volume_photons: the camera's segments in scattering media are kept
 * for the volume photons' gather (volume_gather.cl), and the light they carry is left to them. */
#include "builtins.h"
#include "rng.h"
#include "integrator/direct_light.h"
#include "integrator/volume_light.h"
#include "geom/camera.h"
#include "integrator/camera_connect.h"
#include "shared.h"
#include "geom/medium.h"
#include "integrator/indirect_paths.h"
#include "integrator/pass_state.h"

/* offset from the pixel centre: the filter table (inverse CDF) at u in [0, 1), lerped */
inline float filter_offset(__global const float *table, float u) {
    float x = u * (float)FILTER_TABLE_SIZE - 0.5f;
    x = clamp(x, 0.0f, (float)(FILTER_TABLE_SIZE - 1));
    int k = min((int)x, FILTER_TABLE_SIZE - 2);
    float t = x - (float)k;
    return mix(table[k], table[k + 1], t);
}

/* The numbers of the next-event estimation at the eye path's vertex `depth` (a mirror, glass
 * or glossy vertex before the visible point): the pixel's Sobol set for it (rng.h ld_set, its
 * own scramble), as Cycles samples its lights; pseudo-random past LD_SETS vertices. */
inline float3 eye_nee_u(uint pass, uint key, int depth, uint *rng) {
    if (depth < LD_SETS) return ld_set(pass, key, (uint)depth).xyz;
    return (float3)(rnd(rng), rnd(rng), rnd(rng));
}

__kernel void eye_pass(SCENE_PARAMS FILM_PARAMS VP_PARAMS uint pass_index, uint seed,
                       float initial_radius, float auto_radius_pixels, float radius_scale,
                       __global const float *filter_table, __global uint *counters,
                       uint path_indirect, float lt_kappa, uint volume_photons, uint path_filter,
                       __global float4 *pf_pos, __global float4 *pf_v, __global float4 *pf_w) {
    SCENE_LOAD(scene);
    FILM_LOAD(film);
    VP_LOAD(vps);
    __global const Camera *cam = scene->camera;
    int id = WORK_ITEM();
    int rw = cam->region[2], rh = cam->region[3];
    if (id >= rw * rh) return;
    if (path_filter) pf_w[id] = (float4)(0.0f); /* no record (path_filter.cl) until one is made */
    if (!film->active[id]) {               /* converged (adaptive sampling): no visible point */
        vps->pos[id] = (float4)(0.0f);
        return;
    }
    /* RADIUS_GLOBAL: no radius until this pass's visible point sets one (the photons' light
     * tracing takes all of a pixel that has none: no merge there to weigh it against) */
    if (radius_scale > 0.0f) film->radius[id] = 0.0f;
    int i = id % rw, j = id / rw;
    uint rng = rng_seed(seed, pass_index, (uint)id, 1u);
    /* the pixel's position and the lens, stratified over the passes: a set of the pixel's
     * Owen-scrambled Sobol numbers (rng.h ld_set), the position the set's (0, 2)-sequence pair,
     * as the path's choices and directions below (sets of their own key).  Most of a Cornell
     * box's noise is at its lamp's edge: its direct light's noise at 256 passes was 0.0088
     * with the R2 sequence, 0.0076 with these (Cycles: 0.0078).  Where visible points gather
     * photons the pixel's radius statistics follow where its points fell, pass after pass, and
     * Sobol's passes alternate between parts of the pixel; the estimate stays consistent (a
     * pass's radius depends only on the passes before it, and its photons estimate the light
     * blurred by that radius), and on the benchmark's caustics it converges as fast as with
     * pseudo-random positions (docs/BENCHMARKS.md, "The eye pass's numbers"): the glossy
     * spheres' error fell by 10-14 % with these. */
    uint prng = rng_seed(seed, 0u, (uint)id, 4u);    /* the pixel's key, the same each pass */
    uint nee_key = rng_seed(seed, 0u, (uint)id, 6u);  /* its next-event estimation's */
    uint path_key = rng_seed(seed, 0u, (uint)id, 7u); /* its path's choices and directions */
    float4 uc = ld_set(pass_index, prng, 0u);
    /* pixel filter by importance sampling (as Cycles): offsets from the filter's inverse CDF */
    float px = (float)(cam->region[0] + i) + 0.5f + filter_offset(filter_table, uc.x);
    float py = (float)(cam->region[1] + j) + 0.5f + filter_offset(filter_table, uc.y);
    float3 o, d;
    float tmax;
    camera_ray(cam, px, py, uc.z, uc.w, &o, &d, &tmax);
    /* the ray's footprint (Bump nodes: svm_bump.h) */
    float2 diff = SVM_FOOTPRINT ? camera_differential(cam, px, py) : (float2)(0.0f);
    float3 beta = (float3)(1.0f), L = (float3)(0.0f);
    float path_len = 0.0f;
    uint mask = VIS_CAMERA;
    uint path = PATH_CAMERA;           /* the ray, as the Light Path node sees it */
    /* the density of the sample that made this ray, and the normal its vertex sampled the world
     * around, for the MIS weight of the emitter it finds */
    float prev_pdf = INFINITY;
    /* the smallest density of the path's bounces (Filter Glossy, path_state.h) */
    float min_pdf = INFINITY;
    float3 prev_n = (float3)(0.0f, 0.0f, 1.0f), prev_p = (float3)(0.0f);
    float4 vp = (float4)(0.0f);
    /* alpha: a camera ray (through transparent surfaces, and transparent glass) that reaches
     * the world on a transparent film, or a holdout, is transparency, not radiance (Cycles'
     * transparent background path) */
    bool film_clear = true;
    float clear = 0.0f;
    ShaderData sd;
#if PPM_ABSORPTION
    Media media;
    media_init(&media);
#endif
#if PPM_VOLUME
    /* the camera inside media (a room of fog): those holding the ray's origin */
    media_at(scene, o, &media);
    sd.media = &media;
    int vbounce = 0; /* the path's scatterings in media (Light Paths > Volume bounces) */
    int bounds = 0; /* the media's boundaries it crossed (media_boundary) */
    int nseg = 0; /* the camera's segments kept for the volume photons' gather */
#endif
    __global const LightPaths *lp = scene->light_paths;
    int term = TERM_NONE; /* past a Light Paths limit: how the path ends (path_state.h) */
    /* with volume photons and eye paths for the indirect light: 1 after the path's first
     * scattering in a medium, 2 once only singular bounces followed it (the light such a path
     * finds is the volume photons' L S+ M, photon_pass.cl: not added here) */
    int vchain = 0;
    for (int depth = 0, transparent = 0, vertex = 0;;) {
        Hit h = bvh_intersect(scene, o, d, tmax, mask, false);
        /* the clamp of what this ray finds: direct after at most one bounce (path_state.h) */
        float clamp_found = clamp_limit(depth - 1, lp);
#if PPM_VOLUME
        /* the segment inside a medium (volume_light.h medium_segment): its emission, and the
         * lights the ray meets along it, each through the transmittance to it, with the path's
         * weight at the segment's start; then where the path scatters (free-flight distance
         * sampling, while the path may still scatter) or the transmittance to the hit.  The
         * numbers: the pixel's Sobol set for the segment, as its vertices' (rng.h ld_set), the
         * equiangular and the free-flight distances stratified over the passes
         * (pseudo-random numbers had 7.6x Cycles' error in a spot light's cone) */
        float3 beta_in = beta;
        int vm = media_top(&media);
        Segment sg = segment(o, d, 0.0f, (float3)(0.0f));
        bool kept = false; /* this segment kept for the volume photons */
        if (vm >= 0) {
            /* (a camera ray past the clip end in the world's medium goes on forever, as
             * Cycles': the fog beyond it scatters, the background is lost in it) */
            float seg = h.leaf >= 0 ? h.t : vm == world_medium(scene) ? PPM_INF : tmax;
            Mix mx = media_mix(&media, scene->materials);
            bool scat = term == TERM_NONE && mix_scatters(&mx);
            float4 ul = scat ? ld_set_or_rnd(pass_index, path_key, (uint)vertex++, &rng)
                             : (float4)(0.0f);
            L += medium_segment(scene, &media, o, d, seg, scat, (float4)(ul.z, ul.y, ul.w, ul.x),
                                max(lp->transparent_max_bounces - transparent, 0),
                                (float2)(clamp_found, clamp_limit(depth, lp)), true, &beta, &sg);
            /* the camera's segments in scattering media, for the volume photons' gather
             * (volume_gather.cl): its path's state, the weight at its start */
            kept = volume_photons && scat && vbounce == 0 && nseg < VOLUME_SEGMENTS;
            if (kept) {
                __global float4 *v = vps->segments + 4 * (VOLUME_SEGMENTS * id + nseg++);
                v[0] = (float4)(o, seg);
                v[1] = (float4)(d, as_float(mx.field));
                v[2] = (float4)(beta_in, as_float(path));
                v[3] = (float4)(mx.sigma_a + mx.sigma_s, mx.g);
            }
        }
#elif PPM_ABSORPTION
        /* the segment inside a medium (lights seen inside one: attenuated as far as the hit) */
        if (h.leaf >= 0) beta *= media_transmittance(&media, scene->materials, h.t);
#endif
        float pdf_l = 0.0f;
#if PPM_LIGHTS_SEEN
        {
            /* the lights the ray meets before the surface, each a transparent bounce; the path
             * ends at the one that reaches the limit */
#if PPM_VOLUME
            LightRay r = light_ray(o, d, h.leaf < 0 ? tmax : h.t, mask, prev_p, prev_n, prev_pdf,
                                   vchain == 2 ? (float3)(0.0f) : beta_in, clamp_found);
            light_ray_in(&r, scene, &media);
#else
            LightRay r = light_ray(o, d, h.leaf < 0 ? tmax : h.t, mask, prev_p, prev_n, prev_pdf,
                                   beta, clamp_found);
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
            /* scattered in the medium at p: next-event estimation there with the phase function,
             * then a sample of the phase function, which finds the emitters with size under
             * MIS and, while Volume bounces allow, goes on as a path (Cycles' volume scatter:
             * with Volume bounces 0, single scattering) */
            float3 p = o + sg.s * d;
            float g = sg.g;
            film_clear = false;
            int crossings = max(lp->transparent_max_bounces - transparent, 0);
            L += clamp_sample(beta
                                  * volume_nee(scene, &sg, sg.s, sg.pdf, g, &media, crossings,
                                               eye_nee_u(pass_index, nee_key, depth, &rng)),
                              clamp_limit(depth, lp));
            float4 up = ld_set_or_rnd(pass_index, path_key, (uint)vertex++, &rng);
            float pdf, u1 = up.x, u2 = up.y;
            float3 wo = hg_sample(d, g, u1, u2, &pdf); /* (its weight: phase / pdf = 1) */
            term = path_volume_bounce(&path, &depth, &vbounce, lp);
            /* volume photons: with indirect light by photons the light this point scatters
             * from other than the emitters is theirs (the path only finds emitters); with eye
             * paths what reaches it through mirrors and glass (vchain) */
            if (volume_photons && !path_indirect) term = TERM_AFTER_TRANSPARENT;
            vchain = kept && vbounce == 1 ? 1 : 0; /* (a segment not kept: the path's light) */
            prev_pdf = pdf;
            prev_n = (float3)(0.0f); /* (as volume_nee gave the pick) */
            prev_p = p;
            mask = VIS_DIFFUSE;
            o = p;
            d = wo;
            tmax = PPM_INF;
            if (!(max3(beta) > 0.0f)) break;
            continue;
        }
#endif
        if (h.leaf < 0) {
            if (film_clear && cam->film_transparent) {
                clear += (beta.x + beta.y + beta.z) * (1.0f / 3.0f);
                break;
            }
            if (mask == VIS_CAMERA && (scene->emitter_info->world_flags & WORLD_HIDDEN_CAMERA))
                break;
            pdf_l = PPM_WORLD && scene->emitter_info->has_world && !isinf(prev_pdf)
                        ? world_light_pdf(scene, d, prev_p, prev_n)
                        : 0.0f;
            if (vchain != 2)
                L += clamp_sample(beta * world_le(scene, d) * mis_power(prev_pdf, pdf_l),
                                  clamp_found);
            break;
        }
        path_len += h.t;
        Surface s = surface_at(scene, h);
        float foot_r = diff.x + path_len * diff.y;
        shader_setup(scene, &sd, &s, h.u, h.v, path, h.t, -d,
                     footprint_at(scene, s.tri, h.leaf, h.u, h.v, foot_r));
        shader_blur(&sd, filter_glossy_alpha(min_pdf, lp));
        if (film_clear && max3(sd.holdout) > 0.0f) {
            float3 t = beta * sd.holdout;
            clear += (t.x + t.y + t.z) * (1.0f / 3.0f);
        }
        if (max3(sd.emission) > 0.0f && vchain != 2)
            L += clamp_sample(beta * sd.emission
                                  * mesh_hit_mis(scene, &h, o, d, prev_pdf, prev_p, prev_n),
                              clamp_found);
        if (term != TERM_NONE) {
            /* past a limit: the emission above, and after the last bounce on through the
             * surface's transparency (Cycles' TERMINATE_AFTER_TRANSPARENT) */
            if (term == TERM_ON_NEXT_SURFACE || !(max3(sd.transparent) > 0.0f)) break;
            beta *= sd.transparent;
            if (!(max3(beta) > 0.0f)) break;
#if PPM_VOLUME
            media_cross_transparent(&media, scene->materials, s.material, !sd.backfacing);
#endif
            o = offset_ray(s.p, -sd.Ng, scene->emitter_info->offset_scale);
            tmax = PPM_INF;
#if PPM_VOLUME
            if (media_boundary(scene->materials, s.material)) {
                if (++bounds > VOLUME_BOUNDS_MAX) break;
                continue;
            }
#endif
            path = path_transparent(path);
            term = max(term, path_limit_transparent(++transparent, lp));
            continue;
        }
        float sw = sd.sw_gather + sd.sw_continue;
        if (!(sw > 0.0f)) break;
        /* A vertex with gathered and followed closures (a diffuse base under a glossy layer):
         * next-event estimation for all of them here, before the path picks one side; each
         * side's sample of its closures is then weighted against that estimate's density (all
         * the closures').  Estimated on the side chosen, the direct light carried the choice's
         * noise: a sun-lit Principled cone and ground rendered at 3.5x the noise (issue 24). */
        bool mixed = sd.sw_gather > 0.0f && sd.sw_continue > 0.0f && sd.continue_glossy;
        if (mixed)
            L += clamp_sample(beta
                                  * direct_nee_u(scene, &sd, s.p, MASK_ALL, true,
                                                 eye_nee_u(pass_index, nee_key, depth, &rng)),
                              clamp_limit(depth, lp));
        /* Filter Glossy: the photons' light at a blurred vertex, or at one where no direction
         * a photon comes from has the density the setting asks (a diffuse one when it is above
         * 1 / pi), is the eye paths' (path_state.h): a visible point here gathers none.  Then,
         * unless the vertex lets light through (transparency, the film's transparent glass),
         * the path takes no side: it goes on from here through all the closures (one sample
         * of their mixture, as Cycles'), and all the light it finds is its own
         * (indirect_paths.h INDIRECT_EVERY). */
        bool gathers = lp->filter_glossy <= 0.0f
                       || (!filter_glossy_blurs(min_pdf, lp)
                           && !filter_glossy_blurs(shader_pdf_bound(&sd), lp));
        bool whole = !gathers && sd.sw_gather > 0.0f && !(max3(sd.transparent) > 0.0f)
                     && !(film_clear && (cam->film_transparent & FILM_TRANSPARENT_GLASS));
        /* the choice of the vertex's side and the continuing sample's numbers: the pixel's
         * Sobol set for the vertex (pseudo-random past LD_SETS) */
        float4 uv = ld_set_or_rnd(pass_index, path_key, (uint)vertex++, &rng);
        if (whole || uv.w * sw < sd.sw_gather) {
            /* a visible point: the gather's closures, weighted by 1 / their probability (all
             * the closures, whole) */
            float3 bvp = whole ? beta : beta * (sw / sd.sw_gather);
            /* direct light: next-event estimation and a sample of the closures (MIS); with
             * path_indirect or whole the continuing path's (indirect_paths below) */
            if (!path_indirect && !whole && mixed)
                L += clamp_sample(bvp * direct_bsdf(scene, &sd, s.p, MASK_GATHER, MASK_ALL, &rng),
                                  clamp_limit(depth, lp));
            else if (!path_indirect && !whole)
                L += direct_light(scene, &sd, s.p, MASK_GATHER, bvp, clamp_limit(depth, lp), &rng);
            vp = gathers ? (float4)(s.p, sd.gather_transmits ? 2.0f : 1.0f) : (float4)(0.0f);
            /* the surface's own normal: the gather's disc lies in it, as the photons do (the
             * gather shades the point again) */
            vps->nrm[id] = (float4)(sd.Ng, as_float(path));
            bool lambert;
            float3 albedo = gather_albedo(&sd, &lambert);
            /* (with Filter Glossy the gather asks every photon's direction the closures'
             * density: it shades the point) */
            if (lambert && !(lp->filter_glossy > 0.0f && gathers)) {
                /* f is one constant: it goes into the path weight, the gather sums flux */
                vps->beta[id] = (float4)(bvp * albedo * (1.0f / PPM_PI), foot_r);
                vps->shade[id] = (float4)(0.0f, 0.0f, as_float(-1), 0.0f);
            } else {
                vps->beta[id] = (float4)(bvp, foot_r); /* (w: the gather's footprint) */
                vps->shade[id] = (float4)(h.u, h.v, as_float(h.leaf), as_float(pack_unit(sd.wi)));
            }
            /* denoising passes: albedo through the specular chain, world-space normal */
            film->aux_albedo[id] += (float4)(beta * albedo, 1.0f);
            film->aux_normal[id] += (float4)(sd.N, 1.0f);
            /* the gather radius: RADIUS_PIXEL (radius_scale 0) sets it at the pixel's first
             * visible point and film_update shrinks it; RADIUS_GLOBAL (radius_scale > 0, the
             * pass's factor of Knaus & Zwicker's sequence, options.py global_radius_scale)
             * sets it every pass from this visible point's own footprint, so a pass's radius
             * depends on its own sample alone and passes render apart and merge exactly */
            if (film->radius[id] <= 0.0f || radius_scale > 0.0f) {
                float foot = camera_pixel_size(cam) * (cam->type == CAMERA_ORTHO ? 1.0f : path_len);
                float r0 = initial_radius > 0.0f ? initial_radius : auto_radius_pixels * foot;
                r0 = isfinite(r0) && r0 > 0.0f ? r0 : FLT_MIN;
                film->radius0[id] = r0;
                film->radius[id] = radius_scale > 0.0f ? fmax(r0 * radius_scale, FLT_MIN) : r0;
            }
            /* a point the camera sees directly: the photons' light tracing renders the same
             * paths, and the merge takes its side of the balance heuristic (photon_pass.cl
             * connect_camera) */
            if (lt_kappa > 0.0f && depth == 0) {
                /* the first pass counts them: with none, the render stops connecting photons
                 * to the camera (Renderer.iterate) */
                if (pass_index == 0u) atomic_inc(&counters[CNT_SEEN]);
                float m = merge_factor(cam, s.p, sd.Ng, lt_kappa) * film->radius[id]
                          * film->radius[id];
                if (m > 0.0f) {
                    float4 b = vps->beta[id];
                    vps->beta[id] = (float4)(b.xyz * (m / (1.0f + m)), b.w);
                }
            }
            /* direct and indirect light by path tracing (indirect_paths.h); the photons bring
             * caustics (with indirect light by photons and Filter Glossy, the paths bring what
             * it blurs); where no photon is gathered, the paths bring it all */
            PathRecord rec = {path_filter != 0u, false};
            IndirectStart start = {min_pdf,
                                   whole ? MASK_ALL : MASK_GATHER,
                                   !gathers        ? INDIRECT_EVERY
                                   : path_indirect ? INDIRECT_ALL
                                                   : INDIRECT_BLURRED,
                                   mixed,
                                   path_indirect || whole,
                                   &rec};
            if (path_indirect || lp->filter_glossy > 0.0f)
                L += record_tail(&rec,
                                 indirect_paths(scene, &sd, s.p, s.material, bvp, depth, path,
                                                pass_index, rng_seed(seed, 0u, (uint)id, 5u), start,
#if PPM_ABSORPTION
                                                &media,
#endif
                                                &rng),
                                 pf_pos + id, pf_v + id, pf_w + id);
            break;
        }
        /* the path goes on through the other closures (mirrors, glass, smooth glossy lobes,
         * transparency), weighted by 1 / their probability */
        beta *= sw / sd.sw_continue;
        if (sd.continue_glossy && !mixed)
            L += clamp_sample(beta
                                  * direct_nee_u(scene, &sd, s.p, MASK_CONTINUE, true,
                                                 eye_nee_u(pass_index, nee_key, depth, &rng)),
                              clamp_limit(depth, lp));
        BsdfSample b;
        if (!shader_sample(&sd, MASK_CONTINUE, uv.xyz, &b)) break;
        float pdf_mis = b.pdf; /* the density the emitter it finds is weighed against */
        if (mixed && !isinf(pdf_mis))
            pdf_mis = shader_mis_pdf(&sd, b.wo, MASK_CONTINUE, MASK_ALL, pdf_mis);
        beta *= b.weight;
        bool transmit = (b.label & LABEL_TRANSMIT) != 0;
        o = offset_ray(s.p, transmit ? -sd.Ng : sd.Ng, scene->emitter_info->offset_scale);
        d = b.wo;
        tmax = PPM_INF;
        if (!(max3(beta) > 0.0f)) break;
        if (b.label & LABEL_TRANSPARENT) {
            /* straight through: not a bounce (as Cycles' transparent bounces), the ray keeps
             * its type and its MIS state; a medium's boundary enters or leaves it */
#if PPM_VOLUME
            media_cross_transparent(&media, scene->materials, s.material, !sd.backfacing);
            if (media_boundary(scene->materials, s.material)) {
                if (++bounds > VOLUME_BOUNDS_MAX) break;
                continue;
            }
#endif
            path = path_transparent(path);
            term = path_limit_transparent(++transparent, lp);
            continue;
        }
        vchain = vchain > 0 && (b.label & LABEL_SINGULAR) ? 2 : 0;
        film_clear = film_clear && (cam->film_transparent & FILM_TRANSPARENT_GLASS)
                     && (b.label & LABEL_TRANSMIT) && !(b.label & LABEL_DIFFUSE)
                     && b.roughness2 <= cam->glass_roughness * cam->glass_roughness;
        depth++;
        path = path_bounce(path, b.label);
        term = path_limit(path, depth, lp); /* past it: the emitter this sample finds only */
        prev_pdf = sd.continue_glossy ? pdf_mis : INFINITY;
        /* (pdf_mis is the mixture's density over all the closures, or INFINITY) */
        min_pdf = fmin(min_pdf, pdf_mis);
        prev_n = sd.N;
        prev_p = s.p;
        mask = transmit ? VIS_TRANSMISSION : VIS_GLOSSY;
#if PPM_ABSORPTION
        if (transmit) media_cross(&media, s.material, !sd.backfacing);
#endif
    }
    vps->pos[id] = vp;
#if PPM_VOLUME
    if (volume_photons && nseg < VOLUME_SEGMENTS)
        vps->segments[4 * (VOLUME_SEGMENTS * id + nseg)] = (float4)(0.0f); /* (the last) */
#endif
    /* this pass's sample (the film adds it to its sums, progressive.cl film_add_sample);
     * NaN/Inf guard: drop the sample, count it (render stats) */
    bool ok = isfinite(L.x) && isfinite(L.y) && isfinite(L.z);
    film->direct_pass[id] = ok ? (float4)(L, 1.0f) : (float4)(0.0f);
    if (!ok) atomic_inc(&counters[CNT_NAN]);
    if (!ok && path_filter) pf_w[id] = (float4)(0.0f); /* (the sample is dropped) */
    if (clear > 0.0f && isfinite(clear)) film->transparency[id] += clear;
}
