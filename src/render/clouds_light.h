/* clouds_light.h — CPU side of the cloud pass (SPEC 8.4–8.5; Harris & Lastra 2001, Harris 2003):
 * the splat falloff and opacity of a cloud particle, the phase functions, the multiple forward
 * scattering light sweep and the impostor cross-fade weight. No GL: the GL pass
 * (render_clouds.c), the tests and the benchmark use it. */
#ifndef SQ_CLOUDS_LIGHT_H
#define SQ_CLOUDS_LIGHT_H

#include <stddef.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "render/depth_sort.h"
#include "squall/drawable.h"
#include "squall/sqmath.h"

/* eta(t) / eta_1 = 2|t|³ - 3t² + 1 for |t| <= 1, 0 beyond (SPEC 8.5 ⚠: |t|, clamped). */
float sq__cloud_splat(float t);
/* Opacity alpha of a particle at sprite radius t (see sq_clouds_view). */
float sq__cloud_alpha(const sq_clouds_view *v, float tau, float t);
/* Phase function (1/sr, normalised to 1) for the eye pass: HG(g) or Rayleigh. cos_theta is the
 * dot of the propagation directions (sun light, light toward the eye). */
float sq__cloud_phase(const sq_clouds_view *v, float g, float cos_theta);
/* Fraction of the scattered light that stays in the beam: p(0) gamma, at most 1 (Harris's
 * a tau p(l, -l) gamma / 4 pi with p normalised to 4 pi). */
float sq__cloud_forward_fraction(const sq_clouds_view *v, float g);
/* Impostor weight of a cloud at distance d: 0 up to dist_3d (particles only), 1 from
 * dist_impostor on (impostor only), a smoothstep between (both, cross-faded). */
float sq__cloud_impostor_weight(float d, float dist_3d, float dist_impostor);

/* Result of the light sweeps, per particle (input order) and as a shadow map. */
typedef struct sq__cloud_light {
    int n;
    float *sun;     /* I_k: light reaching particle k as a ratio to the sun (Harris MFS) */
    float *direct;  /* Beer transmittance toward the sun (no in-scatter) */
    float *diffuse; /* multiply scattered radiance / E: Eddington slab along the sun ray */
    float *sky;     /* ambient transmittance from above (two-stream on the zenith depth) */
    /* the sun sweep's buffer after every particle: light arriving below the clouds */
    int nx, ny;
    float *shadow;
    sq_mat4 shadow_matrix; /* world -> (u, v) in [0, 1]² of the shadow map */
    float texel_m;
    /* workspace */
    size_t cap, buf_cap;
    uint32_t *key, *idx, *key2, *idx2;         /* sun order (idx) and scratch */
    uint32_t *key_s, *idx_s, *key_s2, *idx_s2; /* zenith order and scratch */
    float *buf_d, *buf_sky;
    uint64_t comparisons;
} sq__cloud_light;

/* Runs the sun sweep (MFS light, Beer transmittance, shadow map) and, when the view asks for
 * the diffuse term, the zenith sweep; sun_dir points toward the sun. Particles are processed
 * in order of their distance from the light (stable radix sort), each reading the buffer at
 * its centre (I_k) and then splatting g_k + T_k I into it, so that I_k = g_{k-1} + T_{k-1}
 * I_{k-1} along a ray (SPEC 8.4 ⚠: g_{k-1}, not S4's g_{k+1}). Splats conserve the particle's
 * attenuation cross-section on the texel grid. */
sq_result sq__cloud_light_compute(sq_context *ctx, sq__cloud_light *L, const sq_clouds_view *v,
                                  sq_vec3 sun_dir);
void sq__cloud_light_free(sq_context *ctx, sq__cloud_light *L);

/* The sweeps' and the eye pass's orderings: render/depth_sort.h. */

#endif
