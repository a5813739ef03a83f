#ifndef PPM_LIGHT_TREE_H
#define PPM_LIGHT_TREE_H
#include "scene.h"
/* --- the light tree (ppm_engine/scene/light_tree.py) ---------------------------------------------
 * Next-event estimation among many local emitters: from the shading point p (normal n) each
 * inner node chooses a child in proportion to the child's importance at p, a bound on the
 * light its emitters can give there (Estevez & Conty 2018): its power over the squared
 * distance to its box's centre, times the cosine at the
 * emitters the orientation cone still allows towards p, times the cosine at p (either side: a
 * transmitting closure takes light from behind), each widened by the angle the box subtends.
 * Every bound is conservative, so an emitter that can light p has a positive probability; the
 * MIS of a ray that finds an emitter walks up from its leaf making the same choices
 * (light_tree_pmf): the same choices, multiplied in the other order. */

/* the importance of tree node k at p (normal n) */
inline float light_tree_importance(__global const LightTreeNode *t, float3 p, float3 n) {
    float E = t->energy;
    if (!(E > 0.0f)) return 0.0f;
    float3 lo = F3(t->bmin), hi = F3(t->bmax);
    float3 v = 0.5f * (lo + hi) - p; /* towards the node */
    float r2 = 0.25f * dot(hi - lo, hi - lo), d2 = dot(v, v);
    /* p within the node's ball: no angle bound, and the distance to its centre no less than a
     * quarter of its radius (the node's nearest emitters are that close or closer; E / r^2
     * made a large node around p lose to small ones beside it: the many-light bench scene's
     * noise x sqrt(time) fell by a fifth with this) */
    if (!(d2 > r2)) return E / fmax(fmax(d2, 0.0625f * r2), 1e-30f);
    float d = sqrt(d2);
    float theta_u = asin(fmin(sqrt(r2 / d2), 1.0f)); /* the half angle the ball subtends */
    /* at the emitters: the angle between the cone's axis and the direction to p, less the
     * cone's spread and the ball's angle */
    float cos_e = clamp(-dot(F3(t->axis), v) / d, -1.0f, 1.0f);
    float theta = fmax(acos(cos_e) - t->theta_o - theta_u, 0.0f);
    if (theta >= t->theta_e) return 0.0f;
    /* at p: the angle to the normal on the nearer side, less the ball's angle */
    float cos_i = fmin(fabs(dot(n, v)) / d, 1.0f);
    float theta_i = fmax(acos(cos_i) - theta_u, 0.0f);
    return E * cos(theta) * cos(theta_i) / d2;
}

/* Whether node t surely lights p (normal n): Cycles' lower bound on its importance above zero
 * (kernel/light/tree.h there): p outside the node's ball, the whole ball above p's horizon
 * (either side) and within every emitter's reach (the cone's axis within pi/2 - theta_o of
 * every direction to p, and theta_e - theta_o) */
inline bool light_tree_surely_lights(__global const LightTreeNode *t, float3 p, float3 n) {
    float3 lo = F3(t->bmin), hi = F3(t->bmax);
    float3 v = 0.5f * (lo + hi) - p;
    float r2 = 0.25f * dot(hi - lo, hi - lo), d2 = dot(v, v);
    if (!(d2 > r2) || !(t->energy > 0.0f)) return false;
    float d = sqrt(d2);
    float theta_u = asin(fmin(sqrt(r2 / d2), 1.0f));
    if (acos(fmin(fabs(dot(n, v)) / d, 1.0f)) + theta_u >= M_PI_2_F) return false;
    float theta = acos(clamp(-dot(F3(t->axis), v) / d, -1.0f, 1.0f)) + theta_u + t->theta_o;
    return theta <= t->theta_e && theta < M_PI_2_F;
}

