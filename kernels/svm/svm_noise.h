#ifndef PPM_SVM_NOISE_H
#define PPM_SVM_NOISE_H
#include "types.h"

/* The hashes and the Perlin noise of Cycles' procedural textures (learnt from its util/hash.h,
 * kernel/svm/noise.h and fractal_noise.h; written here for OpenCL), so that a procedural texture
 * gives the very values Cycles gives.  A point of 1 to 4 dimensions is a float4 whose unused
 * components are 0; `dim` says how many are used. */

/* --- hashes ------------------------------------------------------------------------------- */

/* x rotated left by k bits, 0 < k < 32 (PoCL calls rotate() out of line) */
#define TEX_ROTL(x, k) (((x) << (k)) | ((x) >> (32u - (k))))
/* lookup3's final mix of (a, b, c), c the hash (scalars or vectors of uint alike) */
/* clang-format off */
#define TEX_LOOKUP3_FINAL(a, b, c)                     \
    c ^= b; c -= TEX_ROTL(b, 14u);                     \
    a ^= c; a -= TEX_ROTL(c, 11u);                     \
    b ^= a; b -= TEX_ROTL(a, 25u);                     \
    c ^= b; c -= TEX_ROTL(b, 16u);                     \
    a ^= c; a -= TEX_ROTL(c, 4u);                      \
    b ^= a; b -= TEX_ROTL(a, 14u);                     \
    c ^= b; c -= TEX_ROTL(b, 24u)
/* clang-format on */
/* select(a, b, m) of float8 where m is a relational result (-1 or 0 per lane), bitwise */
#define TEX_SEL8(a, b, m) as_float8((as_int8(a) & ~(m)) | (as_int8(b) & (m)))

/* Bob Jenkins' lookup3 hash of `n` (1 to 4) 32-bit keys, as Cycles' hash_uint[234] */
/* (lookup3's rounds three to a line, as Bob Jenkins writes them) */
/* clang-format off */
inline uint tex_jenkins(int n, uint4 k) {
    uint a, b, c;
    a = b = c = 0xdeadbeefu + ((uint)n << 2) + 13u;
    a += k.x;
    if (n >= 2) b += k.y;
    if (n >= 3) c += k.z;
    if (n == 4) {                                    /* lookup3's mix, then the 4th key */
        a -= c; a ^= TEX_ROTL(c, 4u);  c += b;
        b -= a; b ^= TEX_ROTL(a, 6u);  a += c;
        c -= b; c ^= TEX_ROTL(b, 8u);  b += a;
        a -= c; a ^= TEX_ROTL(c, 16u); c += b;
        b -= a; b ^= TEX_ROTL(a, 19u); a += c;
        c -= b; c ^= TEX_ROTL(b, 4u);  b += a;
        a += k.w;
    }
    TEX_LOOKUP3_FINAL(a, b, c);
    return c;
}
/* clang-format on */

/* `n` floats (their bits) hashed to [0, 1] (hash_float[234]_to_float) */
inline float tex_hashf(int n, float4 k) {
    return (float)tex_jenkins(n, as_uint4(k)) * (1.0f / 4294967296.0f);
}

/* `n` floats hashed to a colour (hash_float[234]_to_float3): below 4 dimensions the key
 * extended by 1 and by 2, in 4 its components shuffled */
inline float3 tex_hashf3(int n, float4 k) {
    if (n == 4) return (float3)(tex_hashf(4, k), tex_hashf(4, k.zxwy), tex_hashf(4, k.wzyx));
    float4 k1 = k, k2 = k;
    if (n == 1) {
        k1.y = 1.0f;
        k2.y = 2.0f;
    } else if (n == 2) {
        k1.z = 1.0f;
        k2.z = 2.0f;
    } else {
        k1.w = 1.0f;
        k2.w = 2.0f;
    }
    return (float3)(tex_hashf(n, k), tex_hashf(n + 1, k1), tex_hashf(n + 1, k2));
}

