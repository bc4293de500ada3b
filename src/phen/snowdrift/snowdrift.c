/* snowdrift.c — the wind-driven snow phenomenon (SPEC §5, S1): lifecycle, the per-step loop of
 * S1 §3.2 (wind on the lattice, then snow transport, deposition and erosion every few wind
 * steps), the world voxelised into solid cells, and the drawables (falling flakes, snow cover),
 * metrics and fields. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "phen/snowflakes.h"
#include "snowdrift_internal.h"
#include "squall/par.h"
#include "squall/rng.h"

#define SNOW_PI 3.14159265358979323846
#define FLAKE_STREAM 0x534E4F57464C4Bull /* RNG stream of the visual flakes */
/* the drawn snow cover continues this far beyond the lattice, fading into the ground */
#define COVER_MARGIN_M 24.0

static int cover_margin(const sq_snowdrift_desc *d)
{
    int m = (int)ceil(COVER_MARGIN_M / d->cell_size_m);
    const int cap = d->cells[0] > d->cells[1] ? d->cells[0] : d->cells[1];
    return m < 2 ? 2 : m > cap ? cap : m;
}

static sq_lbm_desc lbm_desc(const sq_snowdrift_desc *d)
{
    sq_lbm_desc l;
    memset(&l, 0, sizeof l);
    l.cells = (sq_dims){d->cells[0], d->cells[1], d->cells[2]};
    l.cell_size_m = d->cell_size_m;
    l.dt_s = d->dt_s;
    l.tau = d->tau;
    l.viscosity_m2s = d->eddy_viscosity_m2s;
    l.collision = SQ_LBM_COLLISION_SMAGORINSKY;
    l.smagorinsky_c = d->smagorinsky_c;
    if (d->boundary == SQ_SNOWDRIFT_INFLOW) {
        const bool east = cos(d->wind_dir_deg * SNOW_PI / 180.0) >= 0;
        l.bc[SQ_LBM_FACE_XMIN] = east ? SQ_LBM_BC_INFLOW : SQ_LBM_BC_OUTFLOW;
        l.bc[SQ_LBM_FACE_XMAX] = east ? SQ_LBM_BC_OUTFLOW : SQ_LBM_BC_INFLOW;
        l.bc[SQ_LBM_FACE_YMIN] = l.bc[SQ_LBM_FACE_YMAX] = SQ_LBM_BC_PERIODIC;
    } else {
        l.bc[SQ_LBM_FACE_XMIN] = l.bc[SQ_LBM_FACE_XMAX] = SQ_LBM_BC_RECYCLE;
        l.bc[SQ_LBM_FACE_YMIN] = l.bc[SQ_LBM_FACE_YMAX] = SQ_LBM_BC_RECYCLE;
    }
    l.bc[SQ_LBM_FACE_ZMIN] = SQ_LBM_BC_WALL;
    l.bc[SQ_LBM_FACE_ZMAX] = SQ_LBM_BC_FREE_SLIP;
    l.wind.speed_mps = d->wind_speed_mps;
    l.wind.heading_deg = d->wind_dir_deg;
    l.wind.ref_height_m = d->ref_height_m;
    l.wind.roughness_m = d->roughness_m;
    l.wind.beaufort = d->beaufort;
    l.wind.gust_period_s = d->gust_period_s;
    l.wind.ramp_mps2 = d->wind_ramp_mps2;
    /* under mpirun the wind lattice is split over the ranks (slabs along z) and the snow in
     * the same slabs (snowdrift_split.c, docs/mpi.md) */
    l.decompose = true;
    return l;
}

void sq__snowdrift_lbm_desc(const sq_snowdrift_desc *d, sq_lbm_desc *out) { *out = lbm_desc(d); }

uint64_t sq_snowdrift_memory_bytes(const sq_snowdrift_desc *desc)
{
    sq_snowdrift_desc d;
    sq_snowdrift_desc_resolve(desc, &d);
    const sq_lbm_desc l = lbm_desc(&d);
    const uint64_t n = (uint64_t)d.cells[0] * d.cells[1] * d.cells[2];
    const uint64_t cols = (uint64_t)d.cells[0] * d.cells[1];
    return sq_lbm_memory_bytes(&l) + n * 18 /* snow counts and flags */ +
           n * 2 * sizeof(float) /* airborne-snow and surface-u* fields */ +
           cols * 2 * (sizeof(int64_t) + sizeof(float)) /* surface list, grows if needed */ +
           cols * sizeof(float) + (uint64_t)d.cells[1] * 5 * sizeof(double) +
           (uint64_t)(d.cells[0] + 2 * cover_margin(&d)) * (d.cells[1] + 2 * cover_margin(&d)) *
               (4 * sizeof(float) + sizeof(int64_t)) /* drawn snow cover */ +
           (uint64_t)d.visual_flakes * 7 * sizeof(float) + sizeof(struct sq_snowdrift);
}

void sq_snowdrift_destroy(sq_snowdrift *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    sq_lbm_destroy(s->lbm);
    if (s->slab)
        sq__snow_slab_destroy(s->slab); /* its snow with it */
    else
        sq__snow_destroy(s->snow);
    sq_free(ctx, s->tot);
    sq_free(ctx, s->rank_cells);
    sq_free(ctx, s->chg);
    sq_free(ctx, s->chg_all);
    sq_free(ctx, s->chg_count);
    sq_free(ctx, s->gair);
    sq_free(ctx, s->gkind);
    sq_free(ctx, s->fpos);
    sq_free(ctx, s->frot);
    sq_free(ctx, s->fspin);
    sq_free(ctx, s->depth);
    sq_free(ctx, s->surf_h);
    sq_free(ctx, s->cover);
    sq_free(ctx, s->air_kgm3);
    sq_free(ctx, s->ustar);
    sq_free(ctx, s->surf);
    sq_free(ctx, s->surf_us);
    sq_free(ctx, s->ground_z);
    sq_free(ctx, s->fade_w);
    sq_free(ctx, s->src_col);
    sq_free(ctx, s->fradius);
    sq_free(ctx, s->ffade);
    sq_free(ctx, s->tally_part);
    sq_free(ctx, s);
}

/* ---- visual flakes ------------------------------------------------------------------------ */

static bool cell_of(const sq_snowdrift *s, const float p[3], int *i, int *j, int *k)
{
    *i = (int)floor(((double)p[0] - s->origin[0]) / s->h);
    *j = (int)floor(((double)p[1] - s->origin[1]) / s->h);
    *k = (int)floor(((double)p[2] - s->origin[2]) / s->h);
    return *i >= 0 && *j >= 0 && *k >= 0 && *i < s->nx && *j < s->ny && *k < s->nz;
}