/* the probability of the first child of inner node k, from the two children's importances */
inline float light_tree_left(__global const LightTreeNode *tree, int k, float3 p, float3 n) {
    int c = tree[k].child;
    float i0 = light_tree_importance(tree + c, p, n),
          i1 = light_tree_importance(tree + c + 1, p, n);
    float s = i0 + i1;
    return s > 0.0f && isfinite(s) ? i0 / s : 0.5f;
}

/* Whether the descent stops at inner node t for p: its ball is seen under a small angle
 * (LIGHT_TREE_STOP), so that its emitters' importance at p is their power to within it; the
 * pick among them is then by power, over the tree's order (a node's emitters are contiguous:
 * ppm_engine/scene/light_tree.py).  Deep descents cost more than they gain where every emitter of a
 * node looks alike (a bulb's thousand triangles seen from across the room). */
inline bool light_tree_stops(__global const LightTreeNode *t, float3 p) {
    if (t->child < 0) return false;
    float3 lo = F3(t->bmin), hi = F3(t->bmax);
    float3 v = 0.5f * (lo + hi) - p;
    return 0.25f * dot(hi - lo, hi - lo) < LIGHT_TREE_STOP * dot(v, v);
}

inline float light_tree_cdf(const Scene *scene, int j) { return j < 0 ? 0.0f : scene->tree_cdf[j]; }

/* the probability of the emitter at position j of the tree's order among node t's, by power */
inline float light_tree_share(const Scene *scene, __global const LightTreeNode *t, int j) {
    float lo = light_tree_cdf(scene, t->first - 1),
          hi = light_tree_cdf(scene, t->first + t->count - 1);
    return hi > lo ? (light_tree_cdf(scene, j) - light_tree_cdf(scene, j - 1)) / (hi - lo)
                   : 1.0f / (float)t->count;
}

/* An emitter of the tree for p (normal n) from the uniform number u; *pmf its probability. */
inline int light_tree_sample(const Scene *scene, float3 p, float3 n, float u, float *pmf) {
    __global const LightTreeNode *tree = scene->light_tree;
    int k = 0;
    float q = 1.0f;
    while (tree[k].child >= 0) {
        if (light_tree_stops(tree + k, p)) {
            /* by power among the node's emitters: the first whose CDF passes u's place */
            int a = tree[k].first, b = a + tree[k].count - 1;
            float lo = light_tree_cdf(scene, a - 1), hi = light_tree_cdf(scene, b);
            float v = lo + u * (hi - lo);
            while (a < b) {
                int mid = (a + b) >> 1;
                if (v < scene->tree_cdf[mid]) b = mid;
                else a = mid + 1;
            }
            *pmf = q * light_tree_share(scene, tree + k, a);
            return scene->tree_emitters[a];
        }
        float p0 = light_tree_left(tree, k, p, n);
        if (u < p0) {
            u = u / p0;
            q *= p0;
            k = tree[k].child;
        } else {
            u = (u - p0) / (1.0f - p0);
            q *= 1.0f - p0;
            k = tree[k].child + 1;
        }
        u = clamp(u, 0.0f, 0.99999994f);
    }
    *pmf = q;
    return -1 - tree[k].child;
}

/* The probability light_tree_sample gives emitter e at p (normal n); 0 when not a member:
 * the same choices from the root down to the leaf, or to the node where the descent stops. */
inline float light_tree_pmf(const Scene *scene, int e, float3 p, float3 n) {
    __global const LightTreeNode *tree = scene->light_tree;
    int leaf = scene->emitter_leaf[e];
    if (leaf < 0) return 0.0f;
    int path[LIGHT_TREE_STACK], m = 0;
    for (int k = leaf; k >= 0 && m < LIGHT_TREE_STACK; k = tree[k].parent) path[m++] = k;
    float q = 1.0f;
    for (int i = m - 1; i > 0; i--) {
        int k = path[i];
        if (light_tree_stops(tree + k, p))
            return q * light_tree_share(scene, tree + k, tree[leaf].first);
        float p0 = light_tree_left(tree, k, p, n);
        q *= path[i - 1] == tree[k].child ? p0 : 1.0f - p0;
    }
    return q;
}
#endif
