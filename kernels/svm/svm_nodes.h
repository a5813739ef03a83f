#ifndef PPM_SVM_NODES_H
#define PPM_SVM_NODES_H
#include "shared.h"
#include "svm/svm_util.h"

/* The arithmetic of the value nodes, as Cycles evaluates them (its kernel/svm/math_util.h,
 * mix.h, util/color.h: learnt from there, written here); the operations are shared.h's
 * MATH_*, VMATH_*, MIX_* (ppm_engine/scene/shader_program.py MATH_OPS, VMATH_OPS, MIX_OPS, which
 * folds constants with the same formulas). */

inline float svm_safe_div(float a, float b) { return b != 0.0f ? a / b : 0.0f; }
inline float svm_safe_mod(float a, float b) { return b != 0.0f ? fmod(a, b) : 0.0f; }
inline float svm_safe_pow(float a, float b) {
    if (a < 0.0f && b != trunc(b)) return 0.0f;
    if (a == 0.0f && b < 0.0f) return 0.0f;
    return a < 0.0f ? ((((int)b) & 1) ? -pow(-a, b) : pow(-a, b)) : pow(a, b);
}
inline float svm_wrap(float v, float hi, float lo) {
    float r = hi - lo;
    return r != 0.0f ? v - r * floor((v - lo) / r) : lo;
}
inline float svm_smoothmin(float a, float b, float c) {
    if (c != 0.0f) {
        float h = fmax(c - fabs(a - b), 0.0f) / c;
        return fmin(a, b) - h * h * h * c * (1.0f / 6.0f);
    }
    return fmin(a, b);
}
inline float svm_pingpong(float a, float b) {
    if (b == 0.0f) return 0.0f;
    float x = (a - b) / (b * 2.0f);
    return fabs((x - floor(x)) * b * 2.0f - b);
}
inline float svm_sign(float a) { return a == 0.0f ? 0.0f : copysign(1.0f, a); }

inline float svm_math(int op, float a, float b, float c) {
    switch (op) {
    case MATH_ADD: return a + b;
    case MATH_SUBTRACT: return a - b;
    case MATH_MULTIPLY: return a * b;
    case MATH_DIVIDE: return svm_safe_div(a, b);
    case MATH_MULTIPLY_ADD: return a * b + c;
    case MATH_POWER: return svm_safe_pow(a, b);
    case MATH_LOGARITHM: return (a > 0.0f && b > 0.0f && b != 1.0f) ? log(a) / log(b) : 0.0f;
    case MATH_SQRT: return a > 0.0f ? sqrt(a) : 0.0f;
    case MATH_INVERSE_SQRT: return a > 0.0f ? 1.0f / sqrt(a) : 0.0f;
    case MATH_ABSOLUTE: return fabs(a);
    case MATH_EXPONENT: return exp(a);
    case MATH_MINIMUM: return fmin(a, b);
    case MATH_MAXIMUM: return fmax(a, b);
    case MATH_LESS_THAN: return a < b ? 1.0f : 0.0f;
    case MATH_GREATER_THAN: return a > b ? 1.0f : 0.0f;
    case MATH_SIGN: return svm_sign(a);
    case MATH_COMPARE: return (a == b || fabs(a - b) <= fmax(c, FLT_EPSILON)) ? 1.0f : 0.0f;
    case MATH_SMOOTH_MIN: return svm_smoothmin(a, b, c);
    case MATH_SMOOTH_MAX: return -svm_smoothmin(-a, -b, c);
    case MATH_ROUND: return floor(a + 0.5f);
    case MATH_FLOOR: return floor(a);
    case MATH_CEIL: return ceil(a);
    case MATH_TRUNC: return trunc(a);
    case MATH_FRACT: return a - floor(a);
    case MATH_MODULO: return svm_safe_mod(a, b);
    case MATH_FLOORED_MODULO: return b != 0.0f ? a - floor(a / b) * b : 0.0f;
    case MATH_WRAP: return svm_wrap(a, b, c);
    case MATH_SNAP: return floor(svm_safe_div(a, b)) * b;
    case MATH_PINGPONG: return svm_pingpong(a, b);
    case MATH_SINE: return sin(a);
    case MATH_COSINE: return cos(a);
    case MATH_TANGENT: return tan(a);
    case MATH_ARCSINE: return asin(clamp(a, -1.0f, 1.0f));
    case MATH_ARCCOSINE: return acos(clamp(a, -1.0f, 1.0f));
    case MATH_ARCTANGENT: return atan(a);
    case MATH_ARCTAN2: return (a == 0.0f && b == 0.0f) ? 0.0f : atan2(a, b);
    case MATH_SINH: return sinh(a);
    case MATH_COSH: return cosh(a);
    case MATH_TANH: return tanh(a);
    case MATH_RADIANS: return a * (PPM_PI / 180.0f);
    case MATH_DEGREES: return a * (180.0f / PPM_PI);
    }
    return 0.0f;
}

