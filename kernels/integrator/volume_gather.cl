/* The volume photons' gather along the camera's segments in media (PPM_VOLUME; docs/VOLUMES.md):
 * the beam radiance estimate (Jarosz, Zwicker & Jensen 2008).  A photon of this pass's radius r
 * counts for a segment o + s d (0 <= s < t, the eye pass's: eye_pass.cl) that passes within r
 * of it, its flux times the phase function between the photon's direction and the camera's,
 * times the transmittance from its projection on the segment back to the segment's start, over
 * pi r^2; times the camera path's weight at the start, into this pass's photon splats
 * (film.lt_pass, which the film divides by the photons emitted, as the light tracing's).
 *
 * The volume photons are in a stochastic spatial hash of cells of 2 r (passes/volume.py): the
 * segment walks the cells it crosses (a 3D DDA), and from each cell R reads the cells within r
 * of its piece of the segment (R and its neighbours).  A photon counts only from its own cell
 * and from the cell R its projection on the segment lies in, so it is counted once: the entry's
 * photon stands for the entry's n photons (flux x n) as in the surfaces' gather (gather.cl),
 * an unbiased estimate of the sum over them.  Most cells of a segment hold no photon near it:
 * a bit per block of 4^3 cells (VOLUME_BLOCK_SHIFT; hashed into VOLUME_MARK_BITS bits), set
 * by every photon within r of the block (volume_mark), lets the walk skip them with one read. */
#include "builtins.h"
#include "scene.h"
#include "integrator/hash.h"
#include "geom/geometry.h"
#include "geom/medium.h"
#include "shared.h"
#if PPM_SVM /* (heterogeneous media; passes/volume.py builds without it where there are none) */
#include "geom/medium_field.h"
#endif
#include "integrator/path_state.h"
#include "integrator/pass_state.h"
#include "shared.h"

/* the most cells a segment walks (a longer one is cut there) */
#define VOLUME_WALK_MAX 4096
/* a block of the marks: 2^VOLUME_BLOCK_SHIFT cells per axis (the marks' bits: VOLUME_MARK_BITS,
 * passes/volume.py) */
#define VOLUME_BLOCK_SHIFT 2

/* whether the block of cell `cell` is marked */
inline bool volume_marked(__global const uint *marks, long3 cell) {
    uint b = cell_hash(cell >> VOLUME_BLOCK_SHIFT, (uint)(VOLUME_MARK_BITS - 1));
    return (marks[b >> 5] & (1u << (b & 31u))) != 0u;
}

/* Each stored volume photon (ph_pos, the first min(stored, capacity)) sets the bits of the blocks
 * its box of half side r overlaps (marks: VOLUME_MARK_BITS bits, cleared before). */
__kernel void volume_mark(__global const float4 *ph_pos, __global const uint *counters,
                          uint capacity, __global const Grid *grid, float radius,
                          __global uint *marks) {
    uint i = WORK_ITEM();
    if (i >= min(counters[CNT_VSTORED], capacity)) return;
    Grid g = *grid;
    float3 p = ph_pos[i].xyz;
    long3 lo = cell_of(p - radius, &g) >> VOLUME_BLOCK_SHIFT;
    long3 hi = cell_of(p + radius, &g) >> VOLUME_BLOCK_SHIFT;
    for (long z = lo.z; z <= hi.z; z++)
        for (long y = lo.y; y <= hi.y; y++)
            for (long x = lo.x; x <= hi.x; x++) {
                uint b = cell_hash((long3)(x, y, z), (uint)(VOLUME_MARK_BITS - 1));
                atomic_or(&marks[b >> 5], 1u << (b & 31u));
            }
}

/* the checkpoints of a heterogeneous segment's transmittance (beam_tr) */
#define BEAM_TABLE 16

/* a segment as its gather reads it */
typedef struct {
    float3 o, d;
    float4 medium; /* its extinction coefficient, its phase function's anisotropy */
    uint e;        /* the camera path's state (path_state.h) */
    float r;       /* the photons' radius */
    int field;     /* its medium where that is a field (geom/medium_field.h), else -1 */
    float step;    /* the field's checkpoints: every step from the start, their transmittance */
    float3 tab[BEAM_TABLE + 1];
    uint seed;
} Beam;

