/* squall/drawable.h — the contract between phenomena and renderers (ARCHITECTURE.md).
 * A phenomenon publishes read-only views after each step; the renderer (GL or the reference
 * path tracer) draws them by kind and never learns which phenomenon made them. All pointers
 * are borrowed: valid until the owner's next step or destroy. */
#ifndef SQ_DRAWABLE_H
#define SQ_DRAWABLE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/sqmath.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sq_drawable_kind {
    SQ_DRAWABLE_NONE = 0,
    SQ_DRAWABLE_VOLUME = 1,
    SQ_DRAWABLE_PARTICLES = 2,
    SQ_DRAWABLE_SURFACE = 3,
    SQ_DRAWABLE_CLOUDS = 4,
    SQ_DRAWABLE_SNOW_COVER = 5
} sq_drawable_kind;

/* Participating medium on a regular grid inside an axis-aligned box.
 * Extinction coefficient of channel c at a point: beta_ext[c] = density * sigma_ext[c] (1/m).
 * Scattering: beta_sca = albedo[c] * beta_ext[c]. Phase: Henyey–Greenstein with g[c]
 * (cos theta = dot of propagation directions, g > 0 forward), optionally mixed with a second
 * lobe g2 with weight w2. Channels are linear R, G, B. */
typedef struct sq_volume_view {
    const float *density;  /* nx*ny*nz, x fastest; any unit consistent with sigma_ext */
    int nx, ny, nz;
    sq_vec3 origin_m;      /* min corner of the box */
    sq_vec3 size_m;        /* extent of the box; cell (i,j,k) centre = origin + (i+.5)*size/nx */
    float sigma_ext[3];    /* extinction per unit density (1/m per density unit) */
    float albedo[3];       /* single-scattering albedo */
    float g[3];            /* HG asymmetry */
    float g2;              /* second lobe asymmetry (e.g. -0.3 back lobe); used if w2 > 0 */
    float w2;              /* weight of the second lobe in [0, 1); 0 = single lobe */
    float density_max;     /* max of density (for the renderer's normalisation) */
    /* 0 (default): the density varies trilinearly between cell centres. (0, 1]: the grid is
     * a filtered picture of a sharp interface (dust against clear air): where the density
     * falls from its local maximum to near zero within about a cell, the renderer draws the
     * edge at the half-maximum contour, this much sharper (1: a fifth of a cell wide);
     * docs/validation.md, "Sharp dust edges" */
    float edge_sharpness;
    /* 0 (default): nothing is drawn outside the box. > 0: the box is drawn this far (m)
     * beyond its two y faces with the density mirrored at them, so a body wider than its grid
     * (a storm's wall running across the view beyond a strip-shaped domain) does not end at
     * the grid's sides; docs/validation.md, "Dust beyond the domain's sides" */
    float mirror_y_m;
    uint64_t version;      /* increments whenever density changes */
} sq_volume_view;

typedef enum sq_sprite_kind {
    SQ_SPRITE_DEFAULT = 0,  /* = SQ_SPRITE_PUFF */
    SQ_SPRITE_PUFF = 1,     /* soft dust puff (gaussian with noise) */
    SQ_SPRITE_DISC = 2,     /* gaussian snow disc */
    SQ_SPRITE_FLAKE6 = 3,   /* six-fold snowflake */
    SQ_SPRITE_SPLAT = 4,    /* cloud splat: Hermite falloff (SPEC 8.5) */
    SQ_SPRITE_SPHERE = 5    /* lit opaque sphere impostor (avalanche particles) */
} sq_sprite_kind;

/* Camera-facing particles. Opacity model: a particle's optical depth through its centre is
 * tau[i] * sigma_rel[c] for channel c (sigma_rel normalised so green = 1); the sprite
 * shape scales it across the quad. Lit by sun (through the volume light buffer if any) and sky
 * with single scattering: colour = albedo * (sun * phase(g) * shadow + sky ambient). */
