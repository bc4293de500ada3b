/* squall/snowdrift.h — wind-driven snowfall and drifting snow (source document S1, Wang et al.
 * 2004), physically corrected as SPEC §5 recommends:
 *   - wind: the D3Q15 lattice-Boltzmann solver of squall/lbm.h (Smagorinsky-stabilised, τ > ½,
 *     corrected equilibrium), terrain and obstacles as bounce-back cells, a free-slip sky, S1's
 *     recycling of the outflow (periodic x and y) held at the requested wind by a controlled
 *     body force, or an inflow face with a log-law profile; gusts by Beaufort level with zero
 *     mean (SPEC §5.5);
 *   - snow on the same lattice (SPEC §5.6): integer flake counts per cell, carried
 *     stochastically with mean displacement (u − u_fall)Δt, deposited by the stable/roll-off
 *     rules, cells holding more than `threshold` flakes turn solid and obstruct the wind,
 *     erosion where the friction velocity exceeds its threshold (S1 eqs 12–13 on u*);
 *   - snowfall in mm/h water equivalent; one flake is 1/threshold of a cell of deposited snow
 *     (see `speedup` for time-lapse accumulation);
 *   - drawables: falling flakes (a visual particle pool carried by the lattice wind) and the
 *     snow cover (a heightfield of deposited depth over the world).
 * Units: SI everywhere. */
#ifndef SQ_SNOWDRIFT_H
#define SQ_SNOWDRIFT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_snowdrift_boundary {
    SQ_SNOWDRIFT_RECYCLE = 0, /* S1: what leaves one side re-enters the other (periodic x, y) */
    SQ_SNOWDRIFT_INFLOW = 1   /* log-law inflow on the upwind x face, outflow on the other */
} sq_snowdrift_boundary;

/* Zero fields take the defaults named in `squall params snowdrift` (the parameter table in
 * src/phen/snowdrift/snowdrift_plugin.c is the reference); fields marked "0 is physical" keep 0. */
typedef struct sq_snowdrift_desc {
    uint64_t seed;               /* 0 is a valid seed */
    /* domain: the wind/snow lattice */
    int cells[3];                /* 0 -> 128 64 48 */
    double cell_size_m;          /* 0 -> 1 m */
    double center_m[2];          /* domain centre x, y; 0 is physical */
    double dt_s;                 /* lattice (wind) time step; 0 -> automatic: the fastest wind
                                  * with gusts moves 0.08 cells per step */
    /* wind (SPEC §5.2–5.5) */
    double wind_speed_mps;       /* mean wind at ref_height_m; 0 is physical (calm) */
    double wind_dir_deg;         /* direction the wind blows toward, deg from east; 0 is physical */
    double beaufort;             /* gust level n_B, amplitude μ_g = n_B/20; 0 is physical (none) */
    double gust_period_s;        /* gusts redrawn this often; 0 -> 3 s */
    double wind_ramp_mps2;       /* progressive set-up rate; 0 is physical (instantaneous) */
    double ref_height_m;         /* height of the quoted wind above the ground; 0 -> 10 m */
    double roughness_m;          /* log-law roughness z0 of the snow surface; 0 -> 0.005 m */
    int boundary;                /* sq_snowdrift_boundary; 0 = recycle (S1) */
    double eddy_viscosity_m2s;   /* background viscosity of the lattice air; 0 -> 0.01 m²/s */
    double smagorinsky_c;        /* Smagorinsky constant; 0 -> 0.16 */
    double tau;                  /* lattice relaxation time (> 1/2); 0 -> from
                                  * eddy_viscosity_m2s: 1/2 + 3 ν Δt/Δx² */
    /* snow (SPEC §5.6) */
    double snowfall_mmh;         /* water-equivalent snowfall rate; 0 is physical (none) */
    double speedup;              /* time-lapse factor of snowfall and erosion; 0 -> 1 */
    double fall_speed_mps;       /* settling speed of flakes; 0 -> 1.0 m/s */
    int threshold;               /* flakes that fill a cell (more: solid); 0 -> 10 (S1) */
    double snow_density_kgm3;    /* deposited snow density (flake mass); 0 -> 150 kg/m³ */
    bool no_erosion;             /* true: deposited snow never lifts */
    double ustar_threshold_mps;  /* erosion threshold friction velocity; 0 -> 0.25 m/s */
    double erosion_efficiency;   /* eff in S1 eq 13, in (0, 1]; 0 -> 1 */
    double saturation_time_s;    /* t_sat in S1 eq 12; 0 -> 1 s */
    double saltation_kgm3;       /* airborne snow in a surface cell at saturation; 0 -> 0.05 */
    double snow_cfl;             /* largest flake displacement per snow step, cells; 0 -> 0.5 */
    /* drawables */
    int visual_flakes;           /* falling-snow particles drawn; 0 is physical (none) */
    double flake_radius_m;       /* drawn flake radius; 0 -> 0.03 m */
    /* smallest angular radius a flake is drawn with (mrad); a flake seen smaller is enlarged to
     * it and made fainter by (true/drawn radius)², keeping its projected area x opacity (a
     * radius of 0.9 px at 360 px of height and a 55° field of view is 2.5 mrad); 0 -> 2.5 */
    double flake_min_mrad;
} sq_snowdrift_desc;

