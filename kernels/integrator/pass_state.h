#ifndef PPM_PASS_STATE_H
#define PPM_PASS_STATE_H
#include "shared.h"

/* The passes' per-pixel state as two values, as kernels/scene.h makes the scene one.  FILM_DATA
 * and VP_DATA (shared.h, generated from ppm_engine/render/film.py FILM_BUFFERS and
 * ppm_engine/render/passes/eye.py VP_BUFFERS) list the film's and the visible points' buffers
 * once; from them come
 *   - FILM_PARAMS and VP_PARAMS, the parameters of a kernel that reads them (after
 *     SCENE_PARAMS, before its own; named film_NAME and vp_NAME, bound by name from Film.args
 *     and VisiblePoints.args, device/program.py Launch),
 *   - Film and VisiblePoints, structs of __global pointers, and FILM_LOAD(film) and
 *     VP_LOAD(vps), which fill one at the kernel's entry: helpers take `const Film *` and
 *     `const VisiblePoints *`.
 * A new per-pixel buffer is one row of FILM_BUFFERS or VP_BUFFERS; nothing here changes. */
#define PASS_FIELD(T, name) __global T *name;
typedef struct {
    FILM_DATA(PASS_FIELD)
} Film;
typedef struct {
    VP_DATA(PASS_FIELD)
} VisiblePoints;

#define FILM_PARAM(T, name) __global T *film_##name,
#define FILM_PARAMS FILM_DATA(FILM_PARAM)
#define VP_PARAM(T, name) __global T *vp_##name,
#define VP_PARAMS VP_DATA(VP_PARAM)

#define FILM_VALUE(T, name) film_##name,
#define FILM_LOAD(film)                                \
    const Film film##_value = {FILM_DATA(FILM_VALUE)}; \
    const Film *film = &film##_value
#define VP_VALUE(T, name) vp_##name,
#define VP_LOAD(vps)                                       \
    const VisiblePoints vps##_value = {VP_DATA(VP_VALUE)}; \
    const VisiblePoints *vps = &vps##_value
#endif