/* The transmittance from the segment's start to s: a homogeneous medium's closed form; in a
 * field, one ratio-tracking estimate over the segment read at the checkpoint below s (the
 * segment's, beam_segment) times another from there to s (numbers from the photon's index k):
 * unbiased, about one density evaluation per photon. */
inline float3 beam_tr(const Scene *scene, const Beam *bm, float s, uint k) {
#if PPM_SVM
    if (bm->field < 0) return medium_tr(bm->medium.xyz, s);
    int j = clamp((int)(s / bm->step), 0, BEAM_TABLE);
    float sj = (float)j * bm->step;
    float3 T = bm->tab[j];
    uint rng = pcg_hash(k ^ bm->seed);
    Mix x = mix_extinction(scene, bm->field, bm->medium.xyz);
    medium_ratio(scene, &x, bm->o + sj * bm->d, bm->d, s - sj, ratio_rate(BEAM_TABLE * bm->step),
                 &rng, &T);
    return T;
#else
    return medium_tr(bm->medium.xyz, s);
#endif
}

/* The photons of the cells around cell c (within r of the piece s.x <= s < s.y of the segment
 * o + s d) whose projection lies in that piece: the sum of n x flux x phase x transmittance */
inline float3 beam_cell(const Scene *scene, const Photons *photons, const Grid *g,
                        __global const ulong *table, uint mask, const Beam *bm, float2 s, long3 c,
                        __global const LightPaths *lp, uint *used) {
    float3 o = bm->o, d = bm->d, pa = o + s.x * d, pb = o + s.y * d, acc = (float3)(0.0f);
    float r = bm->r;
    long3 lo = max(cell_of(fmin(pa, pb) - r, g), c - (long)1);
    long3 hi = min(cell_of(fmax(pa, pb) + r, g), c + (long)1);
    for (long cz = lo.z; cz <= hi.z; cz++)
        for (long cy = lo.y; cy <= hi.y; cy++)
            for (long cx = lo.x; cx <= hi.x; cx++) {
                long3 nc = (long3)(cx, cy, cz);
                uint h = cell_hash(nc, mask);
                uint cnt = ENTRY_COUNT(table, h);
                if (cnt == 0u) continue;
                uint pi = ENTRY_INDEX(table, h);
                float3 w = photons->vpos[pi].xyz - o;
                float sp = dot(w, d);
                if (!(sp >= s.x && sp < s.y)) continue; /* another piece's */
                float3 x = w - sp * d;
                if (dot(x, x) > r * r) continue;
                long3 pc = cell_of(photons->vpos[pi].xyz, g);
                if (pc.x != nc.x || pc.y != nc.y || pc.z != nc.z) continue; /* not this cell's */
                if (!path_join_medium(bm->e, photons->vpath[pi], lp)) continue;
                float4 pf = photons->vflux[pi];
                float ph = hg_phase(dot(d, unpack_unit(as_uint(pf.w))), bm->medium.w);
                acc += (float)cnt * ph * pf.xyz * beam_tr(scene, bm, sp, pi);
                *used += cnt;
            }
    return acc;
}

/* One segment: (o, t), (d, its media's field or -1), (the camera path's weight, its state), (the
 * media's extinction but the field's, their anisotropy) (eye_pass.cl) */
