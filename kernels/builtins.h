/* Inline versions of the vector builtins the kernels call most, for the OpenCL compilers that
 * call them out of line.  PoCL 3.0 (pocl-binary-distribution, LLVM 14) compiles fmax(float3,
 * float3), dot, cross, sqrt and the like into calls into its kernel library: in the BVH loop
 * every slab test made six calls (docs/BENCHMARKS.md, "The builtins inlined").  With
 * PPM_INLINE_BUILTINS defined (device/program.py: on PoCL only; a GPU driver's own builtins are
 * instructions already) the names below are macros for overloads that compile to instructions:
 * each has the OpenCL definition (fmin and fmax keep the non-NaN argument, clamp is
 * fmin(fmax(x, lo), hi), mix is a + (b - a) t, isfinite is |x| <= FLT_MAX, floor rounds down; the programs are
 * built without -cl-finite-math-only, which would fold that), and length and normalize fall back to
 * the library's scaled versions where the squared length is not a normal float.  Included first by
 * every program. */
#ifndef PPM_BUILTINS_H
#define PPM_BUILTINS_H

/* The work item's index in a one-dimensional launch of this engine: Launch (ppm_engine/render/
 * device/program.py) runs a launch of 65,536 items or more as rows of GRID_ROW items (a 2D
 * grid), so that no dimension reaches PoCL's "small grid" limit and each kernel compiles once
 * (PoCL builds a binary for grids under the limit and another for larger ones).  Every kernel
 * takes its index from here, never from get_global_id(0) alone (test_kernel_sources). */
#define WORK_ITEM() (get_global_id(1) * get_global_size(0) + get_global_id(0))

#ifdef PPM_INLINE_BUILTINS

#define PPM_OVL __attribute__((overloadable, always_inline)) inline

/* fmin, fmax: gentype (x, gentype y) and (x, float y) */
PPM_OVL float ppm_fmin(float a, float b) { return __builtin_fminf(a, b); }
PPM_OVL float ppm_fmax(float a, float b) { return __builtin_fmaxf(a, b); }
PPM_OVL float2 ppm_fmin(float2 a, float2 b) {
    return (float2)(__builtin_fminf(a.x, b.x), __builtin_fminf(a.y, b.y));
}
PPM_OVL float2 ppm_fmax(float2 a, float2 b) {
    return (float2)(__builtin_fmaxf(a.x, b.x), __builtin_fmaxf(a.y, b.y));
}
PPM_OVL float3 ppm_fmin(float3 a, float3 b) {
    return (float3)(__builtin_fminf(a.x, b.x), __builtin_fminf(a.y, b.y),
                    __builtin_fminf(a.z, b.z));
}
PPM_OVL float3 ppm_fmax(float3 a, float3 b) {
    return (float3)(__builtin_fmaxf(a.x, b.x), __builtin_fmaxf(a.y, b.y),
                    __builtin_fmaxf(a.z, b.z));
}
PPM_OVL float4 ppm_fmin(float4 a, float4 b) {
    return (float4)(__builtin_fminf(a.x, b.x), __builtin_fminf(a.y, b.y), __builtin_fminf(a.z, b.z),
                    __builtin_fminf(a.w, b.w));
}
PPM_OVL float4 ppm_fmax(float4 a, float4 b) {
    return (float4)(__builtin_fmaxf(a.x, b.x), __builtin_fmaxf(a.y, b.y), __builtin_fmaxf(a.z, b.z),
                    __builtin_fmaxf(a.w, b.w));
}
PPM_OVL float2 ppm_fmin(float2 a, float b) { return ppm_fmin(a, (float2)(b)); }
PPM_OVL float2 ppm_fmax(float2 a, float b) { return ppm_fmax(a, (float2)(b)); }
PPM_OVL float3 ppm_fmin(float3 a, float b) { return ppm_fmin(a, (float3)(b)); }
PPM_OVL float3 ppm_fmax(float3 a, float b) { return ppm_fmax(a, (float3)(b)); }
PPM_OVL float4 ppm_fmin(float4 a, float b) { return ppm_fmin(a, (float4)(b)); }
PPM_OVL float4 ppm_fmax(float4 a, float b) { return ppm_fmax(a, (float4)(b)); }

