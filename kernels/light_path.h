#ifndef PPM_LIGHT_PATH_H
#define PPM_LIGHT_PATH_H
#include "closure_types.h"

/* The ray that reached a shading point, as the Light Path node sees it (kernels/svm.h), packed
 * into one uint: its type (PATH_*, 7 bits) and the bounces before it, 5 bits each (saturating
 * at 31): all, transparent, diffuse, glossy, transmission.  Bounces follow Cycles'
 * path_state_next: a reflection counts as diffuse or glossy, a transmission as transmission,
 * a singular lobe is glossy and singular; a transparent crossing keeps the type. */
#define PATH_CAMERA 1u
#define PATH_SHADOW 2u
#define PATH_DIFFUSE 4u
#define PATH_GLOSSY 8u
#define PATH_SINGULAR 16u
#define PATH_REFLECT 32u
#define PATH_TRANSMIT 64u
#define PATH_DEPTH 0          /* path_count fields */
#define PATH_TRANSPARENT_DEPTH 1
#define PATH_DIFFUSE_DEPTH 2
#define PATH_GLOSSY_DEPTH 3
#define PATH_TRANSMISSION_DEPTH 4

inline uint path_count(uint p, int k) { return (p >> (7 + 5 * k)) & 31u; }
inline uint path_add(uint p, int k) { return path_count(p, k) < 31u ? p + (1u << (7 + 5 * k)) : p; }

/* the state after a bounce with sample label `label` */
inline uint path_bounce(uint p, int label) {
    p = path_add(p, PATH_DEPTH);
    uint f = (label & LABEL_DIFFUSE) ? PATH_DIFFUSE : (label & LABEL_GLOSSY) ? PATH_GLOSSY
           : (PATH_GLOSSY | PATH_SINGULAR);
    if (label & LABEL_TRANSMIT) {
        f |= PATH_TRANSMIT;
        p = path_add(p, PATH_TRANSMISSION_DEPTH);
    } else {
        f |= PATH_REFLECT;
        p = path_add(p, (label & LABEL_DIFFUSE) ? PATH_DIFFUSE_DEPTH : PATH_GLOSSY_DEPTH);
    }
    return (p & ~127u) | f;
}

/* the state after a transparent crossing (the type kept) */
inline uint path_transparent(uint p) { return path_add(p, PATH_TRANSPARENT_DEPTH); }

/* output k of the Light Path node (shader_program LIGHT_PATH_OUTPUTS) for state p and the
 * length of the ray's last segment */
inline float path_output(uint p, float length, int k) {
    if (k < 7) return (p >> k) & 1u ? 1.0f : 0.0f;
    if (k == 7) return 0.0f;                                    /* volume scatter */
    if (k == 8) return length;
    if (k == 14) return 0.0f;                                   /* portal depth */
    const int field[5] = {PATH_DEPTH, PATH_DIFFUSE_DEPTH, PATH_GLOSSY_DEPTH,
                          PATH_TRANSPARENT_DEPTH, PATH_TRANSMISSION_DEPTH};
    return (float)path_count(p, field[clamp(k - 9, 0, 4)]);
}
#endif
