/* Light tracing: an unbiased reference estimator, independent of the photon map (the
 * benchmark's reference where no Cycles estimator samples the light, ppm_engine/light_tracer.py).
 * Photons leave the emitters as in the photon pass; at every vertex whose closures can be
 * evaluated (not singular) the photon's flux is connected to the pinhole camera: through the
 * BSDF toward the camera, the visibility of the segment, and the camera's importance, splatted
 * into the pixels the pixel filter reaches.  It renders the paths that reach the camera from a
 * non-singular vertex (L (S|D)* D E in Heckbert's notation); what the camera sees through mirrors
 * and glass it cannot, and lt_coverage marks those pixels. */
#include "rng.h"
#include "photon_emission.h"
#include "shader.h"
#include "direct_light.h"
#include "camera.h"
#include "shared.h"
#include "medium.h"

/* p seen by the pinhole camera: raster position (full-frame pixels, y up), the unit direction
 * from p to the camera, its distance (orthographic: to the view plane) and the factor from a
 * radiance at p to the film's measure (pixel area), without the pixel filter:
 * 1 / (d^2 cos^3 theta A_pixel) for a perspective camera, 1 / A_pixel for an orthographic one.
 * False when p is behind, outside the clip range or outside the frame's filter reach. */
inline bool camera_project(__global const Camera *cam, float3 p, float reach, float *px, float *py,
                           float3 *to_cam, float *dist, float *we) {
    __global const float *m = cam->to_world;
    float3 c = (float3)(m[3], m[7], m[11]);
    float3 ax = (float3)(m[0], m[4], m[8]), ay = (float3)(m[1], m[5], m[9]),
           az = (float3)(m[2], m[6], m[10]);
    float3 v = p - c;
    float3 pc = (float3)(dot(v, ax), dot(v, ay), dot(v, az));
    float depth = -pc.z;
    if (!(depth > cam->clip[0] && depth < cam->clip[1])) return false;
    float a_pix = cam->extent[0] * cam->extent[1] / ((float)cam->width * (float)cam->height);
    float xc, yc;
    if (cam->type == CAMERA_ORTHO) {
        xc = pc.x;
        yc = pc.y;
        *to_cam = az;
        *dist = depth;
        *we = 1.0f / a_pix;
    } else {
        xc = pc.x / depth;
        yc = pc.y / depth;
        float d2 = dot(v, v), cos_c = depth / sqrt(d2);
        *dist = sqrt(d2);
        *to_cam = -v / *dist;
        *we = 1.0f / (d2 * cos_c * cos_c * cos_c * a_pix);
    }
    *px = ((xc - cam->shift[0]) / cam->extent[0] + 0.5f) * (float)cam->width;
    *py = ((yc - cam->shift[1]) / cam->extent[1] + 0.5f) * (float)cam->height;
    float x0 = (float)cam->region[0], y0 = (float)cam->region[1];
    return *px > x0 - reach && *px < x0 + (float)cam->region[2] + reach && *py > y0 - reach
           && *py < y0 + (float)cam->region[3] + reach;
}

/* float atomic add (compare-and-swap on the bits) */
inline void atomic_add_float(volatile __global float *a, float v) {
    union {
        uint u;
        float f;
    } old, new_;
    do {
        old.f = *a;
        new_.f = old.f + v;
    } while (atomic_cmpxchg((volatile __global uint *)a, old.u, new_.u) != old.u);
}

/* the pixel filter's normalised 1D density (pixel units) at offset x: a table over
 * [-reach, reach] (ppm_engine/light_tracer.py filter_density) */
inline float filter_at(__global const float *table, int n, float reach, float x) {
    float t = (x + reach) / (2.0f * reach) * (float)(n - 1);
    if (!(t >= 0.0f && t <= (float)(n - 1))) return 0.0f;
    int k = min((int)t, n - 2);
    float f = t - (float)k;
    return mix(table[k], table[k + 1], f);
}

/* splat a contribution at raster (px, py) into the pixels the filter reaches (image: rgb per
 * pixel of the render region, row 0 = bottom) */
inline void splat(__global const Camera *cam, __global float *image, __global const float *table,
                  int n_table, float reach, float px, float py, float3 c) {
    int rw = cam->region[2], rh = cam->region[3];
    float lx = px - (float)cam->region[0], ly = py - (float)cam->region[1];
    int i0 = max((int)floor(lx - reach), 0), i1 = min((int)floor(lx + reach), rw - 1);
    int j0 = max((int)floor(ly - reach), 0), j1 = min((int)floor(ly + reach), rh - 1);
    for (int j = j0; j <= j1; j++) {
        float wy = filter_at(table, n_table, reach, ly - ((float)j + 0.5f));
        if (wy <= 0.0f) continue;
        for (int i = i0; i <= i1; i++) {
            float w = wy * filter_at(table, n_table, reach, lx - ((float)i + 0.5f));
            if (w <= 0.0f) continue;
            int id = 3 * (j * rw + i);
            atomic_add_float(image + id, c.x * w);
            atomic_add_float(image + id + 1, c.y * w);
            atomic_add_float(image + id + 2, c.z * w);
        }
    }
}

__kernel void light_trace(SCENE_PARAMS uint pass_index, uint seed, int max_bounces, uint n_photons,
                          __global const float *filter_density, int n_table, float reach,
                          __global float *image, __global uint *counters) {
    SCENE_LOAD(scene);
    uint id = get_global_id(0);
    if (id >= n_photons) return;
    __global const Camera *cam = scene->camera;
    uint rng = rng_seed(seed, pass_index, id, 5u);
    float3 o, d, flux;
    float rs;
    float2 nee;
    if (!emit_photon(scene, &rng, &o, &d, &flux, &rs, &nee)) return;
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
#if PPM_ABSORPTION
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
                    splat(cam, image, filter_density, n_table, reach, px, py, c);
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
    int id = get_global_id(0);
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
