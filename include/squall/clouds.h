/* squall/clouds.h — clouds from WRF output with a structured particle system (source document S4,
 * Wang, Xie & Yuan 2013; SPEC §8), physically corrected:
 *   - cloud field: the hydrometeor mass concentrations of a WRF run (cloud water, ice, snow,
 *     rain; g/m³), interpolated in time between the stored outputs, turned into extinction by
 *     the geometric-optics relation beta = 3 W / (2 rho r_eff) (include/squall/optics.h) and a
 *     Henyey–Greenstein phase with the extinction-weighted asymmetry (droplets 0.85, ice 0.75);
 *     sub-grid structure: the cloud fraction of a cell (CLDFRA, or cloud_fraction) is the share of it covered
 *     by a deterministic fBm pattern that keeps the cell's mean extinction;
 *   - clouds: connected cells whose condensate exceeds a threshold; per cloud the centre,
 *     extent, boundary cells and liquid/ice water paths;
 *   - particles: each cloud's cells filled with particles whose density follows the extinction
 *     (deterministic Philox seeding), carried by the wind, re-initialised at the end of their
 *     life; their optical depth keeps the field's extinction cross-section;
 *   - structured particles: leader clustering by the similarity measures (1)–(3) with per-
 *     attribute thresholds, deterministic and grid-accelerated (SPEC 8.3 ⚠);
 *   - drawing: published as an SQ_DRAWABLE_CLOUDS view (Harris multiple forward scattering with
 *     the g_{k−1} index, splat alpha, billboards, impostors: src/render/render_clouds.c) or, in
 *     volume mode, as an SQ_DRAWABLE_VOLUME of the same extinction field (half-angle slicing,
 *     and the reference path tracer).
 * Sources: a WRF file (netCDF, through the io layer's reader) or an analytic field (cumulus or
 * stratocumulus) for tests and benchmarks. Units: SI (m, s) except concentrations in g/m³. */
#ifndef SQ_CLOUDS_H
#define SQ_CLOUDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/plugin.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_clouds_source {
    SQ_CLOUDS_SOURCE_WRF = 0,       /* wrf_file */
    SQ_CLOUDS_SOURCE_CUMULUS = 1,   /* analytic cumulus field (tests, benchmarks) */
    SQ_CLOUDS_SOURCE_STRATOCUMULUS = 2 /* analytic broken stratocumulus deck */
} sq_clouds_source;

typedef enum sq_clouds_mode {
    SQ_CLOUDS_MODE_PARTICLES = 0, /* structured/plain particles, MFS, billboards, impostors */
    SQ_CLOUDS_MODE_VOLUME = 1     /* the extinction field as a volume (half-angle slicing) */
} sq_clouds_mode;

typedef enum sq_clouds_symbolic {
    SQ_CLOUDS_SYMBOLIC_S4 = 0, /* measure (3) as printed, clamped to [0, 1] */
    SQ_CLOUDS_SYMBOLIC_VDM = 1 /* normalised value-difference metric */
} sq_clouds_symbolic;

/* Zero fields take the defaults of `squall params clouds` (the table in
 * src/phen/clouds/clouds_plugin.c is the reference); fields marked "0 is physical" keep 0. */
