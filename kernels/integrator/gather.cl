/* Gather: each visible point visits every cell its gather disc overlaps (up to 5 per axis with
 * the default cell = r_max / 2; passes/hash_build.py CELL_SCALE), one photon fetch per cell.
 * The entry's photon stands for all n photons of the entry (flux x n) and is accepted only
 * in its own cell: two cells that share an entry are then never counted twice, and the
 * estimate is unbiased (each photon of the entry is chosen with probability 1/n and counted
 * only from its own cell, within the radius).  Each photon's flux is weighted by the visible
 * point's BSDF for the photon's incoming direction: the point's closures are set up again here
 * from its hit (kernels/closure/shader.h), so a visible point is 64 bytes (passes/eye.py). */
#include "builtins.h"
#include "integrator/hash.h"
#include "closure/shader.h"
#include "geom/bvh.h"
#include "integrator/pass_state.h"

/* photons on a surface facing another way (thin walls, corners) are not this point's */
/* the gather region is a disc, not a ball: photons farther than this x r from the visible
 * point's tangent plane are not its own (a floor under a closed box would otherwise gather the
 * photons on the box's inner bottom face; a table top those under it).  The density estimate
 * over pi r^2 is unchanged on a plane; on a curved surface only r > curvature radius / 2
 * loses photons. */
/* guard for absurd radius/cell ratios (the grid setup keeps cell >= r_max / 2: <= 5^3) */

/* The cells the gather disc can touch: the disc's own bounding box (half extent along axis k
 * r sqrt(1 - n_k^2) + t |n_k|, t the half thickness), not the sphere's.  On a floor with cells
 * of r_max / 2 that is 5 x 5 x 2 cells instead of 5^3. */
inline void disc_cells(float3 x, float3 n, float r, const Grid *g, long3 *lo, long3 *hi) {
    float3 an = fabs(n);
    float3 h = fmin((float3)(r),
                    r * sqrt(fmax(1.0f - an * an, 0.0f)) + (DISC_HALF_THICKNESS * r) * an);
    *lo = cell_of(x - h, g);
    *hi = min(cell_of(x + h, g), *lo + (long)(MAX_CELLS_PER_AXIS - 1));
}

/* squared distance from x to cell c's box (0 inside), the box grown by a margin that covers
 * the rounding of cell_of (so a cell is only ever skipped when the disc surely misses it) */
inline float cell_dist2(float3 x, long3 c, const Grid *g) {
    float3 b0 = F3(g->bmin) + convert_float3(c) * g->cell_size;
    float3 margin = 1e-3f * g->cell_size + 5e-7f * (fabs(x) + fabs(F3(g->bmin)));
    float3 dd = fmax(fmax(b0 - x, x - (b0 + g->cell_size)) - margin, (float3)(0.0f));
    return dot(dd, dd);
}

/* A visible point's shading for the gather: its closures, and whether they are all Lambert
 * (then f is one constant, lambert_f).  A point whose f is not one constant sets its closures
 * up at its first photon (gather_shade): most points of a pass meet none where photons carry
 * only caustics, and setting them up was half of the gather's time (a row of rough glass
 * cubes before a textured wall, 192 x 64: the gather 4.1 -> 2.2 ms, the pass 19.9 -> 18.1
 * ms; the same image bit for bit). */
typedef struct {
#if PPM_GATHER_SHADE
    ShaderData sd;
    float4 shade;       /* the hit (VP_BUFFERS shade) and the footprint to set it up from */
    float foot_r;
    bool shaded;        /* sd set up */
#endif
    float3 nrm;
    uint path;          /* the ray that reached the point (path_state.h) */
    float3 beta;        /* its path weight (with the albedo / pi of a Lambert point) */
    __global const LightPaths *lp;
    float limit;        /* Clamp Indirect's limit on a sample's r + g + b (0: none) */
    float3 lambert_f;
    bool lambert;
    bool transmits;
} GatherPoint;

inline void gather_point(const Scene *scene, const VisiblePoints *vps, uint id, GatherPoint *gp) {
    float4 vp = vps->pos[id], nrm = vps->nrm[id], shade = vps->shade[id], beta = vps->beta[id];
    float foot_r = SVM_FOOTPRINT ? beta.w : 0.0f;
    gp->nrm = nrm.xyz;
    gp->path = as_uint(nrm.w);
    gp->beta = beta.xyz;
    gp->lp = scene->light_paths;
    gp->limit = gp->lp->clamp_indirect;
    gp->transmits = vp.w > 1.5f;
    gp->lambert = true;
    gp->lambert_f = (float3)(1.0f);
#if PPM_GATHER_SHADE
    gp->shaded = true;
    if (as_int(shade.z) < 0)
        return;             /* f = 1: a Lambert point's f is in its path weight (eye_pass.cl) */
    gp->shade = shade;
    gp->foot_r = foot_r;
    gp->shaded = false;     /* not a Lambert point (eye_pass.cl): set up at its first photon */
    gp->lambert = false;
#endif
}

/* The point's closures from its hit, once (gather_point); whether they are all Lambert and
 * their f then */
