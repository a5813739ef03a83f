#ifndef PPM_FEATURES_H
#define PPM_FEATURES_H
/* The scene features the eye and photon passes compile (ppm_engine/features.py: built with
 * -D PPM_SPECIALIZED and one -D per feature the scene has).  A program built without
 * PPM_SPECIALIZED has every feature (tests, debug kernels, RenderOptions(specialize=False)).
 *   PPM_SPECULAR     mirrors or glass: the eye pass follows specular bounces
 *   PPM_GLASS        glass (refraction, Fresnel)
 *   PPM_LIGHT_POINT  point and spot lights      PPM_LIGHT_SUN   sun lights
 *   PPM_LIGHT_AREA   area lights                PPM_EMISSIVE    emissive triangles (and MIS)
 *   PPM_WORLD        an emitting world          PPM_LIGHTS_SEEN lights seen by camera rays
 *   PPM_DOF          depth of field             PPM_TEXTURES    image textures
 */
#ifndef PPM_SPECIALIZED
#define PPM_SPECULAR 1
#define PPM_GLASS 1
#define PPM_LIGHT_POINT 1
#define PPM_LIGHT_SUN 1
#define PPM_LIGHT_AREA 1
#define PPM_EMISSIVE 1
#define PPM_WORLD 1
#define PPM_LIGHTS_SEEN 1
#define PPM_DOF 1
#define PPM_TEXTURES 1
#endif
#endif