inline float3 beam_segment(const Scene *scene, const Photons *photons, const Grid *g,
                           __global const ulong *table, uint mask, float r,
                           __global const float4 *v, __global const uint *marks, uint *used) {
    float4 a = v[0], b = v[1], c = v[2];
    float3 o = a.xyz, d = b.xyz;
    Beam bm;
    bm.o = o;
    bm.d = d;
    bm.medium = v[3];
    bm.e = as_uint(c.w);
    bm.r = r;
#if PPM_SVM
    bm.field = as_int(b.w);
#else
    bm.field = -1;
#endif
    /* the segment inside the grid's box */
    float3 inv = 1.0f / select(d, (float3)(1e-30f), isequal(d, (float3)(0.0f)));
    float3 t0 = (F3(g->bmin) - o) * inv, t1 = (F3(g->bmax) - o) * inv;
    float3 tn = fmin(t0, t1), tf = fmax(t0, t1);
    float s0 = fmax(0.0f, fmax(tn.x, fmax(tn.y, tn.z)));
    float s1 = fmin(a.w, fmin(tf.x, fmin(tf.y, tf.z)));
    if (!(s1 > s0)) return (float3)(0.0f);
#if PPM_SVM
    if (bm.field >= 0) { /* a field: its transmittance at the checkpoints, one ratio tracking */
        bm.step = s1 / BEAM_TABLE;
        bm.seed = ray_hash(o, d);
        uint rng = pcg_hash(bm.seed);
        bm.tab[0] = (float3)(1.0f);
        Mix x = mix_extinction(scene, bm.field, bm.medium.xyz);
        for (int j = 1; j <= BEAM_TABLE; j++) {
            bm.tab[j] = bm.tab[j - 1];
            medium_ratio(scene, &x, o + (float)(j - 1) * bm.step * d, d, bm.step, ratio_rate(s1),
                         &rng, &bm.tab[j]);
        }
    }
#endif
    /* the walk (Amanatides & Woo): the cell, the distances to its next boundary per axis */
    long3 cell = cell_of(o + s0 * d, g);
    long3 step = (long3)(d.x > 0.0f ? 1 : -1, d.y > 0.0f ? 1 : -1, d.z > 0.0f ? 1 : -1);
    float3 cf = convert_float3(cell) + select((float3)(0.0f), (float3)(1.0f), d > 0.0f);
    float3 next = (F3(g->bmin) + cf * g->cell_size - o) * inv;
    next = select(next, (float3)(INFINITY), isequal(d, (float3)(0.0f)));
    float3 delta = fabs(g->cell_size * inv);
    float3 acc = (float3)(0.0f);
    float sa = s0;
    for (int k = 0; k < VOLUME_WALK_MAX; k++) {
        float sb = fmin(fmin(next.x, fmin(next.y, next.z)), s1);
        if (volume_marked(marks, cell))
            acc += beam_cell(scene, photons, g, table, mask, &bm, (float2)(sa, sb), cell,
                             scene->light_paths, used);
        if (sb >= s1) break;
        if (next.x <= next.y && next.x <= next.z) {
            cell.x += step.x;
            next.x += delta.x;
        } else if (next.y <= next.z) {
            cell.y += step.y;
            next.y += delta.y;
        } else {
            cell.z += step.z;
            next.z += delta.z;
        }
        sa = sb;
    }
    return c.xyz * acc;
}

/* Per pixel (n), its segments (VOLUME_SEGMENTS at most, the first of length 0 ends them)
 * against the volume photons' table (radius r this pass), added to film.lt_pass. */
__kernel void
volume_gather(SCENE_PARAMS FILM_PARAMS VP_PARAMS PHOTON_PARAMS __global const ulong *table,
              uint table_mask, float radius, __global const uint *marks, uint n,
              __global uint *counters) {
    SCENE_LOAD(scene);
    FILM_LOAD(film);
    VP_LOAD(vps);
    PHOTON_LOAD(photons);
    uint id = WORK_ITEM();
    if (id >= n || !film->active[id]) return;
    Grid g = *photons->vgrid;
    if (g.valid == 0u || !(radius > 0.0f)) return;
    float3 sum = (float3)(0.0f);
    uint used = 0u;
    for (int k = 0; k < VOLUME_SEGMENTS; k++) {
        __global const float4 *v = vps->segments + 4 * (VOLUME_SEGMENTS * id + k);
        if (!(v[0].w > 0.0f)) break;
        sum += beam_segment(scene, photons, &g, table, table_mask, radius, v, marks, &used);
    }
    sum *= 1.0f / (PPM_PI * radius * radius);
    if (max3(sum) > 0.0f && isfinite(sum.x) && isfinite(sum.y) && isfinite(sum.z))
        vstore3(vload3(id, film->lt_pass) + sum, id, film->lt_pass);
    if (used) atomic_add(&counters[CNT_USED], used);
}
