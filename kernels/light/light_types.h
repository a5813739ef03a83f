#ifndef PPM_LIGHT_TYPES_H
#define PPM_LIGHT_TYPES_H
#include "geom/geometry.h"
#include "scene.h"

/* Each emitter type in one place: how camera and specular rays see it (*_seen), its sample for
 * next-event estimation (*_direct) and its photon emission (*_emit).  Which types a program
 * compiles is decided once, in the dispatchers (direct_light.h, photon_emission.h), by the
 * 0/1 feature flags of shared.h; the compiler drops the functions no dispatcher reaches.
 * Emissive triangles are light_mesh.h's, the world world.h's. */

/* A sample toward an emitter for next-event estimation: the contribution is
 * beta x (f cos) x E / pmf, E = the radiance arriving along wi over the density of wi (for a
 * point or a sun without size, its irradiance on a surface facing it). */
typedef struct {
    float3 wi;               /* unit direction from the shading point's offset origin */
    float3 E;
    float dist; /* shadow ray length: ends just short of the emitter (PPM_INF: none) */
    float pdf_dir; /* solid-angle density of wi (MIS against the BSDF sample); 0 for
                                emitters no ray can hit (points, suns) */
} LightSample;

/* --- sun: a disc of angular diameter L->radius in direction -L->direction ------------------- */
inline void sun_direct(const Light *L, float u1, float u2, LightSample *s) {
    float3 to_sun = -F3(L->direction);
    if (L->radius > 0.0f) {
        float sh = sin(0.5f * L->radius), ch = cos(0.5f * L->radius);
        s->wi = sample_cone(to_sun, 2.0f * sh * sh, u1, u2); /* 1 - cos r, stably */
        /* disc radiance E/(pi sin^2 r) times the cone's solid angle 2 pi (1 - cos r):
         * 4 sin^2(r/2) / sin^2 r = 1 / cos^2(r/2) */
        s->E = F3(L->emit) / (ch * ch);
    } else {
        s->wi = to_sun;
        s->E = F3(L->emit);
    }
}

/* a ray that escapes the scene along d sees the sun's disc (half-angle L->radius > 0) with the
 * radiance sun_direct samples, E / (pi sin^2 r); a sun without size is seen by no ray */
inline float3 sun_seen(const Light *L, float3 d) {
    float r = L->radius;
    if (!(r > 0.0f) || dot(d, -F3(L->direction)) < cos(r)) return (float3)(0.0f);
    float sr = sin(r);
    return F3(L->emit) / (PPM_PI * sr * sr);
}

/* photons from a disc of the scene's bounding radius R around its centre c, facing the sun */
inline void sun_emit(const Light *L, float3 c, float R, float pmf, float u1, float u2, float u3,
                     float u4, float3 *o, float3 *d, float3 *flux) {
    float3 dir = F3(L->direction);
    float sh = sin(0.5f * L->radius);
    *d = L->radius > 0.0f ? sample_cone(dir, 2.0f * sh * sh, u3, u4) : dir;
    float2 q = sample_disk(u1, u2) * R;
    float3 t, b;
    make_frame(dir, &t, &b);
    *o = c - R * dir + q.x * t + q.y * b;
    *flux = F3(L->emit) * (PPM_PI * R * R / pmf);
}

