#ifndef PPM_CAMERA_CONNECT_H
#define PPM_CAMERA_CONNECT_H
/* Connections of light-path vertices to the pinhole camera (light tracing:
 * kernels/integrator/light_trace.cl, the reference estimator; kernels/integrator/photon_pass.cl,
 * the photons' strategy against the merge). */
#include "builtins.h"
#include "geom/camera.h"

/* p seen by the pinhole camera: raster position (full-frame pixels, y up), the unit direction
 * from p to the camera, the length of the connection (from p to the near clipping plane, where
 * the camera's rays start: camera_ray, as Cycles'; an occluder between there and p hides p from
 * the camera, one nearer than the clipping plane, or behind an orthographic view's eye where the
 * clipping plane is (a viewport's negative clip start), is cut away as the camera rays cut it)
 * and the factor from a radiance at p to the film's measure (pixel area), without the pixel
 * filter: 1 / (d^2 cos^3 theta A_pixel) for a perspective camera (d to the eye), 1 / A_pixel for
 * an orthographic one.  False when p is behind, outside the clip range or outside the frame's
 * filter reach. */
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
        *dist = depth - cam->clip[0];
        *we = 1.0f / a_pix;
    } else {
        xc = pc.x / depth;
        yc = pc.y / depth;
        float d2 = dot(v, v), d = sqrt(d2), cos_c = depth / d;
        *to_cam = -v / d;
        *dist = d * (1.0f - cam->clip[0] / depth);     /* the eye's distance less the clip's */
        *we = 1.0f / (d2 * cos_c * cos_c * cos_c * a_pix);
    }
    *px = ((xc - cam->shift[0]) / cam->extent[0] + 0.5f) * (float)cam->width;
    *py = ((yc - cam->shift[1]) / cam->extent[1] + 0.5f) * (float)cam->height;
    float x0 = (float)cam->region[0], y0 = (float)cam->region[1];
    return *px > x0 - reach && *px < x0 + (float)cam->region[2] + reach && *py > y0 - reach
           && *py < y0 + (float)cam->region[3] + reach;
}

/* the pixel filter's normalised 1D density (pixel units) at offset x: a table over
 * [-reach, reach] (ppm_engine/render/light_tracer.py filter_density) */
inline float filter_at(__global const float *table, int n, float reach, float x) {
    float t = (x + reach) / (2.0f * reach) * (float)(n - 1);
    if (!(t >= 0.0f && t <= (float)(n - 1))) return 0.0f;
    int k = min((int)t, n - 2);
    float f = t - (float)k;
    return mix(table[k], table[k + 1], f);
}

/* Where a splat goes: the image (rgb per pixel of the render region, row 0 = bottom), the
 * pixel filter's density table (filter_at) and, for the light-tracing side of the balance
 * heuristic against the merge, the film's radii and kappa (0: no weight). */
typedef struct {
    __global float *image;
    __global const float *table;
    __global const float *radius;
    int n_table;
    float reach;
    float kappa;
} Splat;

/* splat a contribution at raster (px, py) into the pixels the filter reaches.  mis > 0: each
 * pixel q takes the light-tracing side of the balance heuristic against the merge at its
 * visible point, 1 / (1 + mis radius_q^2) (mis: merge_factor's value over r^2 at this point). */
inline void splat(__global const Camera *cam, const Splat *sp, float px, float py, float3 c,
                  float mis) {
    int rw = cam->region[2], rh = cam->region[3];
    float reach = sp->reach;
    float lx = px - (float)cam->region[0], ly = py - (float)cam->region[1];
    int i0 = max((int)floor(lx - reach), 0), i1 = min((int)floor(lx + reach), rw - 1);
    int j0 = max((int)floor(ly - reach), 0), j1 = min((int)floor(ly + reach), rh - 1);
    for (int j = j0; j <= j1; j++) {
        float wy = filter_at(sp->table, sp->n_table, reach, ly - ((float)j + 0.5f));
        if (wy <= 0.0f) continue;
        for (int i = i0; i <= i1; i++) {
            float w = wy * filter_at(sp->table, sp->n_table, reach, lx - ((float)i + 0.5f));
            if (w <= 0.0f) continue;
            int id = j * rw + i;
            if (mis > 0.0f) {
                float r = sp->radius[id];
                w /= 1.0f + mis * r * r;
            }
            atomic_add_float(sp->image + 3 * id, c.x * w);
            atomic_add_float(sp->image + 3 * id + 1, c.y * w);
            atomic_add_float(sp->image + 3 * id + 2, c.z * w);
        }
    }
}

/* The merge's side of the balance heuristic against light tracing, over r^2 (VCM, Georgiev et
 * al. 2012): a light path ending at p is merged with a visible point that the camera sees
 * directly at p with density kappa pi r^2 p_E(p) relative to its connection to the camera, p_E
 * the camera's density of sampling p through one pixel in area measure (we times the cosine at
 * the surface: the inverse of the pixel's footprint on it).  merge_density: from the cosine
 * between the surface and the direction to the camera and we (camera_project), the one
 * formula both sides use; merge_factor: at p with normal ng, 0 where the camera cannot see p
 * (no connection: the merge takes it all). */
inline float merge_density(float kappa, float cos_surface, float we) {
    return kappa * PPM_PI * fabs(cos_surface) * we;
}

inline float merge_factor(__global const Camera *cam, float3 p, float3 ng, float kappa) {
    float px, py, dist, we;
    float3 wc;
    if (!camera_project(cam, p, 1e30f, &px, &py, &wc, &dist, &we)) return 0.0f;
    float f = merge_density(kappa, dot(ng, wc), we);
    return isfinite(f) ? f : 0.0f;
}

#endif
