/* reference_internal.h — the reference CPU path tracer's private types: the scene prepared for
 * tracing (terrain and surface heightfields, obstacles, volumes with brick majorants, sun and
 * sky), the counter-based per-pixel random stream, and the geometric and phase-function
 * routines that the tests check one by one. Geometry and path state are double precision;
 * density grids stay float. See ref_trace.c for the integrator and the conventions
 * (SPEC §2.1, §2.6, §3.1). */
#ifndef SQ_REFERENCE_INTERNAL_H
#define SQ_REFERENCE_INTERNAL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "core/core_internal.h"
#include "squall/drawable.h"
#include "squall/render.h"
#include "squall/rng.h"
#include "squall/world.h"

/* ---- small double vector ----------------------------------------------------------------- */
typedef struct sq__dv3 {
    double x, y, z;
} sq__dv3;

static inline sq__dv3 sq__dv(double x, double y, double z)
{
    sq__dv3 r = {x, y, z};
    return r;
}
static inline sq__dv3 sq__dv_add(sq__dv3 a, sq__dv3 b) { return sq__dv(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline sq__dv3 sq__dv_sub(sq__dv3 a, sq__dv3 b) { return sq__dv(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline sq__dv3 sq__dv_scale(sq__dv3 a, double s) { return sq__dv(a.x * s, a.y * s, a.z * s); }
static inline sq__dv3 sq__dv_madd(sq__dv3 o, sq__dv3 d, double t)
{
    return sq__dv(o.x + d.x * t, o.y + d.y * t, o.z + d.z * t);
}
static inline double sq__dv_dot(sq__dv3 a, sq__dv3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline sq__dv3 sq__dv_cross(sq__dv3 a, sq__dv3 b)
{
    return sq__dv(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline sq__dv3 sq__dv_norm(sq__dv3 a)
{
    double l = sqrt(sq__dv_dot(a, a));
    return l > 0.0 ? sq__dv_scale(a, 1.0 / l) : sq__dv(0.0, 0.0, 0.0);
}
static inline sq__dv3 sq__dv_from(sq_vec3 v) { return sq__dv((double)v.x, (double)v.y, (double)v.z); }

/* ---- random stream: stream = pixel index, index = sample * 2^32 + block ------------------ */
typedef struct sq__ref_rng {
    uint64_t seed, stream, index;
    uint32_t buf[4];
    int avail;
} sq__ref_rng;

static inline void sq__ref_rng_init(sq__ref_rng *r, uint64_t seed, uint64_t pixel, uint64_t sample)
{
    r->seed = seed;
    r->stream = pixel;
    r->index = sample << 32;
    r->avail = 0;
}

/* Uniform in the open interval (0, 1) from 32 random bits. */
static inline double sq__ref_rand(sq__ref_rng *r)
{
    if (r->avail == 0) {
        sq_rng_bits(r->seed, r->stream, r->index++, r->buf);
        r->avail = 4;
    }
    uint32_t b = r->buf[--r->avail];
    return ((double)b + 0.5) * (1.0 / 4294967296.0);
}

/* ---- scene ------------------------------------------------------------------------------- */
/* How a heightfield's albedo is found at a hit. */
typedef enum sq__ref_shade {
    SQ__REF_SHADE_CONST = 0,   /* albedo as stored */
    SQ__REF_SHADE_TERRAIN = 1, /* terrain.frag: kind colour, rock on steep slopes, detail noise */
    SQ__REF_SHADE_DETAIL = 2,  /* surface.frag, non-snow: albedo * (0.9 + 0.2 fbm(p.xy / 3)) */
} sq__ref_shade;

/* A heightfield z = h[j*nx+i] at (ox + i*dx, oy + j*dy): the terrain or a surface drawable.
 * Each grid cell is two triangles split along the (i,j)-(i+1,j+1) diagonal (as the GL mesh);
 * shading normals interpolate the given vertex normals or central differences. */
typedef struct sq__ref_heightfield {
    int nx, ny;
    double ox, oy, dx, dy;
    const float *h;
    const float *normals;   /* 3*nx*ny unit normals or NULL (then central differences) */
    const float *coverage;  /* surfaces: blend weight of the material (NULL -> 1) */
    float *cell_max;        /* (nx-1)*(ny-1) max corner height; -INF for undrawn cells */
    float *block_max;       /* bnx*bny max over blocks of SQ__REF_BLOCK cells */
    int bnx, bny;
    double zmin, zmax;
    sq__ref_shade shade;
    double albedo[3];       /* CONST/DETAIL: the albedo; TERRAIN: colour on gentle slopes */
    double steep[3];        /* TERRAIN: colour on steep slopes */
    /* surfaces: what shows where coverage < 1 (the terrain's shading) */
    sq__ref_shade under_shade;
    double under_albedo[3], under_steep[3];
} sq__ref_heightfield;

#define SQ__REF_BLOCK 8

typedef struct sq__ref_obstacle {
    sq__dv3 c;           /* footprint centre x, y and base z */
    double cos_yaw, sin_yaw;
    double hx, hy, h;    /* half footprint and wall height */
    double roof;         /* ridge height above the walls (HOUSE), else 0 */
    double albedo[3];    /* walls (and gables) */
    double roof_albedo[3];
    bool fence;          /* porous boards: 10 cm boards, 5 cm gaps, rails at the ends */
    bool along_x;        /* fence boards counted along local x (else y) */
    sq__dv3 bmin, bmax;  /* world AABB */
} sq__ref_obstacle;

typedef struct sq__ref_volume {
    const float *density;
    int nx, ny, nz;
    sq__dv3 org, size;
    double sig[3], alb[3], g[3], g2, w2;
    double sig_max;      /* max over channels of sig */
    bool same_phase;     /* g equal in all channels */
    float *brick_max;    /* max clamped density influencing each brick (trilinear apron) */
    int bn[3];
    sq__dv3 brick_size;
} sq__ref_volume;

#define SQ__REF_BRICK 8
#define SQ__REF_MAX_VOLUMES 32

typedef struct sq__ref_scene {
    bool has_terrain;
    sq__ref_heightfield terrain;
    sq__ref_heightfield *surfaces;
    int surface_count;
    sq__ref_obstacle *obstacles;
    int obstacle_count;
    sq__ref_volume *volumes;
    int volume_count;
    sq__dv3 sun_dir;     /* unit, toward the sun */
    double sun_rad[3];   /* world->sun_radiance: radiance of a white plane facing the sun */
    double sun_e[3];     /* irradiance on a plane normal to the sun = pi * sun_rad */
    bool sun_on;
    double zenith[3], horizon[3], ground[3];
    double turbidity;
    double inv_exaggeration; /* 1 / the world's vertical exaggeration */
    double eps_scale;    /* ray offset length for this scene */
    sq_context *ctx;
} sq__ref_scene;

/* What a ray hits first among opaque things. */
typedef struct sq__ref_hit {
    double t;
    sq__dv3 ng;          /* geometric normal facing the ray origin */
    sq__dv3 ns;          /* shading normal on the same side as ng */
    double albedo[3];
} sq__ref_hit;

/* Builds the tracing scene from the world and drawables (validates volumes: NaN density,
 * negative sigma_ext, albedo outside [0,1], |g| >= 1, w2 outside [0,1)). isotropic forces
 * g = 0 and w2 = 0. Particles are ignored. */
sq_result sq__ref_scene_create(sq_context *ctx, const sq_world *world,
                               const sq_drawable *drawables, int count, bool isotropic,
                               sq__ref_scene **out);
void sq__ref_scene_destroy(sq__ref_scene *s);

/* The analytic sky of the GL renderer (shaders/frame_common.glsl sq_sky_radiance, line for
 * line) seen from world height z_m: zenith/horizon gradient, haze glow around the sun from the
 * turbidity's aerosol above z_m (scale height 1.5 km above sea level, physical heights), ground
 * light below the horizon and, with with_sun, the sun disc (0.27 deg radius). */
void sq__ref_sky(const sq__ref_scene *s, sq__dv3 d, double z_m, bool with_sun, double out[3]);

/* Terrain albedo at a point with unit shading normal n, as terrain.frag. */
void sq__ref_terrain_albedo(const double flat[3], const double steep[3], sq__dv3 p, sq__dv3 n,
                            double out[3]);
/* The GL shaders' value noise and 3-octave fBm (frame_common.glsl sq_value_noise, sq_fbm). */
double sq__ref_value_noise(double x, double y);
double sq__ref_fbm(double x, double y);

/* Colour tables of the GL renderer (renderer.c). */
void sq__terrain_albedo(const sq_world *w, sq_vec3 *flat, sq_vec3 *steep);
sq_vec3 sq__material_albedo(sq_material m);

/* Renders a prepared scene with an already validated desc (the body of sq_reference_render;
 * tests use it to set scene properties the world cannot express, e.g. a constant terrain
 * albedo). */
sq_result sq__ref_render_scene(sq_context *ctx, const sq_reference_desc *desc,
                               const sq__ref_scene *s, const sq_camera *camera, float *rgb_out);

/* Nearest opaque hit (terrain, surfaces, obstacles) with t in (tmin, tmax). */
bool sq__ref_intersect(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double tmin, double tmax,
                       sq__ref_hit *hit);
/* True if anything opaque lies on the ray with t in (tmin, tmax) (shadow rays). */
bool sq__ref_occluded(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double tmin, double tmax);
/* Nearest hit of one heightfield; ng/ns/albedo filled unless hit is NULL. */
bool sq__ref_heightfield_intersect(const sq__ref_heightfield *hf, sq__dv3 o, sq__dv3 d,
                                   double tmin, double tmax, sq__ref_hit *hit);
/* Nearest hit of one obstacle (a convex polytope: box, or box plus gable roof; fences porous
 * as mesh.frag); hit may be NULL. */
bool sq__ref_obstacle_intersect(const sq__ref_obstacle *ob, sq__dv3 o, sq__dv3 d, double tmin,
                                double tmax, sq__ref_hit *hit);
/* Bilinear terrain height at (x, y), the edge extended outside. */
double sq__ref_heightfield_height(const sq__ref_heightfield *hf, double x, double y);

/* Clamped density, trilinear with clamp-to-edge inside the box (as a linear GL 3D texture),
 * 0 outside. */
double sq__ref_volume_density(const sq__ref_volume *v, sq__dv3 p);
/* Next tentative collision of volume v on the ray after t_start (and before t_end), with the
 * brick majorant there (per unit length, max over channels). INFINITY when none. */
double sq__ref_volume_next(const sq__ref_volume *v, sq__dv3 o, sq__dv3 d, double t_start,
                           double t_end, sq__ref_rng *rng, double *majorant);
/* Ratio-tracking transmittance (per channel) of all volumes along (o, d) over [0, t_end). */
void sq__ref_transmittance(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double t_end,
                           sq__ref_rng *rng, double tr[3]);

/* Henyey–Greenstein phase function, cos_theta = dot of propagation directions, g > 0 forward
 * (SPEC §2.6); normalised over the sphere. */
double sq__hg_eval(double g, double cos_theta);
/* Samples cos_theta from HG(g) with one uniform. */
double sq__hg_sample_cos(double g, double u);
/* A unit vector at cos_theta from d with azimuth 2*pi*u. */
sq__dv3 sq__ref_direction_around(sq__dv3 d, double cos_theta, double u);

#endif
