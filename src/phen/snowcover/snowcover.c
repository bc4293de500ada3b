/* snowcover.c — the snow-cover phenomenon (squall/snowcover.h, SPEC §6): the depth accumulated
 * over simulated time in a top-down grid, the falling-snow pool (snowcover_flakes.c), and what
 * the renderer draws: the snow-cover view (occlusion map, shell, BRDF: render_snowcover.c) and
 * the flakes as particles. */
#include <math.h>
#include <string.h>

#include "phen/snowflakes.h"
#include "snowcover_internal.h"

sq_result sq_snowcover_create(sq_context *ctx, const sq_snowcover_desc *desc,
                              const sq_world *world, sq_snowcover **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowcover", "sq_snowcover_create: out is NULL");
    *out = NULL;
    sq_result res = sq_snowcover_validate(ctx, desc, world);
    if (res != SQ_OK) return res;
    sq_snowcover *s = sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    s->world = world;
    sq_snowcover_desc_resolve(desc, &s->d);
    sq__snowcover_grid(&s->d, world, &s->nx, &s->ny, s->origin, &s->cell_m);
    const size_t cells = (size_t)s->nx * (size_t)s->ny;
    s->depth = sq_alloc(ctx, cells * sizeof(float));
    s->nflakes = s->d.flakes;
    const size_t nf = (size_t)(s->nflakes > 0 ? s->nflakes : 1);
    s->pool = sq_alloc(ctx, SQ__SNOWCOVER_FLAKE_FLOATS * nf * sizeof(float));
    if (!s->depth || !s->pool) {
        sq_snowcover_destroy(s);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "snowcover",
                        "out of memory for a %dx%d snow grid and %d flakes", s->nx, s->ny,
                        s->nflakes);
    }
    s->pos = s->pool;
    s->vel = s->pos + 3 * nf;
    s->birth = s->vel + 3 * nf;
    s->rot = s->birth + 2 * nf;
    s->spin = s->rot + nf;
    s->radius = s->spin + nf;
    s->fade = s->radius + nf;
    s->water_m = s->d.snowfall_mmh * 1e-3 * s->d.prior_h;
    const float d0 = (float)sq_snowcover_depth_m(s);
    for (size_t i = 0; i < cells; i++) s->depth[i] = d0;
    s->version = 1;
    s->box_m = s->d.reach_m;
    *out = s;
    return SQ_OK;
}

void sq_snowcover_destroy(sq_snowcover *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    sq_free(ctx, s->depth);
    sq_free(ctx, s->pool);
    sq_free(ctx, s);
}

double sq_snowcover_max_stable_dt(const sq_snowcover *s)
{
    (void)s;
    return 0.0;
}

double sq_snowcover_depth_m(const sq_snowcover *s)
{
    return s->water_m * SQ_SNOWCOVER_RHO_WATER / s->d.density_kgm3;
}

/* Width of the band inside another layer's depth input over which its depth blends into this
 * model's (no seam at the input's edge): 8 of its cells, at most a quarter of its narrower side. */
static double input_fade_m(const sq_named_field *in)
{
    const double dx = (double)in->spacing_m.x, dy = (double)in->spacing_m.y;
    const double narrow = fmin(in->nx * dx, in->ny * dy);
    return fmin(8.0 * fmax(dx, dy), 0.25 * narrow);
}

/* Depth where f_p > 0: every column's highest surface is exposed to the sky (the occlusion map
 * decides, per point, what lies below it), so the snowfall adds rate × Δt × ρ_water / ρ_snow of
 * depth to every cell of the grid; the renderer scales it by f_e per point. Where another
 * layer's depth covers the cell (the snowdrift's drifts) that depth is the depth, blended into
 * the model's with a smoothstep over input_fade_m inside the input's edge. */