/* Whether the lattice cell (i, j, k) is solid for the snow and the wind (terrain, obstacles,
 * filled snow cells); the snow's kinds and the wind's solid flags agree between steps (a
 * split snow holds its slab only; the wind's flags are the whole lattice's on every rank). */
static inline bool solid_cell(const sq_snowdrift *s, int i, int j, int k)
{
    if (s->slab) return sq_lbm_is_solid(s->lbm, i, j, k);
    return s->snow->kind[i + (int64_t)s->nx * (j + (int64_t)s->ny * k)] != SQ_SNOW_AIR;
}

/* Places flake f uniformly in the air of the domain (anywhere) or in the top layer. The draws
 * are keyed by (key, flake, attempt), so flakes can be respawned in parallel and the result
 * does not depend on the thread count. */
static void spawn_flake(sq_snowdrift *s, int f, bool anywhere, uint64_t key)
{
    for (int attempt = 0; attempt < 8; attempt++) {
        float u[4];
        sq_rng_uniform4(s->d.seed, FLAKE_STREAM, (key << 24 | (uint64_t)f) * 8 + (uint64_t)attempt,
                        u);
        float *p = &s->fpos[3 * f];
        p[0] = (float)(s->origin[0] + (double)u[0] * s->nx * s->h);
        p[1] = (float)(s->origin[1] + (double)u[1] * s->ny * s->h);
        const double top = s->origin[2] + s->nz * s->h;
        p[2] = (float)(anywhere ? s->origin[2] + (double)u[2] * s->nz * s->h
                                : top - (double)u[2] * s->h);
        s->frot[f] = 6.2831853f * u[3];
        s->fspin[f] = (u[2] - 0.5f) * 3.0f;
        int i, j, k;
        if (cell_of(s, p, &i, &j, &k) && !solid_cell(s, i, j, k)) return;
    }
}

/* The flakes are drawn (and moved) while it snows. */
static bool flakes_drawn(const sq_snowdrift *s) { return s->nflakes > 0 && s->d.snowfall_mmh > 0; }

/* Moves the visual flakes by (u − u_fall ẑ) dt with the lattice wind of their cell; flakes that
 * land or leave are respawned at the top (keyed by the step: thread-count independent). */
static void move_flakes(sq_snowdrift *s, double dt, const sq_lbm_views *v)
{
    const float fall = (float)s->d.fall_speed_mps;
    const double lx = s->nx * s->h, ly = s->ny * s->h;
    const float *ux = v->u[0].data, *uy = v->u[1].data, *uz = v->u[2].data;
    const int64_t sy = v->u[0].sy, sz = v->u[0].sz;
    const uint64_t key = (uint64_t)s->steps + 1; /* key 0: the flakes placed at create */
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(s->nflakes >= 4096))
    for (int f = 0; f < s->nflakes; f++) {
        float *p = &s->fpos[3 * f];
        int i, j, k;
        if (!cell_of(s, p, &i, &j, &k)) {
            spawn_flake(s, f, false, key);
            continue;
        }
        const int64_t c = i + j * sy + k * sz;
        const float u = ux[c], w = uy[c];
        const float z = uz[c] - fall;
        p[0] += (float)((double)u * dt);
        p[1] += (float)((double)w * dt);
        p[2] += (float)((double)z * dt);
        s->frot[f] += (float)((double)s->fspin[f] * dt);
        /* wrap horizontally (the snow leaves and re-enters like the recycled wind) */
        if ((double)p[0] < s->origin[0]) p[0] += (float)lx;
        if ((double)p[0] >= s->origin[0] + lx) p[0] -= (float)lx;
        if ((double)p[1] < s->origin[1]) p[1] += (float)ly;
        if ((double)p[1] >= s->origin[1] + ly) p[1] -= (float)ly;
        if (!cell_of(s, p, &i, &j, &k) || solid_cell(s, i, j, k))
            spawn_flake(s, f, false, key); /* landed or left: a new flake at the top */
    }
}

/* ---- lifecycle ---------------------------------------------------------------------------- */

static void reduce_totals(sq_snowdrift *s);

static void *xalloc(sq_snowdrift *s, size_t bytes, bool *ok)
{
    void *p = sq_alloc_zero(s->ctx, bytes);
    if (!p) *ok = false;
    return p;
}

