/* squall/snowcover.h — snow lying on every surface of the world and falling snow around the
 * camera (source document S2, Hu et al., chapter 2; SPEC §6 with its corrections):
 *   - depth in metres accumulated over simulated time: a snowfall rate (mm/h water equivalent)
 *     and the density of the fallen snow give d(depth)/dt = rate ρ_water / ρ_snow on the highest
 *     surface of every column, kept in a top-down accumulation grid over the world; the named
 *     levels none / light / medium / heavy are presets of that model (hours of snowfall before
 *     t = 0 at a rate);
 *   - the renderer's snow cover (sq_snow_cover_view): the adaptive view-dependent occlusion map,
 *     exposure × inclination, the displaced snow shell and the snow BRDF (render_snowcover.c);
 *   - falling snow (SPEC §6.6): a pool of flakes in an emitter placed relative to the camera,
 *     linear drag toward the wind with the exact exponential update (terminal fall speed v_t,
 *     drag rate k_d = g / v_t), velocity noise scaled by √Δt, spin, recycling at the birth
 *     position when a flake reaches the ground; drawn in 3–5 depth layers with their own base
 *     sizes and the distance-attenuation law S = S_layer √(1 / (A + B D + C D²)) (S2 eq 2.4),
 *     hidden nearer than the first layer.
 * Units: SI everywhere. */
#ifndef SQ_SNOWCOVER_H
#define SQ_SNOWCOVER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/field.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_snowcover_level {
    SQ_SNOWCOVER_CUSTOM = 0, /* snowfall_mmh and prior_h as given */
    SQ_SNOWCOVER_NONE = 1,   /* bare: no snow lying, none falling */
    SQ_SNOWCOVER_LIGHT = 2,  /* 1 mm/h for 2 h before t = 0: 2 cm at 100 kg/m3 */
    SQ_SNOWCOVER_MEDIUM = 3, /* 2.5 mm/h for 4 h: 10 cm */
    SQ_SNOWCOVER_HEAVY = 4   /* 5 mm/h for 6 h: 30 cm */
} sq_snowcover_level;

/* Zero fields take the defaults named in `squall params snowcover` (the parameter table in
 * src/phen/snowcover/snowcover_plugin.c is the reference); "0 is physical" fields keep 0. */
typedef struct sq_snowcover_desc {
    uint64_t seed;              /* 0 is a valid seed */
    /* snowfall and depth */
    int level;                  /* sq_snowcover_level; 0 = custom */
    double snowfall_mmh;        /* water-equivalent rate; 0 is physical (none) */
    double density_kgm3;        /* of the lying snow; 0 -> 100 kg/m3 */
    double prior_h;             /* hours of snowfall at the rate before t = 0; 0 is physical */
    double speedup;             /* time-lapse factor of the accumulation; 0 -> 1 */
    double cell_m;              /* accumulation grid cell; 0 -> the world's extent / 512, >= 1 m */
    /* occlusion map and look (SPEC §6.2–6.5) */
    double detail_m;            /* D_snow; 0 -> 250 m */
    int map_size;               /* texels per side; 0 -> 1024 */
    int taps;                   /* M: 1, 4, 5 or 9; 0 -> 4 (S2) */
    double tap_radius;          /* texels; 0 -> 1 */
    double bias_m;              /* depth bias b; 0 -> 0.05 m */
    double noise;               /* noise amplitude of inclination and normal; 0 -> 0.3 */
    double noise_scale_m;       /* first-octave wavelength; 0 -> 2 m */
    double shell_blend;         /* shell direction: toward 0 smoothed normal .. 1 up; 0 -> 0.5 */
    int brdf;                   /* sq_snow_brdf: 0 physical, 1 Blinn–Phong (S2) */
    double albedo;              /* snow albedo (green; red and blue from it); 0 -> 0.9 */
    double sparkle;             /* glints, (0, 1]; 0 -> 0.5 */
    double shininess;           /* Blinn–Phong exponent; 0 -> 24 */
    /* falling snow */
    int flakes;                 /* pool size; 0 is physical (none) */
    int layers;                 /* depth layers 3..5; 0 -> 4 */
    double near_m;              /* first layer's near edge: nearer flakes hidden; 0 -> 1.5 m */
    double reach_m;             /* emitter depth ahead of the camera; 0 -> 80 m */
    double size_mrad;           /* base angular radius of the first layer at D = 1 m; 0 -> 6 */
    double layer_growth;        /* base size ratio between successive layers; 0 -> 1.3 */
    float atten[3];             /* A, B, C of eq 2.4 (D in m); all 0 -> 0, 1, 0 */
    double fall_speed_mps;      /* terminal fall speed v_t; 0 -> 1 m/s (0.5–1.5) */
    double turbulence_mps;      /* stationary std of the velocity noise; 0 is physical */
    double spin_rad_s;          /* largest flake spin; 0 is physical (none) */
    double wind_speed_mps;      /* wind the flakes relax toward; 0 is physical */
    double wind_dir_deg;        /* direction it blows toward, from east ccw; 0 is physical */
} sq_snowcover_desc;

