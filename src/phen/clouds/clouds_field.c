/* clouds_field.c — the cloud field on the model grid (SPEC §8; issue 10): the source's fields at
 * the current time, their optics per cell (extinction beta = sum_s 3 C_s / (2 rho_s r_eff,s) and
 * the extinction-weighted Henyey–Greenstein asymmetry, include/squall/optics.h), sampling at any
 * world point (bilinear between columns, linear in height between mass points of the
 * terrain-following levels) and the sub-grid structure.
 *
 * Sub-grid structure: a 30 km model cell holding 0.3 g/m³ is a grid-box mean; real clouds fill a
 * fraction f of it (the cell's cloud fraction: CLDFRA when the source has it, else the desc's
 * value) at f times less area and correspondingly more water. A soft mask m(p) in [0, 1] of a
 * 3D fBm pattern (horizontal size subgrid_scale_m, a quarter of it vertically, drifting with the
 * mean wind of the cloudy cells) is thresholded at its (1 - f) quantile, and the extinction at p
 * is beta(p) m(p) / E[m]: the pattern covers f of the cell and keeps its mean extinction. The
 * quantiles and E[m] come from a table sampled once from the same noise. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "clouds_internal.h"

#define PACK 8
#define SUB_SAMPLES 16384
#define SUB_OCTAVES 3
#define REFF_ICE_MIN_M 2.5e-6   /* Thompson's bounds for the ice effective radius */
#define REFF_ICE_MAX_M 125e-6
#define REFF_RAIN_MIN_M 50e-6
#define REFF_RAIN_MAX_M 5e-3

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

static float subgrid_noise(const sq__subgrid *s, float x, float y, float z)
{
    return sq_noise_fbm3(&s->noise, (x - s->offset[0]) / s->scale_m,
                         (y - s->offset[1]) / s->scale_m, z / s->scale_z_m, SUB_OCTAVES, 2.0f,
                         0.5f);
}

static float smooth_mask(float n, float theta, float w)
{
    float t = (n - (theta - w)) / (2.0f * w);
    t = t < 0.0f ? 0.0f : (t > 1.0f ? 1.0f : t);
    return t * t * (3.0f - 2.0f * t);
}

/* Threshold and mean mask per cloud fraction from the noise's empirical distribution. */
static sq_result subgrid_table(sq_context *ctx, sq__subgrid *s)
{
    float *v = sq_alloc(ctx, SUB_SAMPLES * sizeof(float));
    if (!v) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for the noise table");
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < SUB_SAMPLES; i++) {
        /* a low-discrepancy (R3) walk through 64 pattern cells per axis */
        const float x = 64.0f * (float)fmod(0.5 + 0.8191725134 * i, 1.0);
        const float y = 64.0f * (float)fmod(0.5 + 0.6710436067 * i, 1.0);
        const float z = 64.0f * (float)fmod(0.5 + 0.5497004779 * i, 1.0);
        v[i] = sq_noise_fbm3(&s->noise, x, y, z, SUB_OCTAVES, 2.0f, 0.5f);
        sum += (double)v[i];
        sum2 += (double)v[i] * (double)v[i];
    }
    qsort(v, SUB_SAMPLES, sizeof(float), cmp_float);
    const double mean = sum / SUB_SAMPLES;
    const double sd = sqrt(fmax(sum2 / SUB_SAMPLES - mean * mean, 1e-12));
    s->width = (float)(0.3 * sd);
    for (int t = 0; t < SQ__SUBGRID_TABLE; t++) {
        const float f = (float)t / (float)(SQ__SUBGRID_TABLE - 1);
        float theta;
        if (t == SQ__SUBGRID_TABLE - 1) theta = v[0] - 4.0f * s->width; /* all covered */
        else if (t == 0) theta = v[SUB_SAMPLES - 1] + 4.0f * s->width;  /* none */
        else theta = v[(int)((1.0f - f) * (float)(SUB_SAMPLES - 1))];
        double m = 0.0;
        for (int i = 0; i < SUB_SAMPLES; i++) m += (double)smooth_mask(v[i], theta, s->width);
        s->theta[t] = theta;
        s->mean[t] = (float)(m / SUB_SAMPLES);
    }
    sq_free(ctx, v);
    return SQ_OK;
}