typedef struct sq_snowdrift sq_snowdrift;

/* Snow budget since creation. fallen = airborne + deposited + left, exactly in flakes. */
typedef struct sq_snowdrift_budget {
    uint64_t fallen_flakes, airborne_flakes, deposited_flakes, left_flakes, eroded_flakes;
    double flake_mass_kg;
    double fallen_kg, airborne_kg, deposited_kg, left_kg;
    int64_t snow_cells;          /* cells filled with snow (solid for the wind) */
    double depth_mean_m, depth_max_m; /* deposited depth over the domain's columns */
} sq_snowdrift_budget;

/* Work done since creation and the wall-clock time of each stage (ms, summed over all calls;
 * for benchmarks: `squall bench snowdrift`). */
typedef struct sq_snowdrift_stats {
    int64_t steps;          /* sq_snowdrift_step calls */
    int64_t lbm_steps;      /* lattice (wind) steps */
    int64_t snow_steps;     /* snow steps (each spans lbm_steps_per_snow_step wind steps) */
    int lbm_steps_per_snow_step;
    double lbm_dt_s;        /* wind step */
    int64_t cells;          /* lattice cells */
    double ms_lbm;          /* wind: collide + stream, boundaries, drive */
    double ms_ustar;        /* friction velocity (and the velocity views it needs) */
    double ms_transport;    /* snowfall + stochastic transport */
    double ms_deposit;      /* deposition, roll-off, solidification */
    double ms_erode;        /* erosion */
    double ms_couple;       /* snow cells turned solid / fluid in the wind lattice */
    double ms_flakes;       /* visual flakes moved by the wind */
    double ms_derived;      /* drawables: snow cover heightfield, airborne-snow field */
    double ms_budget;       /* budget / metrics */
} sq_snowdrift_stats;

/* Copies in to out with zero fields replaced by their defaults (the table of `squall params
 * snowdrift`); never validates. */
SQ_API sq_result sq_snowdrift_desc_resolve(const sq_snowdrift_desc *in, sq_snowdrift_desc *out);
/* Every rule of desc (the lattice's own rules, tau and Mach, through sq_lbm_desc_validate;
 * obstacles inside the lattice) before anything is allocated: SQ_ERR_INVALID_ARG naming
 * sq_snowdrift_desc.<key>, the value and the rule. */
SQ_API sq_result sq_snowdrift_validate(sq_context *ctx, const sq_snowdrift_desc *desc,
                                       const sq_world *world);
/* Bytes sq_snowdrift_create will allocate for a resolved desc. */
SQ_API uint64_t sq_snowdrift_memory_bytes(const sq_snowdrift_desc *desc);
/* world: terrain and obstacles become solid cells; borrowed, must outlive the snowdrift. */
SQ_API sq_result sq_snowdrift_create(sq_context *ctx, const sq_snowdrift_desc *desc,
                                     const sq_world *world, sq_snowdrift **out);
SQ_API void sq_snowdrift_destroy(sq_snowdrift *s);
/* Advances dt_s: as many wind steps as fit (the lattice step is fixed by the Mach limit; the
 * remainder carries over), a snow step every few wind steps. */
SQ_API sq_result sq_snowdrift_step(sq_snowdrift *s, double dt_s);
/* 0: any step (the phenomenon sub-cycles internally). */
SQ_API double sq_snowdrift_max_stable_dt(const sq_snowdrift *s);
/* Changes the mean wind during a run (Mach-checked). */
SQ_API sq_result sq_snowdrift_set_wind(sq_snowdrift *s, double speed_mps, double dir_deg);
SQ_API void sq_snowdrift_get_budget(const sq_snowdrift *s, sq_snowdrift_budget *out);
SQ_API void sq_snowdrift_get_stats(const sq_snowdrift *s, sq_snowdrift_stats *out);

#ifdef __cplusplus
}
#endif
#endif