static sq_result accumulate(sq_snowcover *s, double dt_s)
{
    const double dw = s->d.snowfall_mmh * 1e-3 / 3600.0 * dt_s * s->d.speedup;
    if (dw <= 0.0 && !s->has_depth_in) return SQ_OK;
    const double next_m = (s->water_m + fmax(dw, 0.0)) * SQ_SNOWCOVER_RHO_WATER /
                          s->d.density_kgm3;
    if (!(next_m <= SQ_SNOWCOVER_MAX_DEPTH_M))
        return sq__fail(s->ctx, SQ_ERR_TOO_LARGE, "snowcover",
                        "the snow would lie %.4g m deep at t = %g s, deeper than any snow cover "
                        "ever measured (%.2f m, Mount Ibuki 1927): lower snowfall.rate_mmh "
                        "(%g mm/h) or snowfall.speedup (%g), or shorten the run", next_m, s->time_s + dt_s,
                        SQ_SNOWCOVER_MAX_DEPTH_M, s->d.snowfall_mmh, s->d.speedup);
    if (dw > 0.0) s->water_m += dw;
    const float d = (float)sq_snowcover_depth_m(s);
    const sq_named_field *in = s->has_depth_in ? &s->depth_in : NULL;
    const double fade = in ? input_fade_m(in) : 0.0;
    for (int j = 0; j < s->ny; j++)
        for (int i = 0; i < s->nx; i++) {
            float v = d;
            if (in) {
                /* the input's depth where it covers the cell centre (nearest sample) */
                const double x = s->origin[0] + (i + 0.5) * s->cell_m;
                const double y = s->origin[1] + (j + 0.5) * s->cell_m;
                const double fi = (x - (double)in->origin_m.x) / (double)in->spacing_m.x + 0.5;
                const double fj = (y - (double)in->origin_m.y) / (double)in->spacing_m.y + 0.5;
                if (fi >= 0.0 && fj >= 0.0 && fi < in->nx && fj < in->ny) {
                    const float q = in->data[(size_t)fj * (size_t)in->nx + (size_t)fi];
                    const double edge = fmin(fmin(fi, in->nx - fi) * (double)in->spacing_m.x,
                                             fmin(fj, in->ny - fj) * (double)in->spacing_m.y);
                    const double e = fade > 0.0 ? fmin(1.0, edge / fade) : 1.0;
                    if (isfinite(q)) v = d + (float)(e * e * (3.0 - 2.0 * e)) * (q - d);
                }
            }
            s->depth[(size_t)j * (size_t)s->nx + (size_t)i] = v;
        }
    s->version++;
    return SQ_OK;
}

static bool usable(const sq_named_field *f, int nz)
{
    return f && f->data && f->nx > 0 && f->ny > 0 && f->nz == nz && f->spacing_m.x > 0.0f &&
           f->spacing_m.y > 0.0f && (nz == 1 || f->spacing_m.z > 0.0f);
}

void sq_snowcover_set_inputs(sq_snowcover *s, const sq_named_field *depth,
                             const sq_named_field *u, const sq_named_field *v,
                             const sq_named_field *w)
{
    if (!s) return;
    s->has_depth_in = usable(depth, 1);
    if (s->has_depth_in) s->depth_in = *depth;
    s->has_wind_in = u && v && w && u->nz > 1 && usable(u, u->nz) && usable(v, u->nz) &&
                     usable(w, u->nz) && v->nx == u->nx && w->nx == u->nx && v->ny == u->ny &&
                     w->ny == u->ny;
    if (s->has_wind_in) {
        s->wind_in[0] = *u;
        s->wind_in[1] = *v;
        s->wind_in[2] = *w;
    }
}

bool sq__snowcover_input_wind(const sq_snowcover *s, const float p[3], double w[3])
{
    if (!s->has_wind_in) return false;
    const sq_named_field *f = &s->wind_in[0];
    const float *o = &f->origin_m.x, *h = &f->spacing_m.x;
    const int n[3] = {f->nx, f->ny, f->nz};
    size_t idx = 0, stride = 1;
    for (int a = 0; a < 3; a++) {
        const double c = ((double)p[a] - (double)o[a]) / (double)h[a] + 0.5; /* centres at o */
        if (!(c >= 0.0 && c < n[a])) return false;
        idx += (size_t)c * stride;
        stride *= (size_t)n[a];
    }
    const bool solid = f->invalid && f->invalid[idx];
    for (int a = 0; a < 3; a++) w[a] = solid ? 0.0 : (double)s->wind_in[a].data[idx];
    return true;
}