sq_result sq_snowdrift_create(sq_context *ctx, const sq_snowdrift_desc *desc,
                              const sq_world *world, sq_snowdrift **out)
{
    if (out) *out = NULL;
    if (!ctx || !out)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift", "sq_snowdrift_create: NULL argument");
    sq_result r = sq_snowdrift_validate(ctx, desc, world);
    if (r != SQ_OK) return r;
    sq_snowdrift_desc d;
    sq_snowdrift_desc_resolve(desc, &d);
    r = sq_context_check_memory(ctx, sq_snowdrift_memory_bytes(&d), "snowdrift lattice");
    if (r != SQ_OK) return r;
    sq_snowdrift *s = (sq_snowdrift *)sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    s->d = d;
    s->world = world;
    s->nx = d.cells[0];
    s->ny = d.cells[1];
    s->nz = d.cells[2];
    s->h = d.cell_size_m;
    s->origin[0] = d.center_m[0] - 0.5 * s->nx * s->h;
    s->origin[1] = d.center_m[1] - 0.5 * s->ny * s->h;
    /* one layer below the lowest ground point: the bottom layer is solid ground everywhere */
    double zmin = 0;
    if (world) {
        zmin = INFINITY;
        for (int j = 0; j <= s->ny; j++)
            for (int i = 0; i <= s->nx; i++) {
                const float z = sq_world_height_at(world, (float)(s->origin[0] + i * s->h),
                                                   (float)(s->origin[1] + j * s->h));
                if ((double)z < zmin) zmin = (double)z;
            }
    }
    s->origin[2] = zmin - s->h;

    const sq_lbm_desc ld = lbm_desc(&d);
    r = sq_lbm_create(ctx, &ld, &s->lbm);
    if (r != SQ_OK) {
        sq_snowdrift_destroy(s);
        return r;
    }
    const sq_lbm_info in = sq_lbm_get_info(s->lbm);
    s->lbm_dt = in.dt_s;
    /* snow step: as many wind steps as keep the flake displacement within snow_cfl cells */
    const double per_step = in.max_wind_lu + d.fall_speed_mps * in.dt_s / s->h;
    s->sub = (int)floor(d.snow_cfl / per_step);
    if (s->sub < 1) s->sub = 1;
    sq__snow_params sp;
    memset(&sp, 0, sizeof sp);
    sp.dx_m = s->h;
    sp.dt_s = s->sub * s->lbm_dt;
    sp.fall_speed_mps = d.fall_speed_mps;
    sp.threshold = d.threshold;
    sp.snow_density_kgm3 = d.snow_density_kgm3;
    sp.snowfall_mmh = d.snowfall_mmh;
    sp.speedup = d.speedup;
    sp.ustar_threshold_mps = d.ustar_threshold_mps;
    sp.erosion_efficiency = d.erosion_efficiency;
    sp.saturation_time_s = d.saturation_time_s;
    sp.saltation_kgm3 = d.saltation_kgm3;
    sp.periodic[0] = d.boundary == SQ_SNOWDRIFT_RECYCLE;
    sp.periodic[1] = true;
    sp.seed = d.seed;
    const int nranks = sq_par_size();
    if (nranks > 1) { /* the snow in the lattice's z slabs, each rank its own */
        r = sq__snow_slab_create(ctx, (sq_dims){s->nx, s->ny, s->nz}, &sp, &s->slab);
        if (r == SQ_OK) {
            s->snow = sq__snow_slab_snow(s->slab);
            sq__snow_slab_range(s->slab, &s->slab_lo, &s->slab_own, &s->slab_l0);
        }
        r = sq_par_agree(r);
    } else {
        r = sq__snow_create(ctx, (sq_dims){s->nx, s->ny, s->nz}, &sp, &s->snow);
    }
    if (r != SQ_OK) {
        sq_snowdrift_destroy(s);
        return r;
    }
    const size_t cols = (size_t)s->nx * s->ny, n = cols * s->nz;
    bool ok = true;
    if (s->slab) {
        s->tot = (int64_t *)xalloc(s, (cols + 6) * sizeof(int64_t), &ok);
        s->rank_cells = (int64_t *)xalloc(s, (size_t)nranks * sizeof(int64_t), &ok);
        s->chg_count = (int64_t *)xalloc(s, (size_t)(nranks + 1) * sizeof(int64_t), &ok);
        s->gkind = (uint8_t *)xalloc(s, n, &ok);
        if (sq_par_rank() == 0) s->gair = (uint32_t *)xalloc(s, n * sizeof(uint32_t), &ok);
        const int split[3] = {0, 0, 1};
        for (int q = 0; q < nranks && s->rank_cells; q++) {
            sq_par_block b;
            (void)sq_par_decompose((sq_dims){s->nx, s->ny, s->nz}, split, NULL, 2, nranks, q, &b);
            s->rank_cells[q] = (int64_t)b.n.nx * b.n.ny * b.n.nz;
        }
    }
    s->margin = cover_margin(&d);
    s->ex = s->nx + 2 * s->margin;
    s->ey = s->ny + 2 * s->margin;
    const size_t ecols = (size_t)s->ex * s->ey;
    s->depth = (float *)xalloc(s, cols * sizeof(float), &ok);
    s->surf_h = (float *)xalloc(s, ecols * sizeof(float), &ok);
    s->cover = (float *)xalloc(s, ecols * sizeof(float), &ok);
    s->ground_z = (float *)xalloc(s, ecols * sizeof(float), &ok);
    s->fade_w = (float *)xalloc(s, ecols * sizeof(float), &ok);
    s->src_col = (int64_t *)xalloc(s, ecols * sizeof(int64_t), &ok);
    s->air_kgm3 = (float *)xalloc(s, n * sizeof(float), &ok);
    s->ustar = (float *)xalloc(s, (size_t)s->snow->n * sizeof(float), &ok); /* the snow's */
    s->surf_cap = (int64_t)cols * 2;
    s->surf = (int64_t *)xalloc(s, (size_t)s->surf_cap * sizeof(int64_t), &ok);
    s->surf_us = (float *)xalloc(s, (size_t)s->surf_cap * sizeof(float), &ok);
    s->tally_part = (double *)xalloc(s, (size_t)s->ny * 5 * sizeof(double), &ok);
    uint8_t *mask = (uint8_t *)xalloc(s, n, &ok);
    if (d.snowfall_mmh > 0) {
        s->nflakes = d.visual_flakes;
        s->fpos = (float *)xalloc(s, (size_t)s->nflakes * 3 * sizeof(float), &ok);
        s->frot = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
        s->fspin = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
        s->fradius = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
        s->ffade = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
    }
    if (s->slab) ok = sq_par_agree(ok ? SQ_OK : SQ_ERR_OUT_OF_MEMORY) == SQ_OK;
    if (!ok) {
        sq_free(ctx, mask);
        sq_snowdrift_destroy(s);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    /* terrain, obstacles and closed meshes at cell centres become solid cells for wind and
     * snow (the bottom layer always) */
    if (world) {
        const int dims[3] = {s->nx, s->ny, s->nz};
        r = sq_world_voxelise(world, s->origin, s->h, dims, SQ_SOLID_ALL, mask);
        if (r != SQ_OK) {
            sq_free(ctx, mask);
            sq_snowdrift_destroy(s);
            return r;
        }
    }
    for (size_t c = 0; c < cols; c++) mask[c] = 1;
    /* the snow's planes (a slab's: its own and the neighbours' edge planes) */
    const int kz = s->slab ? s->slab_lo - s->slab_l0 : 0;
    for (int kl = 0; kl < s->snow->nz; kl++)
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < s->nx; i++)
                if (mask[(size_t)i + cols * (size_t)(kl + kz) + (size_t)s->nx * j])
                    sq__snow_set_static(s->snow, i, j, kl, true);
    r = sq_lbm_set_solid_mask(s->lbm, mask);
    sq_free(ctx, mask);
    if (r != SQ_OK) {
        sq_snowdrift_destroy(s);
        return r;
    }
    for (int f = 0; f < s->nflakes; f++) spawn_flake(s, f, true, 0);
    /* as if it had been snowing for a while: the air holds the steady falling concentration,
     * λ flakes per top cell per step spread over the fall of (u_g dt/dx) cells per step
     * (counted as fallen, so the budget holds from the start) */
    {
        sq__snow *sn = s->snow;
        const double lambda = sq__snow_flakes_per_top_cell(&sn->p);
        const double per_cell = lambda / (d.fall_speed_mps * sn->p.dt_s / s->h);
        /* a slab: its own planes, drawn by global cell */
        const int64_t c0 = s->slab ? (int64_t)s->slab_l0 * (int64_t)cols : 0;
        const int64_t c1 = s->slab ? c0 + (int64_t)s->slab_own * (int64_t)cols : sn->n;
        const int64_t g0 = (int64_t)kz * (int64_t)cols;
        for (int64_t c = c0; c < c1 && per_cell > 0; c++) {
            if (sn->kind[c] != SQ_SNOW_AIR) continue;
            const double x =
                per_cell + sq_rng_uniform_d(d.seed, FLAKE_STREAM + 1, (uint64_t)(c + g0));
            const uint32_t m = (uint32_t)x;
            sn->air[c] += m;
            sn->fallen += m;
        }
    }
    /* the drawn snow cover (static parts cached once): the ground under every drawn column,
     * the lattice column whose depth it shows (periodic continuation across recycled faces,
     * the edge column across open ones) and the weight fading that depth to 0 over the margin
     * (smoothstep of the distance from the lattice, in columns) */
    {
        const int M = s->margin;
        const bool per[2] = {d.boundary == SQ_SNOWDRIFT_RECYCLE, true};
        for (int jj = 0; jj < s->ey; jj++)
            for (int ii = 0; ii < s->ex; ii++) {
                const int i = ii - M, j = jj - M;
                const size_t q = (size_t)ii + (size_t)s->ex * jj;
                const float x = (float)(s->origin[0] + (i + 0.5) * s->h);
                const float y = (float)(s->origin[1] + (j + 0.5) * s->h);
                s->ground_z[q] =
                    world ? sq_world_surface_at(world, x, y) : (float)(s->origin[2] + s->h);
                const int oi = i < 0 ? -i : i >= s->nx ? i - s->nx + 1 : 0;
                const int oj = j < 0 ? -j : j >= s->ny ? j - s->ny + 1 : 0;
                const double t = 1.0 - sqrt((double)oi * oi + (double)oj * oj) / M;
                const double w = t <= 0 ? 0.0 : t * t * (3.0 - 2.0 * t);
                s->fade_w[q] = (float)w;
                int si = per[0] ? ((i % s->nx) + s->nx) % s->nx : i < 0 ? 0 : i >= s->nx ? s->nx - 1 : i;
                int sj = per[1] ? ((j % s->ny) + s->ny) % s->ny : j < 0 ? 0 : j >= s->ny ? s->ny - 1 : j;
                s->src_col[q] = si + (int64_t)s->nx * sj;
            }
    }
    s->derived_dirty = s->air_dirty = true;
    /* a distributed run: the wind lattice's slabs and the snow's slabs must be the same; the
     * totals, and the whole lattice gathered to rank 0 now (collective calls), so that the
     * fields, drawables and metrics asked before the first frame find them ready */
    if (s->slab) {
        sq_lbm_views lv;
        int z0 = -1;
        r = sq_lbm_get_slab_views(s->lbm, &lv, &z0);
        if (r == SQ_OK && (z0 != s->slab_lo || lv.u[0].n.nz != s->slab_own))
            r = sq__fail(ctx, SQ_ERR_INTERNAL, "snowdrift",
                         "rank %d: the wind's slab (planes %d + %d) is not the snow's (%d + %d)",
                         sq_par_rank(), z0, lv.u[0].n.nz, s->slab_lo, s->slab_own);
        r = sq_par_agree(r);
        if (r == SQ_OK) r = sq__snowdrift_frame_sync(s, true);
        if (r != SQ_OK) {
            sq_snowdrift_destroy(s);
            return r;
        }
        reduce_totals(s);
    }
    sq_log(ctx, SQ_LOG_INFO, "snowdrift",
           "lattice %dx%dx%d of %g m, wind step %.4g s, snow every %d wind steps, flake %.3g kg",
           s->nx, s->ny, s->nz, s->h, s->lbm_dt, s->sub, s->snow->flake_mass_kg);
    *out = s;
    return SQ_OK;
}

