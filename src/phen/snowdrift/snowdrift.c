/* snowdrift.c — the wind-driven snow phenomenon (SPEC §5, S1): lifecycle, the per-step loop of
 * S1 §3.2 (wind on the lattice, then snow transport, deposition and erosion every few wind
 * steps), the world voxelised into solid cells, and the drawables (falling flakes, snow cover),
 * metrics and fields. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "snowdrift_internal.h"
#include "squall/rng.h"

#define SNOW_PI 3.14159265358979323846
#define FLAKE_STREAM 0x534E4F57464C4Bull /* RNG stream of the visual flakes */

static sq_lbm_desc lbm_desc(const sq_snowdrift_desc *d)
{
    sq_lbm_desc l;
    memset(&l, 0, sizeof l);
    l.cells = (sq_dims){d->cells[0], d->cells[1], d->cells[2]};
    l.cell_size_m = d->cell_size_m;
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
    return l;
}

uint64_t sq_snowdrift_memory_bytes(const sq_snowdrift_desc *desc)
{
    sq_snowdrift_desc d;
    sq_snowdrift_desc_resolve(desc, &d);
    const sq_lbm_desc l = lbm_desc(&d);
    const uint64_t n = (uint64_t)d.cells[0] * d.cells[1] * d.cells[2];
    const uint64_t cols = (uint64_t)d.cells[0] * d.cells[1];
    return sq_lbm_memory_bytes(&l) + n * 18 /* snow counts and flags */ +
           n * sizeof(float) /* airborne-snow field */ + cols * 3 * sizeof(float) +
           (uint64_t)d.visual_flakes * 5 * sizeof(float) + sizeof(struct sq_snowdrift);
}

