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
/* uniform in [0, 1) from 32 random bits (their top 24: exact in a float) */
inline float bits_unit(uint bits) { return (float)(bits >> 8) * (1.0f / 16777216.0f); }
inline float rnd(uint *s) { return bits_unit(rng_next(s)); }

/* Low-discrepancy samples over the passes for a pixel's first path dimensions (eye paths,
 * indirect_paths.h), as Cycles' default sampler draws them: the Sobol sequence with Owen
 * scrambling by hashing (Burley, "Practical Hash-based Owen Scrambling", JCGT 2020).  The
 * dimensions come in sets of four; each set is the 4D Sobol sequence (Joe & Kuo's direction
 * numbers for its first four dimensions, SOBOL_V: every dimension's first 2^m points stratify [0,
 * 1) into 2^m equal cells, the first two dimensions are a (0, 2)-sequence, the other pairs have
 * t <= 2), its pass index shuffled and each dimension's bits scrambled with seeds hashed from
 * the pixel's key and the set: sets are independent of each other (padding), pixels of each
 * other, and every pass's sample is uniform (the estimate stays unbiased).  Over the passes a
 * pixel's samples stay stratified in every dimension and pair of its set: the share of its
 * light samples in a soft shadow, or of its paths that survive Russian roulette, follows the
 * probability closely.  It replaced Weyl sequences of square roots of primes (rotated per
 * pixel), whose error fell more slowly than 1/sqrt(N) after a few hundred passes
 * (docs/BENCHMARKS.md). */
#define LD_SETS 24          /* 12 vertices of two sets (indirect_paths.h) */
/* SOBOL_V[d - 1][i]: the direction number of bit i of the index in dimension d = 1, 2, 3, its
 * bits reversed (dimension 0, the van der Corput sequence, is the index's bits reversed): the
 * values are built and scrambled in reversed order, one reversal each instead of three
 * (tests/test_indirect.py derives the table; the formatter leaves its rows) */
/* clang-format off */
__constant uint SOBOL_V[3][32] = {
    {0x00000001u, 0x00000003u, 0x00000005u, 0x0000000fu, 0x00000011u, 0x00000033u, 0x00000055u,
     0x000000ffu, 0x00000101u, 0x00000303u, 0x00000505u, 0x00000f0fu, 0x00001111u, 0x00003333u,
     0x00005555u, 0x0000ffffu, 0x00010001u, 0x00030003u, 0x00050005u, 0x000f000fu, 0x00110011u,
     0x00330033u, 0x00550055u, 0x00ff00ffu, 0x01010101u, 0x03030303u, 0x05050505u, 0x0f0f0f0fu,
     0x11111111u, 0x33333333u, 0x55555555u, 0xffffffffu},
    {0x00000001u, 0x00000003u, 0x00000006u, 0x00000009u, 0x00000017u, 0x0000003au, 0x00000071u,
     0x000000a3u, 0x00000116u, 0x00000339u, 0x00000677u, 0x000009aau, 0x00001601u, 0x00003903u,
     0x00007706u, 0x0000aa09u, 0x00010117u, 0x0003033au, 0x00060671u, 0x000909a3u, 0x00171616u,
     0x003a3939u, 0x00717777u, 0x00a3aaaau, 0x01170001u, 0x033a0003u, 0x06710006u, 0x09a30009u,
     0x16160017u, 0x3939003au, 0x77770071u, 0xaaaa00a3u},
    {0x00000001u, 0x00000003u, 0x00000004u, 0x0000000au, 0x0000001fu, 0x0000002eu, 0x00000045u,
     0x000000c9u, 0x0000011bu, 0x000002a4u, 0x0000079au, 0x00000b67u, 0x0000101eu, 0x0000302du,
     0x00004041u, 0x0000a0c3u, 0x0001f104u, 0x0002e28au, 0x000457dfu, 0x000c9baeu, 0x0011a105u,
     0x002a7289u, 0x0079e7dbu, 0x00b6dba4u, 0x0100011au, 0x030002a7u, 0x0400079eu, 0x0a000b6du,
     0x1f001001u, 0x2e003003u, 0x45004004u, 0xc900a00au}};
