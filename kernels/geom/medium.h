#ifndef PPM_MEDIUM_H
#define PPM_MEDIUM_H
#include "types.h"
#include "geom/geometry.h"

/* Homogeneous absorption inside closed glass meshes (a material's Volume Absorption, Beer-Lambert
 * along the path): the media a path is in, innermost last.  A refraction into a mesh enters its
 * material's medium and one out of it leaves that medium, wherever it is in the list, so a
 * liquid inside a glass is two levels and either surface order works.  Paths start outside
 * every medium (a camera inside glass sees it as clear; with PPM_VOLUME the media that hold
 * the camera or a light are found by a ray: media_at).  Compiled with PPM_ABSORPTION only. */
#define MEDIUM_DEPTH 4

typedef struct {
    int mat[MEDIUM_DEPTH];
    int n;
} Media;

inline void media_init(Media *m) { m->n = 0; }

/* a copy of the media *src (none when src is 0) */
inline Media media_copy(const Media *src) {
    Media m;
    if (src) m = *src;
    else media_init(&m);
    return m;
}

/* exp(-sigma_t t), 1 where sigma_t is 0 (a clear medium over an unbounded segment: not NaN) */
inline float3 medium_tr(float3 sigma_t, float t) {
    return exp(-select(sigma_t * t, (float3)(0.0f), isequal(sigma_t, (float3)(0.0f))));
}

/* whether material mt's medium has a density field (geom/medium_field.h) */
inline bool material_field(__global const Material *mt) {
#if PPM_VOLUME && PPM_SVM
    return mt->density_program > 0;
#else
    return false;
#endif
}

/* The media's extinction coefficient: every medium on the stack summed, as Cycles sums the
 * volumes of its stack (absorption, and with PPM_VOLUME scattering), but for a density field's
 * (geom/medium_field.h: tracked, its coefficients per unit of density). */
inline float3 media_extinction(const Media *m, __global const Material *materials) {
    float3 s = (float3)(0.0f);
    for (int k = 0; k < m->n; k++) {
        __global const Material *mt = materials + m->mat[k];
        if (material_field(mt)) continue;
#if PPM_VOLUME
        s += F3(mt->absorption) + F3(mt->scattering);
#else
        s += F3(mt->absorption);
#endif
    }
    return s;
}

/* the fraction of light left after a segment of length t in the media (what scatters out of
 * the segment is lost too: photons and the eye paths' rays past their last scattering carry
 * only what goes straight through; a field's: media_transmittance_ray) */
inline float3 media_transmittance(const Media *m, __global const Material *materials, float t) {
    if (m->n == 0) return (float3)(1.0f);
#if PPM_VOLUME
    return medium_tr(media_extinction(m, materials), t);
#else
    return exp(-media_extinction(m, materials) * t);
#endif
}

/* a refraction through a surface of material mat: entering (the path arrived on the side the
 * geometric normal points to, the outside of a closed mesh) or leaving */
inline void media_cross(Media *m, int mat, bool entering) {
    if (entering) {
        if (m->n < MEDIUM_DEPTH) m->mat[m->n++] = mat;   /* deeper nesting: treated as clear */
        return;
    }
    for (int k = m->n - 1; k >= 0; k--) {
        if (m->mat[k] != mat) continue;
        for (int j = k; j < m->n - 1; j++) m->mat[j] = m->mat[j + 1];
        m->n--;
        return;
    }
}
#if PPM_VOLUME
/* --- homogeneous media (PPM_VOLUME; ppm_engine/scene/materials.py MAT_VOLUME) ----------------
 * A mesh whose material has only a Volume output is a transparent boundary; crossing it (by the
 * geometric normal: entering where the ray meets its front, as Cycles' volume stack) enters or
 * leaves its medium, as a refraction enters or leaves glass's.  A segment is in the innermost
 * medium (overlapping media do not add up yet). */
inline void media_cross_transparent(Media *m, __global const Material *materials, int mat,
                                    bool entering) {
    if (materials[mat].flags & MAT_VOLUME) media_cross(m, mat, entering);
}

