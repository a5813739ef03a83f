#ifndef PPM_CAMERA_H
#define PPM_CAMERA_H
#include "geom/geometry.h"

/* Cycles' camera rays exactly (ppm_engine/blender/export/camera.py): pixel (px, py) in full-frame
 * pixel units, y up from the bottom; planar clipping; thin-lens depth of field. */
inline void camera_ray(__global const Camera *cam, float px, float py, float u1, float u2,
                       float3 *o, float3 *d, float *tmax) {
    float xc = (px / (float)cam->width - 0.5f) * cam->extent[0] + cam->shift[0];
    float yc = (py / (float)cam->height - 0.5f) * cam->extent[1] + cam->shift[1];
    float3 oc, dc;
    float depth_scale;    /* planar depth per unit of t along the normalised direction */
    if (cam->type == CAMERA_ORTHO) {
        oc = (float3)(xc, yc, 0.0f);
        dc = (float3)(0.0f, 0.0f, -1.0f);
    } else {
        oc = (float3)(0.0f);
        dc = (float3)(xc, yc, -1.0f);
    }
#if PPM_DOF
    if (cam->aperture_radius > 0.0f) {
        float2 lens;
        int blades = cam->aperture_blades;
        if (blades >= 3) {
            /* regular polygon: pick a sector, sample its triangle */
            float fk = floor(u1 * (float)blades);
            float uu = u1 * (float)blades - fk;
            float a0 = cam->aperture_rotation + 2.0f * PPM_PI * fk / (float)blades;
            float a1 = a0 + 2.0f * PPM_PI / (float)blades;
            float2 b = sample_triangle(uu, u2);
            lens = b.x * (float2)(cos(a0), sin(a0)) + b.y * (float2)(cos(a1), sin(a1));
        } else {
            lens = sample_disk(u1, u2);
        }
        lens *= cam->aperture_radius;
        lens.x /= cam->aperture_ratio > 0.0f ? cam->aperture_ratio : 1.0f;
        float3 focus = oc + dc * (cam->focus_distance / -dc.z);
        oc += (float3)(lens.x, lens.y, 0.0f);
        dc = focus - oc;
    }
#endif
    float len = length(dc);
    dc /= len;
    depth_scale = -dc.z;
    float t0 = cam->clip[0] / depth_scale, t1 = cam->clip[1] / depth_scale;
    __global const float *m = cam->to_world;
    float3 ow = (float3)(m[0] * oc.x + m[1] * oc.y + m[2] * oc.z + m[3],
                         m[4] * oc.x + m[5] * oc.y + m[6] * oc.z + m[7],
                         m[8] * oc.x + m[9] * oc.y + m[10] * oc.z + m[11]);
    float3 dw = (float3)(m[0] * dc.x + m[1] * dc.y + m[2] * dc.z,
                         m[4] * dc.x + m[5] * dc.y + m[6] * dc.z,
                         m[8] * dc.x + m[9] * dc.y + m[10] * dc.z);
    *d = normalize(dw);
    *o = ow + t0 * (*d);
    *tmax = t1 - t0;
}

/* Cycles' Window texture coordinates of world point P (learnt from its camera_world_to_ndc
 * and the Texture Coordinate node): P in the camera's frame, divided by its depth for a
 * perspective camera, as a fraction of the full frame's view plane (the inverse of
 * camera_ray's raster mapping: 0..1 across the image, y up); z is 0.  A point in the
 * perspective camera's own plane (depth 0) gives 0, as Cycles' projection. */
inline float3 camera_window(__global const Camera *cam, float3 P) {
    __global const float *m = cam->to_world;
    float3 d = P - (float3)(m[3], m[7], m[11]);
    float3 pc = (float3)(m[0] * d.x + m[4] * d.y + m[8] * d.z,      /* rotation transposed */
                         m[1] * d.x + m[5] * d.y + m[9] * d.z,
                         m[2] * d.x + m[6] * d.y + m[10] * d.z);
    float2 s = pc.xy;
    if (cam->type != CAMERA_ORTHO) {
        if (pc.z == 0.0f) return (float3)(0.0f);
        s /= -pc.z;
    }
    return (float3)((s.x - cam->shift[0]) / cam->extent[0] + 0.5f,
                    (s.y - cam->shift[1]) / cam->extent[1] + 0.5f, 0.0f);
}

/* size of one pixel on the view plane at distance 1 (ortho: in scene units) */
inline float camera_pixel_size(__global const Camera *cam) {
    return cam->extent[0] / (float)cam->width;
}

/* Cycles' compact ray differential of a perspective camera ray of camera-space direction d
 * (on the plane z = -1): the mean change of the normalised direction over one pixel in x and
 * one in y (the pinhole's: depth of field ignored) */
inline float camera_dD(__global const Camera *cam, float3 d) {
    float ex = cam->extent[0] / (float)cam->width, ey = cam->extent[1] / (float)cam->height;
    float3 n = normalize(d);
    return 0.5f
           * (length(normalize(d + (float3)(ex, 0.0f, 0.0f)) - n)
              + length(normalize(d + (float3)(0.0f, ey, 0.0f)) - n));
}

/* (dP, dD) of the camera ray through pixel position (px, py), as Cycles makes it (from the
 * pinhole, depth of field or not): the footprint's radius at distance t along the ray from its
 * origin (and along the whole path after it: Cycles' bounces keep dD) is dP + t dD.
 * Perspective: dP = dD x the origin's distance from the camera (the ray starts on the near
 * clipping plane); orthographic: one pixel's width (Cycles' dP: its x step for both axes),
 * dD = 0. */
inline float2 camera_differential(__global const Camera *cam, float px, float py) {
    if (cam->type == CAMERA_ORTHO) return (float2)(camera_pixel_size(cam), 0.0f);
    float xc = (px / (float)cam->width - 0.5f) * cam->extent[0] + cam->shift[0];
    float yc = (py / (float)cam->height - 0.5f) * cam->extent[1] + cam->shift[1];
    float3 d = (float3)(xc, yc, -1.0f);
    float dD = camera_dD(cam, d);
    return (float2)(cam->clip[0] * length(d) * dD, dD);
}

/* The footprint's radius a camera ray would have at world position P (the photons': measured
 * straight from the camera position; behind the camera, the centre pixel's) */
inline float camera_footprint_at(__global const Camera *cam, float3 P) {
    if (cam->type == CAMERA_ORTHO) return camera_pixel_size(cam);
    __global const float *m = cam->to_world;
    float3 q = P - (float3)(m[3], m[7], m[11]);
    float3 c = (float3)(m[0] * q.x + m[4] * q.y + m[8] * q.z, m[1] * q.x + m[5] * q.y + m[9] * q.z,
                        m[2] * q.x + m[6] * q.y + m[10] * q.z);
    float dist = length(q);
    if (!(c.z < 0.0f)) return dist * camera_pixel_size(cam);
    return dist * camera_dD(cam, c / -c.z);
}
#endif
