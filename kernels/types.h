/* What the kernels share: the structs, codes and flags generated from the Python tables
 * (shared.h: ppm_engine/tools/shared_header.py), and the F3 helper. */
#ifndef PPM_TYPES_H
#define PPM_TYPES_H
#include "shared.h"

#define F3(a) ((float3)((a)[0], (a)[1], (a)[2]))

#endif