/* The PCG hashes of "Hash Functions for GPU Rendering" (JCGT 2020) in Cycles' signed variant
 * (hash_pcg[234]d_i: arithmetic shifts, the sign bit cleared), over `n` = 2, 3 or 4 ints, to
 * [0, 1] each (hash_int[234]_to_float[234]); unsigned arithmetic wraps as Cycles' ints do. */
inline float4 tex_pcg(int n, int4 key) {
    const uint m = 1664525u;
    uint4 v = as_uint4(key) * m + 1013904223u;
    for (int round = 0; round < 2; round++) {
        if (round) v ^= as_uint4(as_int4(v) >> 16);
        if (n == 2) {
            v.x += v.y * m;
            v.y += v.x * m;
        } else {
            v.x += v.y * (n == 4 ? v.w : v.z);
            v.y += v.z * v.x;
            v.z += v.x * v.y;
            if (n == 4) v.w += v.y * v.z;
        }
    }
    int4 h = as_int4(v & 0x7fffffffu);
    float4 f = convert_float4(h) * (1.0f / 2147483648.0f);
    if (n == 2) f.zw = (float2)(0.0f);
    else if (n == 3) f.w = 0.0f;
    return f;
}

/* --- Perlin noise --------------------------------------------------------------------------- */

inline float tex_fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
inline float tex_neg_if(float v, int c) { return c ? -v : v; }

inline float tex_grad(int dim, uint hash, float4 d) {
    int h = (int)hash;
    if (dim == 1) {
        h &= 15;
        return tex_neg_if(1.0f + (float)(h & 7), h & 8) * d.x;
    }
    if (dim == 2) {
        h &= 7;
        float u = h < 4 ? d.x : d.y, v = 2.0f * (h < 4 ? d.y : d.x);
        return tex_neg_if(u, h & 1) + tex_neg_if(v, h & 2);
    }
    if (dim == 3) {
        h &= 15;
        float u = h < 8 ? d.x : d.y;
        float v = h < 4 ? d.y : ((h == 12 || h == 14) ? d.x : d.z);
        return tex_neg_if(u, h & 1) + tex_neg_if(v, h & 2);
    }
    h &= 31;
    float u = h < 24 ? d.x : d.y, v = h < 16 ? d.y : d.z, s = h < 8 ? d.z : d.w;
    return tex_neg_if(u, h & 1) + tex_neg_if(v, h & 2) + tex_neg_if(s, h & 4);
}

/* The gradient at corner `o` (0 or 1 per axis) of the cell at c, seen from the point at d */
inline float tex_corner(int dim, int4 c, float4 d, int4 o) {
    return tex_grad(dim, tex_jenkins(dim, as_uint4(c + o)), d - convert_float4(o));
}

/* Perlin noise of `dim` dimensions, unscaled: the corners' gradients blended by the fade of
 * each axis, x first */
inline float tex_perlin(int dim, float4 p) {
    float4 fl = floor(p), d = p - fl;
    int4 c = convert_int4(fl);
    float4 u = (float4)(tex_fade(d.x), tex_fade(d.y), tex_fade(d.z), tex_fade(d.w));
    float v[8];
    int n = 1 << min(dim, 3);
    float r = 0.0f;
    for (int wk = 0; wk < (dim == 4 ? 2 : 1); wk++) {
        for (int k = 0; k < n; k++)
            v[k] = tex_corner(dim, c, d, (int4)(k & 1, (k >> 1) & 1, (k >> 2) & 1, wk));
        for (int k = 0; k < n / 2; k++) v[k] = mix(v[2 * k], v[2 * k + 1], u.x);
        if (dim >= 2)
            for (int k = 0; k < n / 4; k++) v[k] = mix(v[2 * k], v[2 * k + 1], u.y);
        if (dim >= 3) v[0] = mix(v[0], v[1], u.z);
        r = wk ? mix(r, v[0], u.w) : v[0];
    }
    return r;
}

/* Perlin noise of 3 dimensions, as tex_perlin(3, p) to the bit: its eight corners at once
 * (lookup3's final on eight lanes, their gradients by selects, the blends on the even and odd
 * lanes), which a CPU's vector unit runs side by side: the noise was most of the cost of a
 * smoke's density (docs/BENCHMARKS.md) */