/* ---- friction velocity on the surface ----------------------------------------------------- */

/* u* (SPEC §5.6 erosion) is needed only where snow can lift: air cells resting on a solid
 * cell. The list of those cells is rebuilt from the snow's kinds (which the wind's solid flags
 * follow), u* is computed there by the wind solver, and every other cell of the field stays 0. */
static sq_result surface_friction_velocity(sq_snowdrift *s, sq_field_view *out)
{
    const sq__snow *sn = s->snow;
    const int64_t cols = (int64_t)s->nx * s->ny;
    for (int64_t q = 0; q < s->nsurf; q++) s->ustar[s->surf[q]] = 0.0f;
    s->nsurf = 0;
    int64_t m = 0;
    /* a slab: its own planes (the plane below the first is held, its kinds current) */
    const int64_t cend = s->slab ? (int64_t)(s->slab_l0 + s->slab_own) * cols : sn->n;
    for (int64_t c = cols; c < cend; c++) {
        if (sn->kind[c] != SQ_SNOW_AIR || sn->kind[c - cols] == SQ_SNOW_AIR) continue;
        if (m == s->surf_cap) { /* more surface than foreseen (overhangs): grow */
            const int64_t cap = 2 * s->surf_cap;
            int64_t *ns = (int64_t *)sq_alloc(s->ctx, (size_t)cap * sizeof(int64_t));
            float *nu = (float *)sq_alloc(s->ctx, (size_t)cap * sizeof(float));
            if (!ns || !nu) {
                sq_free(s->ctx, ns);
                sq_free(s->ctx, nu);
                return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "snowdrift",
                                "surface list of %lld cells: out of memory", (long long)cap);
            }
            memcpy(ns, s->surf, (size_t)m * sizeof(int64_t));
            sq_free(s->ctx, s->surf);
            sq_free(s->ctx, s->surf_us);
            s->surf = ns;
            s->surf_us = nu;
            s->surf_cap = cap;
        }
        s->surf[m++] = c;
    }
    s->nsurf = m;
    sq_result r;
    if (s->slab) { /* from the slab's own wind: the list in global cells for the call */
        const int64_t g0 = (int64_t)(s->slab_lo - s->slab_l0) * cols;
        for (int64_t q = 0; q < m; q++) s->surf[q] += g0;
        r = sq_lbm_get_slab_friction_velocity_at(s->lbm, m, s->surf, s->surf_us);
        for (int64_t q = 0; q < m; q++) s->surf[q] -= g0;
    } else {
        r = sq_lbm_get_friction_velocity_at(s->lbm, m, s->surf, s->surf_us);
    }
    if (r != SQ_OK) return r;
    for (int64_t q = 0; q < m; q++) s->ustar[s->surf[q]] = s->surf_us[q];
    *out = (sq_field_view){s->ustar, {sn->nx, sn->ny, sn->nz}, 1, s->nx, (ptrdiff_t)cols};
    return SQ_OK;
}

/* ---- the snow split over the ranks (under mpirun) ------------------------------------------ */

