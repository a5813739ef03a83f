/* Light tracing: an unbiased reference estimator, independent of the photon map (the
 * benchmark's reference where no Cycles estimator samples the light,
 * ppm_engine/render/light_tracer.py). Photons leave the emitters as in the photon pass; at every
 * vertex whose closures can be evaluated (not singular) the photon's flux is connected to the
 * pinhole camera: through the BSDF toward the camera, the visibility of the segment, and the
 * camera's importance, splatted into the pixels the pixel filter reaches.  It renders the paths
 * that reach the camera from a non-singular vertex (L (S|D)* D E in Heckbert's notation); what the
 * camera sees through mirrors and glass it cannot, and lt_coverage marks those pixels. */
#include "builtins.h"
#include "rng.h"
#include "integrator/photon_emission.h"
#include "closure/shader.h"
#include "integrator/direct_light.h"
#include "geom/camera.h"
#include "integrator/camera_connect.h"
#include "shared.h"
#include "geom/medium.h"

__kernel void light_trace(SCENE_PARAMS uint pass_index, uint seed, int max_bounces, uint n_photons,
                          __global const float *filter_density, int n_table, float reach,
                          __global float *image, __global uint *counters) {
    SCENE_LOAD(scene);
    uint id = WORK_ITEM();
    if (id >= n_photons) return;
    __global const Camera *cam = scene->camera;
    uint rng = rng_seed(seed, pass_index, id, 5u);
    Splat sp = {image, filter_density, image, n_table, reach, 0.0f};
    float3 o, d, flux;
    float rs;
    float2 nee;
    bool delta;
    int caster;
    int gbin;
    if (!emit_photon(scene, &rng, false, false, &o, &d, &flux, &rs, &nee, &delta, &caster, &gbin))
        return;
    uint mask = VIS_SHADOW;
#if PPM_ABSORPTION
    Media media;
    media_init(&media);
#endif
    ShaderData sd;
    uint path = 0u;
    for (int bounce = 0, transparent = 0; bounce <= max_bounces;) {
        Hit h = bvh_intersect(scene, o, d, PPM_INF, mask, false);
        if (h.leaf < 0) break;
        float3 before = flux;
#if PPM_VOLUME
        flux *= media_transmittance_ray(scene, &media, o, d, h.t);
#elif PPM_ABSORPTION
        flux *= media_transmittance(&media, scene->materials, h.t);
#endif
        Surface s = surface_at(scene, h);
        /* the connection to the camera: the closures as the camera sees them */
        float px, py, dist, we;
        float3 wc;
        if (camera_project(cam, s.p, reach, &px, &py, &wc, &dist, &we)) {
            ShaderData sc;
            shader_setup(scene, &sc, &s, h.u, h.v, PATH_CAMERA, h.t, wc,
                         footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                      SVM_FOOTPRINT ? camera_footprint_at(cam, s.p) : 0.0f));
            float pdf;
            float3 f = shader_eval(&sc, -d, MASK_ALL, &pdf);     /* f cos(light side) */
            float cos_lg = fabs(dot(s.ng, d)), cos_cg = fabs(dot(s.ng, wc));
            if (max3(f) > 0.0f && cos_lg > 0.0f) {
                bool front = dot(wc, s.ng) > 0.0f;
                float3 org = offset_ray(s.p, front ? s.ng : -s.ng,
                                        scene->emitter_info->offset_scale);
                float3 T = shadow_transmittance(scene, org, wc, dist * 0.9999f,
                                                scene->light_paths->transparent_max_bounces);
                float3 c = flux * f * T * (cos_cg / cos_lg * we);
                if (max3(T) > 0.0f && isfinite(c.x) && isfinite(c.y) && isfinite(c.z))
                    splat(cam, &sp, px, py, c, 0.0f);
            }
        }
        if (bounce == max_bounces) break;
        shader_setup(scene, &sd, &s, h.u, h.v, path, h.t, -d,
                     footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                  SVM_FOOTPRINT ? camera_footprint_at(cam, s.p) : 0.0f));
        BsdfSample b;
        float3 rand = (float3)(rnd(&rng), rnd(&rng), rnd(&rng));
        if (!shader_sample_light(&sd, MASK_ALL, rand, &b, scene->shading_tables)) break;
        flux *= b.weight;
        if (!(b.label & LABEL_TRANSPARENT)) {
            /* the adjoint of the shading normals (Veach 5.3), as the photon pass: a camera
             * path through a smooth-shaded surface weighs what it finds by the shading normal's
             * cosines, light arrives and leaves by the surface's own */
            float adj = shading_adjoint(d, b.wo, sd.N, sd.Ng);
            if (!(adj > 0.0f)) break;
            flux *= adj;
        }
        bool transmit = (b.label & LABEL_TRANSMIT) != 0;
        float measure = 1.0f;
        if (transmit && b.eta != 1.0f) {          /* as the photon pass (photon_pass.cl) */
            measure = 1.0f / (b.eta * b.eta);
            flux *= measure;
        }
        if (b.label & LABEL_TRANSPARENT) {
            if (++transparent > scene->light_paths->transparent_max_bounces) break;
            path = path_transparent(path);
        } else {
            bounce++;
            path = path_bounce(path, b.label);
            mask = bounce_visibility(b.label);
#if PPM_ABSORPTION
            if (transmit) media_cross(&media, s.material, dot(d, s.ng) < 0.0f);
#endif
        }
        o = offset_ray(s.p, transmit ? -sd.Ng : sd.Ng, scene->emitter_info->offset_scale);
        d = b.wo;
        float q = fmin(1.0f, max3(flux) / (max3(before) * measure));
        if (!(q > 0.0f) || rnd(&rng) >= q) break;
        flux /= q;
    }
}

/* Which pixels light tracing renders: 1 where the camera ray through the pixel centre first
 * meets a surface without emission whose closures are all evaluable (no mirror, glass,
 * transparency or smooth glossy lobe the eye pass would follow), else 0. */
__kernel void lt_coverage(SCENE_PARAMS __global float *covered) {
    SCENE_LOAD(scene);
    int id = WORK_ITEM();
    __global const Camera *cam = scene->camera;
    int rw = cam->region[2], rh = cam->region[3];
    if (id >= rw * rh) return;
    float px = (float)(cam->region[0] + id % rw) + 0.5f;
    float py = (float)(cam->region[1] + id / rw) + 0.5f;
    float3 o, d;
    float tmax;
    camera_ray(cam, px, py, 0.5f, 0.5f, &o, &d, &tmax);
    Hit h = bvh_intersect(scene, o, d, tmax, VIS_CAMERA, false);
    float ok = 0.0f;
    if (h.leaf >= 0) {
        Surface s = surface_at(scene, h);
        ShaderData sd;
        shader_setup(scene, &sd, &s, h.u, h.v, PATH_CAMERA, h.t, -d,
                     footprint_at(scene, s.tri, h.leaf, h.u, h.v,
                                  SVM_FOOTPRINT ? camera_footprint_at(cam, s.p) : 0.0f));
        ok = (sd.sw_continue <= 0.0f && max3(sd.emission) <= 0.0f) ? 1.0f : 0.0f;
    }
    covered[id] = ok;
}
