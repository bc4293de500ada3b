/* avalanche_hazard.c — what avalanche practice reads from a simulation (AvaFrame's com1DFA
 * outputs, the Swiss hazard maps): maps over the whole terrain of the peak flow depth, the peak
 * speed, the peak pressure rho0 v², the deposit depth and the travel angle, sampled every
 * SQ_AVAL_TRACK_S of simulated time; the thalweg (the path of the mass centre) with the run-out
 * measured along it, the alpha angle, Lied & Bakkehøi's beta point and their statistical alpha,
 * and the mass balance.
 *
 * Definitions (per hazard cell of area A, particles i in it, V_i = m / max(rho_i, rho0)):
 *   depth  = sum V_i / A  (volume per map area: integrates to the volume; the slope-normal
 *            thickness is depth x cos(slope))
 *   speed  = sum V_i |v_i| / sum V_i,  pressure = rho0 speed² (kPa)
 *   travel angle of particle i = atan((z0_i − z_i) / s_i): z0 the terrain under its release
 *            position, z the terrain under it now, s its horizontal path length; the cell keeps
 *            the smallest over the particles that reached it (at the tip of the deposit: the
 *            alpha angle of the most mobile snow).
 * Lied & Bakkehøi (1980), 111 Norwegian paths: alpha = 0.96 beta − 1.4 deg (r = 0.92,
 * SD 2.3 deg), beta the angle from the top of the release to the point where the path's slope
 * first falls below 10 deg. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "avalanche_internal.h"

#define MOD "avalanche"
#define DEG (180.0 / SQ_PI)
#define BETA_SLOPE_DEG 10.0 /* Lied & Bakkehøi's beta point */
#define BETA_BASE_M 100.0   /* horizontal length over which the path's slope is measured */

sq_result sq__aval_hazard_alloc(sq_avalanche *a)
{
    sq_context *ctx = a->ctx;
    const size_t cells = (size_t)a->plan.hz_nx * (size_t)a->plan.hz_ny;
    const size_t n = a->plan.count;
    a->hz_vol = (double *)sq_alloc_zero(ctx, cells * sizeof(double));
    a->hz_mom = (double *)sq_alloc_zero(ctx, cells * sizeof(double));
    a->hz_depth_peak = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->hz_speed_peak = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->hz_pressure_peak = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->hz_alpha = (float *)sq_alloc(ctx, cells * sizeof(float));
    a->hz_deposit = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->tr_z0 = (float *)sq_alloc(ctx, n * sizeof(float));
    a->tr_path = (float *)sq_alloc_zero(ctx, n * sizeof(float));
    a->tr_px = (float *)sq_alloc(ctx, n * sizeof(float));
    a->tr_py = (float *)sq_alloc(ctx, n * sizeof(float));
    a->thw_cap = 1024;
    a->thw = (double *)sq_alloc(ctx, (size_t)a->thw_cap * 3 * sizeof(double));
    if (!a->hz_vol || !a->hz_mom || !a->hz_depth_peak || !a->hz_speed_peak ||
        !a->hz_pressure_peak || !a->hz_alpha || !a->hz_deposit || !a->tr_z0 || !a->tr_path ||
        !a->tr_px || !a->tr_py || !a->thw)
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "out of memory for the hazard maps");
    for (size_t c = 0; c < cells; c++) a->hz_alpha[c] = NAN;
    a->track_t = -1.0;
    return SQ_OK;
}

void sq__aval_hazard_free(sq_avalanche *a)
{
    sq_context *ctx = a->ctx;
    sq_free(ctx, a->hz_vol);
    sq_free(ctx, a->hz_mom);
    sq_free(ctx, a->hz_depth_peak);
    sq_free(ctx, a->hz_speed_peak);
    sq_free(ctx, a->hz_pressure_peak);
    sq_free(ctx, a->hz_alpha);
    sq_free(ctx, a->hz_deposit);
    sq_free(ctx, a->tr_z0);
    sq_free(ctx, a->tr_path);
    sq_free(ctx, a->tr_px);
    sq_free(ctx, a->tr_py);
    sq_free(ctx, a->thw);
}

