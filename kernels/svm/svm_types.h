#ifndef PPM_SVM_TYPES_H
#define PPM_SVM_TYPES_H
#include "shared.h"

/* What a build of the shader program interpreter (svm.h) contains: the op codes the scene's
 * programs use (PPM_SVM_OPS: a bit per op code SVM_* of shared.h, a ulong; every op without
 * it), the mesh attributes a point carries (PPM_ATTRIBUTES: room for the scene's
 * `attributes`), and what follows from the ops: the object's matrices, the Bump node's
 * footprint. */
#ifndef PPM_SVM_OPS
#define PPM_SVM_OPS 0x7fffffffffffffffUL
#endif
#define SVM_HAS(op) ((PPM_SVM_OPS >> (op)) & 1)
#ifndef PPM_ATTRIBUTES
/* room for the mesh attributes at a point: a specialised build's -D is the scene's stride, a
 * build of every feature has room for the most a scene reads (the stride then read at run
 * time, EmitterInfo.n_attributes: scenes share the build) */
#define PPM_ATTRIBUTES (PPM_ALL_FEATURES ? MAX_ATTRIBUTES : 1)
#endif
/* the object's matrices in the context: Mapping and Vector Transform, object-space normal maps */
#define SVM_OBJECT_MATRICES (SVM_HAS(SVM_MAPPING) || SVM_HAS(SVM_NORMAL_MAP))
/* the Bump node's footprint offsets in the context (svm_bump.h) */
#define SVM_HAS_BUMP SVM_HAS(SVM_BUMP)
/* whether a build reads footprints at all (callers skip computing them otherwise) */
#define SVM_FOOTPRINT (PPM_SVM && SVM_HAS_BUMP)
#endif
