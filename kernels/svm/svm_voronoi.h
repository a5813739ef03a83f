#ifndef PPM_SVM_VORONOI_H
#define PPM_SVM_VORONOI_H
#include "shared.h"
#include "svm/svm_noise.h"

/* Cycles' Voronoi Texture (learnt from its kernel/svm/voronoi.h, written here for OpenCL): the
 * features F1, F2, Smooth F1, Distance to Edge and N-Sphere Radius in 1 to 4 dimensions with
 * their fractal octaves.  One code for every dimension: a point is a float4 whose unused
 * components stay 0, the cell loops collapse to offset 0 on unused axes. */

typedef struct {
    float scale, detail, roughness, lacunarity, smoothness, exponent, randomness, max_distance;
    int dim, feature, metric, normalize;
} TexVoronoi;

inline float4 tex_vmask(int dim, float4 p) {
    if (dim < 4) p.w = 0.0f;
    if (dim < 3) p.z = 0.0f;
    if (dim < 2) p.y = 0.0f;
    return p;
}

/* the metric between a and b; `bound` leaves out the final root (same ordering, cheaper) */
inline float tex_vdist(const TexVoronoi *v, float4 a, float4 b, bool bound) {
    float4 d = fabs(a - b);
    switch (v->metric) {
    case VORONOI_MANHATTAN: return d.x + d.y + d.z + d.w;
    case VORONOI_CHEBYCHEV: return fmax(fmax(d.x, d.y), fmax(d.z, d.w));
    case VORONOI_MINKOWSKI: {
        float e = v->exponent, s = pow(d.x, e);
        if (v->dim >= 2) s += pow(d.y, e);
        if (v->dim >= 3) s += pow(d.z, e);
        if (v->dim >= 4) s += pow(d.w, e);
        return bound ? s : pow(s, 1.0f / e);
    }
    default: { /* VORONOI_EUCLIDEAN */ float s = dot(d, d); return bound ? s : sqrt(s);
    }
    }
}

/* the feature point of a cell, in [0, 1] per axis before randomness, and its colour */
inline float4 tex_vpoint(int dim, int4 cell) {
    if (dim == 1)
        return (float4)(tex_hashf(1, (float4)((float)cell.x, 0.0f, 0.0f, 0.0f)), 0.0f, 0.0f, 0.0f);
    return tex_pcg(dim, cell);
}

inline float3 tex_vcolor(int dim, int4 cell) {
    if (dim == 1) return tex_hashf3(1, (float4)((float)cell.x, 0.0f, 0.0f, 0.0f));
    if (dim == 2) cell.zw = (int2)(0);
    return tex_pcg(dim == 2 ? 3 : dim, cell).xyz;
}

#define VOR_LOOP(r, c)                                                                 \
    int4 R = (int4)(r, v->dim >= 2 ? r : 0, v->dim >= 3 ? r : 0, v->dim >= 4 ? r : 0); \
    for (int ow = -R.w; ow <= R.w; ow++)                                               \
        for (int oz = -R.z; oz <= R.z; oz++)                                           \
            for (int oy = -R.y; oy <= R.y; oy++)                                       \
                for (int ox = -R.x; ox <= R.x; ox++) {                                 \
                    int4 c = (int4)(ox, oy, oz, ow);

typedef struct {
    float distance;
    float3 color;
    float4 position;
} TexVorOut;

/* F1, F2 or Smooth F1 of one octave at coord */
inline TexVorOut tex_voronoi_octave(const TexVoronoi *v, float4 coord) {
    float4 cellf = floor(coord), lp = coord - cellf;
    int4 cell = convert_int4(cellf);
    TexVorOut o = {0.0f, (float3)(0.0f), (float4)(0.0f)};
    if (v->feature == VORONOI_SMOOTH_F1 && v->smoothness != 0.0f) {
        float h = -1.0f, sd = 0.0f;
        float3 sc = (float3)(0.0f);
        float4 sp = (float4)(0.0f);
        VOR_LOOP(2, off)
        float4 pt = convert_float4(off) + tex_vpoint(v->dim, cell + off) * v->randomness;
        float d = tex_vdist(v, pt, lp, false);
        if (h == -1.0f) {
            h = 1.0f;
        } else {
            float x = 0.5f + 0.5f * (sd - d) / v->smoothness;
            h = x < 0.0f ? 0.0f : x >= 1.0f ? 1.0f : (3.0f - 2.0f * x) * (x * x);
        }
        float corr = v->smoothness * h * (1.0f - h);
        sd = mix(sd, d, h) - corr;
        corr /= 1.0f + 3.0f * v->smoothness;
        sc = mix(sc, tex_vcolor(v->dim, cell + off), h) - corr;
        sp = mix(sp, pt, h) - corr;
    }
    o.distance = sd;
    o.color = sc;
    o.position = tex_vmask(v->dim, cellf + sp);
    return o;
}
bool f2 = v->feature == VORONOI_F2;
float d1 = FLT_MAX, d2 = FLT_MAX;
int4 o1 = (int4)(0), o2 = (int4)(0);
float4 p1 = (float4)(0.0f), p2 = (float4)(0.0f);
VOR_LOOP(1, off)
float4 pt = convert_float4(off) + tex_vpoint(v->dim, cell + off) * v->randomness;
float d = tex_vdist(v, pt, lp, !f2);
if (d < d1) {
    d2 = d1;
    o2 = o1;
    p2 = p1;
    d1 = d;
    o1 = off;
    p1 = pt;
} else if (f2 && d < d2) {
    d2 = d;
    o2 = off;
    p2 = pt;
}
}
if (f2) {
    d1 = d2;
    o1 = o2;
    p1 = p2;
}
o.distance = f2 ? d1 : tex_vdist(v, p1, lp, false);
o.color = tex_vcolor(v->dim, cell + o1);
o.position = p1 + cellf;
return o;
}