/* Cell of the hazard grid holding (x, y), or −1. */
static ptrdiff_t hz_cell(const sq__aval_plan *pl, float x, float y)
{
    const double fx = ((double)x - pl->hz_origin[0]) / pl->hz_cell;
    const double fy = ((double)y - pl->hz_origin[1]) / pl->hz_cell;
    if (!(fx >= 0.0 && fy >= 0.0 && fx < (double)pl->hz_nx && fy < (double)pl->hz_ny)) return -1;
    return (ptrdiff_t)fy * pl->hz_nx + (ptrdiff_t)fx;
}

/* Bins the current particles into hz_vol / hz_mom (the whole grid is cleared first). */
static void bin_particles(sq_avalanche *a, const sq_sph_view *v)
{
    const sq__aval_plan *pl = &a->plan;
    const size_t cells = (size_t)pl->hz_nx * (size_t)pl->hz_ny;
    memset(a->hz_vol, 0, cells * sizeof(double));
    memset(a->hz_mom, 0, cells * sizeof(double));
    const double rho0 = pl->d.density_kgm3, m = a->particle_mass;
    for (size_t i = 0; i < v->count; i++) {
        const ptrdiff_t c = hz_cell(pl, v->x[i], v->y[i]);
        if (c < 0) continue;
        const double r = (double)v->density[i] > rho0 ? (double)v->density[i] : rho0;
        const double vol = m / r;
        const double ux = v->vx[i], uy = v->vy[i], uz = v->vz[i];
        const double sp = sqrt(ux * ux + uy * uy + uz * uz);
        a->hz_vol[c] += vol;
        a->hz_mom[c] += vol * sp;
    }
}

void sq__aval_hazard_track(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    const sq_sph_view v = sq_sph_particles(a->sph);
    const bool first = a->track_t < 0.0;
    a->track_t = a->time_s;
    /* travel tracking by particle id */
    double cx = 0.0, cy = 0.0;
    for (size_t i = 0; i < v.count; i++) {
        const uint32_t id = v.id[i];
        cx += (double)v.x[i];
        cy += (double)v.y[i];
        if (id >= pl->count) continue;
        if (first) {
            a->tr_z0[id] = sq_world_height_at(a->world, v.x[i], v.y[i]);
        } else {
            const float dxp = v.x[i] - a->tr_px[id], dyp = v.y[i] - a->tr_py[id];
            a->tr_path[id] += sqrtf(dxp * dxp + dyp * dyp);
        }
        a->tr_px[id] = v.x[i];
        a->tr_py[id] = v.y[i];
    }
    /* the maps: peaks of this sample */
    bin_particles(a, &v);
    const double area = pl->hz_cell * pl->hz_cell;
    const double rho0 = pl->d.density_kgm3;
    const float min_path = (float)(2.0 * pl->spacing);
    for (size_t i = 0; i < v.count; i++) {
        const ptrdiff_t c = hz_cell(pl, v.x[i], v.y[i]);
        if (c < 0) continue;
        if (a->hz_vol[c] > 0.0) { /* first particle of the cell in this sample: the cell's peaks */
            const double depth = a->hz_vol[c] / area, sp = a->hz_mom[c] / a->hz_vol[c];
            if (depth > (double)a->hz_depth_peak[c]) a->hz_depth_peak[c] = (float)depth;
            if (sp > (double)a->hz_speed_peak[c]) a->hz_speed_peak[c] = (float)sp;
            const double p = 1e-3 * rho0 * sp * sp;
            if (p > (double)a->hz_pressure_peak[c]) a->hz_pressure_peak[c] = (float)p;
            a->hz_vol[c] = -a->hz_vol[c]; /* done for this sample */
        }
        const uint32_t id = v.id[i];
        if (id < pl->count && a->tr_path[id] > min_path) {
            const float z = sq_world_height_at(a->world, v.x[i], v.y[i]);
            const float ang = (float)(atan2((double)(a->tr_z0[id] - z), (double)a->tr_path[id]) * DEG);
            if (!(a->hz_alpha[c] <= ang)) a->hz_alpha[c] = ang; /* NaN compares false */
        }
    }
    /* the thalweg: the mass centre, when it has moved a spacing */
    if (v.count > 0) {
        cx /= (double)v.count;
        cy /= (double)v.count;
        const int n = a->thw_n;
        const bool moved = n == 0 || hypot(cx - a->thw[3 * (n - 1)], cy - a->thw[3 * (n - 1) + 1]) >
                                         pl->spacing;
        if (moved) {
            if (n == a->thw_cap) {
                double *t = (double *)sq_alloc(a->ctx, (size_t)n * 6 * sizeof(double));
                if (!t) return; /* the thalweg stops growing; reported through its length */
                memcpy(t, a->thw, (size_t)n * 3 * sizeof(double));
                sq_free(a->ctx, a->thw);
                a->thw = t;
                a->thw_cap = 2 * n;
            }
            a->thw[3 * n] = cx;
            a->thw[3 * n + 1] = cy;
            a->thw[3 * n + 2] = sq_world_height_at(a->world, (float)cx, (float)cy);
            a->thw_n = n + 1;
        }
    }
}

