/* clouds_source.c — where the clouds phenomenon's fields come from: a WRF run through the io
 * layer's reader (include/squall/wrf.h: derived fields on the mass grid, interpolated between
 * stored times), or an analytic field on a terrain-following grid over the world's terrain for
 * tests and benchmarks:
 *   cumulus: fair-weather cumuli with flat bases and domed, lumpy tops; the liquid water grows
 *     with height above the base (adiabatic-like), towers drift with a uniform wind;
 *   stratocumulus: a deck whose water grows linearly from base to top, broken into cells by a
 *     thresholded fBm pattern (about 70 % cover).
 * Both evolve slowly (a 20-minute pulse of the water content) so that particle lifetimes and
 * the time interpolation are exercised. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "clouds_internal.h"
#include "squall/noise.h"
#include "squall/rng.h"

#if defined(SQ_HAVE_PROJ) && SQ_HAVE_PROJ
#include "squall/wrf.h"
#include "world/world_struct.h"
#define CLOUDS_HAVE_WRF 1
#else
#define CLOUDS_HAVE_WRF 0
#endif

#define SYN_WIND_U 4.0f  /* m/s, analytic fields drift east-north-east */
#define SYN_WIND_V 1.5f
#define SYN_PULSE_S 1200.0
#define SYN_MAX_CLOUDS 64

typedef struct syn_cloud {
    float cx, cy;   /* centre at t = 0 (m) */
    float radius;   /* base radius (m) */
    float top;      /* top above the base (m) */
    float phase;    /* pulse phase (rad) */
    float lwc;      /* peak water (g/m³) */
} syn_cloud;

struct sq__cloud_source {
    sq_context *ctx;
    sq__cloud_grid grid;
    int kind;
    double start_s;
    /* analytic */
    sq_clouds_desc d;
    sq_noise noise;
    syn_cloud clouds[SYN_MAX_CLOUDS];
    int nclouds;
    float *z, *zw, *lwc, *u, *v, *w, *terrain;
#if CLOUDS_HAVE_WRF
    sq_wrf *wrf;
    sq_wrf_info info;
#endif
};

/* ---- analytic fields ---------------------------------------------------------------------- */
static sq_result syn_open(sq__cloud_source *s, const sq_world *world)
{
    const sq_clouds_desc *d = &s->d;
    sq__cloud_grid *g = &s->grid;
    g->nx = d->synthetic_cells[0];
    g->ny = d->synthetic_cells[1];
    g->nz = d->synthetic_cells[2];
    g->dx = (float)(d->synthetic_size_m[0] / g->nx);
    g->dy = (float)(d->synthetic_size_m[1] / g->ny);
    g->x0 = (float)(-0.5 * d->synthetic_size_m[0]) + 0.5f * g->dx;
    g->y0 = (float)(-0.5 * d->synthetic_size_m[1]) + 0.5f * g->dy;
    g->duration_s = 0.0;
    g->analytic = true;
    snprintf(g->description, sizeof g->description, "analytic %s field %dx%dx%d over %.0f x %.0f m",
             s->kind == SQ_CLOUDS_SOURCE_CUMULUS ? "cumulus" : "stratocumulus", g->nx, g->ny,
             g->nz, d->synthetic_size_m[0], d->synthetic_size_m[1]);
    const size_t cells = (size_t)g->nx * g->ny * g->nz, cols = (size_t)g->nx * g->ny;
    sq_context *ctx = s->ctx;
    s->z = sq_alloc(ctx, cells * sizeof(float));
    s->zw = sq_alloc(ctx, (cells + cols) * sizeof(float));
    s->lwc = sq_alloc(ctx, cells * sizeof(float));
    s->u = sq_alloc(ctx, cells * sizeof(float));
    s->v = sq_alloc(ctx, cells * sizeof(float));
    s->w = sq_alloc_zero(ctx, cells * sizeof(float));
    s->terrain = sq_alloc(ctx, cols * sizeof(float));
    if (!s->z || !s->zw || !s->lwc || !s->u || !s->v || !s->w || !s->terrain)
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for the analytic field");
    /* terrain-following levels of equal thickness from the ground to base + size_z */
    const float dz = (float)((d->synthetic_base_m + d->synthetic_size_m[2]) / g->nz);
    for (int j = 0; j < g->ny; j++)
        for (int i = 0; i < g->nx; i++) {
            const float x = g->x0 + (float)i * g->dx, y = g->y0 + (float)j * g->dy;
            /* the model's terrain: the world's, without its vertical exaggeration */
            const float h =
                world ? sq_world_height_at(world, x, y) / sq__clouds_exaggeration(world) : 0.0f;
            s->terrain[(size_t)j * g->nx + i] = h;
            for (int k = 0; k <= g->nz; k++)
                s->zw[((size_t)k * g->ny + j) * g->nx + i] = h + (float)k * dz;
            for (int k = 0; k < g->nz; k++) {
                const size_t c = sq__cell(g, i, j, k);
                s->z[c] = 0.5f * (s->zw[c] + s->zw[c + cols]);
                s->u[c] = SYN_WIND_U;
                s->v[c] = SYN_WIND_V;
            }
        }
    sq_noise_init(&s->noise, d->seed ^ 0x5eedc10dULL);
    /* cumulus towers: Philox positions keeping a radius from the edges */
    s->nclouds = d->synthetic_clouds < SYN_MAX_CLOUDS ? d->synthetic_clouds : SYN_MAX_CLOUDS;
    const float sx = (float)d->synthetic_size_m[0], sy = (float)d->synthetic_size_m[1];
    const float sz = (float)d->synthetic_size_m[2];
    for (int c = 0; c < s->nclouds; c++) {
        float u[4];
        sq_rng_uniform4(d->seed, 0x63756d756cULL, (uint64_t)c, u);
        syn_cloud *cl = &s->clouds[c];
        cl->radius = (0.10f + 0.08f * u[2]) * fminf(sx, sy);
        cl->cx = (u[0] - 0.5f) * (sx - 2.5f * cl->radius);
        cl->cy = (u[1] - 0.5f) * (sy - 2.5f * cl->radius);
        cl->top = (0.45f + 0.45f * u[3]) * sz;
        cl->phase = 6.2831853f * u[0] * u[3];
        cl->lwc = (float)d->synthetic_lwc_g_m3 * (0.7f + 0.3f * u[1]);
    }
    return SQ_OK;
}