typedef struct sq_clouds_desc {
    int source;                       /* sq_clouds_source */
    char wrf_file[SQ_PARAM_STRING_MAX]; /* WRF output (netCDF) for source wrf */
    double start_s;                   /* file time at phenomenon time 0, s after the first
                                         stored time; 0 is physical */
    uint64_t seed;                    /* particles, sub-grid pattern, leader order; 0 is valid */
    /* analytic sources */
    int synthetic_cells[3];           /* 0 -> 48 48 24 */
    double synthetic_size_m[3];       /* 0 -> 12000 12000 3000 */
    double synthetic_base_m;          /* cloud base above the terrain; 0 -> 800 m */
    double synthetic_lwc_g_m3;        /* peak liquid water; 0 -> 0.6 g/m³ */
    int synthetic_clouds;             /* cumulus count; 0 -> 5 */
    /* optics (include/squall/optics.h defaults) */
    double reff_droplet_um, reff_ice_um, reff_snow_um, reff_rain_um; /* 0 -> 10, 25, 100, 500 */
    double g_droplet, g_ice;          /* 0 -> 0.85, 0.75 */
    bool reff_fixed;                  /* ignore QNICE/QNRAIN (else r_eff of ice and rain from them) */
    bool rayleigh;                    /* S4's Rayleigh phase (seed reproduction only) */
    /* clouds */
    double threshold_g_m3;            /* condensate above which a cell is cloud; 0 -> 0.01 */
    bool no_subgrid;                  /* no sub-grid fBm structure inside model cells */
    double subgrid_scale_m;           /* horizontal size of sub-grid cells; 0 -> 6000 m */
    double cloud_fraction;            /* coverage where the file has no CLDFRA (or only a 0/1
                                         flag, or 0 in a cloudy cell); 0 -> 1 */
    /* particles */
    int particles;                    /* total; 0 -> 15000 */
    double particles_per_km3;         /* > 0: the count from the clouds' volume instead; 0 = off */
    double radius_m;                  /* billboard radius; 0 -> from the particle spacing */
    double lifetime_s;                /* 0 -> 1800 s */
    bool plain;                       /* draw every particle, not the structured particles */
    double cluster_radius_m;          /* position thresholds sigma = 1 - r / range; 0 -> radius */
    double sigma_density, sigma_stage, sigma_phase; /* thresholds; 0 -> 0.8, 0.6, 0.5 */
    int symbolic;                     /* sq_clouds_symbolic */
    /* lighting and drawing (the view's fields) */
    int mode;                         /* sq_clouds_mode */
    bool splat_opacity;               /* Harris/S4: T = 1 - (1 - e^-tau_splat) eta(t) */
    double eta1;                      /* splat peak eta_1; 0 -> 0.4 (S4) */
    double tau_splat;                 /* S4's tau_k; 0 -> 80 */
    double splat_noise;               /* splat texture noise amplitude; 0 -> 0.5 */
    bool smooth_splat;                /* no texture noise (S4's smooth splat) */
    double albedo;                    /* single-scattering albedo; 0 -> 0.999 */
    double gamma_sr;                  /* forward solid angle kept in the light; 0 -> 0.09 sr */
    int light_buffer;                 /* MFS light-buffer texels per side; 0 -> 512 */
    bool harris_only;                 /* no diffuse (two-stream) light added to Harris MFS */
    bool no_shadows;                  /* clouds do not shadow the terrain */
    double dist_3d_m;                 /* particles nearer than this; 0 -> 60 km */
    double dist_impostor_m;           /* impostors farther than this; 0 -> 90 km */
    double impostor_angle_deg;        /* refresh tolerance; 0 -> 2 deg */
    bool no_impostors;                /* particles at every distance */
    int volume_cells[3];              /* volume mode voxels; 0 -> 128 128 48 */
} sq_clouds_desc;

typedef struct sq_clouds sq_clouds;

/* Per-cloud statistics of the current state (world metres, concentrations in g/m³). */
typedef struct sq_cloud_info {
    sq_vec3 center_m;     /* condensate-weighted centre */
    sq_vec3 min_m, max_m; /* extent */
    int cells;            /* model cells */
    int boundary_cells;   /* cells with a 6-neighbour outside the cloud */
    double lwp_g_m2;      /* liquid water path (cloud + rain) averaged over the footprint */
    double iwp_g_m2;      /* ice water path (ice + snow) averaged over the footprint */
    double top_m;         /* highest cloudy cell centre, m above sea level (unexaggerated) */
} sq_cloud_info;

typedef struct sq_clouds_stats {
    int clouds;           /* connected clouds */
    int particles;        /* live particles */
    int clusters;         /* structured particles (= particles when structured is off) */
    double cover_fraction;   /* columns with any cloudy cell / all columns */
    double cloud_top_m;      /* highest cloudy cell, m above sea level */
    double lwp_g_m2, iwp_g_m2; /* domain means */
    double ms_model;      /* last step: field, segmentation, particles, clustering (ms) */
    double ms_cluster;    /* of which clustering */
} sq_clouds_stats;

/* Copies in to out with every zero field replaced by its default (see each field). Never
 * validates; SQ_ERR_INVALID_ARG only for NULL pointers. */
SQ_API sq_result sq_clouds_desc_resolve(const sq_clouds_desc *in, sq_clouds_desc *out);
/* Checks every rule of desc against world before anything is allocated: SQ_ERR_INVALID_ARG
 * naming sq_clouds_desc.<key>, the value and the rule; SQ_ERR_IO for an unreadable WRF file. */
SQ_API sq_result sq_clouds_validate(sq_context *ctx, const sq_clouds_desc *desc,
                                    const sq_world *world);
/* Bytes of the particle system and grids (the file's size is read at create). */
SQ_API uint64_t sq_clouds_memory_bytes(const sq_clouds_desc *desc);
SQ_API sq_result sq_clouds_create(sq_context *ctx, const sq_clouds_desc *desc,
                                  const sq_world *world, sq_clouds **out);
SQ_API void sq_clouds_destroy(sq_clouds *c);
SQ_API double sq_clouds_max_stable_dt(const sq_clouds *c);
SQ_API sq_result sq_clouds_step(sq_clouds *c, double dt_s);
SQ_API sq_result sq_clouds_stats_get(const sq_clouds *c, sq_clouds_stats *out);
/* Cloud i of sq_clouds_stats.clouds. */
SQ_API sq_result sq_clouds_cloud(const sq_clouds *c, int i, sq_cloud_info *out);
/* The drawable of the current state (the desc's mode). */
SQ_API sq_result sq_clouds_drawable(sq_clouds *c, sq_drawable *out);
/* The volume drawable of the same extinction field, whatever the mode (comparisons). */
SQ_API sq_result sq_clouds_volume_drawable(sq_clouds *c, sq_drawable *out);

#ifdef __cplusplus
}
#endif
#endif