inline float3 svm_safe_div3(float3 a, float3 b) {
    return (float3)(svm_safe_div(a.x, b.x), svm_safe_div(a.y, b.y), svm_safe_div(a.z, b.z));
}

/* Vector Math: the vector result, *value the float one (DOT_PRODUCT, DISTANCE, LENGTH) */
inline float3 svm_vector_math(int op, float3 a, float3 b, float3 c, float s, float *value) {
    *value = 0.0f;
    switch (op) {
    case VMATH_ADD: return a + b;
    case VMATH_SUBTRACT: return a - b;
    case VMATH_MULTIPLY: return a * b;
    case VMATH_DIVIDE: return svm_safe_div3(a, b);
    case VMATH_MULTIPLY_ADD: return a * b + c;
    case VMATH_CROSS_PRODUCT: return cross(a, b);
    case VMATH_PROJECT: {
        float l = dot(b, b);
        return l != 0.0f ? b * (dot(a, b) / l) : (float3)(0.0f);
    }
    case VMATH_REFLECT: {
        float3 n = svm_safe_normalize(b);
        return a - 2.0f * dot(n, a) * n;
    }
    case VMATH_REFRACT: { /* refract a through normal b, index s */
        float3 n = svm_safe_normalize(b);
        float d = dot(n, a), k = 1.0f - s * s * (1.0f - d * d);
        return k < 0.0f ? (float3)(0.0f) : s * a - (s * d + sqrt(k)) * n;
    }
    case VMATH_FACEFORWARD: return dot(c, b) < 0.0f ? a : -a;
    case VMATH_DOT_PRODUCT: *value = dot(a, b); return (float3)(0.0f);
    case VMATH_DISTANCE: *value = distance(a, b); return (float3)(0.0f);
    case VMATH_LENGTH: *value = length(a); return (float3)(0.0f);
    case VMATH_SCALE: return a * s;
    case VMATH_NORMALIZE: return svm_safe_normalize(a);
    case VMATH_ABSOLUTE: return fabs(a);
    case VMATH_POWER:
        return (float3)(svm_safe_pow(a.x, b.x), svm_safe_pow(a.y, b.y), svm_safe_pow(a.z, b.z));
    case VMATH_SIGN: return (float3)(svm_sign(a.x), svm_sign(a.y), svm_sign(a.z));
    case VMATH_MINIMUM: return fmin(a, b);
    case VMATH_MAXIMUM: return fmax(a, b);
    case VMATH_FLOOR: return floor(a);
    case VMATH_CEIL: return ceil(a);
    case VMATH_FRACTION: return a - floor(a);
    case VMATH_MODULO:
        return (float3)(svm_safe_mod(a.x, b.x), svm_safe_mod(a.y, b.y), svm_safe_mod(a.z, b.z));
    case VMATH_WRAP:
        return (float3)(svm_wrap(a.x, b.x, c.x), svm_wrap(a.y, b.y, c.y), svm_wrap(a.z, b.z, c.z));
    case VMATH_SNAP: return floor(svm_safe_div3(a, b)) * b;
    case VMATH_SINE: return sin(a);
    case VMATH_COSINE: return cos(a);
    case VMATH_TANGENT: return tan(a);
    }
    return (float3)(0.0f);
}