/* A cumulus tower at one time: its centre drifting with the wind (wrapped into the domain),
 * its pulsing top and the reach of its widest lump. Computed once per read, not per cell. */
typedef struct syn_tower {
    float cx, cy, pulse, top, reach;
} syn_tower;

static void syn_towers(const sq__cloud_source *s, double t, syn_tower *tw)
{
    const float ox = SYN_WIND_U * (float)t, oy = SYN_WIND_V * (float)t;
    const float sx = (float)s->d.synthetic_size_m[0], sy = (float)s->d.synthetic_size_m[1];
    for (int c = 0; c < s->nclouds; c++) {
        const syn_cloud *cl = &s->clouds[c];
        float cx = cl->cx + ox, cy = cl->cy + oy;
        cx -= sx * floorf(cx / sx + 0.5f);
        cy -= sy * floorf(cy / sy + 0.5f);
        tw[c].cx = cx;
        tw[c].cy = cy;
        tw[c].pulse = 0.85f + 0.15f * sinf(6.2831853f * (float)(t / SYN_PULSE_S) + cl->phase);
        tw[c].top = cl->top * tw[c].pulse;
        /* beyond the widest lump: rz <= radius (0.85 + 0.3 |noise|), |noise| <= sqrt(3/2) */
        tw[c].reach = 1.3f * cl->radius;
    }
}

/* True when (x, y) lies within tower c's reach (the only clouds a column can hold). */
static bool syn_in_reach(const syn_tower *tw, float x, float y)
{
    const float ddx = x - tw->cx, ddy = y - tw->cy;
    return ddx * ddx + ddy * ddy < tw->reach * tw->reach;
}

/* Water of tower c at (x, y, h above the base), (x, y) within its reach. */
static float syn_cumulus(const sq__cloud_source *s, const syn_tower *tw, int c, float x, float y,
                         float h)
{
    const syn_cloud *cl = &s->clouds[c];
    if (h < 0.0f || h > cl->top * 1.15f) return 0.0f;
    const float hz = h / tw->top;
    if (hz > 1.1f) return 0.0f;
    const float cx = tw->cx, cy = tw->cy;
    /* lumpy dome: radius shrinks toward the top, modulated by noise (cauliflower) */
    const float lump = sq_noise3(&s->noise, (x - cx) / (0.35f * cl->radius),
                                 (y - cy) / (0.35f * cl->radius), h / (0.3f * cl->top) + 3.7f * (float)c);
    const float rz = cl->radius * sqrtf(fmaxf(0.0f, 1.0f - hz * hz)) * (0.85f + 0.3f * lump) *
                     (0.75f + 0.25f * (1.0f - hz));
    const float dx = x - cx, dy = y - cy;
    const float r2 = (dx * dx + dy * dy) / fmaxf(rz * rz, 1.0f);
    if (r2 >= 1.0f) return 0.0f;
    const float adiabatic = powf(fmaxf(hz, 0.0f), 0.7f) * 0.9f + 0.1f;
    return cl->lwc * tw->pulse * adiabatic * (1.0f - r2) * (1.0f - r2 * r2 * 0.5f);
}