sq_result sq__cloud_field_init(sq_context *ctx, sq__cloud_field *f, const sq__cloud_grid *grid,
                               const sq_clouds_desc *d, float exaggeration)
{
    memset(f, 0, sizeof *f);
    f->grid = *grid;
    f->exaggeration = exaggeration;
    const size_t cells = (size_t)grid->nx * grid->ny * grid->nz;
    const size_t cols = (size_t)grid->nx * grid->ny;
    f->cells = cells;
    f->z = sq_alloc(ctx, cells * sizeof(float));
    f->zw = sq_alloc(ctx, (cells + cols) * sizeof(float));
    bool ok = f->z && f->zw;
    for (int s = 0; s < SQ_HYDRO_COUNT; s++) ok = ok && (f->conc[s] = sq_alloc_zero(ctx, cells * sizeof(float)));
    ok = ok && (f->beta = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->g = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->pack = sq_alloc(ctx, cells * PACK * sizeof(float)));
    ok = ok && (f->cond = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->frac = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->u = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->v = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->w = sq_alloc(ctx, cells * sizeof(float)));
    ok = ok && (f->terrain = sq_alloc(ctx, cols * sizeof(float)));
    ok = ok && (f->label = sq_alloc(ctx, cells * sizeof(int32_t)));
    if (!ok) {
        sq__cloud_field_free(ctx, f);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for the cloud field (%zu cells)",
                        cells);
    }
    sq_cloud_optics o;
    memset(&o, 0, sizeof o);
    o.r_eff_m[SQ_HYDRO_CLOUD] = d->reff_droplet_um * 1e-6;
    o.r_eff_m[SQ_HYDRO_ICE] = d->reff_ice_um * 1e-6;
    o.r_eff_m[SQ_HYDRO_SNOW] = d->reff_snow_um * 1e-6;
    o.r_eff_m[SQ_HYDRO_RAIN] = d->reff_rain_um * 1e-6;
    o.g[SQ_HYDRO_CLOUD] = d->g_droplet;
    o.g[SQ_HYDRO_ICE] = d->g_ice;
    if (sq_cloud_optics_resolve(&o, &f->optics) != SQ_OK) {
        const sq_result r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds", "layer clouds: optics: %s",
                                     sq_last_error());
        sq__cloud_field_free(ctx, f);
        return r;
    }
    f->reff_from_number = !d->reff_fixed;
    f->rayleigh = d->rayleigh;
    f->sub.on = !d->no_subgrid;
    f->sub.scale_m = (float)d->subgrid_scale_m;
    f->sub.scale_z_m = 0.25f * (float)d->subgrid_scale_m;
    sq_noise_init(&f->sub.noise, d->seed ^ 0x5ab9e1dULL);
    const sq_result r = subgrid_table(ctx, &f->sub);
    if (r != SQ_OK) sq__cloud_field_free(ctx, f);
    f->frac_default = (float)d->cloud_fraction;
    for (size_t c = 0; c < cells; c++) f->frac[c] = f->frac_default;
    return r;
}

void sq__cloud_field_free(sq_context *ctx, sq__cloud_field *f)
{
    sq_free(ctx, f->z);
    sq_free(ctx, f->zw);
    for (int s = 0; s < SQ_HYDRO_COUNT; s++) sq_free(ctx, f->conc[s]);
    sq_free(ctx, f->beta);
    sq_free(ctx, f->g);
    sq_free(ctx, f->pack);
    sq_free(ctx, f->cond);
    sq_free(ctx, f->frac);
    sq_free(ctx, f->u);
    sq_free(ctx, f->v);
    sq_free(ctx, f->w);
    sq_free(ctx, f->terrain);
    sq_free(ctx, f->label);
    memset(f, 0, sizeof *f);
}

static float clampf(float v, float lo, float hi) { return v < lo ? lo : (v > hi ? hi : v); }