/* clamp: floats (bounds of the same type or scalars) and integers */
PPM_OVL float ppm_clamp(float x, float lo, float hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float2 ppm_clamp(float2 x, float2 lo, float2 hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float3 ppm_clamp(float3 x, float3 lo, float3 hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float4 ppm_clamp(float4 x, float4 lo, float4 hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float2 ppm_clamp(float2 x, float lo, float hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float3 ppm_clamp(float3 x, float lo, float hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL float4 ppm_clamp(float4 x, float lo, float hi) { return ppm_fmin(ppm_fmax(x, lo), hi); }
PPM_OVL int ppm_clamp(int x, int lo, int hi) { return x < lo ? lo : x > hi ? hi : x; }
PPM_OVL uint ppm_clamp(uint x, uint lo, uint hi) { return x < lo ? lo : x > hi ? hi : x; }
PPM_OVL long ppm_clamp(long x, long lo, long hi) { return x < lo ? lo : x > hi ? hi : x; }

/* mix: (gentype, gentype, gentype) and (gentype, gentype, float) */
PPM_OVL float ppm_mix(float a, float b, float t) { return a + (b - a) * t; }
PPM_OVL float2 ppm_mix(float2 a, float2 b, float2 t) { return a + (b - a) * t; }
PPM_OVL float3 ppm_mix(float3 a, float3 b, float3 t) { return a + (b - a) * t; }
PPM_OVL float4 ppm_mix(float4 a, float4 b, float4 t) { return a + (b - a) * t; }
PPM_OVL float2 ppm_mix(float2 a, float2 b, float t) { return a + (b - a) * t; }
PPM_OVL float3 ppm_mix(float3 a, float3 b, float t) { return a + (b - a) * t; }
PPM_OVL float4 ppm_mix(float4 a, float4 b, float t) { return a + (b - a) * t; }

PPM_OVL float ppm_fabs(float a) { return __builtin_fabsf(a); }
PPM_OVL float2 ppm_fabs(float2 a) { return (float2)(__builtin_fabsf(a.x), __builtin_fabsf(a.y)); }
PPM_OVL float3 ppm_fabs(float3 a) {
    return (float3)(__builtin_fabsf(a.x), __builtin_fabsf(a.y), __builtin_fabsf(a.z));
}
PPM_OVL float4 ppm_fabs(float4 a) {
    return (float4)(__builtin_fabsf(a.x), __builtin_fabsf(a.y), __builtin_fabsf(a.z),
                    __builtin_fabsf(a.w));
}

PPM_OVL float ppm_sqrt(float a) { return __builtin_sqrtf(a); }
PPM_OVL float3 ppm_sqrt(float3 a) {
    return (float3)(__builtin_sqrtf(a.x), __builtin_sqrtf(a.y), __builtin_sqrtf(a.z));
}

PPM_OVL float ppm_dot(float a, float b) { return a * b; }
PPM_OVL float ppm_dot(float2 a, float2 b) { return a.x * b.x + a.y * b.y; }
PPM_OVL float ppm_dot(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
PPM_OVL float ppm_dot(float4 a, float4 b) { return a.x * b.x + a.y * b.y + a.z * b.z + a.w * b.w; }
PPM_OVL float3 ppm_cross(float3 a, float3 b) {
    return (float3)(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

/* the squared length where it is a normal float; the library's (which scales) elsewhere */
PPM_OVL float ppm_length(float2 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? __builtin_sqrtf(d) : length(v);
}
PPM_OVL float ppm_length(float3 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? __builtin_sqrtf(d) : length(v);
}
PPM_OVL float ppm_length(float4 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? __builtin_sqrtf(d) : length(v);
}
PPM_OVL float2 ppm_normalize(float2 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? v * (1.0f / __builtin_sqrtf(d)) : normalize(v);
}
PPM_OVL float3 ppm_normalize(float3 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? v * (1.0f / __builtin_sqrtf(d)) : normalize(v);
}
PPM_OVL float4 ppm_normalize(float4 v) {
    float d = ppm_dot(v, v);
    return d >= FLT_MIN && d <= FLT_MAX ? v * (1.0f / __builtin_sqrtf(d)) : normalize(v);
}

/* floor: round towards minus infinity (one instruction on a CPU with SSE4.1; PoCL calls its
 * library: 3 % of a Noise Texture's smoke pass, from the Perlin noise's cell) */
PPM_OVL float ppm_floor(float a) { return __builtin_floorf(a); }
PPM_OVL float2 ppm_floor(float2 a) {
    return (float2)(__builtin_floorf(a.x), __builtin_floorf(a.y));
}
PPM_OVL float3 ppm_floor(float3 a) {
    return (float3)(__builtin_floorf(a.x), __builtin_floorf(a.y), __builtin_floorf(a.z));
}
PPM_OVL float4 ppm_floor(float4 a) {
    return (float4)(__builtin_floorf(a.x), __builtin_floorf(a.y), __builtin_floorf(a.z),
                    __builtin_floorf(a.w));
}

/* isfinite: a float's magnitude at most FLT_MAX (NaN compares false); the scalar is 1 or 0,
 * a vector's components -1 or 0, as OpenCL's relational functions */
PPM_OVL int ppm_isfinite(float a) { return __builtin_fabsf(a) <= FLT_MAX; }
PPM_OVL int3 ppm_isfinite(float3 a) { return ppm_fabs(a) <= (float3)(FLT_MAX); }
PPM_OVL int4 ppm_isfinite(float4 a) { return ppm_fabs(a) <= (float4)(FLT_MAX); }

/* (PoCL's own headers name its library functions by macros of these names) */
#undef fmin
#define fmin ppm_fmin
#undef fmax
#define fmax ppm_fmax
#undef clamp
#define clamp ppm_clamp
#undef mix
#define mix ppm_mix
#undef fabs
#define fabs ppm_fabs
#undef sqrt
#define sqrt ppm_sqrt
#undef dot
#define dot ppm_dot
#undef cross
#define cross ppm_cross
#undef length
#define length ppm_length
#undef normalize
#define normalize ppm_normalize
#undef isfinite
#define isfinite ppm_isfinite
#undef floor
#define floor ppm_floor

#endif

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

#endif