/* Water of the stratocumulus deck (depth = size_z / 3) at (x, y, h above the base). */
static float syn_stratocumulus(const sq__cloud_source *s, float x, float y, float h, double t)
{
    const float depth = (float)s->d.synthetic_size_m[2] / 3.0f;
    if (h < 0.0f || h > depth) return 0.0f;
    const float cell = 0.12f * (float)fmin(s->d.synthetic_size_m[0], s->d.synthetic_size_m[1]);
    const float ox = SYN_WIND_U * (float)t, oy = SYN_WIND_V * (float)t;
    const float n = sq_noise_fbm3(&s->noise, (x - ox) / cell, (y - oy) / cell,
                                  0.2f * (float)(t / SYN_PULSE_S), 4, 2.0f, 0.5f);
    /* cover: cells where n exceeds -0.1 (about 70 %), soft edges; tops bulge with n */
    const float cover = fminf(fmaxf((n + 0.1f) / 0.15f, 0.0f), 1.0f);
    const float top = depth * (0.75f + 0.5f * fminf(fmaxf(n + 0.1f, 0.0f), 0.5f));
    if (h > top) return 0.0f;
    return (float)s->d.synthetic_lwc_g_m3 * cover * (0.15f + 0.85f * h / top);
}

/* The analytic field at time t: per column, only the towers within reach are evaluated (the
 * water is the largest of theirs, so skipping the others changes nothing); columns in parallel,
 * each cell written by one thread. */
static void syn_read(sq__cloud_source *s, double t, sq__cloud_frame *fr)
{
    const sq__cloud_grid *g = &s->grid;
    syn_tower tw[SYN_MAX_CLOUDS];
    if (s->kind == SQ_CLOUDS_SOURCE_CUMULUS) syn_towers(s, t, tw);
    const int nt = sq_context_threads(s->ctx);
    const int ncols = g->nx * g->ny;
    SQ_OMP(omp parallel for schedule(dynamic, 16) num_threads(nt))
    for (int q = 0; q < ncols; q++) {
        const int i = q % g->nx, j = q / g->nx;
        const float x = g->x0 + (float)i * g->dx, y = g->y0 + (float)j * g->dy;
        int near[SYN_MAX_CLOUDS], nn = 0;
        if (s->kind == SQ_CLOUDS_SOURCE_CUMULUS)
            for (int c = 0; c < s->nclouds; c++)
                if (syn_in_reach(&tw[c], x, y)) near[nn++] = c;
        for (int k = 0; k < g->nz; k++) {
            const size_t c = sq__cell(g, i, j, k);
            const float h = s->z[c] - s->terrain[(size_t)j * g->nx + i] -
                            (float)s->d.synthetic_base_m;
            float v = 0.0f;
            if (s->kind == SQ_CLOUDS_SOURCE_CUMULUS) {
                for (int m = 0; m < nn; m++) {
                    const float w = syn_cumulus(s, &tw[near[m]], near[m], x, y, h);
                    if (w > v) v = w;
                }
            } else {
                v = syn_stratocumulus(s, x, y, h, t);
            }
            s->lwc[c] = v;
        }
    }
    memset(fr, 0, sizeof *fr);
    fr->z_m = s->z;
    fr->z_w_m = s->zw;
    fr->conc[SQ_HYDRO_CLOUD] = s->lwc;
    fr->u = s->u;
    fr->v = s->v;
    fr->w = s->w;
    fr->terrain_m = s->terrain;
}

