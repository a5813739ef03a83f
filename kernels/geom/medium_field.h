#ifndef PPM_MEDIUM_FIELD_H
#define PPM_MEDIUM_FIELD_H
#include "rng.h"
#include "svm/svm.h"
#include "geom/medium.h"
#include "geom/volume_grid.h"
#include "geom/majorant_grid.h"
#include "integrator/path_state.h"

/* Heterogeneous media (PPM_VOLUME with PPM_SVM; docs/VOLUMES.md): a medium whose Density is
 * driven by nodes (export/material_volume.py) has a density program, evaluated at a point in
 * the space of the object it is bound to (its Object and Generated coordinates, a Volume
 * object's grids as its attributes: geom/volume_grid.h), that scales its absorption and
 * scattering there (its emission is not scaled, as Cycles' Principled Volume's).  Its majorants
 * (a bound of the density per cell of its object's box, geom/majorant_grid.h, found on the
 * device by render/medium_bound.py, or from a grid's voxels; Material.majorant the largest)
 * set the rate of tentative collisions: null scattering (Woodcock tracking), with weights (Kutz
 * et al. 2017, "Spectral and Decomposition Tracking") so that chromatic coefficients and a
 * density above the majorant stay unbiased; its transmittance alone by the telescoping
 * estimator (medium_transmittance).  A homogeneous medium takes none of this (geom/medium.h's
 * closed forms). */
#if PPM_VOLUME
/* the most tentative collisions one segment tracks (a denser one is cut there: its weight 0) */
#define MEDIUM_TRACK_MAX 4096
/* the fewest tentative collisions ratio tracking takes over a segment (an emitting field's, or
 * an unbounded one's: the others' transmittance is medium_transmittance's): the rates raised by
 * what raises the box's to that (any rate keeps it unbiased; more collisions, less noise) */
#define MEDIUM_RATIO_STEPS 16.0f
/* the telescoping estimator's orders (medium_transmittance): the order j's probability
 * TELESCOPE_STOP (1 - TELESCOPE_STOP)^j (Cycles' numbers), the last one's all that is left */
#define TELESCOPE_STOP 0.9f
#define TELESCOPE_ORDERS 4

/* whether medium mat's density is a field */
inline bool medium_field(const Scene *scene, int mat) {
#if PPM_SVM
    return mat >= 0 && scene->materials[mat].density_program > 0;
#else
    return false;
#endif
}

/* a density program's binds past its density (their first word: scene/shader_program.py
 * FIELD_*, tests/test_volume_fields.py checks them), and the stack slot of bind `which` of
 * medium mat's (-1: none) */
#define FIELD_GLOW 1
#define FIELD_TINT 2
inline int field_bind(const Scene *scene, int mat, int which) {
#if PPM_SVM
    int p = mat >= 0 ? scene->materials[mat].density_program : 0;
    if (p <= 0) return -1;
    for (int b = 1; b < scene->svm[p].x; b++)
        if (scene->svm[p + 1 + b].x == which) return scene->svm[p + 1 + b].w;
#endif
    return -1;
}
/* whether medium mat's field program also gives its emission (an emission driven by nodes, a
 * Volume object's blackbody emission through its temperature grid; export/material_volume.py
 * _glow) */
inline bool medium_glows(const Scene *scene, int mat) {
    return field_bind(scene, mat, FIELD_GLOW) >= 0;
}
/* whether its field program gives its scattering's colour per point (a Principled
 * Volume's Color Attribute grid, export/material_volume.py _tint) */
inline bool medium_tinted(const Scene *scene, int mat) {
    return field_bind(scene, mat, FIELD_TINT) >= 0;
}

/* the density of medium mat's field at P (>= 0; NaN and negative ones 0, as Cycles clamps; 0
 * where mat is none); where glow is given, *glow its emission per metre there (medium_glows),
 * a Volume object's grids then read as Cycles reads them for its shading, stochastically
 * (numbers rng: a function of a voxel's value, the blackbody's of the temperature, is mixed
 * trilinearly, not the values) */
