#ifndef PPM_SHADING_TABLES_H
#define PPM_SHADING_TABLES_H
/* The shading tables in one float buffer (ppm_engine/shading_tables.py builds it and states
 * the same layout; tests/test_closures.py checks the two agree): GGX albedos for the energy
 * compensation of multiple scattering, the Fresnel albedos of the layering, the sheen's LTC
 * fit.  Each axis samples [0, 1] at n points, read with linear interpolation (x fastest). */
#define TAB_GGX_E 0                   /* [mu 32][rough 32]: albedo of GGX, F = 1 */
#define TAB_GGX_EAVG 1024             /* [rough 32]: its cosine-weighted average */
#define TAB_GLASS_E 1056              /* [z 16][mu 16][rough 16]: GGX glass, ior > 1 */
#define TAB_GLASS_EAVG 5152           /* [z 16][rough 16] */
#define TAB_GLASS_INV_E 5408          /* [z 16][mu 16][rough 16]: GGX glass, 1 / ior */
#define TAB_GLASS_INV_EAVG 9504       /* [z 16][rough 16] */
#define TAB_SCHLICK_IOR_S 9760        /* [z 16][mu 16][rough 16]: F0..1 blend of the real
                                         Fresnel's albedo (generalised Schlick, exponent < 0) */
#define TAB_SCHLICK_S 13856           /* [z 16][mu 16][rough 16]: the same for Schlick's
                                         exponent 5 (1 - z) / z */
#define TAB_SHEEN 17952               /* [3][rough 32][mu 32]: sheen LTC a, b and albedo */
#define TAB_SIZE 21024

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