inline float tex_perlin3(float4 p) {
    float4 fl = floor(p), d = p - fl;
    int4 c = convert_int4(fl);
    const int8 ox = (int8)(0, 1, 0, 1, 0, 1, 0, 1), oy = (int8)(0, 0, 1, 1, 0, 0, 1, 1),
               oz = (int8)(0, 0, 0, 0, 1, 1, 1, 1);
    uint8 a = (uint8)(0xdeadbeefu + (3u << 2) + 13u), b = a, h = a;
    a += as_uint8((int8)(c.x) + ox);
    b += as_uint8((int8)(c.y) + oy);
    h += as_uint8((int8)(c.z) + oz);
    TEX_LOOKUP3_FINAL(a, b, h);
    int8 k = as_int8(h) & 15;
    float8 dx = (float8)(d.x) - convert_float8(ox), dy = (float8)(d.y) - convert_float8(oy),
           dz = (float8)(d.z) - convert_float8(oz);
    float8 u = TEX_SEL8(dy, dx, k < 8);
    float8 v = TEX_SEL8(TEX_SEL8(dz, dx, (k == 12) | (k == 14)), dy, k < 4);
    float8 g = TEX_SEL8(u, -u, (k & 1) != 0) + TEX_SEL8(v, -v, (k & 2) != 0);
    float4 x = mix(g.even, g.odd, (float4)(tex_fade(d.x)));
    float2 y = mix(x.even, x.odd, (float2)(tex_fade(d.y)));
    return mix(y.x, y.y, tex_fade(d.z));
}

/* Signed noise in about [-1, 1] (snoise_[1234]d): repeated every 100000 to keep precision.
 * Not inlined: the fractal noises call it from five loops, each of which inlined its four
 * Perlin noises into every program with shader programs (a build of every feature: 19.5 ->
 * 14.7 s for the Cornell box's four programs; a density sample's time the same) */
__attribute__((noinline)) float tex_snoise(int dim, float4 p) {
    float4 corr = select((float4)(0.0f), (float4)(0.5f),
                         isgreaterequal(fabs(p), (float4)(1000000.0f)));
    /* (fmod is a loop in PoCL's library, 6 % of a Noise Texture's smoke pass: only where it
     * changes p) */
    if (any(isgreaterequal(fabs(p), (float4)(100000.0f)))) p = fmod(p, (float4)(100000.0f));
    p += corr;
    /* (each dimension its own call: a constant dim unrolls the corner loops into registers) */
    float r = dim == 1   ? tex_perlin(1, p)
              : dim == 2 ? tex_perlin(2, p)
              : dim == 3 ? tex_perlin3(p)
                         : tex_perlin(4, p);
    return r * (dim == 1 ? 0.25f : dim == 2 ? 0.6616f : dim == 3 ? 0.9820f : 0.8344f);
}

/* --- fractal noise (Cycles' fractal_noise.h); `detail` already clamped by the caller --------- */

inline float tex_fbm(int dim, float4 p, float detail, float rough, float lacun, bool normalize) {
    float fscale = 1.0f, amp = 1.0f, maxamp = 0.0f, sum = 0.0f;
    for (int i = 0; i <= (int)detail; i++) {
        sum += tex_snoise(dim, fscale * p) * amp;
        maxamp += amp;
        amp *= rough;
        fscale *= lacun;
    }
    float rmd = detail - floor(detail);
    if (rmd != 0.0f) {
        float sum2 = sum + tex_snoise(dim, fscale * p) * amp;
        return normalize ? mix(0.5f * sum / maxamp + 0.5f, 0.5f * sum2 / (maxamp + amp) + 0.5f, rmd)
                         : mix(sum, sum2, rmd);
    }
    return normalize ? 0.5f * sum / maxamp + 0.5f : sum;
}