typedef struct sq_particles_view {
    int count;
    const float *position;     /* 3*count, world metres */
    const float *radius_m;     /* count; NULL -> radius_default_m */
    const float *rotation_rad; /* count, in-plane rotation; NULL -> 0 */
    const float *tau;          /* count, optical depth through the centre; NULL -> tau_default */
    const float *fade;         /* count, [0,1] multiplier (spawn fade-in / boundary fade-out) */
    const float *color;        /* 3*count albedo per particle; NULL -> albedo */
    float radius_default_m;
    float tau_default;
    float sigma_rel[3];        /* per-channel extinction relative to green; 0 -> 1,1,1 */
    float albedo[3];           /* single-scattering albedo per channel */
    float g;                   /* HG asymmetry for sun light */
    sq_sprite_kind sprite;
    float softness_m;          /* depth fade distance against opaque geometry; 0 = hard */
    uint64_t version;
} sq_particles_view;

typedef enum sq_material {
    SQ_MATERIAL_DEFAULT = 0, /* = terrain-like rock/soil */
    SQ_MATERIAL_SAND = 1,
    SQ_MATERIAL_SNOW = 2,
    SQ_MATERIAL_ROCK = 3,
    SQ_MATERIAL_SNOW_DEBRIS = 4 /* avalanche snow: granular lumps, shadowed gaps (GL renderer;
                                   the reference path tracer shades it as textured snow) */
} sq_material;

/* A heightfield surface z = height[j*nx+i] at (origin.x + i*dx, origin.y + j*dy) drawn over the
 * world (e.g. deposited snow, avalanche deposit). Cells with coverage 0 are not drawn. */
typedef struct sq_surface_view {
    int nx, ny;
    sq_vec3 origin_m;
    float dx_m, dy_m;
    const float *height_m;  /* nx*ny absolute heights */
    const float *coverage;  /* nx*ny in [0,1]: blend weight of the material (NULL -> 1) */
    sq_material material;
    sq_vec3 albedo;         /* 0 -> material default */
    uint64_t version;
} sq_surface_view;

/* One cloud of a clouds view: its particles are the contiguous range [first, first + count);
 * centre and radius bound their discs (impostors are fitted to this sphere). */
typedef struct sq_cloud_group {
    sq_vec3 center_m;
    float radius_m;
    int first, count;
} sq_cloud_group;

/* Cloud particles lit by Harris multiple forward scattering (SPEC 8.4–8.5, src/render/
 * render_clouds.c): the renderer sorts them by distance from the sun and carries the light
 * I_k = g_{k-1} + T_{k-1} I_{k-1} through a light buffer, then draws camera-facing billboards
 * back to front with the view-dependent phase function; distant groups become impostors.
 * Opacity of particle k at sprite radius t in [0, 1] (eta(t) = 2|t|³ - 3t² + 1):
 *   physical:       alpha = 1 - exp(-tau[k] eta(t))
 *   splat_opacity:  alpha = (1 - exp(-tau_splat)) eta_1 eta(t)   (Harris / S4, tau = 80) */
typedef struct sq_clouds_view {
    int count;
    const float *position;     /* 3*count, world metres */
    const float *radius_m;     /* count */
    const float *tau;          /* count, optical depth through the centre (physical opacity) */
    const float *g;            /* count, HG asymmetry per particle; NULL -> g_default */
    const sq_cloud_group *groups; /* group_count groups covering [0, count); NULL: one group */
    int group_count;
    float g_default;           /* HG asymmetry (droplets 0.85) */
    float albedo;              /* single-scattering albedo */
    bool rayleigh;             /* S4's Rayleigh phase instead of HG (seed reproduction) */
    bool splat_opacity;        /* Harris/S4 opacity from the splat alpha */
    float eta1, tau_splat;     /* splat peak eta_1 (S4 0.4) and S4's tau_k = 80 */
    float splat_noise;         /* 0..1: eta(t) times a mean-one noise of this amplitude (texture) */
    float gamma_sr;            /* forward solid angle kept in the light (Harris 0.09 sr) */
    int light_buffer;          /* light-buffer texels per side at most (0 -> 512) */
    float light_texels_per_radius; /* and no finer than mean radius / this (0 -> 4) */
    bool multiple_scattering;  /* add the diffuse (two-stream) light to the forward MFS light */
    bool shadows;              /* the clouds shadow the terrain */
    bool impostors;            /* groups beyond dist_impostor_m drawn as impostors */
    float dist_3d_m, dist_impostor_m; /* cross-fade band between particles and impostors */
    float impostor_angle_deg;  /* impostor refreshed when the view angle changes more */
    uint64_t version;          /* changes whenever the particles change */
} sq_clouds_view;