void sq_snowdrift_destroy(sq_snowdrift *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    sq_lbm_destroy(s->lbm);
    sq__snow_destroy(s->snow);
    sq_free(ctx, s->fpos);
    sq_free(ctx, s->frot);
    sq_free(ctx, s->fspin);
    sq_free(ctx, s->depth);
    sq_free(ctx, s->surf_h);
    sq_free(ctx, s->cover);
    sq_free(ctx, s->air_kgm3);
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

/* anywhere: uniformly in the air of the domain; else in the top layer */
static void spawn_flake(sq_snowdrift *s, int f, bool anywhere)
{
    for (int attempt = 0; attempt < 8; attempt++) {
        float u[4];
        sq_rng_uniform4(s->d.seed, FLAKE_STREAM, s->spawn_counter++, u);
        float *p = &s->fpos[3 * f];
        p[0] = (float)(s->origin[0] + (double)u[0] * s->nx * s->h);
        p[1] = (float)(s->origin[1] + (double)u[1] * s->ny * s->h);
        const double top = s->origin[2] + s->nz * s->h;
        p[2] = (float)(anywhere ? s->origin[2] + (double)u[2] * s->nz * s->h
                                : top - (double)u[2] * s->h);
        s->frot[f] = 6.2831853f * u[3];
        s->fspin[f] = (u[2] - 0.5f) * 3.0f;
        int i, j, k;
        if (cell_of(s, p, &i, &j, &k) && !sq_lbm_is_solid(s->lbm, i, j, k)) return;
    }
}

/* Moves the visual flakes by (u − u_fall ẑ) dt with the lattice wind of their cell. */
static void move_flakes(sq_snowdrift *s, double dt, const sq_lbm_views *v)
{
    const float fall = (float)s->d.fall_speed_mps;
    const double lx = s->nx * s->h, ly = s->ny * s->h;
    for (int f = 0; f < s->nflakes; f++) {
        float *p = &s->fpos[3 * f];
        int i, j, k;
        if (!cell_of(s, p, &i, &j, &k)) {
            spawn_flake(s, f, false);
            continue;
        }
        const float u = sq_view_get(&v->u[0], i, j, k), w = sq_view_get(&v->u[1], i, j, k);
        const float z = sq_view_get(&v->u[2], i, j, k) - fall;
        p[0] += (float)((double)u * dt);
        p[1] += (float)((double)w * dt);
        p[2] += (float)((double)z * dt);
        s->frot[f] += (float)((double)s->fspin[f] * dt);
        /* wrap horizontally (the snow leaves and re-enters like the recycled wind) */
        if ((double)p[0] < s->origin[0]) p[0] += (float)lx;
        if ((double)p[0] >= s->origin[0] + lx) p[0] -= (float)lx;
        if ((double)p[1] < s->origin[1]) p[1] += (float)ly;
        if ((double)p[1] >= s->origin[1] + ly) p[1] -= (float)ly;
        if (!cell_of(s, p, &i, &j, &k) || sq_lbm_is_solid(s->lbm, i, j, k))
            spawn_flake(s, f, false); /* landed or left: a new flake at the top */
    }
}

/* ---- lifecycle ---------------------------------------------------------------------------- */

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
    r = sq__snow_create(ctx, (sq_dims){s->nx, s->ny, s->nz}, &sp, &s->snow);
    if (r != SQ_OK) {
        sq_snowdrift_destroy(s);
        return r;
    }
    const size_t cols = (size_t)s->nx * s->ny, n = cols * s->nz;
    bool ok = true;
    s->depth = (float *)xalloc(s, cols * sizeof(float), &ok);
    s->surf_h = (float *)xalloc(s, cols * sizeof(float), &ok);
    s->cover = (float *)xalloc(s, cols * sizeof(float), &ok);
    s->air_kgm3 = (float *)xalloc(s, n * sizeof(float), &ok);
    uint8_t *mask = (uint8_t *)xalloc(s, n, &ok);
    if (d.snowfall_mmh > 0) {
        s->nflakes = d.visual_flakes;
        s->fpos = (float *)xalloc(s, (size_t)s->nflakes * 3 * sizeof(float), &ok);
        s->frot = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
        s->fspin = (float *)xalloc(s, (size_t)s->nflakes * sizeof(float), &ok);
    }
    if (!ok) {
        sq_free(ctx, mask);
        sq_snowdrift_destroy(s);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    /* terrain and obstacles at cell centres become solid cells for wind and snow */
    if (world) {
        for (int k = 0; k < s->nz; k++)
            for (int j = 0; j < s->ny; j++)
                for (int i = 0; i < s->nx; i++) {
                    const sq_vec3 p = sq_v3((float)(s->origin[0] + (i + 0.5) * s->h),
                                            (float)(s->origin[1] + (j + 0.5) * s->h),
                                            (float)(s->origin[2] + (k + 0.5) * s->h));
                    if (k == 0 || sq_world_solid_at(world, p)) {
                        mask[(size_t)i + cols * k + (size_t)s->nx * j] = 1;
                        sq__snow_set_static(s->snow, i, j, k, true);
                    }
                }
    } else {
        for (size_t c = 0; c < cols; c++) {
            mask[c] = 1;
            sq__snow_set_static(s->snow, (int)(c % s->nx), (int)(c / s->nx), 0, true);
        }
    }
    r = sq_lbm_set_solid_mask(s->lbm, mask);
    sq_free(ctx, mask);
    if (r != SQ_OK) {
        sq_snowdrift_destroy(s);
        return r;
    }
    for (int f = 0; f < s->nflakes; f++) spawn_flake(s, f, true);
    /* as if it had been snowing for a while: the air holds the steady falling concentration,
     * λ flakes per top cell per step spread over the fall of (u_g dt/dx) cells per step
     * (counted as fallen, so the budget holds from the start) */
    {
        sq__snow *sn = s->snow;
        const double lambda = sq__snow_flakes_per_top_cell(&sn->p);
        const double per_cell = lambda / (d.fall_speed_mps * sn->p.dt_s / s->h);
        for (int64_t c = 0; c < sn->n && per_cell > 0; c++) {
            if (sn->kind[c] != SQ_SNOW_AIR) continue;
            const double x = per_cell + sq_rng_uniform_d(d.seed, FLAKE_STREAM + 1, (uint64_t)c);
            const uint32_t m = (uint32_t)x;
            sn->air[c] += m;
            sn->fallen += m;
        }
    }
    s->derived_dirty = true;
    sq_log(ctx, SQ_LOG_INFO, "snowdrift",
           "lattice %dx%dx%d of %g m, wind step %.4g s, snow every %d wind steps, flake %.3g kg",
           s->nx, s->ny, s->nz, s->h, s->lbm_dt, s->sub, s->snow->flake_mass_kg);
    *out = s;
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
    while (s->t_acc >= chunk) {
        sq_result r = sq_lbm_step(s->lbm, s->sub); /* wind: S1 §3.2 steps 1–5 */
        if (r == SQ_OK) r = sq_lbm_get_views(s->lbm, &v);
        sq_field_view us = {NULL, {0, 0, 0}, 0, 0, 0};
        if (r == SQ_OK && !s->d.no_erosion) r = sq_lbm_get_friction_velocity(s->lbm, &us);
        if (r == SQ_OK) /* snow: steps 6–8 (transport, deposition, erosion) */
            r = sq__snow_step(s->snow, v.u, s->d.no_erosion ? NULL : &us, s->lbm);
        if (r != SQ_OK) return r;
        s->t_acc -= chunk;
        s->snow_steps++;
        s->derived_dirty = true;
    }
    s->time_s += dt;
    if (s->nflakes > 0) {
        sq_result r = sq_lbm_get_views(s->lbm, &v);
        if (r != SQ_OK) return r;
        move_flakes(s, dt, &v);
    }
    s->version++;
    return SQ_OK;
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

/* Snow depth of column (i, j) in metres: snow-solid cells count full, resting flakes as their
 * share of a cell. */
static double column_depth(const sq_snowdrift *s, int i, int j)
{
    const sq__snow *sn = s->snow;
    double flakes = 0;
    for (int k = 0; k < s->nz; k++) {
        const int64_t c = i + s->nx * (j + (int64_t)s->ny * k);
        if (sn->kind[c] == SQ_SNOW_SOLID)
            flakes += sn->p.threshold;
        else if (sn->kind[c] == SQ_SNOW_AIR)
            flakes += sn->dep[c];
    }
    return flakes / sn->p.threshold * s->h;
}

/* The snow cover on top of the world's surface; coverage ramps over the first 5 cm. */
static void update_derived(sq_snowdrift *s)
{
    if (!s->derived_dirty) return;
    const sq__snow *sn = s->snow;
    const int64_t cols = (int64_t)s->nx * s->ny;
    const double cell_kg = sn->flake_mass_kg / (s->h * s->h * s->h);
    for (int64_t c = 0; c < cols * s->nz; c++) s->air_kgm3[c] = (float)(sn->air[c] * cell_kg);
    for (int j = 0; j < s->ny; j++)
        for (int i = 0; i < s->nx; i++) {
            const double depth = column_depth(s, i, j);
            const int64_t q = i + (int64_t)s->nx * j;
            s->depth[q] = (float)depth;
            const float x = (float)(s->origin[0] + (i + 0.5) * s->h);
            const float y = (float)(s->origin[1] + (j + 0.5) * s->h);
            const float zs = s->world ? sq_world_surface_at(s->world, x, y)
                                      : (float)(s->origin[2] + s->h);
            s->surf_h[q] = zs + (float)depth;
            const float cv = (float)(depth / 0.05);
            s->cover[q] = cv > 1.0f ? 1.0f : cv;
        }
    s->derived_dirty = false;
}

void sq_snowdrift_get_budget(const sq_snowdrift *s, sq_snowdrift_budget *out)
{
    memset(out, 0, sizeof *out);
    if (!s) return;
    sq__snow_budget b;
    sq__snow_get_budget(s->snow, &b);
    const double m = s->snow->flake_mass_kg;
    out->fallen_flakes = b.fallen;
    out->airborne_flakes = b.airborne;
    out->deposited_flakes = b.deposited;
    out->left_flakes = b.left;
    out->eroded_flakes = b.eroded;
    out->flake_mass_kg = m;
    out->fallen_kg = (double)b.fallen * m;
    out->airborne_kg = (double)b.airborne * m;
    out->deposited_kg = (double)b.deposited * m;
    out->left_kg = (double)b.left * m;
    out->snow_cells = b.solid_cells;
    double sum = 0, mx = 0;
    for (int j = 0; j < s->ny; j++)
        for (int i = 0; i < s->nx; i++) {
            const double dpt = column_depth(s, i, j);
            sum += dpt;
            if (dpt > mx) mx = dpt;
        }
    out->depth_mean_m = sum / ((double)s->nx * s->ny);
    out->depth_max_m = mx;
}

/* ---- drawables, metrics, fields ------------------------------------------------------------ */

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
        v->nx = s->nx;
        v->ny = s->ny;
        v->origin_m = sq_v3((float)(s->origin[0] + 0.5 * s->h), (float)(s->origin[1] + 0.5 * s->h),
                            0.0f);
        v->dx_m = v->dy_m = (float)s->h;
        v->height_m = s->surf_h;
        v->coverage = s->cover;
        v->material = SQ_MATERIAL_SNOW;
        v->version = s->version;
    }
    if (s->nflakes > 0 && n < max) {
        sq_drawable *d = &out[n++];
        memset(d, 0, sizeof *d);
        d->kind = SQ_DRAWABLE_PARTICLES;
        d->name = "snowfall";
        sq_particles_view *p = &d->u.particles;
        p->count = s->nflakes;
        p->position = s->fpos;
        p->rotation_rad = s->frot;
        p->radius_default_m = (float)s->d.flake_radius_m;
        p->tau_default = 2.0f; /* opaque flakes */
        for (int c = 0; c < 3; c++) {
            p->sigma_rel[c] = 1.0f;
            p->albedo[c] = 0.95f;
        }
        p->g = 0.5f;
        p->sprite = SQ_SPRITE_FLAKE6;
        p->softness_m = 0.0f;
        p->version = s->version;
    }
    return n;
}

