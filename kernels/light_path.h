#ifndef PPM_LIGHT_PATH_H
#define PPM_LIGHT_PATH_H
#include "closure_types.h"
#include "shared.h"

/* The ray that reached a shading point, as the Light Path node sees it (kernels/svm.h), packed
 * into one uint: its type (PATH_*, 7 bits) and the bounces before it, 5 bits each (saturating
 * at 31): all, transparent, diffuse, glossy, transmission.  Bounces follow Cycles'
 * path_state_next: a reflection counts as diffuse or glossy, a transmission as transmission,
 * a singular lobe is glossy and singular; a transparent crossing keeps the type. */
/* (the type bits are in the order of the Light Path node's outputs, LIGHT_PATH_*) */
#define PATH_CAMERA (1u << LIGHT_PATH_CAMERA)
#define PATH_SHADOW (1u << LIGHT_PATH_SHADOW)
#define PATH_DIFFUSE (1u << LIGHT_PATH_DIFFUSE)
#define PATH_GLOSSY (1u << LIGHT_PATH_GLOSSY)
#define PATH_SINGULAR (1u << LIGHT_PATH_SINGULAR)
#define PATH_REFLECT (1u << LIGHT_PATH_REFLECTION)
#define PATH_TRANSMIT (1u << LIGHT_PATH_TRANSMISSION)
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
    uint f = (label & LABEL_DIFFUSE)  ? PATH_DIFFUSE
             : (label & LABEL_GLOSSY) ? PATH_GLOSSY
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

/* output k of the Light Path node (LIGHT_PATH_*) for state p and the length of the ray's last
 * segment */
inline float path_output(uint p, float length, int k) {
    if (k < LIGHT_PATH_VOLUME_SCATTER) return (p >> k) & 1u ? 1.0f : 0.0f;   /* a type bit */
    if (k == LIGHT_PATH_VOLUME_SCATTER) return 0.0f;
    if (k == LIGHT_PATH_RAY_LENGTH) return length;
    if (k == LIGHT_PATH_PORTAL_DEPTH) return 0.0f;
    /* the depths, from LIGHT_PATH_RAY_DEPTH on */
    const int field[5] = {PATH_DEPTH, PATH_DIFFUSE_DEPTH, PATH_GLOSSY_DEPTH, PATH_TRANSPARENT_DEPTH,
                          PATH_TRANSMISSION_DEPTH};
    return (float)path_count(p, field[clamp(k - LIGHT_PATH_RAY_DEPTH, 0, 4)]);
}
#endif
