#ifndef PPM_SHADING_TABLES_H
#define PPM_SHADING_TABLES_H
#include "shared.h"
/* The shading tables in one float buffer (ppm_engine/scene/shading_tables.py builds it; its LAYOUT
 * gives each table's offset, TAB_* in shared.h, and shape): GGX albedos for the energy
 * compensation of multiple scattering (TAB_GGX_E [mu 32][rough 32], F = 1, and its
 * cosine-weighted average TAB_GGX_EAVG [rough 32]; GGX glass for ior > 1 and 1 / ior,
 * TAB_GLASS_E, TAB_GLASS_INV_E [z 16][mu 16][rough 16] and their averages [z 16][rough 16]),
 * the Fresnel albedos of the layering (TAB_SCHLICK_IOR_S: the F0..1 blend of the real
 * Fresnel's albedo, generalised Schlick with exponent < 0; TAB_SCHLICK_S: the same for
 * Schlick's exponent 5 (1 - z) / z), the sheen's LTC fit (TAB_SHEEN [3][rough 32][mu 32]: a, b
 * and albedo).  Each axis samples [0, 1] at n points, read with linear interpolation (x
 * fastest). */

#define TABLES_ARG __global const float *shading_tables

inline float table_1d(TABLES_ARG, int off, float x, int n) {
    x = clamp(x, 0.0f, 1.0f) * (float)(n - 1);
    int i = min((int)x, n - 1), j = min(i + 1, n - 1);
    float t = x - (float)i;
    return mix(shading_tables[off + i], shading_tables[off + j], t);
}
inline float table_2d(TABLES_ARG, int off, float x, float y, int nx, int ny) {
    y = clamp(y, 0.0f, 1.0f) * (float)(ny - 1);
    int i = min((int)y, ny - 1), j = min(i + 1, ny - 1);
    float t = y - (float)i;
    return mix(table_1d(shading_tables, off + nx * i, x, nx),
               table_1d(shading_tables, off + nx * j, x, nx), t);
}
inline float table_3d(TABLES_ARG, int off, float x, float y, float z, int nx, int ny, int nz) {
    z = clamp(z, 0.0f, 1.0f) * (float)(nz - 1);
    int i = min((int)z, nz - 1), j = min(i + 1, nz - 1);
    float t = z - (float)i;
    return mix(table_2d(shading_tables, off + nx * ny * i, x, y, nx, ny),
               table_2d(shading_tables, off + nx * ny * j, x, y, nx, ny), t);
}
#endif