/* clang-format on */
/* x's bits reversed, and Owen scrambling of x's bits by a hash on x's bits reversed (Vegdahl's
 * hash, "Building a better LK hash", 2021, in place of the Laine-Karras constants of Burley's
 * paper: it measured closer to Cycles at the Cornell box's lamp edge, docs/BENCHMARKS.md): each
 * bit of the result is flipped by a function of the seed and the bits above it, so the
 * stratification of every power-of-two prefix survives.  One body for a uint and for four
 * lanes (ld_set's four coordinates at once, which PoCL runs on the vector unit; its pass index
 * on its own, where four lanes measured 2 % slower). */
#define REVERSE_BITS(x)                                      \
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1); \
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2); \
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4); \
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8); \
    x = (x >> 16) | (x << 16)
#define OWEN_HASH(xr, seed)  \
    xr ^= xr * 0x3d20adeau;  \
    xr += seed;              \
    xr *= (seed >> 16) | 1u; \
    xr ^= xr * 0x05526c56u;  \
    xr ^= xr * 0x53a22864u
inline uint reverse_bits(uint x) {
    REVERSE_BITS(x);
    return x;
}
inline uint4 reverse_bits4(uint4 x) {
    REVERSE_BITS(x);
    return x;
}
inline uint owen_scramble_reversed(uint xr, uint seed) {
    OWEN_HASH(xr, seed);
    return reverse_bits(xr);
}
inline uint4 owen_scramble_reversed4(uint4 xr, uint4 seed) {
    OWEN_HASH(xr, seed);
    return reverse_bits4(xr);
}
/* dimensions 1-3 of the Sobol point `index`, bits reversed: bit i's direction numbers added */
inline void sobol_add_bit(uint index, int i, uint *x1, uint *x2, uint *x3) {
    uint on = 0u - ((index >> i) & 1u);
    *x1 ^= SOBOL_V[0][i] & on;
    *x2 ^= SOBOL_V[1][i] & on;
    *x3 ^= SOBOL_V[2][i] & on;
}
/* set `set` (dimensions 4 set to 4 set + 3) of pass `pass` for the pixel's key: the pass index
 * shuffled by an Owen scramble of its low 16 bits (each power-of-two run of passes stays one
 * aligned block of Sobol points; a bijection, the bits above kept: the Sobol sum runs over 16
 * bits rather than 32 for a render's first 65,536 passes), the four coordinates scrambled with
 * seeds of their own (the set's hashed seed xor a constant per use, as Cycles' sampler
 * derives them: the scramble's multiplications mix them) */
inline float4 ld_set(uint pass, uint key, uint set) {
    uint seed = pcg_hash(key ^ (set * 0x9E3779B9u));
    uint index = (owen_scramble_reversed(reverse_bits(pass), seed ^ 0x2f8b1e35u) & 0xFFFFu)
                 | (pass & ~0xFFFFu);
    /* bits 0-15 in a loop of fixed count (unrolled, no branch), the rest only past 65,536
     * passes */
    uint x1 = 0u, x2 = 0u, x3 = 0u;
    int bits = (index >> 16) != 0u ? 32 : 16;
    for (int i = 0; i < 16; i++) sobol_add_bit(index, i, &x1, &x2, &x3);
    for (int i = 16; i < bits; i++) sobol_add_bit(index, i, &x1, &x2, &x3);
    uint4 r = owen_scramble_reversed4((uint4)(index, x1, x2, x3),
                                      (uint4)(seed)
                                          ^ (uint4)(0x71c3a94du, 0xd46b0e27u, 0x9a5f62b1u,
                                                    0x0ce7d8f3u));
    return convert_float4(r >> 8) * (1.0f / 16777216.0f); /* (bits_unit's) */
}
/* set `set` of the pixel's stream (key) for pass `pass` while set < LD_SETS (ld_set), four
 * pseudo-random numbers from the generator past them */
inline float4 ld_set_or_rnd(uint pass, uint key, uint set, uint *rng) {
    if (set < LD_SETS) return ld_set(pass, key, set);
    return (float4)(rnd(rng), rnd(rng), rnd(rng), rnd(rng));
}
#endif
