#ifndef PPM_LIGHTS_H
#define PPM_LIGHTS_H
#include "bvh.h"
#include "bsdf.h"
#include "textures.h"

/* Everything a kernel needs to see the scene: BVH, shading normals, materials, emitters,
 * textures and UVs. */
#define SCENE_ARGS BVH_ARGS, __global const float *normals, __global const Material *materials, \
    __global const Light *lights, __global const float *emitter_cdf, __global const int *emissive, \
    __global const EmitterInfo *emitter_info, TEXTURE_ARGS
#define SCENE_PASS BVH_PASS, normals, materials, lights, emitter_cdf, emissive, emitter_info, \
    textures, texels, uvs
#define TEXTURE_PASS textures, texels, uvs

/* Emitter chosen in proportion to its power (cdf built by ppm_engine/emitters.py). */
inline int pick_emitter(__global const float *cdf, int n, float u, float *pmf) {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
        int mid = (lo + hi) >> 1;
        if (u < cdf[mid]) hi = mid; else lo = mid + 1;
    }
    *pmf = cdf[lo] - (lo > 0 ? cdf[lo - 1] : 0.0f);
    return lo;
}

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
    float sx = length(F3(L->axis_x)) * L->spot_scale_z, sy = length(F3(L->axis_y)) * L->spot_scale_z;
    return (fabs(sx - 1.0f) < 1e-4f && fabs(sy - 1.0f) < 1e-4f) ? L->spot_cos_half : -1.0f;
}

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

/* Radiance of the scene lights seen directly along o + t d, t < tmax (camera rays and their
 * specular chains; Cycles shows area lights from the front and point lights as spheres).
 * Lights do not block rays: only the nearest one in front of the surface hit counts.
 * ray_type: VIS_CAMERA, VIS_GLOSSY or VIS_TRANSMISSION; lights hidden from it are skipped. */
inline float3 lights_seen(float3 o, float3 d, float tmax, __global const Light *lights,
                          int n_lights, uint ray_type) {
    float3 L = (float3)(0.0f);
    float best = tmax;
    for (int i = 0; i < n_lights; i++) {
        Light l = lights[i];
        if (l.flags & (ray_type << LIGHT_HIDDEN_SHIFT)) continue;
        float3 c = F3(l.position);
        if (false) {}
#ifdef PPM_LIGHT_AREA
        else if (l.type == LIGHT_AREA_RECT || l.type == LIGHT_AREA_ELLIPSE) {
            float3 nl = F3(l.direction);
            float denom = dot(d, nl);
            if (denom >= 0.0f) continue;                      /* emits along its -Z only */
            float t = dot(c - o, nl) / denom;
            if (!(t > 0.0f && t < best)) continue;
            float3 q = o + t * d - c;
            float3 ax = F3(l.axis_x), ay = F3(l.axis_y);
            float u = dot(q, ax) / dot(ax, ax), v = dot(q, ay) / dot(ay, ay);
            bool inside = l.type == LIGHT_AREA_RECT ? (fabs(u) <= 0.5f && fabs(v) <= 0.5f)
                                                    : (u * u + v * v <= 0.25f);
            if (inside) { best = t; L = F3(l.emit); }
        }
#endif
#ifdef PPM_LIGHT_POINT
        else if (l.type == LIGHT_POINT && l.radius > 0.0f && (l.flags & LIGHT_FLAG_SOFT_FALLOFF)) {
            /* soft falloff (Blender's default): Cycles sees the light as a disk of the light's
             * radius facing the ray's origin, not as a sphere (d^2 / (d^2 + r^2) of the sphere's
             * solid angle: -8 % for a light 1 m from a mirror at r = 0.3 m) */
            float3 nl = o - c;
            float dl = length(nl);
            if (!(dl > l.radius)) continue;                   /* starts inside */
            nl /= dl;
            float denom = dot(d, nl);
            if (denom >= 0.0f) continue;
            float t = dot(c - o, nl) / denom;
            if (!(t > 0.0f && t < best)) continue;
            float3 q = o + t * d - c;
            if (dot(q, q) > l.radius * l.radius) continue;
            best = t;
            L = F3(l.emit) / (PPM_PI * l.radius * l.radius);
        } else if (l.type == LIGHT_POINT && l.radius > 0.0f) {
            float3 oc = o - c;
            float b = dot(oc, d), cc = dot(oc, oc) - l.radius * l.radius;
            float disc = b * b - cc;
            if (disc < 0.0f || cc < 0.0f) continue;           /* missed, or starts inside */
            float t = -b - sqrt(disc);
            if (!(t > 0.0f && t < best)) continue;
            best = t;
            L = F3(l.emit) / (PPM_PI * l.radius * l.radius);
        }
#endif
    }
    return L;
}