/* Whether a transparent crossing of material mat is a medium's boundary alone (MAT_BOUNDARY): no
 * transparent bounce, as Cycles' volume bounds; paths count them apart and stop past
 * VOLUME_BOUNDS_MAX (a ray stuck on a surface) */
#define VOLUME_BOUNDS_MAX 1024
inline bool media_boundary(__global const Material *materials, int mat) {
    return (materials[mat].flags & MAT_BOUNDARY) != 0;
}

/* the innermost medium's material, -1 when the path is in none */
inline int media_top(const Media *m) { return m->n > 0 ? m->mat[m->n - 1] : -1; }

/* The media of a stack as one, as Cycles sums the volumes on its stack: the homogeneous ones'
 * coefficients and emission summed, the innermost density field's coefficients per unit of its
 * density apart (its material `field`; a second field counts as clear), the Henyey-Greenstein
 * anisotropy the mean of theirs weighted by their scattering (a mixture of lobes of one g: the
 * same phase function; of different ones, its mean cosine). */
typedef struct {
    float3 sigma_a, sigma_s, emission; /* the homogeneous media's, summed; every one's emission */
    float3 unit_a, unit_s;             /* the field's, per unit of density */
    float g;
    int field, top;                    /* the field's material (-1: none), the innermost's */
} Mix;

inline Mix media_mix(const Media *m, __global const Material *materials) {
    Mix x;
    x.sigma_a = x.sigma_s = x.emission = x.unit_a = x.unit_s = (float3)(0.0f);
    x.field = -1;
    x.top = media_top(m);
    float gs = 0.0f, ws = 0.0f;
    for (int k = m->n - 1; k >= 0; k--) {
        __global const Material *mt = materials + m->mat[k];
        float3 a = F3(mt->absorption), s = F3(mt->scattering);
        x.emission += F3(mt->volume_emission);
        float w = s.x + s.y + s.z;
        if (material_field(mt)) {
            if (x.field >= 0) continue;
            x.field = m->mat[k];
            x.unit_a = a;
            x.unit_s = s;
            w *= mt->majorant;
        } else {
            x.sigma_a += a;
            x.sigma_s += s;
        }
        gs += w * mt->anisotropy;
        ws += w;
    }
    x.g = ws > 0.0f ? clamp(gs / ws, -0.999f, 0.999f) : 0.0f;
    return x;
}

/* whether the mix scatters anywhere */
inline bool mix_scatters(const Mix *x) { return max3(x->sigma_s + x->unit_s) > 0.0f; }

/* the Henyey-Greenstein phase function (per steradian) at cos_theta, the cosine between the
 * direction the light travelled and the one it goes on in (seen from an eye path going along
 * d: dot(d, direction to the light)), as Cycles' single-peaked one */
inline float hg_phase(float cos_theta, float g) {
    float k = 1.0f + g * g - 2.0f * g * cos_theta;
    return (1.0f - g * g) / (4.0f * M_PI_F * k * sqrt(k));
}

/* a direction from the phase function around the ray direction d (numbers u1, u2), *pdf its
 * density: the inverse of its CDF in the cosine (uniform where |g| is tiny) */
inline float3 hg_sample(float3 d, float g, float u1, float u2, float *pdf) {
    float c;
    if (fabs(g) < 1e-3f) {
        c = 1.0f - 2.0f * u1;
    } else {
        float k = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        c = clamp((1.0f + g * g - k * k) / (2.0f * g), -1.0f, 1.0f);
    }
    float s = sqrt(fmax(0.0f, 1.0f - c * c)), phi = 2.0f * M_PI_F * u2;
    float3 t = fabs(d.x) > 0.9f ? (float3)(0.0f, 1.0f, 0.0f) : (float3)(1.0f, 0.0f, 0.0f);
    float3 b1 = normalize(cross(d, t)), b2 = cross(d, b1);
    *pdf = hg_phase(c, g);
    return normalize(c * d + s * (cos(phi) * b1 + sin(phi) * b2));
}

/* the radiance a segment of length t of emission e per metre (extinction sigma_t) emits towards its start:
 * the emission integrated with the transmittance from there (an unbounded one, in the world's
 * medium: none where nothing dims it, as Cycles renders it, not infinite) */