void sq__aval_hazard_deposit(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    const sq_sph_view v = sq_sph_particles(a->sph);
    bin_particles(a, &v);
    const size_t cells = (size_t)pl->hz_nx * (size_t)pl->hz_ny;
    const double inv = 1.0 / (pl->hz_cell * pl->hz_cell), rho0 = pl->d.density_kgm3;
    for (size_t c = 0; c < cells; c++) {
        a->hz_deposit[c] = (float)(a->hz_vol[c] * inv);
        /* the state now is a sample of the flow too: the peaks never fall below it */
        if (!(a->hz_vol[c] > 0.0)) continue;
        const double sp = a->hz_mom[c] / a->hz_vol[c];
        if (a->hz_deposit[c] > a->hz_depth_peak[c]) a->hz_depth_peak[c] = a->hz_deposit[c];
        if (sp > (double)a->hz_speed_peak[c]) a->hz_speed_peak[c] = (float)sp;
        const double p = 1e-3 * rho0 * sp * sp;
        if (p > (double)a->hz_pressure_peak[c]) a->hz_pressure_peak[c] = (float)p;
    }
}

/* The path used for the profile: the straight line from the crown to the thalweg's first point,
 * the thalweg, then straight on along (ux, uy); arc length s (horizontal) from the crown. */
typedef struct path {
    const sq_avalanche *a;
    double s0, len, ux, uy; /* crown -> first point; whole thalweg length from the crown */
} path;

static void path_point(const path *pt, double s, double *x, double *y)
{
    const sq_avalanche *a = pt->a;
    const double *p = a->thw, *c = a->plan.crown;
    const int n = a->thw_n;
    if (s <= pt->s0) {
        const double t = pt->s0 > 0.0 ? s / pt->s0 : 0.0;
        *x = c[0] + t * (p[0] - c[0]);
        *y = c[1] + t * (p[1] - c[1]);
        return;
    }
    double acc = pt->s0;
    for (int k = 0; k + 1 < n; k++) {
        const double L = hypot(p[3 * k + 3] - p[3 * k], p[3 * k + 4] - p[3 * k + 1]);
        if (s <= acc + L) {
            const double t = L > 0.0 ? (s - acc) / L : 0.0;
            *x = p[3 * k] + t * (p[3 * k + 3] - p[3 * k]);
            *y = p[3 * k + 1] + t * (p[3 * k + 4] - p[3 * k + 1]);
            return;
        }
        acc += L;
    }
    *x = p[3 * n - 3] + (s - acc) * pt->ux;
    *y = p[3 * n - 2] + (s - acc) * pt->uy;
}

