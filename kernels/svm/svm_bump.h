#ifndef PPM_SVM_BUMP_H
#define PPM_SVM_BUMP_H
#include "svm/svm_context.h"

/* The Bump node, as Cycles evaluates it (learnt from its svm_node_set_bump and the SVM
 * compiler's refine_bump_nodes).
 *
 * The exporter (export/shader_bump.py) emits the node's Height sub-graph three times: as it is
 * (the centre), and with every position-dependent input (Position, Object and Camera
 * coordinates, UV, Generated, mesh attributes) moved by the filter width times one of the
 * footprint's two offsets dP[0], dP[1].  SVM_BUMP then makes the normal from the three heights.
 *
 * The footprint is Cycles' compact ray differential: a radius r at the hit, and the two offsets
 * r a and r b, (a, b) Cycles' orthonormal pair around the geometric normal (its
 * make_orthonormals: a along (1, 1, 1) x Ng).  Where r comes from (kernels/geom/camera.h):
 *   - camera rays, and rays after any number of bounces or transparent crossings, as Cycles:
 *     r = dP + t dD with t the length of the whole path from the camera ray's origin, dP and
 *     dD the camera ray's (perspective: dD the mean change of the normalised direction over
 *     one pixel in x and in y at the pixel, dP = dD x the distance to the near clipping plane
 *     where the ray starts; orthographic: dP = one pixel's width, dD = 0), since Cycles'
 *     bounces keep the camera's dD and start from the hit's radius; depth of field does not
 *     change them (Cycles takes them from the pinhole);
 *   - the gather shades a visible point again with the radius its eye pass stored;
 *   - photons (Cycles has none): the radius a camera ray would have at the hit, measured from
 *     the camera position straight (so a photon scatters off a bumped surface the camera sees
 *     about as the eye pass shades it).
 * Shadow rays and emitter samples run programs without a footprint (the normal is unused). */

/* Cycles' orthonormal pair around N (its make_orthonormals) */
inline void svm_orthonormals(float3 N, float3 *a, float3 *b) {
    float3 t = (N.x != N.y || N.x != N.z) ? (float3)(N.z - N.y, N.x - N.z, N.y - N.x)
                                          : (float3)(N.z - N.y, N.x + N.z, -N.y - N.x);
    *a = svm_safe_normalize(t);
    *b = cross(N, *a);
}

#if SVM_HAS_BUMP
/* The context's changes over the footprint's offsets dP[k] = r a, r b: the barycentric offsets
 * that move the point by dP[k] in the triangle's plane (Cramer's rule on dP/du, dP/dv), and
 * the per-corner data there (all linear over the triangle: exact finite differences). */
inline void svm_footprint_offsets(SvmContext *cx, const Scene *scene, int p, uint tri, float u,
                                  float v, Footprint fp) {
    float3 a, b;
    svm_orthonormals(cx->Ng, &a, &b);
    float3 n = cross(fp.dpdu, fp.dpdv);
    float nn = dot(n, n);
    if (!(nn > 0.0f)) return;
    float side = dot(fp.n, cx->N) < 0.0f ? -1.0f : 1.0f;
    cx->n_smooth = side * fp.n;
    for (int k = 0; k < 2; k++) {
        float3 D = fp.r * (k == 0 ? a : b);
        float du = dot(cross(D, fp.dpdv), n) / nn, dv = dot(cross(fp.dpdu, D), n) / nn;
        SvmContext o = *cx;
        svm_corner_data(&o, scene, p, tri, u + du, v + dv, cx->P + D);
        cx->dP[k] = D;
        cx->dP_object[k] = o.P_object - cx->P_object;
        cx->dgenerated[k] = o.generated - cx->generated;
        cx->duv[k] = o.uv - cx->uv;
        cx->dn[k] = side * (du * fp.dndu + dv * fp.dndv);
        for (int j = 0; j < PPM_ATTRIBUTES; j++) cx->dattr[k][j] = o.attr[j] - cx->attr[j];
    }
}

/* A position-dependent input (GEOM_UV, GEOM_GENERATED, GEOM_POSITION, GEOM_OBJECT, an
 * attribute's value or alpha; GEOM_NORMAL for the Texture Coordinate's Normal: the smooth
 * normal interpolated there, as Cycles) at offset k of the footprint, scaled by the filter
 * width fw */
inline float4 svm_bump_input(const SvmContext *cx, int what, int k, float fw, float4 x) {
    if (what == GEOM_NORMAL) {
        float3 n = cx->n_smooth + fw * cx->dn[k];
        return dot(n, n) > 0.0f ? (float4)(normalize(n), 0.0f) : x;
    }
    float3 d = what == GEOM_UV          ? (float3)(cx->duv[k], 0.0f)
               : what == GEOM_GENERATED ? cx->dgenerated[k]
               : what == GEOM_POSITION  ? cx->dP[k]
               : what == GEOM_OBJECT    ? cx->dP_object[k]
                                        : (float3)(0.0f);
    if (what >= GEOM_ATTRIBUTE) {
        float4 da = cx->dattr[k][min((what - GEOM_ATTRIBUTE) & (MAX_ATTRIBUTES - 1),
                                     PPM_ATTRIBUTES - 1)];
        return what >= GEOM_ATTRIBUTE_ALPHA ? (float4)(x.x + fw * da.w, 0.0f, 0.0f, 0.0f)
                                            : x + fw * da;
    }
    return (float4)(x.xyz + fw * d, x.w);
}

/* The bumped normal from the heights at the centre and the two offsets (Cycles' surface
 * gradient: the normal of the surface displaced by distance x height along n_in, from the
 * finite differences over fw x the footprint), mixed with n_in by strength. */
inline float3 svm_bump_normal(const SvmContext *cx, float3 n_in, float hc, float hx, float hy,
                              float strength, float distance, bool invert, float fw) {
    float3 dx = cx->dP[0], dy = cx->dP[1];
    float3 Rx = cross(dy, n_in), Ry = cross(n_in, dx);
    float det = dot(dx, Rx);
    float3 grad = (hx - hc) * Rx + (hy - hc) * Ry;
    float scale = invert ? -distance : distance;
    float3 n = svm_safe_normalize(fw * fabs(det) * n_in
                                  - scale * (det < 0.0f ? -1.0f : 1.0f) * grad);
    if (!(dot(n, n) > 0.0f)) return n_in;
    strength = fmax(strength, 0.0f);
    return normalize(strength * n + (1.0f - strength) * n_in);
}
#endif
#endif
