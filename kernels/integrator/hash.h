#ifndef PPM_HASH_H
#define PPM_HASH_H
#include "rng.h"
#include "types.h"

/* One definition of cell and hash for build and query.
 * Cell coordinates come from floor() (never an int cast: negative coordinates), go through
 * 64-bit integers, and are hashed in unsigned 32-bit arithmetic (wrapping is defined), so grids
 * with more than 2^31 cells work: distinct cells that share an entry are told apart by the
 * distance test of the gather. */
inline long3 cell_of(float3 p, const Grid *g) {
    float3 c = (p - F3(g->bmin)) * g->inv_cell_size;
    c = clamp(c, (float3)(-1.0e15f), (float3)(1.0e15f));
    return convert_long3(floor(c));
}

inline uint cell_hash(long3 c, uint mask) {
    uint x = (uint)c.x ^ (uint)(c.x >> 32), y = (uint)c.y ^ (uint)(c.y >> 32),
         z = (uint)c.z ^ (uint)(c.z >> 32);
    return pcg_hash(x * 73856093u ^ y * 19349663u ^ z * 83492791u) & mask;
}

inline bool in_grid(float3 p, const Grid *g) {
    return g->valid > 0u && p.x >= g->bmin[0] && p.y >= g->bmin[1] && p.z >= g->bmin[2]
           && p.x <= g->bmax[0] && p.y <= g->bmax[1] && p.z <= g->bmax[2];
}

/* Entry layout: 16 bytes per entry, count and chosen photon side by side so that the build
 * and the query touch one cache line per entry:
 *   uint [4h] = n (photons hashed here), [4h+1] unused,
 *   with 64-bit atomics: ulong [2h+1] = (random key << 32) | photon index, kept by atom_max;
 *   without: uint [4h+2] = random key (atomic_max), [4h+3] = photon index (second pass). */
#define ENTRY_COUNT(table, h) (((__global uint *)(table))[4 * (h)])
#ifdef PPM_INT64_ATOMICS
#define ENTRY_INDEX(table, h) ((uint)((table)[2 * (h) + 1] & 0xffffffffUL))
#else
#define ENTRY_INDEX(table, h) (((__global const uint *)(table))[4 * (h) + 3])
#endif
#endif
