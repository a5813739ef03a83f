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
    float filter_width;     /* the pixel filter (ppm_engine/film.py filter_table) */
    int filter_type;
    int film_transparent;   /* FILM_TRANSPARENT, FILM_TRANSPARENT_GLASS */
    float glass_roughness;  /* transparent glass: the roughest transmission still clear */
    float exposure;         /* applied by the film's resolve */
} Camera;
#define FILM_TRANSPARENT 1
#define FILM_TRANSPARENT_GLASS 2

/* mirrors materials.KMATERIAL_DTYPE (ppm_engine/materials.py derives it from the scene's
 * materials): what a pass needs of a material before it shades a hit */
#define MAT_EMISSIVE 1u       /* constant emission > 0: an emitter (emitters.py) */
#define MAT_GATHER 2u         /* some closure can hold a visible point and photons */
#define MAT_TRANSPARENT 4u    /* partly transparent (alpha, Transparent BSDF): shadow rays pass */
#define MAT_LAMBERT 8u        /* one node that makes one Lambert closure (and maybe emission):
                                 shader.h's short path */
typedef struct {
    float emission[3];   /* emitted radiance of its emission closures, before textures */
    uint flags;
    int emission_tex;    /* 1-based texture of the emission (kernels/textures.h), 0 = none */
    int node_first;      /* its BSDF nodes: shader_nodes[node_first, + node_count) */
    int node_count;
    float absorption[3]; /* absorption coefficient inside (per metre; glass only: medium.h) */
    int program;         /* first word of its shader program in svm[] (kernels/svm.h), 0 = none */
} Material;

/* BSDF node types: scene_arrays.py NODE_* */
#define NODE_PRINCIPLED 0
#define NODE_DIFFUSE 1
#define NODE_GLOSSY 2
#define NODE_METALLIC 3
#define NODE_GLASS 4
#define NODE_REFRACTION 5
#define NODE_TRANSLUCENT 6
#define NODE_TRANSPARENT 7
#define NODE_SHEEN 8
#define NODE_EMISSION 9
#define NODE_HOLDOUT 10
#define NODE_FLAG_MULTI_GGX 1u      /* multiple scattering compensated (Multiscatter GGX) */
#define NODE_FLAG_CONDUCTOR 2u      /* Metallic BSDF, Physical Conductor: color = n, edge_tint = k */

/* mirrors scene_arrays.SHADER_NODE_DTYPE: one BSDF node of a material with its constant
 * inputs (kernels/shader.h turns it into closures at a hit) */
typedef struct {
    int material;
    int type;
    uint flags;
    float weight;             /* mix weight: the Mix/Add Shader factors on its way to the output */
    float color[3];           /* Base Color / Color */
    float edge_tint[3];       /* Principled Specular Tint; Metallic Edge Tint */
    float emission[3];        /* emission colour x strength */
    float coat_tint[3];
    float sheen_tint[3];
    float roughness;
    float metallic;
    float ior;
    float alpha;
    float transmission;
    float specular_ior_level;
    float anisotropic;
    float anisotropic_rotation;
    float coat_weight;
    float coat_roughness;
    float coat_ior;
    float sheen_weight;
    float sheen_roughness;
    float subsurface_weight;
    float diffuse_roughness;
    int color_texture;        /* 1-based textures multiplying color / emission / alpha */
    int emission_texture;
    int alpha_texture;
    uint bound;               /* inputs its material's program drives (shader_program.BOUND) */
    float normal[3];          /* Normal, Coat Normal (world, viewer's side); 0 = the surface's */
    float coat_normal[3];
} ShaderNode;

/* Emitters for photon emission and next-event estimation, indexed 0..n_emitters-1:
 * [0, n_lights) scene lights, then emissive triangles, then the world (if it emits); and the
 * scene's size (mirrors emitters.EMITTER_INFO_DTYPE). */
typedef struct {
    int n_lights;
    int n_emissive;
    int has_world;
    int n_emitters;
    float world[3];
    float scene_center[3];
    float scene_radius;
    float offset_scale;  /* the scene's size for the ray offsets (geometry.h offset_ray) */
    int world_program;   /* the world's shader program (word in svm), 0 = the constant world */
    int world_flags;     /* WORLD_HIDDEN_CAMERA: camera rays do not see the world */
    int map_w;           /* the world's importance map (world.h; ppm_engine/world_map.py) */
    int map_h;
    float map_mean;      /* mean of the map's values (sin(theta) included) */
    float local_center[3];   /* the emissive triangles' bounding ball where next-event */
    float local_radius;      /* estimation picks among them locally (light_mesh.h); 0: never */
} EmitterInfo;
#define WORLD_HIDDEN_CAMERA 1

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
