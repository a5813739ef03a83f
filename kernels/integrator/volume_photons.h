#ifndef PPM_VOLUME_PHOTONS_H
#define PPM_VOLUME_PHOTONS_H
#include "rng.h"
#include "scene.h"
#include "geom/geometry.h"
#include "geom/medium.h"
#include "geom/medium_field.h"
#include "integrator/pass_state.h"
#include "integrator/path_state.h"

/* Photons in homogeneous media (PPM_VOLUME; docs/VOLUMES.md).  A photon crossing a scattering
 * medium samples a free-flight distance as the eye paths do (geom/medium.h medium_sample: a
 * channel picked by its flux times the albedo, its flux times the transmittance, and the
 * scattering coefficient where it scatters, over the density).  Where it scatters after at least
 * one scattering (the light's first is next-event estimation's, as on surfaces) it is stored as a
 * volume photon: a point with its flux and the direction it came from, which the camera's
 * segments gather by the beam radiance estimate (volume_gather.cl).  Which ones are stored and
 * whether the photon goes on is photon_pass.cl's: with eye paths for the indirect light those
 * after a chain of singular scatterings only (L S+ M, the volumetric caustic: a camera path's
 * next-event estimation in the medium cannot see the light through glass), the photon ending
 * there; with photons for it every one, the photon going on along the phase function. */
#if PPM_VOLUME
/* The segment o + s d (0 <= s < t) in the media of a photon of flux *flux (every one on the
 * stack, summed: geom/medium.h media_mix): where it scatters (*p, returning the innermost
 * medium's material, *g the media's anisotropy) or -1 where it crosses (or the media scatter
 * nothing); *flux times the transmittance over the density, times the scattering coefficient
 * where it scattered. */
inline int photon_medium(const Scene *scene, const Media *media, float3 o, float3 d, float t,
                         uint *rng, float3 *flux, float3 *p, float *g) {
    int vm = media_top(media);
    if (vm < 0) return -1;
    Mix x = media_mix(media, scene->materials);
    *g = x.g;
    if (x.field >= 0) { /* a heterogeneous medium: tracked (geom/medium_field.h) */
        float s = medium_track(scene, &x, o, d, t, mix_scatters(&x), ratio_rate(t), 0.0f, rng, flux,
                               0);
        if (!(s < INFINITY)) return -1;
        *p = o + s * d;
        return vm;
    }
    float3 sigma_t = x.sigma_a + x.sigma_s, sigma_s = x.sigma_s;
    if (!(max3(sigma_s) > 0.0f)) {
        *flux *= medium_tr(sigma_t, t);
        return -1;
    }
    float pdf, u_c = rnd(rng), u_t = rnd(rng);
    float s = medium_sample(sigma_t, sigma_s, t, u_c, u_t, flux, &pdf);
    if (!(s < INFINITY)) return -1;
    *p = o + s * d;
    return vm;
}

/* A volume photon at p that travelled along d with flux `flux` and bounces ppath
 * (path_state.h: the camera path that gathers it joins them), in the first `capacity` slots
 * (counted in CNT_VSTORED; none in a pilot, capacity 0); whether it was counted */
inline bool store_volume_photon(const Photons *photons, float3 p, float3 d, float3 flux, uint ppath,
                                uint capacity, __global uint *counters) {
    if (capacity == 0u) return false;
    if (!(isfinite(flux.x) && isfinite(flux.y) && isfinite(flux.z))) {
        atomic_inc(&counters[CNT_NAN]);
        return false;
    }
    uint k = atomic_inc(&counters[CNT_VSTORED]);
    if (k >= capacity) return true; /* (the next pass has room: VolumeGather.grow) */
    photons->vpos[k] = (float4)(p, 0.0f);
    photons->vflux[k] = (float4)(flux, as_float(pack_unit(-d)));
    photons->vpath[k] = ppath;
    return true;
}
#endif
#endif