/* Grows *buf (keeping its entries) to hold at least `need` entries. */
static bool grow_i64(sq_snowdrift *s, int64_t **buf, int64_t *cap, int64_t need)
{
    if (need <= *cap) return true;
    int64_t c = *cap > 0 ? *cap : 256;
    while (c < need) c *= 2;
    int64_t *b = (int64_t *)sq_alloc(s->ctx, (size_t)c * sizeof(int64_t));
    if (!b) return false;
    if (*cap > 0) memcpy(b, *buf, (size_t)*cap * sizeof(int64_t));
    sq_free(s->ctx, *buf);
    *buf = b;
    *cap = c;
    return true;
}

/* The cells of every slab that turned snow-solid or fluid in the last snow step, passed to the
 * wind lattice (sq_lbm_set_solid is collective) on every rank in the one-rank order (ascending
 * global index: the slabs' lists in rank order). Two meetings: the counts, then the lists
 * (none when nothing changed). */
static sq_result couple_split(sq_snowdrift *s)
{
    const sq__snow *sn = s->snow;
    const int64_t cols = (int64_t)s->nx * s->ny;
    const int64_t c0 = (int64_t)s->slab_l0 * cols, c1 = c0 + (int64_t)s->slab_own * cols;
    const int64_t g0 = (int64_t)(s->slab_lo - s->slab_l0) * cols;
    const int nr = sq_par_size(), me = sq_par_rank();
    int64_t m = 0;
    bool ok = true;
    for (int64_t c = c0; c < c1 && ok; c++) {
        if (!sn->changed[c]) continue;
        ok = grow_i64(s, &s->chg, &s->chg_cap, m + 1);
        if (ok) s->chg[m++] = 2 * (c + g0) + (sn->kind[c] != SQ_SNOW_AIR);
    }
    for (int q = 0; q < nr; q++) s->chg_count[q] = q == me ? m : 0;
    s->chg_count[nr] = ok ? 0 : 1; /* ranks out of memory */
    sq_par_sum_i64(s->chg_count, nr + 1);
    int64_t all = 0;
    for (int q = 0; q < nr; q++) all += s->chg_count[q];
    if (s->chg_count[nr] == 0 && all > 0 && !grow_i64(s, &s->chg_all, &s->chg_all_cap, all))
        ok = false;
    sq_result r = sq_par_agree(s->chg_count[nr] == 0 && ok ? SQ_OK : SQ_ERR_OUT_OF_MEMORY);
    if (r != SQ_OK)
        return sq__fail(s->ctx, r, "snowdrift", "the list of %lld cells that changed kind: out "
                        "of memory", (long long)all);
    if (all == 0) return SQ_OK;
    r = sq_par_allgather_i64(s->chg, s->chg_count, s->chg_all);
    for (int64_t q = 0; q < all && r == SQ_OK; q++) {
        const int64_t c = s->chg_all[q] >> 1;
        const int i = (int)(c % s->nx), j = (int)((c / s->nx) % s->ny), k = (int)(c / cols);
        r = sq_lbm_set_solid(s->lbm, i, j, k, (s->chg_all[q] & 1) != 0);
    }
    return r;
}

/* One snow step of this rank's slab from its own lattice slab's wind: u* on its surface
 * cells, the slab step (flakes handed over at the slab faces), the changed cells to the
 * wind lattice. */
static sq_result snow_step_split(sq_snowdrift *s)
{
    double t0 = sq_time_now(), t1;
    sq_lbm_views lv;
    int z0;
    sq_result r = sq_lbm_get_slab_views(s->lbm, &lv, &z0);
    sq_field_view us = {NULL, {0, 0, 0}, 0, 0, 0};
    if (r == SQ_OK && !s->d.no_erosion) r = surface_friction_velocity(s, &us);
    r = sq_par_agree(r);
    if (r != SQ_OK) return r;
    t1 = sq_time_now();
    s->ms_ustar += 1e3 * (t1 - t0);
    r = sq__snow_slab_step(s->slab, lv.u[0].data, lv.u[1].data, lv.u[2].data,
                           s->d.no_erosion ? NULL : s->ustar);
    t0 = sq_time_now();
    s->snow->ms_transport += 1e3 * (t0 - t1); /* transport, deposition and erosion */
    if (r == SQ_OK) r = couple_split(s);
    s->snow->ms_couple += 1e3 * (sq_time_now() - t0);
    return r;
}

/* The totals of the split snow (s->tot): every slab's own planes summed over the ranks, so
 * the metrics, the budget and the drawn depth are the whole lattice's on every rank. One
 * meeting of (nx ny + 6) integers. */
static void reduce_totals(sq_snowdrift *s)
{
    const sq__snow *sn = s->snow;
    const int nx = s->nx, ny = s->ny;
    const int64_t cols = (int64_t)nx * ny;
    const uint32_t thr = (uint32_t)sn->p.threshold;
    int64_t *v = s->tot;
    int64_t air = 0, dep = 0, solid = 0;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(+:air, dep, solid) \
           if(cols * s->slab_own >= 32768))
    for (int j = 0; j < ny; j++) {
        int64_t *fl = v + (int64_t)nx * j;
        for (int i = 0; i < nx; i++) fl[i] = 0;
        for (int k = s->slab_l0; k < s->slab_l0 + s->slab_own; k++) {
            const int64_t c0 = (int64_t)nx * j + cols * k;
            const uint8_t *kd = sn->kind + c0;
            const uint32_t *a = sn->air + c0, *dp = sn->dep + c0;
            for (int i = 0; i < nx; i++) {
                air += a[i];
                dep += dp[i];
                solid += kd[i] == SQ_SNOW_SOLID;
                fl[i] += kd[i] == SQ_SNOW_SOLID ? thr : kd[i] == SQ_SNOW_AIR ? dp[i] : 0u;
            }
        }
    }
    v[cols + 0] = air;
    v[cols + 1] = dep;
    v[cols + 2] = solid;
    v[cols + 3] = (int64_t)sn->fallen;
    v[cols + 4] = (int64_t)sn->left;
    v[cols + 5] = (int64_t)sn->eroded;
    sq_par_sum_i64(v, (int)(cols + 6));
}

sq_result sq__snowdrift_frame_sync(void *self, bool gather)
{
    sq_snowdrift *s = (sq_snowdrift *)self;
    if (!s->slab || !gather) return SQ_OK;
    sq_result r = sq_lbm_get_views(s->lbm, &s->gviews); /* gathered on every rank */
    const sq__snow *sn = s->snow;
    const int64_t c0 = (int64_t)s->slab_l0 * s->nx * s->ny;
    if (r == SQ_OK) r = sq_par_gather_u32(sn->air + c0, s->rank_cells, s->gair);
    if (r == SQ_OK) r = sq_par_gather_u8(sn->kind + c0, s->rank_cells, s->gkind);
    if (r != SQ_OK) return r;
    if (s->gair) { /* rank 0: the airborne snow of the fields (update_air's) */
        const double cell_kg = sn->flake_mass_kg / (s->h * s->h * s->h) / s->d.speedup;
        const int64_t n = (int64_t)s->nx * s->ny * s->nz;
        const int nt = sq_context_threads(s->ctx);
        (void)nt;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(n >= 32768))
        for (int64_t c = 0; c < n; c++) s->air_kgm3[c] = (float)(s->gair[c] * cell_kg);
    }
    s->air_dirty = false;
    return SQ_OK;
}

