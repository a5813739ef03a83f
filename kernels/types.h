/* Structs shared by the kernels.  Each mirrors a NumPy dtype field for field; only 4-byte
 * scalars and arrays of them, so there is no padding (tests/test_kernels.py test_struct_layouts_match_dtypes checks the
 * sizes on every device). */
#ifndef PPM_TYPES_H
#define PPM_TYPES_H
#include "features.h"

/* visibility bits: ppm_engine/scene_arrays.py VIS_* */
#define VIS_CAMERA 1u
#define VIS_DIFFUSE 2u
#define VIS_GLOSSY 4u
#define VIS_TRANSMISSION 8u
#define VIS_SHADOW 16u

/* light types: scene_arrays.py LIGHT_* */
#define LIGHT_POINT 0
#define LIGHT_SPOT 1
#define LIGHT_SUN 2
#define LIGHT_AREA_RECT 3
#define LIGHT_AREA_ELLIPSE 4
#define LIGHT_FLAG_SOFT_FALLOFF 1u
/* a light hidden from a ray type (object visible_camera/glossy/transmission off):
 * its VIS_* bit shifted by LIGHT_HIDDEN_SHIFT in flags */
#define LIGHT_HIDDEN_SHIFT 8

#define CAMERA_PERSP 0
#define CAMERA_ORTHO 1

/* mirrors scene_arrays.LIGHT_DTYPE */
typedef struct {
    int type;
    uint flags;
    float emit[3];
    float position[3];
    float direction[3];
    float axis_x[3];
    float axis_y[3];
    float radius;
    float spot_cos_half;
    float spot_smooth;
    float spot_scale_z;
} Light;

/* mirrors scene_arrays.CAMERA_DTYPE */
typedef struct {
    int type;
    int width;
    int height;
    int region[4];
    float to_world[12];
    float extent[2];
    float shift[2];
    float clip[2];
    float aperture_radius;
    float focus_distance;
    int aperture_blades;
    float aperture_rotation;
    float aperture_ratio;
    float filter_width;     /* 0: box; > 0: Blackman-Harris over +-filter_width pixels */
} Camera;

/* mirrors materials.KMATERIAL_DTYPE: the lobes the kernels sample, derived from
 * scene_arrays.MATERIAL_DTYPE by ppm_engine/materials.py */
#define MAT_EMISSIVE 1u
#define MAT_DIFFUSE 2u
typedef struct {
    float diffuse[3];    /* Lambert albedo */
    float specular[3];   /* mirror (metal) reflectance */
    float transmit[3];   /* glass transmission tint */
    float emission[3];   /* radiance, both sides */
    float ior;
    float p_metal;       /* lobe selection probability = mixture weight */
    float p_glass;
    uint flags;
    int diffuse_tex;     /* 1-based texture of the base colour (kernels/textures.h), 0 = none */
    int emission_tex;    /* 1-based texture of the emission colour, 0 = none */
    float absorption[3]; /* absorption coefficient inside (per metre; glass only: medium.h) */
} Material;

/* Emitters for photon emission and next-event estimation, indexed 0..n_emitters-1:
 * [0, n_lights) scene lights, then emissive triangles, then the world (if it emits). */
typedef struct {
    int n_lights;
    int n_emissive;
    int has_world;
    int n_emitters;
    float world[3];
    float scene_center[3];
    float scene_radius;
} EmitterInfo;

/* grid of the stochastic hash; written on the device by grid_setup (hash_build.cl) */
typedef struct {
    float bmin[3];
    float bmax[3];
    float cell_size;
    float inv_cell_size;
    float r_max;
    float r_min;
    uint valid;          /* number of visible points this pass */
    uint pad;
} Grid;

#define F3(a) ((float3)((a)[0], (a)[1], (a)[2]))

#endif