inline float3 medium_emission(float3 e, float3 sigma_t, float t) {
    float3 len = select((1.0f - exp(-sigma_t * t)) / sigma_t, (float3)(isfinite(t) ? t : 0.0f),
                        isequal(sigma_t, (float3)(0.0f)));
    return select(e * len, (float3)(0.0f), isequal(e, (float3)(0.0f)));
}

/* The channel probabilities of free-flight distance sampling in a medium (sigma_t, sigma_s) for
 * a path of weight beta, as Cycles picks its channel: in proportion to beta times the channel's
 * albedo; false when nothing scatters. */
inline bool medium_channels(float3 sigma_t, float3 sigma_s, float3 beta, float3 *pc) {
    float3 albedo = select(sigma_s / sigma_t, (float3)(0.0f), isequal(sigma_t, (float3)(0.0f)));
    float3 w = fabs(beta) * albedo;
    float sum = w.x + w.y + w.z;
    if (!(sum > 0.0f) || !isfinite(sum)) return false;
    *pc = w / sum;
    return true;
}

/* the density of scattering at distance s (the channels' mean) */
inline float medium_pdf(float3 sigma_t, float3 pc, float s) {
    return dot(pc, sigma_t * exp(-sigma_t * s));
}

/* Free-flight distance sampling over a segment of length t in a medium (sigma_t, sigma_s): a
 * channel picked by medium_channels (u_c), an exponential distance in it (u_t), the density
 * the mean over the channels.  Returns the distance (INFINITY: the segment crossed) and scales
 * *beta by the transmittance (times sigma_s where it scattered) over that density, *pdf the
 * density of the distance where it scattered. */
inline float medium_sample(float3 sigma_t, float3 sigma_s, float t, float u_c, float u_t,
                           float3 *beta, float *pdf) {
    float3 pc;
    *pdf = 0.0f;
    if (!medium_channels(sigma_t, sigma_s, *beta, &pc)) {
        *beta *= medium_tr(sigma_t, t);
        return INFINITY;
    }
    float st = u_c < pc.x ? sigma_t.x : u_c < pc.x + pc.y ? sigma_t.y : sigma_t.z;
    float s = -log(1.0f - u_t) / st;
    if (s < t) {
        float3 tr = exp(-sigma_t * s);
        *pdf = medium_pdf(sigma_t, pc, s);
        *beta *= *pdf > 0.0f ? sigma_s * tr / *pdf : (float3)(0.0f);
        return s;
    }
    float3 tr = medium_tr(sigma_t, t);
    float pass = dot(pc, tr);
    *beta *= pass > 0.0f ? tr / pass : (float3)(0.0f);
    return INFINITY;
}

/* Equiangular sampling (Kulla & Fajardo 2012) of a distance s in [t0, t1] along o + s d
 * towards the point c: uniform in the angle c subtends, density
 * D / ((theta_1 - theta_0)(D^2 + h^2)), D the distance from c to the line and h = s - the foot
 * of that perpendicular; 0 outside [t0, t1] */
inline float equiangular_pdf(float3 o, float3 d, float t0, float t1, float3 c, float s) {
    if (!(s >= t0 && s <= t1)) return 0.0f;
    float delta = dot(c - o, d);
    float D = fmax(length(c - o - delta * d), 1e-7f);
    float ta = atan2(t0 - delta, D), tb = atan2(t1 - delta, D), h = s - delta;
    return tb > ta ? D / ((tb - ta) * (D * D + h * h)) : 0.0f;
}

inline float equiangular_sample(float3 o, float3 d, float t0, float t1, float3 c, float u,
                                float *pdf) {
    float delta = dot(c - o, d);
    float D = fmax(length(c - o - delta * d), 1e-7f);
    float ta = atan2(t0 - delta, D), tb = atan2(t1 - delta, D);
    float s = clamp(delta + D * tan(mix(ta, tb, u)), t0, t1);
    float h = s - delta;
    *pdf = tb > ta ? D / ((tb - ta) * (D * D + h * h)) : 0.0f;
    return s;
}
#endif
#endif