sq_result sq_snowcover_step(sq_snowcover *s, double dt_s)
{
    if (!s) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "snowcover", "sq_snowcover_step: s is NULL");
    if (!(isfinite(dt_s) && dt_s >= 0.0))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowcover", "step dt = %g s; must be >= 0",
                        dt_s);
    sq_result r = accumulate(s, dt_s);
    if (r != SQ_OK) return r;
    if (s->nflakes > 0 && s->have_camera) {
        const double t0 = sq_time_now();
        if (!s->seeded) sq__snowcover_flakes_seed(s);
        sq__snowcover_flakes_step(s, dt_s);
        s->ms_flakes = 1e3 * (sq_time_now() - t0);
    }
    s->time_s += dt_s;
    return SQ_OK;
}

void sq_snowcover_observe(sq_snowcover *s, const sq_camera *camera)
{
    if (!s || !camera) return;
    s->camera = sq_camera_resolve(*camera);
    s->have_camera = true;
    if (s->nflakes > 0 && !s->seeded) sq__snowcover_flakes_seed(s);
}

/* ---- drawables, metrics, fields ------------------------------------------------------------ */
int sq__snowcover_drawables(sq_snowcover *s, sq_drawable *out, int max)
{
    int n = 0;
    const sq_snowcover_desc *d = &s->d;
    if (n < max && (sq_snowcover_depth_m(s) > 0.0 || s->has_depth_in)) {
        sq_drawable *dr = &out[n++];
        memset(dr, 0, sizeof *dr);
        dr->kind = SQ_DRAWABLE_SNOW_COVER;
        dr->name = "snow-cover";
        sq_snow_cover_view *v = &dr->u.snow_cover;
        v->nx = s->nx;
        v->ny = s->ny;
        v->origin_m = sq_v3((float)s->origin[0], (float)s->origin[1], 0.0f);
        v->dx_m = v->dy_m = (float)s->cell_m;
        v->depth_m = s->depth;
        v->detail_distance_m = (float)d->detail_m;
        v->map_size = d->map_size;
        v->taps = d->taps;
        v->tap_radius_texels = (float)d->tap_radius;
        v->depth_bias_m = (float)d->bias_m;
        v->noise_amplitude = (float)d->noise;
        v->noise_scale_m = (float)d->noise_scale_m;
        v->shell_blend = (float)d->shell_blend;
        v->brdf = d->brdf == 1 ? SQ_SNOW_BRDF_BLINN_PHONG : SQ_SNOW_BRDF_PHYSICAL;
        const float a = (float)d->albedo;
        /* clean snow: a little less red than blue (ice absorbs red) */
        v->albedo = sq_v3(a * 0.96f, a, fminf(1.0f, a * 1.02f));
        v->sparkle = (float)d->sparkle;
        v->shininess = (float)d->shininess;
        v->version = s->version;
    }
    if (s->nflakes > 0 && s->seeded && n < max) {
        const double t0 = sq_time_now();
        sq__snowcover_flakes_size(s);
        s->ms_flakes += 1e3 * (sq_time_now() - t0);
        sq__snowflakes_drawable(&out[n++], s->nflakes, s->pos, s->rot, s->radius, s->fade, 0.005f,
                                0.1f, s->flake_step);
    }
    return n;
}

int sq__snowcover_metrics(sq_snowcover *s, sq_metric *out, int max)
{
    const sq_metric m[] = {
        {"snow_depth_m", sq_snowcover_depth_m(s), "m"},
        {"snow_water_mm", s->water_m * 1e3, "mm"},
        {"flakes", (double)s->nflakes, "1"},
        {"flakes_visible", (double)s->visible, "1"},
    };
    int n = 0;
    for (size_t k = 0; k < sizeof m / sizeof m[0] && n < max; k++) out[n++] = m[k];
    return n;
}

int sq__snowcover_fields(sq_snowcover *s, sq_named_field *out, int max)
{
    if (max < 1) return 0;
    sq_named_field *f = &out[0];
    memset(f, 0, sizeof *f);
    f->name = "surface_snow_thickness";
    f->units = "m";
    f->long_name = "snow depth on the highest surface of each column";
    f->standard_name = "surface_snow_thickness";
    f->data = s->depth;
    f->nx = s->nx;
    f->ny = s->ny;
    f->nz = 1;
    f->origin_m = sq_v3((float)(s->origin[0] + 0.5 * s->cell_m),
                        (float)(s->origin[1] + 0.5 * s->cell_m), 0.0f);
    f->spacing_m = sq_v3((float)s->cell_m, (float)s->cell_m, 1.0f);
    f->level = SQ_FIELD_LEVEL_SURFACE;
    return 1;
}