void sq__cloud_field_update(sq__cloud_field *f, const sq__cloud_frame *fr, double time_s,
                            double dt_s)
{
    const sq__cloud_grid *g = &f->grid;
    const size_t cells = f->cells, cols = (size_t)g->nx * g->ny;
    memcpy(f->z, fr->z_m, cells * sizeof(float));
    memcpy(f->terrain, fr->terrain_m, cols * sizeof(float));
    if (fr->z_w_m) {
        memcpy(f->zw, fr->z_w_m, (cells + cols) * sizeof(float));
    } else { /* interfaces halfway between mass points; the ground below, a mirror on top */
        for (size_t c = 0; c < cols; c++) f->zw[c] = f->terrain[c];
        for (int k = 1; k < g->nz; k++)
            for (size_t c = 0; c < cols; c++)
                f->zw[(size_t)k * cols + c] =
                    0.5f * (f->z[(size_t)(k - 1) * cols + c] + f->z[(size_t)k * cols + c]);
        for (size_t c = 0; c < cols; c++) {
            const size_t top = (size_t)(g->nz - 1) * cols + c;
            f->zw[(size_t)g->nz * cols + c] = 2.0f * f->z[top] - f->zw[top];
        }
    }
    for (int s = 0; s < SQ_HYDRO_COUNT; s++) {
        f->has[s] = fr->conc[s] != NULL;
        if (fr->conc[s]) memcpy(f->conc[s], fr->conc[s], cells * sizeof(float));
        else memset(f->conc[s], 0, cells * sizeof(float));
    }
    memcpy(f->u, fr->u, cells * sizeof(float));
    memcpy(f->v, fr->v, cells * sizeof(float));
    memcpy(f->w, fr->w, cells * sizeof(float));
    /* the cells' cloud fraction: CLDFRA where the source has it and it is > 0 (a cell whose
     * condensate makes it cloudy while the radiation scheme saw no cloud gets the default) */
    if (fr->cldfra) {
        for (size_t c = 0; c < cells; c++)
            f->frac[c] = fr->cldfra[c] > 0.0f ? fr->cldfra[c] : f->frac_default;
        f->frac_from_source = true;
    } else if (f->frac_from_source) {
        for (size_t c = 0; c < cells; c++) f->frac[c] = f->frac_default;
        f->frac_from_source = false;
    }
    /* optics per cell */
    float beta_max = 0.0f;
    double mu = 0.0, mv = 0.0, mw = 0.0;
    for (size_t c = 0; c < cells; c++) {
        float conc[SQ_HYDRO_COUNT], reff[SQ_HYDRO_COUNT] = {0};
        bool any = false;
        for (int s = 0; s < SQ_HYDRO_COUNT; s++) {
            const float q = f->conc[s][c];
            conc[s] = q > 0.0f && isfinite(q) ? q : 0.0f;
            any = any || conc[s] > 0.0f;
        }
        if (!any) { /* clear air: what the mixture gives for no condensate (beta = g = 0) */
            if (!(f->frac[c] >= 0.0f)) f->frac[c] = 0.0f;
            if (f->frac[c] > 1.0f) f->frac[c] = 1.0f;
            f->beta[c] = f->g[c] = f->cond[c] = 0.0f;
            float *p = f->pack + PACK * c;
            p[0] = p[1] = p[2] = p[3] = 0.0f;
            p[4] = f->frac[c];
            p[5] = f->u[c];
            p[6] = f->v[c];
            p[7] = f->w[c];
            continue;
        }
        if (f->reff_from_number && fr->number_ice && conc[SQ_HYDRO_ICE] > 0.0f) {
            const double r = sq_cloud_effective_radius(conc[SQ_HYDRO_ICE], fr->number_ice[c],
                                                       SQ_ICE_DENSITY_KG_M3, 0.0);
            if (r > 0.0)
                reff[SQ_HYDRO_ICE] = clampf((float)r, (float)REFF_ICE_MIN_M, (float)REFF_ICE_MAX_M);
        }
        if (f->reff_from_number && fr->number_rain && conc[SQ_HYDRO_RAIN] > 0.0f) {
            const double r = sq_cloud_effective_radius(conc[SQ_HYDRO_RAIN], fr->number_rain[c],
                                                       SQ_WATER_DENSITY_KG_M3, 0.0);
            if (r > 0.0)
                reff[SQ_HYDRO_RAIN] = clampf((float)r, (float)REFF_RAIN_MIN_M, (float)REFF_RAIN_MAX_M);
        }
        double gg = 0.0;
        const float b = (float)sq_cloud_mixture(&f->optics, conc, reff, &gg);
        f->beta[c] = b;
        f->g[c] = (float)gg;
        const float ice = conc[SQ_HYDRO_ICE] + conc[SQ_HYDRO_SNOW];
        f->cond[c] = conc[SQ_HYDRO_CLOUD] + ice;
        if (b > beta_max) beta_max = b;
        if (!(f->frac[c] >= 0.0f)) f->frac[c] = 0.0f;
        if (f->frac[c] > 1.0f) f->frac[c] = 1.0f;
        float *p = f->pack + PACK * c;
        p[0] = b;
        p[1] = b * (float)gg;
        p[2] = f->cond[c];
        p[3] = ice;
        p[4] = f->frac[c];
        p[5] = f->u[c];
        p[6] = f->v[c];
        p[7] = f->w[c];
        mu += (double)(f->u[c] * b);
        mv += (double)(f->v[c] * b);
        mw += (double)b;
    }
    f->beta_max = beta_max;
    /* the sub-grid pattern drifts with the extinction-weighted mean wind */
    if (mw > 0.0 && dt_s > 0.0) {
        f->sub.offset[0] += (float)(mu / mw * dt_s);
        f->sub.offset[1] += (float)(mv / mw * dt_s);
    }
    f->time_s = time_s;
}