typedef struct sq_snowcover sq_snowcover;

/* Copies in to out with zero fields replaced by their defaults (the table of `squall params
 * snowcover`); never validates. */
SQ_API sq_result sq_snowcover_desc_resolve(const sq_snowcover_desc *in, sq_snowcover_desc *out);
/* Every rule of desc (and against world) before anything is allocated: SQ_ERR_INVALID_ARG
 * naming sq_snowcover_desc.<key>, the value and the rule. */
SQ_API sq_result sq_snowcover_validate(sq_context *ctx, const sq_snowcover_desc *desc,
                                       const sq_world *world);
/* Bytes sq_snowcover_create will allocate for a resolved desc on world. */
SQ_API uint64_t sq_snowcover_memory_bytes(const sq_snowcover_desc *desc, const sq_world *world);
/* world: borrowed, must outlive the phenomenon. */
SQ_API sq_result sq_snowcover_create(sq_context *ctx, const sq_snowcover_desc *desc,
                                     const sq_world *world, sq_snowcover **out);
SQ_API void sq_snowcover_destroy(sq_snowcover *s);
/* Adds dt_s × speedup of snowfall to the depth and moves the flakes. SQ_ERR_TOO_LARGE, with the
 * state unchanged, when the depth would pass the deepest snow cover ever measured (11.82 m):
 * a rate or time-lapse mistake, not a scene the displaced shell can show. */
SQ_API sq_result sq_snowcover_step(sq_snowcover *s, double dt_s);
/* 0: any step (flakes are updated with the exact exponential solution). */
SQ_API double sq_snowcover_max_stable_dt(const sq_snowcover *s);
/* The camera the emitter follows and the layers are measured from (also set by the scene). */
SQ_API void sq_snowcover_observe(sq_snowcover *s, const sq_camera *camera);
/* Inputs from another layer (the scene passes the snowdrift's, SPEC §6 with §5): its snow depth
 * (a 2D field, level SQ_FIELD_LEVEL_SURFACE) replaces this model's depth where it covers the
 * grid, and its wind (u, v, w on a 3D grid) is the wind the flakes relax toward inside it
 * (no wind in its solid cells). Borrowed: valid until the source's next step; NULL clears. */
SQ_API void sq_snowcover_set_inputs(sq_snowcover *s, const sq_named_field *depth,
                                    const sq_named_field *u, const sq_named_field *v,
                                    const sq_named_field *w);
/* Depth (m) on exposed flat ground now: (prior + accumulated) water × ρ_water / ρ_snow. */
SQ_API double sq_snowcover_depth_m(const sq_snowcover *s);

/* The falling-snow update of one flake over dt (SPEC §6.6, exact for piecewise-constant wind):
 * v(t) = w + v_t + (v0 - w - v_t) e^{-k t}, k = g / |v_t|, with v_t = (0, 0, -fall_speed) and
 * the position its integral; noise is added by the caller. For tests. */
SQ_API void sq_snowcover_flake_update(const double wind[3], double fall_speed_mps, double dt_s,
                                      double pos[3], double vel[3]);

#ifdef __cplusplus
}
#endif
#endif