/* Distance to Edge of one octave */
inline float tex_voronoi_edge(const TexVoronoi *v, float4 coord) {
    float4 cellf = floor(coord), lp = coord - cellf;
    int4 cell = convert_int4(cellf);
    if (v->dim == 1) {
        float mid = tex_vpoint(1, cell).x * v->randomness;
        float left = -1.0f + tex_vpoint(1, cell - (int4)(1, 0, 0, 0)).x * v->randomness;
        float right = 1.0f + tex_vpoint(1, cell + (int4)(1, 0, 0, 0)).x * v->randomness;
        return fmin(fabs((mid + left) / 2.0f - lp.x), fabs((mid + right) / 2.0f - lp.x));
    }
    float4 closest = (float4)(0.0f);
    float best = FLT_MAX;
    VOR_LOOP(1, off)
    float4 to = convert_float4(off) + tex_vpoint(v->dim, cell + off) * v->randomness - lp;
    float d = dot(to, to);
    if (d < best) {
        best = d;
        closest = to;
    }
}
best = FLT_MAX;
{
    VOR_LOOP(1, off)
    float4 to = convert_float4(off) + tex_vpoint(v->dim, cell + off) * v->randomness - lp;
    float4 perp = to - closest;
    if (dot(perp, perp) > 0.0001f)
        best = fmin(best, dot((closest + to) / 2.0f, perp / sqrt(dot(perp, perp))));
}
}
return best;
}

/* N-Sphere Radius: half the distance from the nearest point to its own nearest point */
inline float tex_voronoi_radius(const TexVoronoi *v, float4 coord) {
    float4 cellf = floor(coord), lp = coord - cellf;
    int4 cell = convert_int4(cellf);
    float4 closest = (float4)(0.0f), next = (float4)(0.0f);
    int4 closest_off = (int4)(0);
    float best = FLT_MAX;
    VOR_LOOP(1, off)
    float4 pt = convert_float4(off) + tex_vpoint(v->dim, cell + off) * v->randomness;
    float4 d = pt - lp;
    if (dot(d, d) < best) {
        best = dot(d, d);
        closest = pt;
        closest_off = off;
    }
}
best = FLT_MAX;
{
    VOR_LOOP(1, off)
    if (ox == 0 && oy == 0 && oz == 0 && ow == 0) continue;
    int4 c = off + closest_off;
    float4 pt = convert_float4(c) + tex_vpoint(v->dim, cell + c) * v->randomness;
    float4 d = closest - pt;
    if (dot(d, d) < best) {
        best = dot(d, d);
        next = pt;
    }
}
}
float4 d = next - closest;
return sqrt(dot(d, d)) / 2.0f;
}

