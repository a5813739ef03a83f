/* Photon pass: photons emitted from the emitters in proportion to power, traced through
 * specular and diffuse bounces with Russian roulette, stored at diffuse hits after the first
 * (direct light is counted by next-event estimation in the eye pass).  Photons outside this
 * pass's grid (visible points' bounds) cannot be gathered and are only counted. */
#include "photon_emission.h"
#include "hash.h"

#include "counters.h"
#include "medium.h"

__kernel void photon_pass(SCENE_ARGS, uint pass_index, uint seed, int max_bounces, uint n_photons,
                          __global const Grid *grid, uint capacity, __global float4 *ph_pos,
                          __global float4 *ph_flux, __global uint *counters) {
    uint id = get_global_id(0);
    if (id >= n_photons) return;
    Grid g = *grid;
    if (g.valid == 0u) return;
    uint rng = rng_seed(seed, pass_index, id, 2u);
    float3 o, d, flux;
    if (!emit_photon(SCENE_PASS, &rng, &o, &d, &flux)) return;
    uint mask = VIS_SHADOW;    /* the light's own segment: objects that cast no shadow let it by */
#if PPM_ABSORPTION
    Media media;
    media_init(&media);
#endif
    for (int bounce = 0; bounce <= max_bounces; bounce++) {
        Hit h = bvh_intersect(o, d, PPM_INF, mask, false, BVH_PASS);
        if (h.leaf < 0) break;
        float3 before = flux;             /* Russian roulette below: this bounce's albedo */
#if PPM_ABSORPTION
        flux *= media_transmittance(&media, materials, h.t);      /* the segment's medium */
#endif
        Surface s = surface_at(h, tri_v0, tri_e1, tri_e2, normals);
        __global const Material *m = materials + s.material;
        bool front = dot(d, s.ng) < 0.0f;
        float3 ngf = front ? s.ng : -s.ng, nsf = front ? s.ns : -s.ns;
        if (bounce > 0 && (m->flags & MAT_DIFFUSE)) {
            if (!(isfinite(flux.x) && isfinite(flux.y) && isfinite(flux.z))) {
                atomic_inc(&counters[CNT_NAN]);
                break;
            }
            if (in_grid(s.p, &g)) {
                uint k = atomic_inc(&counters[CNT_STORED]);
                if (k < capacity) {
                    ph_pos[k] = (float4)(s.p, as_float(pack_unit(nsf)));
                    ph_flux[k] = (float4)(flux, as_float(pack_unit(-d)));
                } else {
                    atomic_inc(&counters[CNT_OVERFLOW]);
                }
            } else {
                atomic_inc(&counters[CNT_OUTSIDE]);
            }
        }
        if (bounce == max_bounces) break;
        int lobe = choose_lobe(m, rnd(&rng));
        if (lobe == LOBE_ABSORBED) break;
        float measure = 1.0f;             /* refraction's (eta_i/eta_t)^2 on the flux */
        float3 tint = texture_tint(m->diffuse_tex, s.tri, h.u, h.v, TEXTURE_PASS);
        if (lobe == LOBE_DIFFUSE) {
            d = sample_cosine_hemisphere(nsf, rnd(&rng), rnd(&rng));
            if (dot(d, ngf) <= 0.0f) break;
            flux *= F3(m->diffuse) * tint;
            o = offset_ray(s.p, ngf);
            mask = VIS_DIFFUSE;
        } else {
#if PPM_SPECULAR
            float3 leave_n;
            lobe = scatter_specular(lobe, m, tint, s.ng, s.ns, rnd(&rng), false, &d, &flux,
                                    &leave_n, &measure);
#if PPM_ABSORPTION
            if (lobe == LOBE_GLASS_TRANSMIT) media_cross(&media, s.material, front);
#endif
            o = offset_ray(s.p, leave_n);
            mask = lobe == LOBE_GLASS_TRANSMIT ? VIS_TRANSMISSION : VIS_GLOSSY;
#endif
        }
        /* Russian roulette keeps photon power roughly constant: survival is the scattering's
         * albedo (times the medium's transmittance).  The change of measure of refraction is left out of it: a photon entering
         * glass (flux x 1/eta^2) survived with probability 1/eta^2 = 0.44, and one leaving it
         * got x eta^2 back, so behind n panes 0.44^n of the photons carried 2.25^n of the flux:
         * the same mean, and no photon at all behind 20 panes in a pass. */
        float q = fmin(1.0f, max3(flux) / (max3(before) * measure));
        if (!(q > 0.0f) || rnd(&rng) >= q) break;
        flux /= q;
    }
}