__attribute__((noinline)) float medium_point(const Scene *scene, int mat, float3 P, float3 *glow,
                                             float3 *tint, uint *rng) {
#if PPM_SVM
    if (mat < 0) return 0.0f;
    __global const Material *mt = scene->materials + mat;
    int p = mt->density_program;
    if (p <= 0) return 1.0f;
    float3 z = (float3)(0.0f);
    SvmContext cx = svm_context_base((float2)(0.0f), P, 0u, 0.0f, z, z, z, false);
    if (mt->volume_object >= 0) {
        __global const float4 *o = scene->objects + OBJECT_ROWS * (size_t)mt->volume_object;
        float4 h = (float4)(P, 1.0f);
        cx.P_object = (float3)(dot(o[0], h), dot(o[1], h), dot(o[2], h));
        cx.generated = cx.P_object * o[9].xyz + o[10].xyz;
        /* a Volume object's grids: the attributes its program reads (geom/volume_grid.h) */
        if (o[5].z > 0.0f) grid_attributes(scene, o, cx.P_object, cx.attr, glow ? rng : 0);
        for (int r = 0; r < 3; r++) {
            cx.object[r] = o[3 + r];
#if SVM_OBJECT_MATRICES
            cx.to_object[r] = o[r];
            cx.to_world[r] = o[6 + r];
#endif
        }
    }
    float stack[PPM_SVM_STACK];
    svm_eval(scene, p, stack, &cx);
    float d = stack[scene->svm[p + 1].w];
    for (int b = 1; b < scene->svm[p].x; b++) {
        int4 w = scene->svm[p + 1 + b];
        float3 v = fmin(fmax((float3)(stack[w.w], stack[w.w + 1], stack[w.w + 2]), (float3)(0.0f)),
                        (float3)(1e30f)); /* (NaN: 0) */
        if (w.x == FIELD_GLOW && glow) *glow = v;
        if (w.x == FIELD_TINT && tint) *tint = v;
    }
    return d > 0.0f ? fmin(d, 1e30f) : 0.0f;
#else
    return 1.0f;
#endif
}

inline float medium_density(const Scene *scene, int mat, float3 P) {
    return medium_point(scene, mat, P, 0, 0, 0);
}

/* numbers for a ray's tracking where its path has none (shadow rays): hashed from the ray */
inline uint ray_hash(float3 o, float3 d) {
    return pcg_hash(
        as_uint(o.x)
        ^ pcg_hash(as_uint(o.y) ^ pcg_hash(as_uint(o.z) ^ pcg_hash(as_uint(d.x) ^ as_uint(d.y)))));
}

/* the mix's majorant where its field's density is bounded by `bound` (its extinction's largest
 * channel there) */
inline float mix_bound(const Mix *x, float bound) {
    return max3(x->sigma_a + x->sigma_s + (x->unit_a + x->unit_s) * bound);
}

/* the mix's majorant: a bound of its extinction's largest channel (its field at its bound) */
inline float mix_majorant(const Scene *scene, const Mix *x) {
    return mix_bound(x, x->field < 0 ? 0.0f : scene->materials[x->field].majorant);
}

/* the walk of the segment o + s d (0 <= s < t) through medium `field`'s majorant grid
 * (geom/majorant_grid.h; one stretch where it has none) */
inline MajorantWalk field_walk(const Scene *scene, int field, float3 o, float3 d, float t) {
    int grid = field < 0 ? 0 : scene->materials[field].majorant_grid;
    return majorant_walk(grid > 0 ? scene->voxels + grid - 1 : 0, o, d, t);
}

/* the least rate of ratio tracking's collisions over a segment of length t (0: unbounded) */
inline float ratio_rate(float t) { return isfinite(t) && t > 0.0f ? MEDIUM_RATIO_STEPS / t : 0.0f; }