/* --- colour ----------------------------------------------------------------------------- */
inline float3 rgb_to_hsv(float3 rgb) {
    float cmax = max3(rgb), cmin = fmin(rgb.x, fmin(rgb.y, rgb.z)), cdelta = cmax - cmin;
    float v = cmax, s = cmax != 0.0f ? cdelta / cmax : 0.0f, h = 0.0f;
    if (s != 0.0f) {
        float3 c = (cmax - rgb) / cdelta;
        if (rgb.x == cmax) h = c.z - c.y;
        else if (rgb.y == cmax) h = 2.0f + c.x - c.z;
        else h = 4.0f + c.y - c.x;
        h /= 6.0f;
        if (h < 0.0f) h += 1.0f;
    }
    return (float3)(h, s, v);
}
inline float3 hsv_to_rgb(float3 hsv) {
    float h = hsv.x, s = hsv.y, v = hsv.z;
    if (s == 0.0f) return (float3)(v);
    if (h == 1.0f) h = 0.0f;
    h *= 6.0f;
    float i = floor(h), f = h - i, p = v * (1.0f - s), q = v * (1.0f - s * f),
          t = v * (1.0f - s * (1.0f - f));
    int k = (int)i;
    if (k == 0) return (float3)(v, t, p);
    if (k == 1) return (float3)(q, v, p);
    if (k == 2) return (float3)(p, v, t);
    if (k == 3) return (float3)(p, q, v);
    if (k == 4) return (float3)(t, p, v);
    return (float3)(v, p, q);
}
inline float3 rgb_to_hsl(float3 rgb) {
    float cmax = max3(rgb), cmin = fmin(rgb.x, fmin(rgb.y, rgb.z));
    float l = fmin(1.0f, (cmax + cmin) / 2.0f), h = 0.0f, s = 0.0f;
    if (cmax != cmin) {
        float d = cmax - cmin;
        s = l > 0.5f ? d / (2.0f - cmax - cmin) : d / (cmax + cmin);
        if (cmax == rgb.x) h = (rgb.y - rgb.z) / d + (rgb.y < rgb.z ? 6.0f : 0.0f);
        else if (cmax == rgb.y) h = (rgb.z - rgb.x) / d + 2.0f;
        else h = (rgb.x - rgb.y) / d + 4.0f;
        h /= 6.0f;
    }
    return (float3)(h, s, l);
}
inline float3 hsl_to_rgb(float3 hsl) {
    float nr = clamp(fabs(hsl.x * 6.0f - 3.0f) - 1.0f, 0.0f, 1.0f);
    float ng = clamp(2.0f - fabs(hsl.x * 6.0f - 2.0f), 0.0f, 1.0f);
    float nb = clamp(2.0f - fabs(hsl.x * 6.0f - 4.0f), 0.0f, 1.0f);
    float chroma = (1.0f - fabs(2.0f * hsl.z - 1.0f)) * hsl.y;
    return ((float3)(nr, ng, nb) - 0.5f) * chroma + hsl.z;
}

