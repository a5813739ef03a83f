#ifndef PPM_FEATURES_H
#define PPM_FEATURES_H
/* The scene features the eye and photon passes compile (ppm_engine/features.py: built with
 * -D PPM_SPECIALIZED and one -D per feature the scene has).  A program built without
 * PPM_SPECIALIZED has every feature (tests, debug kernels, RenderOptions(specialize=False)).
 * Each flag is 0 or 1 here, so code tests it with #if, or in a plain condition
 * (if (PPM_LIGHT_SUN && ...)) whose dead branch the compiler drops.
 *   PPM_SHADER       a material that is not one Lambert closure (else shader.h's short path only)
 *   PPM_GATHER_SHADE a visible point whose closures are not one Lambert (the gather shades it)
 *   PPM_MICROFACET   GGX lobes (metals, glass, specular layers, coats)
 *   PPM_SHEEN        sheen                      PPM_OREN_NAYAR  rough diffuse
 *   PPM_TRANSLUCENT  translucency               PPM_TRANSPARENT alpha, Transparent BSDF
 *   PPM_ANISOTROPY   anisotropic lobes (the surface's tangents)
 *   PPM_LIGHT_POINT  point and spot lights      PPM_LIGHT_SUN   sun lights
 *   PPM_LIGHT_AREA   area lights                PPM_EMISSIVE    emissive triangles (and MIS)
 *   PPM_WORLD        an emitting world          PPM_LIGHTS_SEEN lights seen by camera rays
 *   PPM_DOF          depth of field             PPM_TEXTURES    image textures
 *   PPM_ABSORPTION   glass with absorption inside (medium.h)
 *   PPM_SVM          shader programs (svm.h; with PPM_SVM_OPS and PPM_SVM_STACK)
 */
#ifndef PPM_SPECIALIZED
#define PPM_ALL_FEATURES 1
#else
#define PPM_ALL_FEATURES 0
#endif
#ifndef PPM_SHADER
#define PPM_SHADER PPM_ALL_FEATURES
#endif
#ifndef PPM_GATHER_SHADE
#define PPM_GATHER_SHADE PPM_ALL_FEATURES
#endif
#ifndef PPM_MICROFACET
#define PPM_MICROFACET PPM_ALL_FEATURES
#endif
#ifndef PPM_SHEEN
#define PPM_SHEEN PPM_ALL_FEATURES
#endif
#ifndef PPM_OREN_NAYAR
#define PPM_OREN_NAYAR PPM_ALL_FEATURES
#endif
#ifndef PPM_TRANSLUCENT
#define PPM_TRANSLUCENT PPM_ALL_FEATURES
#endif
#ifndef PPM_TRANSPARENT
#define PPM_TRANSPARENT PPM_ALL_FEATURES
#endif
#ifndef PPM_ANISOTROPY
#define PPM_ANISOTROPY PPM_ALL_FEATURES
#endif
#ifndef PPM_LIGHT_POINT
#define PPM_LIGHT_POINT PPM_ALL_FEATURES
#endif
#ifndef PPM_LIGHT_SUN
#define PPM_LIGHT_SUN PPM_ALL_FEATURES
#endif
#ifndef PPM_LIGHT_AREA
#define PPM_LIGHT_AREA PPM_ALL_FEATURES
#endif
#ifndef PPM_EMISSIVE
#define PPM_EMISSIVE PPM_ALL_FEATURES
#endif
#ifndef PPM_WORLD
#define PPM_WORLD PPM_ALL_FEATURES
#endif
#ifndef PPM_LIGHTS_SEEN
#define PPM_LIGHTS_SEEN PPM_ALL_FEATURES
#endif
#ifndef PPM_DOF
#define PPM_DOF PPM_ALL_FEATURES
#endif
#ifndef PPM_TEXTURES
#define PPM_TEXTURES PPM_ALL_FEATURES
#endif
#ifndef PPM_ABSORPTION
#define PPM_ABSORPTION PPM_ALL_FEATURES
#endif
#ifndef PPM_SVM
#define PPM_SVM PPM_ALL_FEATURES
#endif
#endif
