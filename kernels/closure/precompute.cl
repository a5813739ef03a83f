/* The GGX tables of kernels/closure/shading_tables.h, computed with the closures' own sampling
 * code (ppm_engine/tools/make_shading_tables.py runs it; the result ships as package data).
 * Each table is an expectation over the closure's samples for a view at cos mu, as Cycles
 * defines its tables (docs/SHADING.md): the albedo eval / pdf, or the blend factor s of
 * F = mix(F0, F90, s).  One work-item per cell; a 4-D Kronecker sequence (Roberts' R4) rotated
 * per cell. */
#include "builtins.h"
#include "closure/closure.h"
#include "rng.h"
#include "shared.h"

/* the value of one sample: rough, mu, z the cell's coordinates, u four uniforms */
inline float table_sample(int kind, float rough, float mu, float z, float4 u) {
    float ior = ior_from_f0(z * z * z * z);
    Closure c;
    c.N = (float3)(0.0f, 0.0f, 1.0f);
    c.T = (float3)(1.0f, 0.0f, 0.0f);
    c.alpha_x = c.alpha_y = rough * rough;
    c.weight = (float3)(1.0f);
    c.sample_weight = 1.0f;
    c.energy_scale = 1.0f;
    c.f0 = c.refl_tint = c.trans_tint = (float3)(1.0f);
    c.f90 = (float3)(1.0f);
    c.gather = 0;
    c.glossy = 0;
    bool glass = kind >= KIND_GLASS_E && kind <= KIND_GLASS_INV_EAVG;
    c.type = glass ? CLOSURE_GGX_GLASS : CLOSURE_GGX_REFLECT;
    c.fresnel = glass ? FRESNEL_DIELECTRIC : FRESNEL_NONE;
    c.ior = kind == KIND_GLASS_INV_E || kind == KIND_GLASS_INV_EAVG ? 1.0f / ior
            : kind == KIND_SCHLICK_S ? 1.0f
                                     : (glass || kind == KIND_SCHLICK_IOR_S ? ior : 1.0f);
    float3 wi = (float3)(sqrt(fmax(0.0f, 1.0f - mu * mu)), 0.0f, mu);
    float3 eval, wo;
    float pdf, eta;
    int label = microfacet_sample(&c, c.N, wi, u.xyz, &eval, &wo, &pdf, &eta);
    if (label == LABEL_NONE || !(pdf != 0.0f)) return 0.0f;
    if (kind == KIND_SCHLICK_IOR_S || kind == KIND_SCHLICK_S) {
        /* the blend factor at this sample's half vector */
        float3 h = normalize(wi + wo);
        float cos_hi = dot(h, wi);
        if (kind == KIND_SCHLICK_S) {
            float exponent = 5.0f * ((1.0f - z) / z);
            return pow(clamp(1.0f - cos_hi, 0.0f, 1.0f), exponent);
        }
        float ct, F0 = f0_from_ior(ior);
        return clamp((fresnel_dielectric(cos_hi, ior, &ct) - F0) / (1.0f - F0), 0.0f, 1.0f);
    }
    return avg3(eval) / pdf;
}

__kernel void ggx_table(int kind, int nx, int ny, int nz, uint samples, __global float *out) {
    int id = WORK_ITEM();
    if (id >= nx * ny * nz) return;
    int x = id % nx, y = (id / nx) % ny, z = id / (nx * ny);
    float rough = nx == 1 ? 0.0f : clamp((float)x / (float)(nx - 1), 1e-4f, 1.0f);
    float mu_cell = ny == 1 ? 0.0f : clamp((float)y / (float)(ny - 1), 1e-4f, 1.0f);
    float zz = nz == 1 ? 0.0f : clamp((float)z / (float)(nz - 1), 1e-4f, 0.99f);
    bool avg = kind == KIND_GGX_EAVG || kind == KIND_GLASS_EAVG || kind == KIND_GLASS_INV_EAVG;
    /* R4: frac(k / g^j), g the root of x^5 = x + 1, in 32-bit fixed point (exact wrap) */
    const uint4 a = (uint4)(3679390609u, 3152041523u, 2700274805u, 2313257605u);
    uint h = pcg_hash((uint)id * 2654435761u + (uint)kind);
    uint4 shift = (uint4)(h, pcg_hash(h + 1u), pcg_hash(h + 2u), pcg_hash(h + 3u));
    float sum = 0.0f, comp = 0.0f;        /* Kahan */
    for (uint k = 0; k < samples; k++) {
        uint4 q = shift + k * a;
        float4 u = convert_float4(q >> 8) * (1.0f / 16777216.0f);
        float mu = avg ? fmax(u.w, 1e-4f) : mu_cell;
        float v = table_sample(kind, rough, mu, zz, u);
        if (avg) v *= 2.0f * mu;
        if (!isfinite(v)) v = 0.0f;
        float yv = v - comp, t = sum + yv;
        comp = (t - sum) - yv;
        sum = t;
    }
    out[id] = clamp(sum / (float)samples, 0.0f, 1.0f);
}