/* The transmittance of the piece [a, b) of the ray o + s d through the media x by the
 * telescoping estimator (medium_transmittance): T_k, the optical depth from k regularly spaced
 * samples of the extinction (a random offset), averaged over N = 2^j interleaved sets, plus
 * the debiasing term of order j >= 1 (the N k samples' T less their two halves', over j's
 * probability), j drawn with probability TELESCOPE_STOP (1 - TELESCOPE_STOP)^j up to
 * TELESCOPE_ORDERS (which takes what is left). */
inline float3 telescope_piece(const Scene *scene, const Mix *x, float3 o, float3 d, float a,
                              float b, int k, uint *rng) {
    float3 ct = x->sigma_a + x->sigma_s, ut = x->unit_a + x->unit_s;
    float u = rnd(rng), pmf = 1.0f;
    int j = 0;
    for (; j < TELESCOPE_ORDERS && u >= TELESCOPE_STOP; j++) {
        u = (u - TELESCOPE_STOP) / (1.0f - TELESCOPE_STOP);
        pmf *= 1.0f - TELESCOPE_STOP;
    }
    if (j < TELESCOPE_ORDERS) pmf *= TELESCOPE_STOP;
    int n = 1 << j;
    float h = (b - a) / (float)(n * k), off = rnd(rng);
    float3 whole = (float3)(0.0f), parts[2] = {(float3)(0.0f), (float3)(0.0f)}, tk = whole;
    for (int m = 0; m < n; m++) {
        float3 tau = (float3)(0.0f);
        for (int i = 0; i < k; i++) {
            int step = i * n + m;
            float s = fmin(a + ((float)step + off) * h, b);
            float3 e = (ct + ut * medium_density(scene, x->field, o + s * d)) * h;
            tau += e;
            parts[step & 1] += e;
        }
        whole += tau;
        tk += exp(-tau * (float)n);
    }
    tk /= (float)n;
    if (j == 0) return tk;
    return tk + (exp(-whole) - 0.5f * (exp(-2.0f * parts[0]) + exp(-2.0f * parts[1]))) / pmf;
}

/* The transmittance of the piece [a, b) of the ray o + s d through the media x by ratio
 * tracking at the rate mu (> 0: a bound of the extinction there, or not: unbiased either way) */
inline float3 ratio_piece(const Scene *scene, const Mix *x, float3 o, float3 d, float a, float b,
                          float mu, uint *rng) {
    float3 ct = x->sigma_a + x->sigma_s, ut = x->unit_a + x->unit_s, T = (float3)(1.0f);
    if (!(mu > 0.0f)) return T;
    for (int k = 0; k < MEDIUM_TRACK_MAX; k++) {
        a -= log(1.0f - rnd(rng)) / mu;
        if (!(a < b)) return T;
        T *= 1.0f - (ct + ut * medium_density(scene, x->field, o + a * d)) / mu;
    }
    return (float3)(0.0f);
}

/* the transmittance of the piece [a, b) of the ray o + s d through the media x whose
 * extinction's bound there is mu: by ratio tracking, or by the telescoping estimator with as
 * many samples as its optical depth at mu (at least one) */
inline float3 medium_piece(const Scene *scene, const Mix *x, float3 o, float3 d, float a, float b,
                           float mu, bool ratio, uint *rng) {
    if (ratio) return ratio_piece(scene, x, o, d, a, b, mu, rng);
    float k = clamp(rint(mu * (b - a)), 1.0f, (float)MEDIUM_TRACK_MAX);
    return telescope_piece(scene, x, o, d, a, b, (int)k, rng);
}

/* The transmittance of the segment o + s d (0 <= s < t) of the media x, with a field, as
 * Cycles' shadows take it: Misso et al. 2022's telescoping estimator ("Unbiased and Consistent
 * Rendering Using Biased Estimators"), whose samples fall at regular steps where ratio
 * tracking's fall at random (as many, and far less noise where the density is smooth: a
 * smoke's shadow).  The segment is cut into pieces along its majorant grid's stretches, each
 * estimated on its own (medium_piece): a run of clear cells (where the bound's samples found no
 * density: the grid's least bound) by ratio tracking (less than a collision in expectation,
 * each a factor near 1); the others by the telescoping estimator, such a piece ending where
 * its optical depth at its largest bound reaches 1, at the segment's end, and before a stretch
 * whose bound is above twice its own (a puff after thin air; ratio tracking there, where the
 * piece is thinner than 1).  Russian roulette below a tenth.  Its expectation: the pieces'
 * regular sampling at 2^TELESCOPE_ORDERS times as many samples (the sum telescopes that far). */