/* ---- WRF ------------------------------------------------------------------------------------- */
#if CLOUDS_HAVE_WRF
static sq_result wrf_open_source(sq__cloud_source *s, const char *path)
{
    const char *paths[1] = {path};
    sq_result r = sq_wrf_open(s->ctx, paths, 1, &s->wrf);
    if (r != SQ_OK) return r;
    sq_wrf_get_info(s->wrf, &s->info);
    sq__cloud_grid *g = &s->grid;
    g->nx = s->info.nx;
    g->ny = s->info.ny;
    g->nz = s->info.nz;
    g->dx = (float)s->info.dx_m;
    g->dy = (float)s->info.dy_m;
    g->x0 = (float)s->info.x0_m;
    g->y0 = (float)s->info.y0_m;
    g->duration_s = s->info.duration_s;
    g->analytic = false;
    snprintf(g->description, sizeof g->description, "%.400s: %dx%dx%d, %d times from %.40s", path,
             g->nx, g->ny, g->nz, s->info.time_count, s->info.time_strings[0]);
    return SQ_OK;
}

static sq_result wrf_read_source(sq__cloud_source *s, double t, sq__cloud_frame *fr)
{
    sq_wrf_state st;
    sq_result r = sq_wrf_read(s->wrf, t, &st);
    if (r != SQ_OK) return r;
    memset(fr, 0, sizeof *fr);
    fr->z_m = st.z_m;
    fr->z_w_m = st.z_w_m;
    for (int q = 0; q < SQ_HYDRO_COUNT && q < SQ_WRF_SPECIES_COUNT; q++) fr->conc[q] = st.q_g_m3[q];
    fr->number_ice = st.ice_number_m3;
    fr->number_rain = st.rain_number_m3;
    /* CLDFRA as the cells' cloud fraction, unless the scheme wrote only 0 or 1: a flag says
     * nothing of the sub-grid cover (the desc's cloud.fraction is used then) */
    fr->cldfra = st.cloud_fraction_is_flag ? NULL : st.cloud_fraction;
    fr->u = st.u_mps;
    fr->v = st.v_mps;
    fr->w = st.w_mps;
    fr->terrain_m = st.terrain_m;
    return SQ_OK;
}
#endif

/* ---- the interface ------------------------------------------------------------------------- */
sq_result sq__cloud_source_open(sq_context *ctx, const sq_clouds_desc *d, const sq_world *world,
                                sq__cloud_source **out)
{
    *out = NULL;
    sq__cloud_source *s = sq_alloc_zero(ctx, sizeof *s);
    if (!s) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for the source");
    s->ctx = ctx;
    s->d = *d;
    s->kind = d->source;
    s->start_s = d->start_s;
    sq_result r;
    if (d->source == SQ_CLOUDS_SOURCE_WRF) {
#if CLOUDS_HAVE_WRF
        r = wrf_open_source(s, d->wrf_file);
#else
        r = sq__fail(ctx, SQ_ERR_UNSUPPORTED, "clouds",
                     "sq_clouds_desc.source = wrf needs the WRF reader (NetCDF + PROJ), which "
                     "this build lacks; use source = cumulus or stratocumulus");
#endif
    } else {
        r = syn_open(s, world);
    }
    if (r != SQ_OK) {
        sq__cloud_source_close(s);
        return r;
    }
    if (d->source == SQ_CLOUDS_SOURCE_WRF && !(d->start_s <= s->grid.duration_s)) {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds",
                     "sq_clouds_desc.wrf.start_s = %g s is after the last stored time of %s "
                     "(%g s)",
                     d->start_s, d->wrf_file, s->grid.duration_s);
        sq__cloud_source_close(s);
        return r;
    }
    *out = s;
    return SQ_OK;
}

void sq__cloud_source_close(sq__cloud_source *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
#if CLOUDS_HAVE_WRF
    sq_wrf_close(s->wrf);
#endif
    sq_free(ctx, s->z);
    sq_free(ctx, s->zw);
    sq_free(ctx, s->lwc);
    sq_free(ctx, s->u);
    sq_free(ctx, s->v);
    sq_free(ctx, s->w);
    sq_free(ctx, s->terrain);
    sq_free(ctx, s);
}

void sq__cloud_source_grid(const sq__cloud_source *s, sq__cloud_grid *out) { *out = s->grid; }

sq_result sq__cloud_source_read(sq__cloud_source *s, double time_s, sq__cloud_frame *out)
{
    double t = s->start_s + time_s;
    if (s->kind != SQ_CLOUDS_SOURCE_WRF) {
        syn_read(s, t, out);
        return SQ_OK;
    }
#if CLOUDS_HAVE_WRF
    if (t > s->grid.duration_s) t = s->grid.duration_s; /* hold the last stored time */
    if (t < 0.0) t = 0.0;
    return wrf_read_source(s, t, out);
#else
    (void)out;
    return sq__fail(s->ctx, SQ_ERR_UNSUPPORTED, "clouds", "no WRF reader in this build");
#endif
}