/* The probability of picking emissive BVH leaf k as the emitter (0 when it is not one):
 * emissive[] holds the emissive leaves in ascending order (ppm_engine/emitters.py). */
inline float emissive_leaf_pmf(int leaf, SCENE_ARGS) {
    int n_lights = emitter_info->n_lights;
    int lo = 0, hi = emitter_info->n_emissive - 1;
    while (lo <= hi) {
        int mid = (lo + hi) >> 1, v = emissive[mid];
        if (v == leaf) {
            int e = n_lights + mid;
            return emitter_cdf[e] - (e > 0 ? emitter_cdf[e - 1] : 0.0f);
        }
        if (v < leaf) lo = mid + 1; else hi = mid - 1;
    }
    return 0.0f;
}

/* --- emissive triangles seen under a large solid angle: sampled by solid angle ----------------
 * Area sampling gives a sample at distance d the weight d^2 / cos: next to a large emitter (a
 * ceiling 1 cm above a lamp, a filament's glass) that weight varies by orders of magnitude.
 * Arvo's (1995) sampling of the spherical triangle is uniform in solid angle instead; it is used
 * when the triangle subtends more than SPHERICAL_MIN_SOLID_ANGLE (area sampling is as good
 * below and keeps full precision for far, small triangles).  The choice depends only on the
 * point and the triangle, so sample_direct and direct_bsdf (its MIS pdf) always agree. */
#define SPHERICAL_MIN_SOLID_ANGLE 0.02f

/* angle between unit vectors, accurate near 0 and pi */
inline float angle_between(float3 u, float3 v) {
    return dot(u, v) < 0.0f ? PPM_PI - 2.0f * asin(fmin(length(u + v) * 0.5f, 1.0f))
                            : 2.0f * asin(fmin(length(v - u) * 0.5f, 1.0f));
}

typedef struct {
    float3 a, b, c;          /* unit directions to the corners */
    float alpha;             /* the spherical triangle's angle at a */
    float area;              /* its solid angle; 0: use area sampling */
} SphTri;

inline SphTri spherical_triangle(float3 o, float3 p0, float3 p1, float3 p2) {
    SphTri t;
    t.area = 0.0f;
    t.a = normalize(p0 - o); t.b = normalize(p1 - o); t.c = normalize(p2 - o);
    float3 n_ab = cross(t.a, t.b), n_bc = cross(t.b, t.c), n_ca = cross(t.c, t.a);
    float l_ab = length(n_ab), l_bc = length(n_bc), l_ca = length(n_ca);
    if (!(l_ab > 1e-7f && l_bc > 1e-7f && l_ca > 1e-7f)) return t;
    n_ab /= l_ab; n_bc /= l_bc; n_ca /= l_ca;
    t.alpha = angle_between(n_ab, -n_ca);
    float A = t.alpha + angle_between(n_bc, -n_ab) + angle_between(n_ca, -n_bc) - PPM_PI;
    t.area = (A > SPHERICAL_MIN_SOLID_ANGLE && A < 2.0f * PPM_PI && isfinite(A)) ? A : 0.0f;
    return t;
}