inline float3 medium_transmittance(const Scene *scene, const Mix *x, float3 o, float3 d, float t,
                                   uint *rng) {
    float top = scene->materials[x->field].majorant;
    MajorantWalk w = field_walk(scene, x->field, o, d, t);
    float3 T = (float3)(1.0f);
    float a = 0.0f, s = 0.0f, mu_piece = 0.0f;
    bool clear_piece = false;
    for (int n = 0; s < t && n < MEDIUM_TRACK_MAX; n++) {
        float bound, end = majorant_stretch(&w, s, top, &bound), mu = mix_bound(x, bound);
        bool clear = bound <= w.clear;
        /* the piece ends before a stretch unlike it (by ratio tracking where it is clear or
         * thin: the edge of a puff, where one regular sample would cost more than collisions) */
        if (s > a && (clear != clear_piece || (!clear && mu > 2.0f * mu_piece))) {
            T *= medium_piece(scene, x, o, d, a, s, mu_piece,
                              clear_piece || mu_piece * (s - a) < 1.0f, rng);
            a = s;
            mu_piece = 0.0f;
        }
        mu_piece = fmax(mu_piece, mu);
        clear_piece = clear;
        s = end;
        /* ... or with it, where its optical depth reaches 1, and at the segment's end */
        if (!(s < t) || (!clear && mu_piece * (s - a) >= 1.0f)) {
            T *= medium_piece(scene, x, o, d, a, s, mu_piece, clear_piece, rng);
            a = s;
            mu_piece = 0.0f;
        }
        float m = max3(fabs(T));
        if (!(m > 0.0f)) return (float3)(0.0f);
        if (m < 0.1f) { /* Russian roulette */
            if (rnd(rng) * 0.1f >= m) return (float3)(0.0f);
            T *= 0.1f / m;
        }
    }
    return T;
}

/* Tracks the segment o + s d (0 <= s < t) through the media x, with a field: tentative
 * collisions at exponential distances of the majorant's rate, stretch by stretch of its
 * majorant grid (geom/majorant_grid.h); at each the media's emission per metre over the
 * majorant times the weight there is added to *L (where L is given: the collision estimator,
 * clamped at `limit`); where `scatter` it is a scattering with a probability in proportion to
 * |beta sigma_s| against |beta sigma_n| (sigma_n = majorant - sigma_t, negative where the
 * density exceeds its bound), else a null collision, *beta times the coefficient over the
 * majorant and that probability; without `scatter` every one is null (ratio tracking: *beta
 * times the transmittance, in expectation), the rates raised by what raises the whole box's to
 * at least `rate`.  Russian roulette below a hundredth of the weight at the start.  Returns
 * where it scattered (INFINITY: it crossed). */