/* the Mix node's colour blend modes (MIX_OPS), t the clamped or unclamped factor */
inline float3 svm_mix_color(int mode, float t, float3 a, float3 b) {
    float tm = 1.0f - t;
    float3 o = a;
    switch (mode) {
    case MIX_MIX: return mix(a, b, t);
    case MIX_ADD: return a + t * b;
    case MIX_MULTIPLY: return a * (tm + t * b);
    case MIX_SUBTRACT: return a - t * b;
    case MIX_SCREEN: return 1.0f - (tm + t * (1.0f - b)) * (1.0f - a);
    case MIX_DIVIDE:
        o.x = b.x != 0.0f ? tm * a.x + t * a.x / b.x : a.x;
        o.y = b.y != 0.0f ? tm * a.y + t * a.y / b.y : a.y;
        o.z = b.z != 0.0f ? tm * a.z + t * a.z / b.z : a.z;
        return o;
    case MIX_DIFFERENCE: return mix(a, fabs(a - b), t);
    case MIX_EXCLUSION: return fmax(mix(a, a + b - 2.0f * a * b, t), 0.0f);
    case MIX_DARKEN: return mix(a, fmin(a, b), t);
    case MIX_LIGHTEN: return mix(a, fmax(a, b), t);
    case MIX_OVERLAY:
        o = select(1.0f - (tm + 2.0f * t * (1.0f - b)) * (1.0f - a), a * (tm + 2.0f * t * b),
                   isless(a, (float3)(0.5f)));
        return o;
    case MIX_DODGE: {
        float3 d = 1.0f - t * b;
        float3 q = select(a / d, (float3)(1.0f), islessequal(d, (float3)(0.0f)));
        q = fmin(q, 1.0f);
        return select(q, a, isequal(a, (float3)(0.0f)));
    }
    case MIX_BURN: {
        float3 d = tm + t * b;
        float3 q = 1.0f - (1.0f - a) / d;
        q = clamp(q, 0.0f, 1.0f);
        return select(q, (float3)(0.0f), islessequal(d, (float3)(0.0f)));
    }
    case MIX_HUE: {
        float3 hb = rgb_to_hsv(b);
        if (hb.y != 0.0f) {
            float3 ha = rgb_to_hsv(a);
            ha.x = hb.x;
            return mix(a, hsv_to_rgb(ha), t);
        }
        return a;
    }
    case MIX_SATURATION: {
        float3 ha = rgb_to_hsv(a);
        if (ha.y != 0.0f) {
            float3 hb = rgb_to_hsv(b);
            ha.y = tm * ha.y + t * hb.y;
            return hsv_to_rgb(ha);
        }
        return a;
    }
    case MIX_VALUE: {
        float3 ha = rgb_to_hsv(a), hb = rgb_to_hsv(b);
        ha.z = tm * ha.z + t * hb.z;
        return hsv_to_rgb(ha);
    }
    case MIX_COLOR: {
        float3 hb = rgb_to_hsv(b);
        if (hb.y != 0.0f) {
            float3 ha = rgb_to_hsv(a);
            ha.x = hb.x;
            ha.y = hb.y;
            return mix(a, hsv_to_rgb(ha), t);
        }
        return a;
    }
    case MIX_SOFT_LIGHT: {
        float3 scr = 1.0f - (1.0f - b) * (1.0f - a);
        return tm * a + t * ((1.0f - a) * b * a + a * scr);
    }
    case MIX_LINEAR_LIGHT: return a + t * (2.0f * b + -1.0f);
    }
    return a;
}

inline float svm_smoothstep(float e0, float e1, float x) {
    if (x < e0) return 0.0f;
    if (x >= e1) return 1.0f;
    float t = (x - e0) / (e1 - e0);
    return (3.0f - 2.0f * t) * t * t;
}

/* Map Range (float): LINEAR, STEPPED, SMOOTHSTEP, SMOOTHERSTEP */
inline float svm_map_range(int type, bool clamp_result, float v, float fmin_, float fmax_,
                           float tmin, float tmax, float steps) {
    if (fmax_ == fmin_)
        return clamp_result ? (tmax > tmin ? clamp(0.0f, tmin, tmax) : clamp(0.0f, tmax, tmin))
                            : 0.0f;
    float f = 0.0f;
    {
        if (type == MAP_RANGE_LINEAR) {
            f = (v - fmin_) / (fmax_ - fmin_);
        } else if (type == MAP_RANGE_STEPPED) {
            f = (v - fmin_) / (fmax_ - fmin_);
            f = steps > 0.0f ? floor(f * (steps + 1.0f)) / steps : 0.0f;
        } else if (type == MAP_RANGE_SMOOTHSTEP) {
            f = fmin_ > fmax_ ? 1.0f - svm_smoothstep(fmax_, fmin_, v)
                              : svm_smoothstep(fmin_, fmax_, v);
        } else { /* MAP_RANGE_SMOOTHERSTEP */
            float t = fmin_ > fmax_ ? clamp((v - fmax_) / (fmin_ - fmax_), 0.0f, 1.0f)
                                    : clamp((v - fmin_) / (fmax_ - fmin_), 0.0f, 1.0f);
            t = t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
            f = fmin_ > fmax_ ? 1.0f - t : t;
        }
    }
    float r = tmin + f * (tmax - tmin);
    if (clamp_result) r = tmax > tmin ? clamp(r, tmin, tmax) : clamp(r, tmax, tmin);
    return r;
}
#endif
