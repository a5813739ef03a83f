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
#endif