/* a direction uniform over the spherical triangle t (t.area > 0), Arvo 1995 */
inline float3 sample_spherical_triangle(const SphTri *t, float u0, float u1) {
    float x = u0 * t->area;                          /* solid angle of the sub-triangle */
    float ca = cos(t->alpha), sa = sin(t->alpha);
    /* phi = Ap_pi - alpha with Ap_pi = pi + x: sin and cos of pi + x - alpha */
    float sin_phi = -sin(x) * ca + cos(x) * sa;
    float cos_phi = -cos(x) * ca - sin(x) * sa;
    float k1 = cos_phi + ca, k2 = sin_phi - sa * dot(t->a, t->b);
    float cos_bp = (k2 + (k2 * cos_phi - k1 * sin_phi) * ca) / ((k2 * sin_phi + k1 * cos_phi) * sa);
    cos_bp = isfinite(cos_bp) ? clamp(cos_bp, -1.0f, 1.0f) : 1.0f;
    float sin_bp = sqrt(fmax(0.0f, 1.0f - cos_bp * cos_bp));
    float3 ca_perp = t->c - dot(t->c, t->a) * t->a;
    float3 cp = cos_bp * t->a + sin_bp * normalize(ca_perp);
    float cos_t = 1.0f - u1 * (1.0f - dot(cp, t->b));
    float sin_t = sqrt(fmax(0.0f, 1.0f - cos_t * cos_t));
    float3 cb_perp = cp - dot(cp, t->b) * t->b;
    float lb = length(cb_perp);
    return normalize(cos_t * t->b + (lb > 0.0f ? sin_t / lb : 0.0f) * cb_perp);
}

