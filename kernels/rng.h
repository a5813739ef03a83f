#ifndef PPM_RNG_H
#define PPM_RNG_H
/* PCG-style hash and generator (Jarzynski & Olano, "Hash Functions for GPU Rendering"). */
inline uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}
/* one independent stream per (seed, pass, work item, purpose) */
inline uint rng_seed(uint seed, uint pass, uint id, uint purpose) {
    return pcg_hash(id ^ pcg_hash(pass ^ pcg_hash(seed ^ pcg_hash(purpose))));
}
inline uint rng_next(uint *s) {
    *s = *s * 747796405u + 2891336453u;
    uint word = ((*s >> ((*s >> 28u) + 4u)) ^ *s) * 277803737u;
    return (word >> 22u) ^ word;
}
/* uniform in [0, 1) */
inline float rnd(uint *s) { return (float)(rng_next(s) >> 8) * (1.0f / 16777216.0f); }

/* Low-discrepancy samples over the passes for a pixel's first few path dimensions (eye paths,
 * indirect_paths.h): dimension d of pass n is the Weyl sequence frac(n alpha_d + r_d), alpha_d
 * the fractional part of the square root of the d-th prime (irrationals independent over the
 * rationals: no two dimensions move in step), r_d a rotation per pixel and dimension from
 * ``key`` (Cranley-Patterson: each pass's sample stays uniform, so the estimate stays unbiased).
 * The first 16 dimensions (a path's first two vertices) spread a pixel's first 16, 64 and 256
 * passes with a star discrepancy below 5 / N (independent numbers: about 6.5 / N); a few later
 * ones (alpha near a simple fraction, sqrt(101) = 10.05) spread worse than independent numbers
 * over the first passes.  Tables chosen for small continued-fraction terms measured worse at
 * equal time on the Cornell box (0.0136-0.0139 against 0.0125), so the plain order stays.
 * Over the passes a pixel's decisions are stratified instead of independent: the share of its
 * paths that survive Russian roulette, or whose light sample falls in a soft shadow, follows
 * the probability closely. */
#define LD_DIMS 96          /* 12 vertices of 8 numbers (indirect_paths.h) */
__constant uint LD_ALPHA[LD_DIMS] = {
    1779033703u, 3144134277u, 1013904242u, 2773480762u, 1359893119u, 2600822924u, 528734635u,
    1541459225u, 3418070365u, 1654270250u, 2438529370u, 355462360u, 1731405415u, 2394180231u,
    3675008525u, 1203062813u, 2925498710u, 3479995859u, 796084093u, 1830299338u, 2336478295u,
    3814765974u, 474308610u, 1863934769u, 3645816497u, 214214161u, 639484402u, 1477814206u,
    1891102055u, 2706455657u, 1157183029u, 1913507325u, 3026663070u, 3392277365u, 887149614u,
    1237834173u, 2276178418u, 3294864124u, 3963601907u, 656899949u, 1628171250u, 1948300446u,
    3523054131u, 3833017748u, 153196534u, 458427541u, 2258461506u, 4007997007u, 285697673u,
    570139515u, 1135321014u, 1974073629u, 2251313177u, 3620569459u, 134086911u, 933187903u,
    1723224488u, 1984608322u, 2763025377u, 3277294613u, 3533056595u, 503553856u, 2239462382u,
    2728129246u, 2971284200u, 3455274624u, 830669862u, 1535707435u, 2696964627u, 2927199279u,
    3385697929u, 4068602425u, 675358098u, 1345217755u, 2009711121u, 2449788317u, 3105617507u,
    3972238493u, 107307157u, 960992129u, 2016442007u, 2226015100u, 3266492245u, 3473134094u,
    4090212631u, 204290891u, 814412129u, 1621600664u, 2022545426u, 2222365506u, 2620715106u,
    3805635780u, 292386301u, 680837383u, 1453021382u, 1836792121u};
inline float ld_sample(uint pass, uint key, int d) {
    uint bits = pass * LD_ALPHA[d] + pcg_hash(key ^ ((uint)d * 0x9E3779B9u));
    return (float)(bits >> 8) * (1.0f / 16777216.0f);
}
#endif