inline void gather_shade(const Scene *scene, GatherPoint *gp) {
#if PPM_GATHER_SHADE
    if (gp->shaded) return;
    gp->shaded = true;
    Hit h;
    h.leaf = as_int(gp->shade.z);
    h.u = gp->shade.x;
    h.v = gp->shade.y;
    h.t = 0.0f;
    Surface s = surface_at(scene, h);
    shader_setup(scene, &gp->sd, &s, h.u, h.v, gp->path, 0.0f, unpack_unit(as_uint(gp->shade.w)),
                 footprint_at(scene, s.tri, h.leaf, h.u, h.v, gp->foot_r));
    gp->lambert = true;
    gp->lambert_f = (float3)(0.0f);
    for (int k = 0; k < gp->sd.n; k++) {
        const Closure *c = &gp->sd.c[k];
        if (!c->gather) continue;
        gp->lambert &= closure_lambert(&gp->sd, c);
        gp->lambert_f += c->weight * (1.0f / PPM_PI);
    }
#endif
}

/* Whether photon pi (at pp) counts for the point at x of normal nrm, in cell c: the cheap tests
 * first (distance, disc), then the cell it belongs to, then the normals; *pf its flux, *cos_l
 * the cosine of its direction. */
inline bool photon_accepted(float3 x, float3 nrm, bool transmits, float r2, float r, float4 pp,
                            __global const float4 *ph_flux, uint pi, long3 c, const Grid *g,
                            float4 *pf, float *cos_l) {
    float3 dd = pp.xyz - x;
    if (dot(dd, dd) > r2) return false;
    if (fabs(dot(dd, nrm)) > DISC_HALF_THICKNESS * r) return false;
    long3 pc = cell_of(pp.xyz, g);
    if (pc.x != c.x || pc.y != c.y || pc.z != c.z) return false;      /* not this cell's */
    float nn = dot(unpack_unit(as_uint(pp.w)), nrm);
    if ((transmits ? fabs(nn) : nn) < NORMAL_COS_MIN) return false;
    *pf = ph_flux[pi];
    *cos_l = dot(unpack_unit(as_uint(pf->w)), nrm);    /* towards where the photon came from */
    return transmits ? fabs(*cos_l) >= 1e-6f : *cos_l > 0.0f;
}

/* An accepted photon's flux times the point's BSDF for its direction, through the closures
 * whose bounce keeps the whole path within the Light Paths limits (path_state.h path_join of
 * the point's and the photon's paths, pe.x), clamped as Cycles clamps the camera path that
 * finds the same light: that path's sample is the point's path weight, times the point's
 * sample weight f cos / pdf for the photon's direction, times the radiance the photon's light
 * path carries (its flux times pe.y; photon_emission.h), and a sample over Clamp Indirect's
 * limit is scaled down to it (path_state.h clamp_sample).  The factor is a function of the
 * light path alone, the one Cycles' sample of that path would get, so the clamped photons
 * estimate Cycles' clamped image, not a clamp of their own flux.  For the caustics a camera
 * path finds through mirrors and glass that sample is exactly Cycles', and so for the light of
 * a point, spot or sun of no size a camera path finds by next-event estimation at the light's
 * first scattering (a metal ball's glossy caustic); such light through a singular first
 * scattering (which no camera path finds) and every photon without clamping are kept whole. */
inline float3 photon_term(const Scene *scene, GatherPoint *gp, float4 pf, float cos_l, uint2 pe) {
    uint kinds = path_join(gp->path, pe.x, gp->lp);
    if (kinds == 0u) return (float3)(0.0f);
    float3 f, ratio;              /* f cos / cos; the sample weight f cos / pdf over beta's */
#if PPM_GATHER_SHADE
    gather_shade(scene, gp);
    if (!gp->lambert) {
        float pdf;
        float3 wp = unpack_unit(as_uint(pf.w));
        float3 fc = shader_eval_kinds(&gp->sd, wp, MASK_GATHER, kinds, &pdf);
        /* f cos over the shading normal's cosine (the photon's flux carries cos_N / cos_Ng:
         * photon_pass.cl) */
        float cs = fabs(dot(wp, gp->sd.N));
        if (!(cs > 1e-6f)) return (float3)(0.0f);
        if (gp->lp->filter_glossy > 0.0f) {
            /* Filter Glossy (path_state.h): light from where a camera path goes from here with
             * a density below the setting is the eye paths' (the eye pass shades every point
             * that gathers with Filter Glossy on) */
            float p_all;
            shader_eval(&gp->sd, wp, MASK_ALL, &p_all);
            if (!filter_glossy_keeps(p_all, gp->lp)) return (float3)(0.0f);
        }
        f = fc * (1.0f / cs);
        ratio = pdf > 0.0f ? fc * (1.0f / pdf) : (float3)(0.0f);
    } else
#endif
    {
        if (!(cos_l > 0.0f && (kinds & JOIN_DIFFUSE))) return (float3)(0.0f);
        f = gp->lambert_f;
        ratio = PPM_PI * gp->lambert_f;
    }
    float3 term = pf.xyz * f;
    float rs = as_float(pe.y);
    if (gp->limit > 0.0f && rs > 0.0f) {
        float3 x = gp->beta * ratio * pf.xyz * rs;
        float s = fabs(x.x) + fabs(x.y) + fabs(x.z);
        if (s > gp->limit) term *= gp->limit / s;
    }
    return term;
}