/* ---- stepping ----------------------------------------------------------------------------- */

sq_result sq_snowdrift_step(sq_snowdrift *s, double dt)
{
    if (!s) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_snowdrift_step: NULL");
    if (!(dt > 0) || !isfinite(dt))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowdrift", "step dt = %g s; must be > 0",
                        dt);
    s->t_acc += dt;
    const double chunk = s->sub * s->lbm_dt;
    sq_lbm_views v;
    bool stepped = false;
    while (s->t_acc >= chunk) {
        double t0 = sq_time_now();
        sq_result r = sq_lbm_step(s->lbm, s->sub); /* wind: S1 §3.2 steps 1–5 */
        double t1 = sq_time_now();
        s->ms_lbm += 1e3 * (t1 - t0);
        s->lbm_steps += s->sub;
        if (s->slab) { /* under mpirun: this rank's slab of the snow from its slab's wind */
            if (r == SQ_OK) r = snow_step_split(s);
            if (r != SQ_OK) return r;
            stepped = true;
        } else {
            if (r == SQ_OK) r = sq_lbm_get_views(s->lbm, &v);
            sq_field_view us = {NULL, {0, 0, 0}, 0, 0, 0};
            if (r == SQ_OK && !s->d.no_erosion) r = surface_friction_velocity(s, &us);
            t0 = sq_time_now();
            s->ms_ustar += 1e3 * (t0 - t1);
            if (r == SQ_OK) /* snow: steps 6–8 (transport, deposition, erosion) */
                r = sq__snow_step(s->snow, v.u, s->d.no_erosion ? NULL : &us, s->lbm);
            if (r != SQ_OK) return r;
        }
        s->t_acc -= chunk;
        s->snow_steps++;
        s->derived_dirty = s->air_dirty = true;
    }
    if (stepped) { /* the split snow's totals: the metrics and the drawn depth */
        const double t0 = sq_time_now();
        reduce_totals(s);
        s->ms_budget += 1e3 * (sq_time_now() - t0);
    }
    s->time_s += dt;
    s->steps++;
    if (flakes_drawn(s)) { /* under mpirun: the whole wind gathered on every rank */
        const double t0 = sq_time_now();
        sq_result r = sq_lbm_get_views(s->lbm, &v);
        if (r != SQ_OK) return r;
        move_flakes(s, dt, &v);
        s->ms_flakes += 1e3 * (sq_time_now() - t0);
    }
    s->version++;
    return SQ_OK;
}

void sq_snowdrift_get_stats(const sq_snowdrift *s, sq_snowdrift_stats *out)
{
    memset(out, 0, sizeof *out);
    if (!s) return;
    out->steps = s->steps;
    out->lbm_steps = s->lbm_steps;
    out->snow_steps = s->snow_steps;
    out->lbm_steps_per_snow_step = s->sub;
    out->lbm_dt_s = s->lbm_dt;
    out->cells = (int64_t)s->nx * s->ny * s->nz;
    out->ms_lbm = s->ms_lbm;
    out->ms_ustar = s->ms_ustar;
    out->ms_transport = s->snow->ms_transport;
    out->ms_deposit = s->snow->ms_deposit;
    out->ms_erode = s->snow->ms_erode;
    out->ms_couple = s->snow->ms_couple;
    out->ms_flakes = s->ms_flakes;
    out->ms_derived = s->ms_derived;
    out->ms_budget = s->ms_budget;
}

double sq_snowdrift_max_stable_dt(const sq_snowdrift *s)
{
    (void)s;
    return 0.0; /* sub-cycled internally at the lattice step */
}

sq_result sq_snowdrift_set_wind(sq_snowdrift *s, double speed_mps, double dir_deg)
{
    if (!s) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_snowdrift_set_wind: NULL");
    return sq_lbm_set_wind(s->lbm, speed_mps, dir_deg);
}

/* One pass over the snow (rows of x in parallel, per-row partial sums added in row order, so
 * the result does not depend on the thread count): the budget sums and the deposited depth of
 * every column (snow-solid cells count full, resting flakes as their share of a cell), written
 * to depth (may be NULL). */
typedef struct snow_tally {
    uint64_t airborne, deposited;
    int64_t solid;
    double depth_mean_m, depth_max_m;
} snow_tally;

/* The same from the split snow's reduced totals, in the one-rank order of the sums. */
static void tally_split(const sq_snowdrift *s, float *depth, snow_tally *t)
{
    const int nx = s->nx, ny = s->ny;
    const int64_t cols = (int64_t)nx * ny;
    const double thr_d = s->snow->p.threshold;
    const int64_t *v = s->tot;
    memset(t, 0, sizeof *t);
    double dsum = 0;
    for (int j = 0; j < ny; j++) {
        double rsum = 0, rmax = 0;
        for (int i = 0; i < nx; i++) {
            const double d = (double)(uint64_t)v[i + (int64_t)nx * j] / thr_d * s->h;
            if (depth) depth[i + (int64_t)nx * j] = (float)d;
            rsum += d;
            if (d > rmax) rmax = d;
        }
        dsum += rsum;
        if (rmax > t->depth_max_m) t->depth_max_m = rmax;
    }
    t->airborne = (uint64_t)v[cols + 0];
    t->deposited = (uint64_t)v[cols + 1];
    t->solid = v[cols + 2];
    t->depth_mean_m = dsum / (double)cols;
}