/* The fractal sum of F1/F2/Smooth F1 octaves (fBm-like, with lerps for the position) */
inline TexVorOut tex_voronoi_fractal(const TexVoronoi *v, float4 coord) {
    float amp = 1.0f, max_amp = 0.0f, scale = 1.0f;
    TexVorOut out = {0.0f, (float3)(0.0f), (float4)(0.0f)};
    bool zero_input = v->detail == 0.0f || v->roughness == 0.0f;
    for (int i = 0; i <= ceil(v->detail); ++i) {
        TexVorOut oc = tex_voronoi_octave(v, coord * scale);
        if (zero_input) {
            max_amp = 1.0f;
            out = oc;
            break;
        }
        if (i <= v->detail) {
            max_amp += amp;
            out.distance += oc.distance * amp;
            out.color += oc.color * amp;
            out.position = mix(out.position, oc.position / scale, amp);
            scale *= v->lacunarity;
            amp *= v->roughness;
        } else {
            float rmd = v->detail - floor(v->detail);
            if (rmd != 0.0f) {
                max_amp = mix(max_amp, max_amp + amp, rmd);
                out.distance = mix(out.distance, out.distance + oc.distance * amp, rmd);
                out.color = mix(out.color, out.color + oc.color * amp, rmd);
                out.position = mix(out.position, mix(out.position, oc.position / scale, amp), rmd);
            }
        }
    }
    if (v->normalize) {
        out.distance /= max_amp * v->max_distance;
        out.color /= max_amp;
    }
    out.position = v->scale != 0.0f ? out.position / v->scale : (float4)(0.0f);
    return out;
}

inline float tex_voronoi_edge_fractal(const TexVoronoi *v, float4 coord) {
    float amp = 1.0f, max_amp = v->max_distance, scale = 1.0f, dist = 8.0f;
    bool zero_input = v->detail == 0.0f || v->roughness == 0.0f;
    for (int i = 0; i <= ceil(v->detail); ++i) {
        float od = tex_voronoi_edge(v, coord * scale);
        if (zero_input) {
            dist = od;
            break;
        }
        if (i <= v->detail) {
            max_amp = mix(max_amp, v->max_distance / scale, amp);
            dist = mix(dist, fmin(dist, od / scale), amp);
            scale *= v->lacunarity;
            amp *= v->roughness;
        } else {
            float rmd = v->detail - floor(v->detail);
            if (rmd != 0.0f) {
                max_amp = mix(max_amp, mix(max_amp, v->max_distance / scale, amp), rmd);
                float ld = mix(dist, fmin(dist, od / scale), amp);
                dist = mix(dist, fmin(dist, ld), rmd);
            }
        }
    }
    return v->normalize ? dist / max_amp : dist;
}

/* The node: coord (x, y, z, w) unscaled; writes distance, colour, position (xyz), w, radius */
inline void tex_voronoi(TexVoronoi v, float4 coord, float *distance, float3 *color,
                        float3 *position, float *w, float *radius) {
    v.detail = clamp(v.detail, 0.0f, 15.0f);
    v.roughness = clamp(v.roughness, 0.0f, 1.0f);
    v.randomness = clamp(v.randomness, 0.0f, 1.0f);
    v.smoothness = clamp(v.smoothness / 2.0f, 0.0f, 0.5f);
    if (v.dim == 1) v.metric = 0;                    /* 1D: the distance is |a - b| */
    coord = tex_vmask(v.dim, coord * v.scale);
    *distance = 0.0f;
    *color = (float3)(0.0f);
    *position = (float3)(0.0f);
    *w = 0.0f;
    *radius = 0.0f;
    float m = 0.5f + 0.5f * v.randomness;
    if (v.feature == VORONOI_DISTANCE_TO_EDGE) {
        v.max_distance = m;
        *distance = tex_voronoi_edge_fractal(&v, coord);
    } else if (v.feature == VORONOI_N_SPHERE_RADIUS) {
        *radius = tex_voronoi_radius(&v, coord);
    } else {
        v.max_distance = tex_vdist(&v, (float4)(0.0f), tex_vmask(v.dim, (float4)(m)), false)
                         * (v.feature == VORONOI_F2 ? 2.0f : 1.0f);
        TexVorOut o = tex_voronoi_fractal(&v, coord);
        *distance = o.distance;
        *color = o.color;
        if (v.dim == 1) {
            *w = o.position.x;
        }        /* 1D: the position is W */
        else {
            *position = o.position.xyz;
            *w = o.position.w;
        }
    }
}
#endif