void sq__cloud_cell_bounds(const sq__cloud_field *f, int i, int j, int k, float *zlo, float *zhi)
{
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny, c = (size_t)j * g->nx + i;
    *zlo = f->zw[(size_t)k * cols + c];
    *zhi = f->zw[(size_t)(k + 1) * cols + c];
}

/* Linear interpolation of the packed values in column (i, j) at physical height z; returns
 * false outside the column (below the ground or above the top interface). */
static bool column_sample(const sq__cloud_field *f, int i, int j, float z, float out[PACK])
{
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny, col = (size_t)j * g->nx + i;
    const int nz = g->nz;
    if (z < f->zw[col] || z > f->zw[(size_t)nz * cols + col]) return false;
    const float *zc = f->z + col;
    int k0, k1;
    float t;
    if (z <= zc[0]) {
        k0 = k1 = 0;
        t = 0.0f;
    } else if (z >= zc[(size_t)(nz - 1) * cols]) {
        k0 = k1 = nz - 1;
        t = 0.0f;
    } else { /* binary search: zc[k0] <= z < zc[k1] */
        int lo = 0, hi = nz - 1;
        while (hi - lo > 1) {
            const int mid = (lo + hi) / 2;
            if (zc[(size_t)mid * cols] <= z) lo = mid;
            else hi = mid;
        }
        k0 = lo;
        k1 = hi;
        const float za = zc[(size_t)k0 * cols], zb = zc[(size_t)k1 * cols];
        t = zb > za ? (z - za) / (zb - za) : 0.0f;
    }
    const float *a = f->pack + PACK * ((size_t)k0 * cols + col);
    const float *b = f->pack + PACK * ((size_t)k1 * cols + col);
    for (int q = 0; q < PACK; q++) out[q] = a[q] + (b[q] - a[q]) * t;
    return true;
}