static void tally(const sq_snowdrift *s, float *depth, snow_tally *t)
{
    if (s->slab) {
        tally_split(s, depth, t);
        return;
    }
    const sq__snow *sn = s->snow;
    const int nx = s->nx, ny = s->ny, nz = s->nz;
    const int64_t cols = (int64_t)nx * ny;
    const uint32_t thr = (uint32_t)sn->p.threshold;
    const double thr_d = sn->p.threshold;
    double *part = s->tally_part;
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(sn->n >= 32768))
    for (int j = 0; j < ny; j++) {
        uint64_t air = 0, dep = 0, solid = 0;
        double dsum = 0, dmax = 0;
        for (int i0 = 0; i0 < nx; i0 += 256) {
            const int m = nx - i0 < 256 ? nx - i0 : 256;
            uint64_t fl[256];
            for (int i = 0; i < m; i++) fl[i] = 0;
            for (int k = 0; k < nz; k++) {
                const int64_t c0 = i0 + (int64_t)nx * j + cols * k;
                const uint8_t *kd = sn->kind + c0;
                const uint32_t *a = sn->air + c0, *dp = sn->dep + c0;
                for (int i = 0; i < m; i++) {
                    air += a[i];
                    dep += dp[i];
                    solid += kd[i] == SQ_SNOW_SOLID;
                    fl[i] += kd[i] == SQ_SNOW_SOLID ? thr : kd[i] == SQ_SNOW_AIR ? dp[i] : 0u;
                }
            }
            for (int i = 0; i < m; i++) {
                const double d = (double)fl[i] / thr_d * s->h;
                if (depth) depth[i0 + i + (int64_t)nx * j] = (float)d;
                dsum += d;
                if (d > dmax) dmax = d;
            }
        }
        part[5 * j + 0] = (double)air;
        part[5 * j + 1] = (double)dep;
        part[5 * j + 2] = (double)solid;
        part[5 * j + 3] = dsum;
        part[5 * j + 4] = dmax;
    }
    memset(t, 0, sizeof *t);
    double dsum = 0;
    for (int j = 0; j < ny; j++) {
        t->airborne += (uint64_t)part[5 * j + 0];
        t->deposited += (uint64_t)part[5 * j + 1];
        t->solid += (int64_t)part[5 * j + 2];
        dsum += part[5 * j + 3];
        if (part[5 * j + 4] > t->depth_max_m) t->depth_max_m = part[5 * j + 4];
    }
    t->depth_mean_m = dsum / (double)cols;
}

/* The snow cover on top of the world's surface, for drawing; coverage ramps over the first
 * 5 cm. Rebuilt only when a frame is drawn after the snow changed. */
static void update_derived(sq_snowdrift *s)
{
    if (!s->derived_dirty) return;
    const double t0 = sq_time_now();
    snow_tally t;
    tally(s, s->depth, &t);
    const int64_t ecols = (int64_t)s->ex * s->ey;
    for (int64_t q = 0; q < ecols; q++) {
        const float w = s->fade_w[q], dpt = s->depth[s->src_col[q]];
        s->surf_h[q] = s->ground_z[q] + w * dpt;
        const float cv = dpt * (1.0f / 0.05f);
        s->cover[q] = w * (cv > 1.0f ? 1.0f : cv);
    }
    s->derived_dirty = false;
    s->ms_derived += 1e3 * (sq_time_now() - t0);
}

/* The airborne-snow mass concentration, only for field export, in kg m-3 of the real snowfall:
 * snow.speedup multiplies the flakes that fall and lift (a time-lapse of the accumulation while
 * the wind stays real-time), so the concentration in the lattice is speedup times the physical
 * one and is divided by it here (the village preset's 10000x made the field 10^4 too large). */
static void update_air(sq_snowdrift *s)
{
    if (!s->air_dirty || s->slab) return; /* split: made from the gathered snow at frame_sync */
    const sq__snow *sn = s->snow;
    const double cell_kg = sn->flake_mass_kg / (s->h * s->h * s->h) / s->d.speedup;
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(sn->n >= 32768))
    for (int64_t c = 0; c < sn->n; c++) s->air_kgm3[c] = (float)(sn->air[c] * cell_kg);
    s->air_dirty = false;
}

void sq_snowdrift_get_budget(const sq_snowdrift *s, sq_snowdrift_budget *out)
{
    memset(out, 0, sizeof *out);
    if (!s) return;
    snow_tally t;
    tally(s, NULL, &t);
    const sq__snow *sn = s->snow;
    const double m = sn->flake_mass_kg;
    const int64_t cols = (int64_t)s->nx * s->ny;
    const uint64_t fallen = s->slab ? (uint64_t)s->tot[cols + 3] : sn->fallen;
    const uint64_t left = s->slab ? (uint64_t)s->tot[cols + 4] : sn->left;
    const uint64_t eroded = s->slab ? (uint64_t)s->tot[cols + 5] : sn->eroded;
    out->fallen_flakes = fallen;
    out->airborne_flakes = t.airborne;
    out->deposited_flakes = t.deposited;
    out->left_flakes = left;
    out->eroded_flakes = eroded;
    out->flake_mass_kg = m;
    out->fallen_kg = (double)fallen * m;
    out->airborne_kg = (double)t.airborne * m;
    out->deposited_kg = (double)t.deposited * m;
    out->left_kg = (double)left * m;
    out->snow_cells = t.solid;
    out->depth_mean_m = t.depth_mean_m;
    out->depth_max_m = t.depth_max_m;
}

/* ---- drawables, metrics, fields ------------------------------------------------------------ */

void sq__snowdrift_observe(sq_snowdrift *s, const sq_camera *camera)
{
    if (!s || !camera) return;
    const sq_camera c = sq_camera_resolve(*camera);
    s->cam_pos = c.position_m;
    s->have_camera = true;
}

/* Flakes seen smaller than the minimum angular radius are drawn at it, with their alpha scaled
 * by (true/drawn radius)² so that projected area x opacity (what a flake too small to resolve
 * contributes to a pixel) stays what it physically is. */
static void size_flakes(sq_snowdrift *s)
{
    const float r0 = (float)s->d.flake_radius_m, amin = (float)(s->d.flake_min_mrad * 1e-3);
    const sq_vec3 e = s->cam_pos;
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(s->nflakes >= 16384))
    for (int f = 0; f < s->nflakes; f++) {
        const float *p = &s->fpos[3 * f];
        const float dx = p[0] - e.x, dy = p[1] - e.y, dz = p[2] - e.z;
        const float rmin = amin * sqrtf(dx * dx + dy * dy + dz * dz);
        if (rmin > r0) {
            const float q = r0 / rmin;
            s->fradius[f] = rmin;
            s->ffade[f] = q * q;
        } else {
            s->fradius[f] = r0;
            s->ffade[f] = 1.0f;
        }
    }
}