inline float medium_track(const Scene *scene, const Mix *x, float3 o, float3 d, float t,
                          bool scatter, float rate, float limit, uint *rng, float3 *beta,
                          float3 *L) {
    float3 ct = x->sigma_a + x->sigma_s, ut = x->unit_a + x->unit_s, ue = x->emission;
    float top = x->field < 0 ? 0.0f : scene->materials[x->field].majorant, mu = mix_bound(x, top);
    bool vary = L && medium_glows(scene, x->field), glow = vary || (L && max3(ue) > 0.0f);
    bool tinted = scatter && medium_tinted(scene, x->field);
    float3 ge = (float3)(0.0f), tn = (float3)(1.0f);
    if (!scatter && !glow && isfinite(t)) { /* the transmittance alone */
        *beta *= medium_transmittance(scene, x, o, d, t, rng);
        return INFINITY;
    }
    float raise = !scatter && mu > 0.0f ? fmax(1.0f, rate / mu) : 1.0f;
    MajorantWalk w = field_walk(scene, x->field, o, d, t);
    float b0 = 0.01f * max3(fabs(*beta)), s = 0.0f;
    int k = 0;
    while (s < t) {
        float bound, end = majorant_stretch(&w, s, top, &bound);
        mu = mix_bound(x, bound) * raise;
        if (!(mu > 0.0f)) { /* nothing attenuates here: the emission along it in closed form
                              * (a field's at a point drawn uniformly on it) */
            if (vary && isfinite(end))
                medium_point(scene, x->field, o + mix(s, end, rnd(rng)) * d, &ge, 0, rng);
            if (glow && isfinite(end)) *L += clamp_sample(*beta * (ue + ge) * (end - s), limit);
            s = end;
            continue;
        }
        for (;; k++) {
            if (k >= MEDIUM_TRACK_MAX) goto cut;
            float s1 = s - log(1.0f - rnd(rng)) / mu;
            if (!(s1 < end)) break;
            s = s1;
            float dens = medium_point(scene, x->field, o + s * d, vary ? &ge : 0, tinted ? &tn : 0,
                                      rng);
            float3 ss = x->sigma_s + x->unit_s * tn * dens, sn = mu - (ct + ut * dens);
            if (glow) *L += clamp_sample(*beta * (ue + ge) / mu, limit);
            if (scatter) {
                float ps = dot(fabs(*beta * ss), (float3)(1.0f)),
                      pn = dot(fabs(*beta * sn), (float3)(1.0f));
                if (!(ps + pn > 0.0f)) goto cut;
                float q = ps / (ps + pn);
                if (rnd(rng) < q) {
                    *beta *= ss / (mu * q);
                    return s;
                }
                *beta *= sn / (mu * (1.0f - q));
            } else {
                *beta *= sn / mu;
            }
            float b = max3(fabs(*beta));
            if (!(b > 0.0f)) goto cut;
            if (b < b0) { /* Russian roulette */
                if (rnd(rng) * b0 >= b) goto cut;
                *beta *= b0 / b;
            }
        }
        s = end;
    }
    return INFINITY;
cut:
    *beta = (float3)(0.0f);
    return INFINITY;
}

/* *T times the transmittance of the segment o + s d (0 <= s < t) of the media x, with a field:
 * medium_track without scattering or emission (medium_transmittance; where the segment is
 * unbounded, ratio tracking at least `rate`) */
inline void medium_ratio(const Scene *scene, const Mix *x, float3 o, float3 d, float t, float rate,
                         uint *rng, float3 *T) {
    medium_track(scene, x, o, d, t, false, rate, 0.0f, rng, T, 0);
}

/* the media x of a field with constant extinction c (the others') where only the extinction
 * matters (ratio tracking: shadow rays, the lights a ray meets, the volume photons' gather) */
inline Mix mix_extinction(const Scene *scene, int field, float3 c) {
    Mix x;
    __global const Material *mt = scene->materials + field;
    x.sigma_a = c;
    x.sigma_s = x.emission = (float3)(0.0f);
    x.unit_a = F3(mt->absorption);
    x.unit_s = F3(mt->scattering);
    x.g = 0.0f;
    x.field = field;
    x.top = field;
    return x;
}

/* the fraction of light left after the segment o + s d (0 <= s < t) in the media m (geom/
 * medium.h media_transmittance; with a field by ratio tracking, numbers hashed from the ray) */
inline float3 media_transmittance_ray(const Scene *scene, const Media *m, float3 o, float3 d,
                                      float t) {
    Mix x = media_mix(m, scene->materials);
    if (x.field < 0) return media_transmittance(m, scene->materials, t);
    uint rng = ray_hash(o, d);
    float3 T = (float3)(1.0f);
    medium_ratio(scene, &x, o, d, t, ratio_rate(t), &rng, &T);
    return T;
}
#endif
#endif