void sq__aval_hazard_summary(sq_avalanche *a, const sq_sph_view *v, sq_avalanche_state *st)
{
    const sq__aval_plan *pl = &a->plan;
    st->thalweg_runout_m = st->thalweg_alpha_deg = st->beta_deg = st->alpha_lb_deg = 0.0;
    const int n = a->thw_n;
    if (n < 1 || v->count == 0) return;
    const double *p = a->thw;
    /* from the crown to the first thalweg point, then along it */
    double len = hypot(p[0] - pl->crown[0], p[1] - pl->crown[1]);
    for (int k = 0; k + 1 < n; k++) len += hypot(p[3 * k + 3] - p[3 * k], p[3 * k + 4] - p[3 * k + 1]);
    /* the front ahead of the thalweg's end, along its last direction (the fall line before
     * the mass centre has moved) */
    double ux = pl->fall_dir[0], uy = pl->fall_dir[1];
    for (int k = n - 1; k > 0; k--) {
        const double dxk = p[3 * n - 3] - p[3 * k - 3], dyk = p[3 * n - 2] - p[3 * k - 2];
        const double l = hypot(dxk, dyk);
        if (l > 4.0 * pl->spacing) {
            ux = dxk / l;
            uy = dyk / l;
            break;
        }
    }
    const double ex = p[3 * n - 3], ey = p[3 * n - 2];
    for (size_t i = 0; i < v->count; i++)
        a->scratch[i] = (float)(((double)v->x[i] - ex) * ux + ((double)v->y[i] - ey) * uy);
    const size_t q = (size_t)floor(pl->d.front_percentile * (double)(v->count - 1) + 0.5);
    const double ahead = sq__aval_select(a->scratch, v->count, q);
    st->thalweg_runout_m = len + ahead;
    const double fx = ex + ahead * ux, fy = ey + ahead * uy;
    const double zf = sq_world_height_at(a->world, (float)fx, (float)fy);
    st->thalweg_alpha_deg = atan2(pl->crown[2] - zf, st->thalweg_runout_m) * DEG;
    /* beta: walk the terrain profile along the path (crown, thalweg, then straight on) in 5 m
     * steps; the first point below which the slope over the next 100 m is under 10 deg */
    const path pt = {a, hypot(p[0] - pl->crown[0], p[1] - pl->crown[1]), len, ux, uy};
    const double tan_b = tan(BETA_SLOPE_DEG / DEG);
    for (double s = 5.0; s < len + ahead + 5000.0; s += 5.0) {
        double x0, y0, x1, y1;
        path_point(&pt, s, &x0, &y0);
        path_point(&pt, s + BETA_BASE_M, &x1, &y1);
        const double z0 = sq_world_height_at(a->world, (float)x0, (float)y0);
        const double z1 = sq_world_height_at(a->world, (float)x1, (float)y1);
        if (z0 - z1 < tan_b * BETA_BASE_M) {
            st->beta_deg = atan2(pl->crown[2] - z0, s) * DEG;
            st->alpha_lb_deg = 0.96 * st->beta_deg - 1.4;
            break;
        }
    }
    if (!isfinite(st->beta_deg)) st->beta_deg = st->alpha_lb_deg = 0.0; /* no such point */
}

int sq__aval_hazard_fields(sq_avalanche *a, sq_named_field *out, int max)
{
    const sq__aval_plan *pl = &a->plan; /* hz_deposit is current: the caller evaluated */
    struct {
        const char *name, *units, *long_name;
        const float *data;
    } f[] = {
        {"deposit_depth", "m", "avalanche snow depth now (snow volume per map area at "
                               "max(rho, rho0))", a->hz_deposit},
        {"peak_flow_depth", "m", "peak flow depth since release (snow volume per map area)",
         a->hz_depth_peak},
        {"peak_speed", "m/s", "peak flow speed since release (volume-weighted mean per cell)",
         a->hz_speed_peak},
        {"peak_pressure", "kPa", "peak impact pressure rho0 v^2 since release",
         a->hz_pressure_peak},
        {"travel_angle", "deg", "smallest travel angle atan((z0 - z) / path) of the snow that "
                                "reached the cell", a->hz_alpha},
    };
    int n = 0;
    for (size_t k = 0; k < sizeof f / sizeof f[0] && n < max; k++) {
        sq_named_field *o = &out[n++];
        memset(o, 0, sizeof *o);
        o->name = f[k].name;
        o->units = f[k].units;
        o->long_name = f[k].long_name;
        o->data = f[k].data;
        o->nx = pl->hz_nx;
        o->ny = pl->hz_ny;
        o->nz = 1;
        o->origin_m = sq_v3((float)(pl->hz_origin[0] + 0.5 * pl->hz_cell),
                            (float)(pl->hz_origin[1] + 0.5 * pl->hz_cell), 0.0f);
        o->spacing_m = sq_v3((float)pl->hz_cell, (float)pl->hz_cell, 1.0f);
        o->level = SQ_FIELD_LEVEL_SURFACE; /* maps of the ground: no vertical coordinate */
    }
    return n;
}
