#ifndef PPM_MEDIUM_H
#define PPM_MEDIUM_H
#include "types.h"

/* Homogeneous absorption inside closed glass meshes (a material's Volume Absorption, Beer-Lambert
 * along the path): the media a path is in, innermost last.  A refraction into a mesh enters its
 * material's medium and one out of it leaves that medium, wherever it is in the list, so a
 * liquid inside a glass is two levels and either surface order works.  Paths start outside
 * every medium (a camera inside glass sees it as clear).  Compiled with PPM_ABSORPTION only. */
#define MEDIUM_DEPTH 4

typedef struct {
    int mat[MEDIUM_DEPTH];
    int n;
} Media;

inline void media_init(Media *m) { m->n = 0; }

/* the fraction of light left after a segment of length t in the innermost medium */
inline float3 media_transmittance(const Media *m, __global const Material *materials, float t) {
    if (m->n == 0) return (float3)(1.0f);
    return exp(-F3(materials[m->mat[m->n - 1]].absorption) * t);
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
#endif