void sq__cloud_field_sample(const sq__cloud_field *f, float x, float y, float zw,
                            sq__cloud_sample *out)
{
    memset(out, 0, sizeof *out);
    const sq__cloud_grid *g = &f->grid;
    float fx = (x - g->x0) / g->dx, fy = (y - g->y0) / g->dy;
    if (!(fx >= -0.5f && fx <= (float)g->nx - 0.5f && fy >= -0.5f && fy <= (float)g->ny - 0.5f))
        return;
    fx = clampf(fx, 0.0f, (float)(g->nx - 1));
    fy = clampf(fy, 0.0f, (float)(g->ny - 1));
    const int i0 = (int)fx, j0 = (int)fy;
    const int i1 = i0 + 1 < g->nx ? i0 + 1 : i0, j1 = j0 + 1 < g->ny ? j0 + 1 : j0;
    const float wx = fx - (float)i0, wy = fy - (float)j0;
    const float z = zw / f->exaggeration;
    float acc[PACK] = {0}, v[PACK];
    const int ci[4] = {i0, i1, i0, i1}, cj[4] = {j0, j0, j1, j1};
    const float cw[4] = {(1 - wx) * (1 - wy), wx * (1 - wy), (1 - wx) * wy, wx * wy};
    for (int q = 0; q < 4; q++) {
        if (cw[q] == 0.0f || !column_sample(f, ci[q], cj[q], z, v)) continue;
        for (int p = 0; p < PACK; p++) acc[p] += cw[q] * v[p];
    }
    out->beta = acc[0];
    out->g = acc[0] > 0.0f ? acc[1] / acc[0] : 0.0f;
    out->cond = acc[2];
    out->ice_fraction = acc[2] > 0.0f ? clampf(acc[3] / acc[2], 0.0f, 1.0f) : 0.0f;
    out->frac = acc[4];
    out->wind[0] = acc[5];
    out->wind[1] = acc[6];
    out->wind[2] = acc[7] * f->exaggeration;
}

static int frac_index(float frac, float *w)
{
    const float t = clampf(frac, 0.0f, 1.0f) * (float)(SQ__SUBGRID_TABLE - 1);
    int i = (int)t;
    if (i >= SQ__SUBGRID_TABLE - 1) i = SQ__SUBGRID_TABLE - 2;
    *w = t - (float)i;
    return i;
}

float sq__cloud_subgrid_mask(const sq__cloud_field *f, float x, float y, float z_phys, float frac)
{
    const sq__subgrid *s = &f->sub;
    if (!s->on) return 1.0f;
    float w;
    const int i = frac_index(frac, &w);
    const float theta = s->theta[i] + (s->theta[i + 1] - s->theta[i]) * w;
    return smooth_mask(subgrid_noise(s, x, y, z_phys), theta, s->width);
}

float sq__cloud_subgrid_weight(const sq__cloud_field *f, float x, float y, float z_phys, float frac)
{
    const sq__subgrid *s = &f->sub;
    if (!s->on) return 1.0f;
    float w;
    const int i = frac_index(frac, &w);
    const float mean = s->mean[i] + (s->mean[i + 1] - s->mean[i]) * w;
    if (!(mean > 1e-6f)) return 0.0f;
    return sq__cloud_subgrid_mask(f, x, y, z_phys, frac) / mean;
}

int64_t sq__cloud_field_cell_at(const sq__cloud_field *f, float x, float y, float zw)
{
    const sq__cloud_grid *g = &f->grid;
    const int i = (int)floorf((x - g->x0) / g->dx + 0.5f), j = (int)floorf((y - g->y0) / g->dy + 0.5f);
    if (i < 0 || j < 0 || i >= g->nx || j >= g->ny) return -1;
    const float z = zw / f->exaggeration;
    const size_t cols = (size_t)g->nx * g->ny, col = (size_t)j * g->nx + i;
    if (z < f->zw[col] || z >= f->zw[(size_t)g->nz * cols + col]) return -1;
    int lo = 0, hi = g->nz; /* zw[lo] <= z < zw[hi] */
    while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (f->zw[(size_t)mid * cols + col] <= z) lo = mid;
        else hi = mid;
    }
    return (int64_t)((size_t)lo * cols + col);
}

void sq__cloud_field_mask_to_clouds(sq__cloud_field *f)
{
    float bmax = 0.0f;
    for (size_t c = 0; c < f->cells; c++) {
        float *p = f->pack + PACK * c;
        if (f->label[c] < 0) p[0] = p[1] = 0.0f;
        if (p[0] > bmax) bmax = p[0];
    }
    f->beta_max = bmax;
}