/* --- point and spot lights: a sphere of L->radius (0: a point) -------------------------------- */
/* Cycles' spot cone: smoothstep over cos(theta), theta measured in the light's scaled frame. */
inline float spot_attenuation(const Light *L, float3 dir_from_light) {
    float3 ax = F3(L->axis_x), ay = F3(L->axis_y);
    float sx = dot(ax, ax), sy = dot(ay, ay);
    float3 loc = (float3)(sx > 0.0f ? dot(dir_from_light, ax) / sx : 0.0f,
                          sy > 0.0f ? dot(dir_from_light, ay) / sy : 0.0f,
                          dot(dir_from_light, F3(L->direction)) * L->spot_scale_z);
    float len = length(loc);
    float c = len > 0.0f ? loc.z / len : -1.0f;
    if (c <= L->spot_cos_half) return 0.0f;
    if (L->spot_smooth <= 0.0f) return 1.0f;
    float t = clamp((c - L->spot_cos_half) / L->spot_smooth, 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

/* a spot whose frame is uniformly scaled has a round cone we can sample directly */
inline float spot_sample_cos(const Light *L) {
    float sx = length(F3(L->axis_x)) * L->spot_scale_z,
          sy = length(F3(L->axis_y)) * L->spot_scale_z;
    return (fabs(sx - 1.0f) < 1e-4f && fabs(sy - 1.0f) < 1e-4f) ? L->spot_cos_half : -1.0f;
}

/* A point light with a radius met along o + t d, 0 < t < tmax: *t, its radiance *Le and the
 * density point_direct gives the direction (*pdf, the emitter's pick not included); false when
 * the ray misses it.  Soft falloff (Blender's default): Cycles sees the light as a disk of the
 * light's radius facing the ray's origin, not as a sphere (d^2 / (d^2 + r^2) of the sphere's
 * solid angle: -8 % for a light 1 m from a mirror at r = 0.3 m).  Spot lights are never seen.
 * Lights do not block rays: the caller sums every light the ray meets (lights_seen). */
inline bool point_seen(const Light *l, float3 o, float3 d, float tmax, float *t, float3 *Le,
                       float *pdf) {
    if (l->type != LIGHT_POINT || !(l->radius > 0.0f)) return false;
    float3 c = F3(l->position);
    float r2 = l->radius * l->radius;
    if (l->flags & LIGHT_FLAG_SOFT_FALLOFF) {
        float3 nl = o - c;
        float dl = length(nl);
        if (!(dl > 0.0f)) return false;
        nl /= dl; /* (a disk at any distance, from within the radius too, as Cycles') */
        float denom = dot(d, nl);
        if (denom >= 0.0f) return false;
        float th = dot(c - o, nl) / denom;
        if (!(th > 0.0f && th < tmax)) return false;
        float3 q = o + th * d - c;
        if (dot(q, q) > r2) return false;
        *t = th;
        *Le = F3(l->emit) / (PPM_PI * r2);
        *pdf = th * th / (-denom * PPM_PI * r2); /* point_direct's disk */
    } else {
        float3 oc = o - c;
        float b = dot(oc, d), cc = dot(oc, oc) - r2;
        float disc = b * b - cc;
        if (disc < 0.0f || cc < 0.0f) return false; /* missed, or starts inside */
        float th = -b - sqrt(disc);
        if (!(th > 0.0f && th < tmax)) return false;
        *t = th;
        *Le = F3(l->emit) / (PPM_PI * r2);
        float x = r2 / (cc + r2); /* sin^2 of the cone */
        *pdf = (1.0f + sqrt(fmax(0.0f, 1.0f - x))) / (2.0f * PPM_PI * x); /* 1 / (2 pi (1 - cos)) */
    }
    return true;
}

inline bool point_direct(const Light *L, float3 o, float u1, float u2, LightSample *s) {
    float3 to = F3(L->position) - o;
    float d2 = dot(to, to), d = sqrt(d2);
    if (!(d > 0.0f)) return false;
    float3 w0 = to / d;
    float3 I = F3(L->emit);
    if (L->type == LIGHT_SPOT) I *= spot_attenuation(L, -w0);
    float r = L->radius;
    if (r > 0.0f && (L->flags & LIGHT_FLAG_SOFT_FALLOFF)) {
        /* Cycles' soft falloff: a disk of radius r facing p, radiance I/(pi r^2), at any
         * distance (a surface within the radius: I cos / (d^2 + r^2) on the axis, where the
         * point's I / d^2 made a lamp 5 mm under a ceiling at r = 1 cm light it 2.6 x) */
        float3 t, b;
        make_frame(w0, &t, &b);
        float2 q = sample_disk(u1, u2) * r;
        float3 tq = to + q.x * t + q.y * b;
        float dq2 = dot(tq, tq);
        s->dist = sqrt(dq2);
        s->wi = tq / s->dist;
        float cos_d = dot(s->wi, w0);
        s->E = I * (cos_d / dq2);
        s->pdf_dir = cos_d > 0.0f ? dq2 / (cos_d * PPM_PI * r * r) : 0.0f;
    } else if (r > 0.0f && d > r) {
        /* sphere of radius r, radiance I/(pi r^2): sample its cone of directions */
        /* 1 - cos = x / (1 + sqrt(1 - x)), x = sin^2 = r^2/d^2: no cancellation */
        float x = r * r / d2, root = sqrt(fmax(0.0f, 1.0f - x));
        s->wi = sample_cone(w0, x / (1.0f + root), u1, u2);
        float bb = dot(s->wi, to);
        s->dist = bb - sqrt(fmax(0.0f, bb * bb - (d2 - r * r)));
        s->E = I * (2.0f / (d2 * (1.0f + root))); /* I 2 pi (1 - cos) / (pi r^2) */
        s->pdf_dir = (1.0f + root) / (2.0f * PPM_PI * x);
    } else {
        s->wi = w0;
        s->dist = d;
        s->E = I / d2;
    }
    return true;
}

inline void point_emit(const Light *L, float pmf, float u1, float u2, float u3, float u4,
                       float scale, float3 *o, float3 *d, float3 *flux) {
    float3 I = F3(L->emit);
    if (L->type == LIGHT_SPOT) {
        float cm = spot_sample_cos(L);
        *d = sample_cone(F3(L->direction), 1.0f - cm, u3, u4);
        *flux = I * (spot_attenuation(L, *d) * 2.0f * PPM_PI * (1.0f - cm) / pmf);
    } else {
        *d = sample_uniform_sphere(u3, u4);
        *flux = I * (4.0f * PPM_PI / pmf);
    }
    *o = F3(L->position);
    if (L->radius > 0.0f && L->type == LIGHT_POINT) {
        /* sphere light: uniform point, cosine-weighted direction; same total power */
        float3 ns = sample_uniform_sphere(u1, u2);
        *d = sample_cosine_hemisphere(ns, u3, u4);
        *o = offset_ray(F3(L->position) + L->radius * ns, ns, scale);
    }
}

/* --- area lights: a rectangle or an ellipse emitting along -Z (L->direction) --------------- */
inline float area_light_area(const Light *L) {
    float a = length(cross(F3(L->axis_x), F3(L->axis_y)));
    return L->type == LIGHT_AREA_ELLIPSE ? a * (PPM_PI / 4.0f) : a;
}

inline float3 area_light_point(const Light *L, float u1, float u2) {
    float2 q;
    if (L->type == LIGHT_AREA_ELLIPSE) q = sample_disk(u1, u2) * 0.5f;
    else q = (float2)(u1 - 0.5f, u2 - 0.5f);
    return F3(L->position) + q.x * F3(L->axis_x) + q.y * F3(L->axis_y);
}

/* An area light met along o + t d, 0 < t < tmax (point_seen's terms); seen from the front only
 * (as Cycles shows area lights) */
inline bool area_seen(const Light *l, float3 o, float3 d, float tmax, float *t, float3 *Le,
                      float *pdf) {
    float3 c = F3(l->position), nl = F3(l->direction);
    float denom = dot(d, nl);
    if (denom >= 0.0f) return false; /* emits along its -Z only */
    float th = dot(c - o, nl) / denom;
    if (!(th > 0.0f && th < tmax)) return false;
    float3 q = o + th * d - c;
    float3 ax = F3(l->axis_x), ay = F3(l->axis_y);
    float u = dot(q, ax) / dot(ax, ax), v = dot(q, ay) / dot(ay, ay);
    bool inside = l->type == LIGHT_AREA_RECT ? (fabs(u) <= 0.5f && fabs(v) <= 0.5f)
                                             : (u * u + v * v <= 0.25f);
    if (!inside) return false;
    *t = th;
    *Le = F3(l->emit);
    *pdf = th * th / (-denom * area_light_area(l)); /* area_direct's density */
    return true;
}

inline bool area_direct(const Light *L, float3 o, float u1, float u2, float scale, LightSample *s) {
    float3 nl = F3(L->direction);
    float3 q = offset_ray(area_light_point(L, u1, u2), nl, scale); /* in front of it */
    float3 tq = q - o;
    float dq2 = dot(tq, tq);
    s->dist = sqrt(dq2);
    if (!(s->dist > 0.0f)) return false;
    s->wi = tq / s->dist;
    float cos_l = -dot(s->wi, nl);
    if (cos_l <= 0.0f) return false;
    s->E = F3(L->emit) * (cos_l * area_light_area(L) / dq2);
    s->pdf_dir = dq2 / (cos_l * area_light_area(L));
    return true;
}

inline void area_emit(const Light *L, float pmf, float u1, float u2, float u3, float u4,
                      float scale, float3 *o, float3 *d, float3 *flux) {
    float3 q = area_light_point(L, u1, u2);
    float3 nl = F3(L->direction);
    *d = sample_cosine_hemisphere(nl, u3, u4);
    *o = offset_ray(q, nl, scale);
    *flux = F3(L->emit) * (PPM_PI * area_light_area(L) / pmf);
}
#endif