inline float tex_multi_fractal(int dim, float4 p, float detail, float rough, float lacun) {
    float value = 1.0f, pwr = 1.0f;
    for (int i = 0; i <= (int)detail; i++) {
        value *= pwr * tex_snoise(dim, p) + 1.0f;
        pwr *= rough;
        p *= lacun;
    }
    float rmd = detail - floor(detail);
    if (rmd != 0.0f) value *= rmd * pwr * tex_snoise(dim, p) + 1.0f;
    return value;
}

inline float tex_hetero_terrain(int dim, float4 p, float detail, float rough, float lacun,
                                float offset) {
    float pwr = rough, value = offset + tex_snoise(dim, p);
    p *= lacun;
    for (int i = 1; i <= (int)detail; i++) {
        value += (tex_snoise(dim, p) + offset) * pwr * value;
        pwr *= rough;
        p *= lacun;
    }
    float rmd = detail - floor(detail);
    if (rmd != 0.0f) value += rmd * ((tex_snoise(dim, p) + offset) * pwr * value);
    return value;
}

inline float tex_hybrid_multi_fractal(int dim, float4 p, float detail, float rough, float lacun,
                                      float offset, float gain) {
    float pwr = 1.0f, value = 0.0f, weight = 1.0f;
    for (int i = 0; weight > 0.001f && i <= (int)detail; i++) {
        weight = fmin(weight, 1.0f);
        float signal = (tex_snoise(dim, p) + offset) * pwr;
        pwr *= rough;
        value += weight * signal;
        weight *= gain * signal;
        p *= lacun;
    }
    float rmd = detail - floor(detail);
    if (rmd != 0.0f && weight > 0.001f) {
        weight = fmin(weight, 1.0f);
        value += rmd * weight * ((tex_snoise(dim, p) + offset) * pwr);
    }
    return value;
}

inline float tex_ridged_multi_fractal(int dim, float4 p, float detail, float rough, float lacun,
                                      float offset, float gain) {
    float pwr = rough, signal = offset - fabs(tex_snoise(dim, p));
    signal *= signal;
    float value = signal;
    for (int i = 1; i <= (int)detail; i++) {
        p *= lacun;
        float weight = clamp(signal * gain, 0.0f, 1.0f);
        signal = offset - fabs(tex_snoise(dim, p));
        signal *= signal;
        signal *= weight;
        value += signal * pwr;
        pwr *= rough;
    }
    return value;
}

/* the Noise Texture's types (NOISE_*) */
inline float tex_noise_select(int dim, int type, float4 p, float detail, float rough, float lacun,
                              float offset, float gain, bool normalize) {
    switch (type) {
    case NOISE_MULTIFRACTAL: return tex_multi_fractal(dim, p, detail, rough, lacun);
    case NOISE_HYBRID_MULTIFRACTAL:
        return tex_hybrid_multi_fractal(dim, p, detail, rough, lacun, offset, gain);
    case NOISE_RIDGED_MULTIFRACTAL:
        return tex_ridged_multi_fractal(dim, p, detail, rough, lacun, offset, gain);
    case NOISE_HETERO_TERRAIN: return tex_hetero_terrain(dim, p, detail, rough, lacun, offset);
    default: return tex_fbm(dim, p, detail, rough, lacun, normalize);       /* NOISE_FBM */
    }
}

/* The random offset in [100, 200] per axis that seeds a distortion or a colour channel
 * (random_float[1234]_offset) */
inline float4 tex_seed_offset(int dim, float seed) {
    if (dim == 1)
        return (float4)(100.0f + tex_hashf(1, (float4)(seed, 0.0f, 0.0f, 0.0f)) * 100.0f, 0.0f,
                        0.0f, 0.0f);
    float4 o = (float4)(0.0f);
    for (int k = 0; k < dim; k++) {
        float h = 100.0f + tex_hashf(2, (float4)(seed, (float)k, 0.0f, 0.0f)) * 100.0f;
        if (k == 0) o.x = h;
        else if (k == 1) o.y = h;
        else if (k == 2) o.z = h;
        else o.w = h;
    }
    return o;
}
#endif