int sq__snowdrift_metrics(sq_snowdrift *s, sq_metric *out, int max)
{
    sq_snowdrift_budget b;
    sq_snowdrift_get_budget(s, &b);
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
    sq_lbm_views v;
    if (sq_lbm_get_views(s->lbm, &v) != SQ_OK) return 0;
    const sq_vec3 o = sq_v3((float)(s->origin[0] + 0.5 * s->h), (float)(s->origin[1] + 0.5 * s->h),
                            (float)(s->origin[2] + 0.5 * s->h));
    const sq_vec3 sp = sq_v3((float)s->h, (float)s->h, (float)s->h);
    int n = 0;
    out[n++] = (sq_named_field){"u", "m s-1", "eastward wind", "eastward_wind", v.u[0].data,
                                s->nx, s->ny, s->nz, o, sp};
    out[n++] = (sq_named_field){"v", "m s-1", "northward wind", "northward_wind", v.u[1].data,
                                s->nx, s->ny, s->nz, o, sp};
    out[n++] = (sq_named_field){"w", "m s-1", "upward air velocity", "upward_air_velocity",
                                v.u[2].data, s->nx, s->ny, s->nz, o, sp};
    out[n++] = (sq_named_field){"blowing_snow_concentration", "kg m-3",
                                "mass concentration of airborne snow", NULL, s->air_kgm3, s->nx,
                                s->ny, s->nz, o, sp};
    out[n++] = (sq_named_field){"snow_depth", "m", "depth of deposited snow",
                                "surface_snow_thickness", s->depth, s->nx, s->ny, 1,
                                sq_v3(o.x, o.y, 0.0f), sp};
    return n;
}