typedef enum sq_snow_brdf {
    SQ_SNOW_BRDF_PHYSICAL = 0,   /* high albedo, forward-scattering sparkle, bluish subsurface */
    SQ_SNOW_BRDF_BLINN_PHONG = 1 /* S2 eqs 2.7-2.8 with a noise-perturbed normal */
} sq_snow_brdf;

/* Snow lying on every opaque surface the renderer draws (terrain, obstacles, meshes; S2 ch. 2,
 * SPEC §6): each frame the renderer draws an orthographic top-down depth map of the world over
 * the view's footprint nearer than detail_distance_m (texel grid snapped to the world), takes
 * the exposure f_e of each point from `taps` samples of it, the inclination f_inc = max(0,
 * N.up) with noise, f_p = f_e f_inc, displaces the surface by f_p-weighted depth along its
 * smoothed normal blended with up, straight up at the top of a wall (a watertight shell; walls
 * stay vertical) and blends the snow shading by f_p.
 * Beyond detail_distance_m, S2's far-field texture blend. depth_m: the snow depth (m) on the
 * highest surface of each column, at cell centres origin + (i + 1/2, j + 1/2) (dx, dy). */
typedef struct sq_snow_cover_view {
    int nx, ny;
    sq_vec3 origin_m;          /* corner of cell (0, 0); z unused */
    float dx_m, dy_m;
    const float *depth_m;      /* nx*ny; outside the grid the nearest edge cell */
    float detail_distance_m;   /* D_snow: the occlusion map's reach */
    int map_size;              /* occlusion map texels per side */
    int taps;                  /* M of eq 2.2: 1, 4, 5 or 9 */
    float tap_radius_texels;
    float depth_bias_m;        /* b: exposed when D_occ - D_act >= -b */
    float noise_amplitude;     /* of the inclination and normal perturbation (0 = none) */
    float noise_scale_m;       /* wavelength of the first octave */
    float shell_blend;         /* displacement direction: 0 smoothed normal .. 1 up */
    sq_snow_brdf brdf;
    sq_vec3 albedo;            /* snow albedo (linear) */
    float sparkle;             /* 0..1 glints of the physical BRDF */
    float shininess;           /* Blinn-Phong exponent n */
    uint64_t version;          /* changes whenever depth_m changes */
} sq_snow_cover_view;

typedef struct sq_drawable {
    sq_drawable_kind kind;
    const char *name; /* e.g. "dust", "snowfall", "snow-cover" */
    union {
        sq_volume_view volume;
        sq_particles_view particles;
        sq_surface_view surface;
        sq_clouds_view clouds;
        sq_snow_cover_view snow_cover;
    } u;
} sq_drawable;

/* Scalar metric published after each step, e.g. {"visibility_2m_min", 312.5, "m"}. */
typedef struct sq_metric {
    const char *name;
    double value;
    const char *unit;
} sq_metric;

/* What origin_m.z of a 2D map (nz == 1) is. */
typedef enum sq_field_level {
    SQ_FIELD_LEVEL_ALTITUDE = 0, /* the world z of a horizontal slice (default) */
    SQ_FIELD_LEVEL_HEIGHT = 1,   /* a height above the terrain surface: a terrain-following map
                                    such as visibility 2 m above the ground */
    SQ_FIELD_LEVEL_SURFACE = 2   /* a property of the surface itself (snow depth); z unused */
} sq_field_level;

/* A named 3D (or 2D with n.nz = 1) field for NetCDF/VTK export. */
typedef struct sq_named_field {
    const char *name;       /* NetCDF variable name, e.g. "dust_mass_concentration" */
    const char *units;      /* UDUNITS string, e.g. "kg m-3" */
    const char *long_name;
    const char *standard_name; /* CF standard name or NULL */
    const float *data;      /* x fastest; nx*ny*nz contiguous */
    int nx, ny, nz;
    sq_vec3 origin_m;       /* centre of cell (0,0,0) */
    sq_vec3 spacing_m;
    const uint8_t *invalid; /* nx*ny*nz, non-zero: no value here (inside a solid, below the
                               ground), written as _FillValue (NetCDF) / NaN (VTK); NULL: every
                               cell has a value. NaN data are written the same way. */
    sq_field_level level;   /* 2D maps: what origin_m.z is (sq_field_level) */
} sq_named_field;

#ifdef __cplusplus
}
#endif
#endif
