/* Eye pass (the paper's first phase): one jittered camera ray per pixel, through specular
 * bounces to the first diffuse hit, where it stores a visible point and adds direct light by
 * next-event estimation.  Emission and background seen directly or through mirrors/glass go to
 * the pixel's direct sum. */
#include "direct_light.h"
#include "camera.h"
#include "counters.h"
#include "medium.h"

/* entries of the pixel filter's table: -D PPM_FILTER_TABLE_SIZE from ppm_engine/film.py */
#define FILTER_TABLE_SIZE PPM_FILTER_TABLE_SIZE

/* offset from the pixel centre: the filter table (inverse CDF) at u = bits / 2^32, lerped */
inline float filter_offset(__global const float *table, uint bits) {
    float x = (float)(bits >> 8) * (1.0f / 16777216.0f) * (float)FILTER_TABLE_SIZE - 0.5f;
    x = clamp(x, 0.0f, (float)(FILTER_TABLE_SIZE - 1));
    int k = min((int)x, FILTER_TABLE_SIZE - 2);
    float t = x - (float)k;
    return mix(table[k], table[k + 1], t);
}

__kernel void eye_pass(__global const Camera *cam, SCENE_ARGS, uint pass_index, uint seed,
                       int max_bounces, float initial_radius, float auto_radius_pixels,
                       __global const float *filter_table,
                       __global float4 *direct, __global float *radius, __global float *radius0,
                       __global float4 *vp_pos, __global float4 *vp_nrm, __global float4 *vp_beta,
                       __global uint *counters, __global float4 *aux_albedo,
                       __global float4 *aux_normal, __global const uint *active) {
    int id = get_global_id(0);
    int rw = cam->region[2], rh = cam->region[3];
    if (id >= rw * rh) return;
    if (!active[id]) {               /* converged (adaptive sampling): no visible point */
        vp_pos[id] = (float4)(0.0f);
        return;
    }
    int i = id % rw, j = id / rw;
    uint rng = rng_seed(seed, pass_index, (uint)id, 1u);
    /* pixel jitter: the R2 sequence (Roberts 2018) over the passes, rotated per pixel
     * (Cranley-Patterson): stratified over passes, so anti-aliasing converges ~1/N */
    uint prng = rng_seed(seed, 0u, (uint)id, 4u);
    uint jx = rng_next(&prng) + pass_index * 3242174889u;     /* 0.7548776662 * 2^32, wraps = frac */
    uint jy = rng_next(&prng) + pass_index * 2447445413u;     /* 0.5698402910 * 2^32 */
    /* pixel filter by importance sampling (as Cycles): offsets from the filter's inverse CDF */
    float px = (float)(cam->region[0] + i) + 0.5f + filter_offset(filter_table, jx);
    float py = (float)(cam->region[1] + j) + 0.5f + filter_offset(filter_table, jy);
    float3 o, d;
    float tmax;
    camera_ray(cam, px, py, rnd(&rng), rnd(&rng), &o, &d, &tmax);
    float3 beta = (float3)(1.0f), L = (float3)(0.0f);
    float path_len = 0.0f;
    uint mask = VIS_CAMERA;
    float4 vp = (float4)(0.0f);
#if PPM_ABSORPTION
    Media media;
    media_init(&media);
#endif
    for (int depth = 0;; depth++) {
        Hit h = bvh_intersect(o, d, tmax, mask, false, BVH_PASS);
#if PPM_ABSORPTION
        /* the segment inside a medium (lights seen inside one: attenuated as far as the hit) */
        if (h.leaf >= 0) beta *= media_transmittance(&media, materials, h.t);
#endif
#if PPM_LIGHTS_SEEN
        L += beta * lights_seen(o, d, h.leaf < 0 ? tmax : h.t, lights, emitter_info->n_lights,
                                  mask);
#endif
        if (h.leaf < 0) {
            L += beta * F3(emitter_info->world);
            break;
        }
        path_len += h.t;
        Surface s = surface_at(h, tri_v0, tri_e1, tri_e2, normals);
        __global const Material *m = materials + s.material;
        if (m->flags & MAT_EMISSIVE)
            L += beta * F3(m->emission)
                 * texture_tint(m->emission_tex, s.tri, h.u, h.v, TEXTURE_PASS);
        float3 tint = texture_tint(m->diffuse_tex, s.tri, h.u, h.v, TEXTURE_PASS);
        int lobe = choose_lobe(m, rnd(&rng));
        if (lobe == LOBE_ABSORBED) break;
        if (lobe == LOBE_DIFFUSE) {
            bool front = dot(d, s.ng) < 0.0f;
            float3 ngf = front ? s.ng : -s.ng, nsf = front ? s.ns : -s.ns;
            float3 bvp = beta * F3(m->diffuse) * tint * (1.0f / PPM_PI);
            L += bvp * direct_lighting(s.p, nsf, ngf, SCENE_PASS, &rng);
            vp = (float4)(s.p, 1.0f);
            vp_nrm[id] = (float4)(nsf, 0.0f);
            vp_beta[id] = (float4)(bvp, 0.0f);
            /* denoising passes: albedo through the specular chain, world-space normal */
            aux_albedo[id] += (float4)(beta * F3(m->diffuse) * tint, 1.0f);
            aux_normal[id] += (float4)(nsf, 1.0f);
            if (radius[id] <= 0.0f) {
                float foot = camera_pixel_size(cam) * (cam->type == CAMERA_ORTHO ? 1.0f : path_len);
                float r0 = initial_radius > 0.0f ? initial_radius : auto_radius_pixels * foot;
                radius[id] = radius0[id] = isfinite(r0) && r0 > 0.0f ? r0 : FLT_MIN;
            }
            break;
        }
#if !PPM_SPECULAR
        break;                       /* no mirror or glass in the scene: no specular bounce */
#else
        if (depth >= max_bounces) break;
        float3 leave_n;
        float measure;                /* 1: camera paths carry no radiance compression */
#if PPM_ABSORPTION
        bool entering = dot(d, s.ng) < 0.0f;
#endif
        lobe = scatter_specular(lobe, m, tint, s.ng, s.ns, rnd(&rng), true, &d, &beta, &leave_n,
                                &measure);
#if PPM_ABSORPTION
        if (lobe == LOBE_GLASS_TRANSMIT) media_cross(&media, s.material, entering);
#endif
        o = offset_ray(s.p, leave_n);
        tmax = PPM_INF;
        mask = lobe == LOBE_GLASS_TRANSMIT ? VIS_TRANSMISSION : VIS_GLOSSY;
        if (!(max3(beta) > 0.0f)) break;
#endif
    }
    vp_pos[id] = vp;
    /* this pass's sample (the film adds it to its sums, progressive.cl film_add_sample);
     * NaN/Inf guard: drop the sample, count it (render stats) */
    bool ok = isfinite(L.x) && isfinite(L.y) && isfinite(L.z);
    direct[id] = ok ? (float4)(L, 1.0f) : (float4)(0.0f);
    if (!ok) atomic_inc(&counters[CNT_NAN]);
}
