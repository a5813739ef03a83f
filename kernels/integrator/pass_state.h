#ifndef PPM_PASS_STATE_H
#define PPM_PASS_STATE_H
#include "shared.h"

/* The passes' state as values, as kernels/scene.h makes the scene one.  FILM_DATA, VP_DATA and
 * PHOTON_DATA (shared.h, generated from ppm_engine/render/film.py FILM_BUFFERS,
 * ppm_engine/render/passes/eye.py VP_BUFFERS and ppm_engine/render/photon_map.py
 * PHOTON_BUFFERS) list the film's, the visible points' and the photons' buffers once; from
 * them come
 *   - FILM_PARAMS, VP_PARAMS and PHOTON_PARAMS, the parameters of a kernel that reads them
 *     (after SCENE_PARAMS, before its own; named film_NAME, vp_NAME and ph_NAME, bound by
 *     name from Film.args, VisiblePoints.args and PhotonMap.args, device/program.py Launch),
 *   - Film, VisiblePoints and Photons, structs of __global pointers, and FILM_LOAD(film),
 *     VP_LOAD(vps) and PHOTON_LOAD(photons), which fill one at the kernel's entry: helpers
 *     take `const Film *`, `const VisiblePoints *`, `const Photons *`.
 * A new buffer is one row of FILM_BUFFERS, VP_BUFFERS or PHOTON_BUFFERS; nothing here
 * changes. */
#define PASS_FIELD(T, name) __global T *name;
typedef struct {
    FILM_DATA(PASS_FIELD)
} Film;
typedef struct {
    VP_DATA(PASS_FIELD)
} VisiblePoints;
typedef struct {
    PHOTON_DATA(PASS_FIELD)
} Photons;

#define FILM_PARAM(T, name) __global T *film_##name,
#define FILM_PARAMS FILM_DATA(FILM_PARAM)
#define VP_PARAM(T, name) __global T *vp_##name,
#define VP_PARAMS VP_DATA(VP_PARAM)
#define PHOTON_PARAM(T, name) __global T *ph_##name,
#define PHOTON_PARAMS PHOTON_DATA(PHOTON_PARAM)

#define FILM_VALUE(T, name) film_##name,
#define FILM_LOAD(film)                                \
    const Film film##_value = {FILM_DATA(FILM_VALUE)}; \
    const Film *film = &film##_value
#define VP_VALUE(T, name) vp_##name,
#define VP_LOAD(vps)                                       \
    const VisiblePoints vps##_value = {VP_DATA(VP_VALUE)}; \
    const VisiblePoints *vps = &vps##_value
#define PHOTON_VALUE(T, name) ph_##name,
#define PHOTON_LOAD(photons)                                     \
    const Photons photons##_value = {PHOTON_DATA(PHOTON_VALUE)}; \
    const Photons *photons = &photons##_value
#endif