/* The start of visible point id's gather, the same in both gathers: false where it has no
 * visible point or this pass no grid (its result written: zero); else its shading (gp), the
 * grid, its radius and the cells its disc overlaps. */
inline bool gather_begin(const Scene *scene, const VisiblePoints *vps, const Photons *photons,
                         __global const float *radius, uint id, GatherPoint *gp, Grid *g, float *r,
                         long3 *lo, long3 *hi) {
    float4 vp = vps->pos[id];
    *g = *photons->grid;
    if (vp.w <= 0.0f || g->valid == 0u) {
        vps->gathered[id] = (float4)(0.0f);
        return false;
    }
    gather_point(scene, vps, id, gp);
    *r = radius[id];
    disc_cells(vp.xyz, gp->nrm, *r, g, lo, hi);
    return true;
}

__kernel void gather(SCENE_PARAMS VP_PARAMS PHOTON_PARAMS __global const float *radius,
                     __global const ulong *table, uint table_mask, uint n,
                     __global uint *counters) {
    SCENE_LOAD(scene);
    VP_LOAD(vps);
    PHOTON_LOAD(photons);
    uint id = WORK_ITEM();
    if (id >= n) return;
    GatherPoint gp;
    Grid g;
    float r;
    long3 lo, hi;
    if (!gather_begin(scene, vps, photons, radius, id, &gp, &g, &r, &lo, &hi)) return;
    float3 x = vps->pos[id].xyz;
    float r2 = r * r;
    float3 phi = (float3)(0.0f);
    float M = 0.0f;
    uint used = 0u; /* photons with light for the point (Counter.USED) */
    for (long cz = lo.z; cz <= hi.z; cz++)
        for (long cy = lo.y; cy <= hi.y; cy++)
            for (long cx = lo.x; cx <= hi.x; cx++) {
                long3 c = (long3)(cx, cy, cz);
                if (cell_dist2(x, c, &g) > r2) continue; /* a corner cell the disc misses */
                uint h = cell_hash(c, table_mask);
                uint cnt = ENTRY_COUNT(table, h);
                if (cnt == 0u) continue;
                uint pi = ENTRY_INDEX(table, h);
                float4 pf;
                float cos_l;
                if (!photon_accepted(x, gp.nrm, gp.transmits, r2, r, photons->pos[pi],
                                     photons->flux, pi, c, &g, &pf, &cos_l))
                    continue;
                M += (float)cnt;
                float3 term = photon_term(scene, &gp, pf, cos_l, photons->path[pi]);
                phi += (float)cnt * term;
                used += max3(term) > 0.0f ? cnt : 0u;
            }
    vps->gathered[id] = (float4)(phi, M);
    if (used) atomic_add(&counters[CNT_USED], used);
}

/* Exact gather (reference mode): every photon of every cell the disc overlaps. */
__kernel void gather_exact(SCENE_PARAMS VP_PARAMS PHOTON_PARAMS __global const float *radius,
                           __global const uint *ranges, __global const uint *sorted_ids,
                           uint table_mask, uint n, __global uint *counters) {
    SCENE_LOAD(scene);
    VP_LOAD(vps);
    PHOTON_LOAD(photons);
    uint id = WORK_ITEM();
    if (id >= n) return;
    GatherPoint gp;
    Grid g;
    float r;
    long3 lo, hi;
    if (!gather_begin(scene, vps, photons, radius, id, &gp, &g, &r, &lo, &hi)) return;
    float3 x = vps->pos[id].xyz;
    float r2 = r * r;
    float3 phi = (float3)(0.0f);
    float M = 0.0f;
    uint used = 0u; /* photons with light for the point (Counter.USED) */
    for (long cz = lo.z; cz <= hi.z; cz++)
        for (long cy = lo.y; cy <= hi.y; cy++)
            for (long cx = lo.x; cx <= hi.x; cx++) {
                if (cell_dist2(x, (long3)(cx, cy, cz), &g) > r2) continue;
                uint h = cell_hash((long3)(cx, cy, cz), table_mask);
                uint end = ranges[2 * h + 1];
                for (uint s = ranges[2 * h]; s < end; s++) {
                    uint pi = sorted_ids[s];
                    float4 pf;
                    float cos_l;
                    if (!photon_accepted(x, gp.nrm, gp.transmits, r2, r, photons->pos[pi],
                                         photons->flux, pi, (long3)(cx, cy, cz), &g, &pf, &cos_l))
                        continue;
                    M += 1.0f;
                    float3 term = photon_term(scene, &gp, pf, cos_l, photons->path[pi]);
                    phi += term;
                    used += max3(term) > 0.0f ? 1u : 0u;
                }
            }
    vps->gathered[id] = (float4)(phi, M);
    if (used) atomic_add(&counters[CNT_USED], used);
}