/* power heuristic weight of strategy a against b */
inline float mis_power(float a, float b) {
    float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

/* Next-event estimation at a diffuse point p (shading normal n and geometric normal ngf both on
 * the side the light must come from).  Returns E with the pixel contribution = beta * f * E,
 * f the Lambert BSDF; one emitter sample, shadow ray through the BVH.  With mis, an emissive
 * triangle's sample is weighted against the BSDF sample of direct_bsdf (power heuristic). */
inline float3 sample_direct(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng, bool mis) {
    EmitterInfo info = *emitter_info;
    if (info.n_emitters == 0) return (float3)(0.0f);
    float pmf;
    int e = pick_emitter(emitter_cdf, info.n_emitters, rnd(rng), &pmf);
    if (!(pmf > 0.0f)) return (float3)(0.0f);
    float u1 = rnd(rng), u2 = rnd(rng);
    /* All geometry from the shadow ray's own origin: a direction computed from p but traced
     * from the offset origin would meet a planar emitter's own plane early at grazing angles
     * (the offset over cos) and the light would shadow itself. */
    float3 o = offset_ray(p, ngf);
    float3 wi, E;
    float dist = PPM_INF;
    bool cosine_included = false;
    float pdf_light = 0.0f;          /* solid-angle pdf of an emissive triangle's sample */
    if (e < info.n_lights) {
        Light L = lights[e];
        if (false) {}
#ifdef PPM_LIGHT_SUN
        else if (L.type == LIGHT_SUN) {
            float3 to_sun = -F3(L.direction);
            if (L.radius > 0.0f) {
                float sh = sin(0.5f * L.radius), ch = cos(0.5f * L.radius);
                wi = sample_cone(to_sun, 2.0f * sh * sh, u1, u2);     /* 1 - cos r, stably */
                /* disc radiance E/(pi sin^2 r) times the cone's solid angle 2 pi (1 - cos r):
                 * 4 sin^2(r/2) / sin^2 r = 1 / cos^2(r/2) */
                E = F3(L.emit) / (ch * ch);
            } else {
                wi = to_sun;
                E = F3(L.emit);
            }
        }
#endif
#ifdef PPM_LIGHT_POINT
        else if (L.type == LIGHT_POINT || L.type == LIGHT_SPOT) {
            float3 to = F3(L.position) - o;
            float d2 = dot(to, to), d = sqrt(d2);
            if (!(d > 0.0f)) return (float3)(0.0f);
            float3 w0 = to / d;
            float3 I = F3(L.emit);
            if (L.type == LIGHT_SPOT) I *= spot_attenuation(&L, -w0);
            float r = L.radius;
            if (r > 0.0f && d > r && (L.flags & LIGHT_FLAG_SOFT_FALLOFF)) {
                /* Cycles' soft falloff: a disk of radius r facing p, radiance I/(pi r^2) */
                float3 t, b;
                make_frame(w0, &t, &b);
                float2 q = sample_disk(u1, u2) * r;
                float3 tq = to + q.x * t + q.y * b;
                float dq2 = dot(tq, tq);
                dist = sqrt(dq2);
                wi = tq / dist;
                E = I * (dot(wi, w0) / dq2);
            } else if (r > 0.0f && d > r) {
                /* sphere of radius r, radiance I/(pi r^2): sample its cone of directions */
                /* 1 - cos = x / (1 + sqrt(1 - x)), x = sin^2 = r^2/d^2: no cancellation */
                float x = r * r / d2, root = sqrt(fmax(0.0f, 1.0f - x));
                wi = sample_cone(w0, x / (1.0f + root), u1, u2);
                float bb = dot(wi, to);
                dist = bb - sqrt(fmax(0.0f, bb * bb - (d2 - r * r)));
                E = I * (2.0f / (d2 * (1.0f + root)));   /* I 2 pi (1 - cos) / (pi r^2) */
            } else {
                wi = w0;
                dist = d;
                E = I / d2;
            }
        }
#endif
#ifdef PPM_LIGHT_AREA
        else if (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE) {
            float3 nl = F3(L.direction);
            float3 q = offset_ray(area_light_point(&L, u1, u2), nl);   /* in front of it */
            float3 tq = q - o;
            float dq2 = dot(tq, tq);
            dist = sqrt(dq2);
            if (!(dist > 0.0f)) return (float3)(0.0f);
            wi = tq / dist;
            float cos_l = -dot(wi, nl);
            if (cos_l <= 0.0f) return (float3)(0.0f);
            E = F3(L.emit) * (cos_l * area_light_area(&L) / dq2);
        }
#endif
        else return (float3)(0.0f);
    }
#ifdef PPM_EMISSIVE
    else if (e < info.n_lights + info.n_emissive) {
        int k = emissive[e - info.n_lights];
        float4 v0 = tri_v0[k], e1 = tri_e1[k], e2 = tri_e2[k];
        float3 c = cross(e1.xyz, e2.xyz);
        float area2 = length(c);
        if (!(area2 > 0.0f)) return (float3)(0.0f);
        float3 nt = c / area2;
        __global const Material *me = materials + as_int(e2.w);
        SphTri st = spherical_triangle(o, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz);
        float2 b;
        float3 q;
        if (st.area > 0.0f) {              /* uniform in solid angle: weight = solid angle */
            wi = sample_spherical_triangle(&st, u1, u2);
            float denom = dot(wi, nt);
            float t = dot(v0.xyz - o, nt) / denom;
            if (!(t > 0.0f && isfinite(t))) return (float3)(0.0f);
            q = o + t * wi;
            /* barycentrics of q for the emission texture */
            float3 dq = q - v0.xyz;
            float d00 = dot(e1.xyz, e1.xyz), d01 = dot(e1.xyz, e2.xyz), d11 = dot(e2.xyz, e2.xyz);
            float d20 = dot(dq, e1.xyz), d21 = dot(dq, e2.xyz), den = d00 * d11 - d01 * d01;
            b = (float2)((d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den);
            E = st.area;
            pdf_light = pmf / st.area;
        } else {                           /* uniform in area: weight = cos area / d^2 */
            b = sample_triangle(u1, u2);
            q = v0.xyz + b.x * e1.xyz + b.y * e2.xyz;
        }
        q = offset_ray(q, dot(o - q, nt) >= 0.0f ? nt : -nt);    /* on our side of it */
        float3 tq = q - o;
        float dq2 = dot(tq, tq);
        dist = st.area > 0.0f ? dot(tq, wi) : sqrt(dq2);   /* along wi: short of the emitter */
        if (!(dist > 0.0f)) return (float3)(0.0f);
        if (!(st.area > 0.0f)) {          /* (solid angle: wi stays the sampled direction,
                                              q only ends the shadow ray) */
            wi = tq / dist;
            float cos_l = fabs(dot(wi, nt));                      /* mesh lights: both sides */
            E = cos_l * 0.5f * area2 / dq2;
            pdf_light = cos_l > 0.0f ? pmf * dq2 / (cos_l * 0.5f * area2) : 0.0f;
        }
        E = E * F3(me->emission)
            * texture_tint(me->emission_tex, as_uint(v0.w), b.x, b.y, TEXTURE_PASS);
    }
#endif
#ifdef PPM_WORLD
    else if (info.has_world) {
        wi = sample_cosine_hemisphere(n, u1, u2);       /* pdf cos/pi: f L cos/pdf = f L pi */
        E = F3(info.world) * PPM_PI;
        cosine_included = true;
    }
#endif
    else return (float3)(0.0f);
    float cos_s = dot(wi, n);
    if (cos_s <= 0.0f || dot(wi, ngf) <= 0.0f) return (float3)(0.0f);
    /* planar emitters: the ray ends just in front of the emitter, so it never reaches it */
    Hit h = bvh_intersect(o, wi, dist, VIS_SHADOW, true, BVH_PASS);
    if (h.leaf >= 0) return (float3)(0.0f);
    float w = mis && pdf_light > 0.0f ? mis_power(pdf_light, cos_s * (1.0f / PPM_PI)) : 1.0f;
    return E * (w * (cosine_included ? 1.0f : cos_s) / pmf);
}

/* The BSDF half of direct light at a diffuse point: one cosine-distributed ray; when it meets
 * an emissive triangle first, its emission weighted against sample_direct's pdf for it (power
 * heuristic).  Near a large emitter (a ceiling 1 cm above a lamp, a filament inside its
 * bulb) next-event estimation alone has unbounded variance (1/d^2); the BSDF sample covers
 * it.  Returns E as sample_direct does (pixel contribution = beta * f * E). */
inline float3 direct_bsdf(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng) {
    float u1 = rnd(rng), u2 = rnd(rng);
#ifndef PPM_EMISSIVE
    return (float3)(0.0f);           /* no emissive triangle: nothing for this sample to find */
#else
    if (emitter_info->n_emissive == 0) return (float3)(0.0f);
    float3 wi = sample_cosine_hemisphere(n, u1, u2);
    float cos_s = dot(wi, n);
    if (cos_s <= 0.0f || dot(wi, ngf) <= 0.0f) return (float3)(0.0f);
    float3 o = offset_ray(p, ngf);
    /* a diffuse bounce's ray (it must find emitters that cast no shadow, which next-event
     * estimation samples too) */
    Hit h = bvh_intersect(o, wi, PPM_INF, VIS_DIFFUSE, false, BVH_PASS);
    if (h.leaf < 0) return (float3)(0.0f);
    float4 e1 = tri_e1[h.leaf], e2 = tri_e2[h.leaf];
    __global const Material *m = materials + as_int(e2.w);
    if (!(m->flags & MAT_EMISSIVE)) return (float3)(0.0f);
    float pmf = emissive_leaf_pmf(h.leaf, SCENE_PASS);
    float3 c = cross(e1.xyz, e2.xyz);
    float area2 = length(c);
    float cos_l = area2 > 0.0f ? fabs(dot(wi, c)) / area2 : 0.0f;
    if (!(pmf > 0.0f && cos_l > 0.0f)) return (float3)(0.0f);   /* NEE never picks it: 0 power */
    /* the pdf of the strategy sample_direct uses for this triangle from this origin */
    float4 v0 = tri_v0[h.leaf];
    SphTri st = spherical_triangle(o, v0.xyz, v0.xyz + e1.xyz, v0.xyz + e2.xyz);
    float pdf_light = st.area > 0.0f ? pmf / st.area : pmf * h.t * h.t / (cos_l * 0.5f * area2);
    /* f Le cos / pdf_bsdf = (rho/pi) Le pi: in E units (times f) that is Le pi */
    return F3(m->emission)
        * texture_tint(m->emission_tex, as_uint(v0.w), h.u, h.v, TEXTURE_PASS)
        * (PPM_PI * mis_power(cos_s * (1.0f / PPM_PI), pdf_light));
#endif
}

/* Direct light at a diffuse point: next-event estimation and the BSDF sample, combined. */
inline float3 direct_lighting(float3 p, float3 n, float3 ngf, SCENE_ARGS, uint *rng) {
    return sample_direct(p, n, ngf, SCENE_PASS, rng, true) + direct_bsdf(p, n, ngf, SCENE_PASS, rng);
}

/* Emit one photon: origin, direction and flux (already divided by all sampling pdfs). */
inline bool emit_photon(SCENE_ARGS, uint *rng, float3 *o, float3 *d, float3 *flux) {
    EmitterInfo info = *emitter_info;
    if (info.n_emitters == 0) return false;
    float pmf;
    int e = pick_emitter(emitter_cdf, info.n_emitters, rnd(rng), &pmf);
    if (!(pmf > 0.0f)) return false;
    float u1 = rnd(rng), u2 = rnd(rng), u3 = rnd(rng), u4 = rnd(rng);
    float3 c = F3(info.scene_center);
    float R = info.scene_radius;
    if (e < info.n_lights) {
        Light L = lights[e];
        if (false) {}
#ifdef PPM_LIGHT_SUN
        else if (L.type == LIGHT_SUN) {
            float3 dir = F3(L.direction);
            float sh = sin(0.5f * L.radius);
            *d = L.radius > 0.0f ? sample_cone(dir, 2.0f * sh * sh, u3, u4) : dir;
            float2 q = sample_disk(u1, u2) * R;
            float3 t, b;
            make_frame(dir, &t, &b);
            *o = c - R * dir + q.x * t + q.y * b;
            *flux = F3(L.emit) * (PPM_PI * R * R / pmf);
        }
#endif
#ifdef PPM_LIGHT_POINT
        else if (L.type == LIGHT_POINT || L.type == LIGHT_SPOT) {
            float3 I = F3(L.emit);
            if (L.type == LIGHT_SPOT) {
                float cm = spot_sample_cos(&L);
                *d = sample_cone(F3(L.direction), 1.0f - cm, u3, u4);
                *flux = I * (spot_attenuation(&L, *d) * 2.0f * PPM_PI * (1.0f - cm) / pmf);
            } else {
                *d = sample_uniform_sphere(u3, u4);
                *flux = I * (4.0f * PPM_PI / pmf);
            }
            *o = F3(L.position);
            if (L.radius > 0.0f && L.type == LIGHT_POINT) {
                /* sphere light: uniform point, cosine-weighted direction; same total power */
                float3 ns = sample_uniform_sphere(u1, u2);
                *d = sample_cosine_hemisphere(ns, u3, u4);
                *o = offset_ray(F3(L.position) + L.radius * ns, ns);
            }
        }
#endif
#ifdef PPM_LIGHT_AREA
        else if (L.type == LIGHT_AREA_RECT || L.type == LIGHT_AREA_ELLIPSE) {
            float3 q = area_light_point(&L, u1, u2);
            float3 nl = F3(L.direction);
            *d = sample_cosine_hemisphere(nl, u3, u4);
            *o = offset_ray(q, nl);
            *flux = F3(L.emit) * (PPM_PI * area_light_area(&L) / pmf);
        }
#endif
        else return false;
    }
#ifdef PPM_EMISSIVE
    else if (e < info.n_lights + info.n_emissive) {
        int k = emissive[e - info.n_lights];
        float4 v0 = tri_v0[k], e1 = tri_e1[k], e2 = tri_e2[k];
        float2 b = sample_triangle(u1, u2);
        float3 q = v0.xyz + b.x * e1.xyz + b.y * e2.xyz;
        float3 cr = cross(e1.xyz, e2.xyz);
        float area2 = length(cr);
        if (!(area2 > 0.0f)) return false;
        float3 nt = cr / area2;
        /* both sides, each with probability 1/2 */
        float side = u3 < 0.5f ? 1.0f : -1.0f;
        float uu = u3 < 0.5f ? 2.0f * u3 : 2.0f * u3 - 1.0f;
        nt *= side;
        *d = sample_cosine_hemisphere(nt, uu, u4);
        *o = offset_ray(q, nt);
        __global const Material *me = materials + as_int(e2.w);
        *flux = F3(me->emission)
                * texture_tint(me->emission_tex, as_uint(v0.w), b.x, b.y, TEXTURE_PASS)
                * (2.0f * PPM_PI * 0.5f * area2 / pmf);
    }
#endif
#ifdef PPM_WORLD
    else if (info.has_world) {
        float3 dir = sample_uniform_sphere(u3, u4);
        float2 q = sample_disk(u1, u2) * R;
        float3 t, b;
        make_frame(dir, &t, &b);
        *d = dir;
        *o = c - R * dir + q.x * t + q.y * b;
        *flux = F3(info.world) * (4.0f * PPM_PI * PPM_PI * R * R / pmf);
    }
#endif
    else return false;
    return max3(*flux) > 0.0f && isfinite(max3(*flux));
}
#endif