int sq__snowdrift_drawables(sq_snowdrift *s, sq_drawable *out, int max)
{
    update_derived(s);
    int n = 0;
    if (n < max) {
        sq_drawable *d = &out[n++];
        memset(d, 0, sizeof *d);
        d->kind = SQ_DRAWABLE_SURFACE;
        d->name = "snow-cover";
        sq_surface_view *v = &d->u.surface;
        v->nx = s->ex;
        v->ny = s->ey;
        v->origin_m = sq_v3((float)(s->origin[0] + (0.5 - s->margin) * s->h),
                            (float)(s->origin[1] + (0.5 - s->margin) * s->h), 0.0f);
        v->dx_m = v->dy_m = (float)s->h;
        v->height_m = s->surf_h;
        v->coverage = s->cover;
        v->material = SQ_MATERIAL_SNOW;
        v->version = s->version;
    }
    if (flakes_drawn(s) && n < max) {
        const bool sized = s->have_camera;
        if (sized) {
            const double t0 = sq_time_now();
            size_flakes(s);
            s->ms_flakes += 1e3 * (sq_time_now() - t0);
        }
        sq__snowflakes_drawable(&out[n++], s->nflakes, s->fpos, s->frot, sized ? s->fradius : NULL,
                                sized ? s->ffade : NULL, (float)s->d.flake_radius_m, 0.0f,
                                s->version);
    }
    return n;
}

int sq__snowdrift_metrics(sq_snowdrift *s, sq_metric *out, int max)
{
    const double t0 = sq_time_now();
    sq_snowdrift_budget b;
    sq_snowdrift_get_budget(s, &b);
    s->ms_budget += 1e3 * (sq_time_now() - t0);
    const sq_lbm_info in = sq_lbm_get_info(s->lbm);
    int n = 0;
#define PUT(nm, val, un)                                                                       \
    do {                                                                                       \
        if (n < max) out[n++] = (sq_metric){nm, (double)(val), un};                           \
    } while (0)
    PUT("snow_depth_mean_m", b.depth_mean_m, "m");
    PUT("snow_depth_max_m", b.depth_max_m, "m");
    PUT("snow_fallen_kg", b.fallen_kg, "kg");
    PUT("snow_airborne_kg", b.airborne_kg, "kg");
    PUT("snow_deposited_kg", b.deposited_kg, "kg");
    PUT("snow_left_kg", b.left_kg, "kg");
    PUT("snow_cells", b.snow_cells, "1");
    PUT("wind_target_mps", in.wind_speed_mps, "m/s");
#undef PUT
    return n;
}

int sq__snowdrift_fields(sq_snowdrift *s, sq_named_field *out, int max)
{
    if (max < 5) return 0;
    update_derived(s);
    update_air(s);
    sq_lbm_views v;
    if (s->slab) /* under mpirun: as gathered at the last frame_sync with gather (rank 0) */
        v = s->gviews;
    else if (sq_lbm_get_views(s->lbm, &v) != SQ_OK)
        return 0;
    const sq_vec3 o = sq_v3((float)(s->origin[0] + 0.5 * s->h), (float)(s->origin[1] + 0.5 * s->h),
                            (float)(s->origin[2] + 0.5 * s->h));
    const sq_vec3 sp = sq_v3((float)s->h, (float)s->h, (float)s->h);
    /* terrain, obstacles and cells filled with snow carry no air */
    const uint8_t *solid = s->slab ? s->gkind : s->snow->kind;
    int n = 0;
    out[n++] = (sq_named_field){"u", "m s-1", "eastward wind", "eastward_wind", v.u[0].data,
                                s->nx, s->ny, s->nz, o, sp, solid, SQ_FIELD_LEVEL_ALTITUDE};
    out[n++] = (sq_named_field){"v", "m s-1", "northward wind", "northward_wind", v.u[1].data,
                                s->nx, s->ny, s->nz, o, sp, solid, SQ_FIELD_LEVEL_ALTITUDE};
    out[n++] = (sq_named_field){"w", "m s-1", "upward air velocity", "upward_air_velocity",
                                v.u[2].data, s->nx, s->ny, s->nz, o, sp, solid,
                                SQ_FIELD_LEVEL_ALTITUDE};
    out[n++] = (sq_named_field){"blowing_snow_concentration", "kg m-3",
                                "mass concentration of airborne snow at the real snowfall rate "
                                "(snow.speedup divided out)",
                                NULL, s->air_kgm3, s->nx, s->ny, s->nz, o, sp, solid,
                                SQ_FIELD_LEVEL_ALTITUDE};
    out[n++] = (sq_named_field){"snow_depth", "m", "depth of deposited snow",
                                "surface_snow_thickness", s->depth, s->nx, s->ny, 1,
                                sq_v3(o.x, o.y, 0.0f), sp, NULL, SQ_FIELD_LEVEL_SURFACE};
    return n;
}

/* ---- live changes (the plug-in's apply_live, snowdrift_plugin.c) ------------------------------
 * d differs from s->d only in live keys: the wind (speed and direction, through the lattice's
 * wind forcing, which checks the Mach limit of the lattice made at create), the snowfall rate
 * (the flakes injected per top cell and snow step from now on) and the drawing of flakes. Flakes
 * are drawn while it snows: a scene that started without snowfall gets its draw.flakes when it
 * starts to snow (placed anywhere in the air, as at create); at 0 mm/h they are not drawn. */
sq_result sq__snowdrift_apply_live(sq_snowdrift *s, const sq_snowdrift_desc *d)
{
    const bool make = d->snowfall_mmh > 0 && s->nflakes == 0 && s->d.visual_flakes > 0;
    float *a[5] = {NULL, NULL, NULL, NULL, NULL};
    if (make) {
        const size_t n = (size_t)s->d.visual_flakes, per[5] = {3, 1, 1, 1, 1};
        bool ok = true;
        for (int k = 0; k < 5; k++) a[k] = (float *)xalloc(s, n * per[k] * sizeof(float), &ok);
        if (!ok) {
            for (int k = 0; k < 5; k++) sq_free(s->ctx, a[k]);
            return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, "snowdrift",
                            "snow.snowfall_mmh = %g: no memory for the %d drawn flakes "
                            "(draw.flakes)",
                            d->snowfall_mmh, s->d.visual_flakes);
        }
    }
    if (d->wind_speed_mps != s->d.wind_speed_mps || d->wind_dir_deg != s->d.wind_dir_deg) {
        const sq_result r = sq_lbm_set_wind(s->lbm, d->wind_speed_mps, d->wind_dir_deg);
        if (r != SQ_OK) {
            for (int k = 0; k < 5; k++) sq_free(s->ctx, a[k]);
            return r;
        }
    }
    if (make) {
        s->fpos = a[0];
        s->frot = a[1];
        s->fspin = a[2];
        s->fradius = a[3];
        s->ffade = a[4];
        s->nflakes = s->d.visual_flakes;
        const uint64_t key = (uint64_t)s->steps + 1;
        for (int f = 0; f < s->nflakes; f++) spawn_flake(s, f, true, key);
    }
    s->snow->p.snowfall_mmh = d->snowfall_mmh;
    s->d = *d;
    s->derived_dirty = true;
    s->version++;
    return SQ_OK;
}
