/* snowdrift_snow.c — the snow model on the wind lattice (SPEC §5.6–5.7, S1 §3.2 steps 6–8):
 * state, parameters, the per-step recipe and the coupling of solid snow cells back to the
 * wind solver (bounce-back). Kernels are in snowdrift_kernels.c. */
#include <math.h>
#include <string.h>

#include "snowdrift_internal.h"

sq__snow_params sq__snow_params_resolve(const sq__snow_params *in)
{
    sq__snow_params p;
    memset(&p, 0, sizeof p);
    if (in) p = *in;
    if (p.dx_m == 0) p.dx_m = 1.0;
    if (p.dt_s == 0) p.dt_s = 0.1;
    if (p.fall_speed_mps == 0) p.fall_speed_mps = 1.0;
    if (p.threshold == 0) p.threshold = 10;
    if (p.snow_density_kgm3 == 0) p.snow_density_kgm3 = 150.0;
    if (p.speedup == 0) p.speedup = 1.0;
    if (p.ustar_threshold_mps == 0) p.ustar_threshold_mps = 0.25;
    if (p.erosion_efficiency == 0) p.erosion_efficiency = 1.0;
    if (p.saturation_time_s == 0) p.saturation_time_s = 1.0;
    if (p.saltation_kgm3 == 0) p.saltation_kgm3 = 0.05;
    return p;
}

static sq_result validate(sq_context *ctx, sq_dims n, const sq__snow_params *p)
{
    if (n.nx < 1 || n.ny < 1 || n.nz < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                        "lattice %dx%dx%d; every axis needs at least 1 cell", n.nx, n.ny, n.nz);
    const struct {
        const char *name;
        double v;
    } pos[] = {{"dx_m", p->dx_m},
               {"dt_s", p->dt_s},
               {"fall_speed_mps", p->fall_speed_mps},
               {"snow_density_kgm3", p->snow_density_kgm3},
               {"speedup", p->speedup},
               {"ustar_threshold_mps", p->ustar_threshold_mps},
               {"erosion_efficiency", p->erosion_efficiency},
               {"saturation_time_s", p->saturation_time_s},
               {"saltation_kgm3", p->saltation_kgm3}};
    for (size_t i = 0; i < sizeof pos / sizeof pos[0]; i++)
        if (!(isfinite(pos[i].v) && pos[i].v > 0))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift", "%s = %g; must be > 0",
                            pos[i].name, pos[i].v);
    if (!(isfinite(p->snowfall_mmh) && p->snowfall_mmh >= 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                        "snow.snowfall_mmh = %g; must be >= 0 (water equivalent)", p->snowfall_mmh);
    if (p->threshold < 1 || p->threshold > 1000000)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                        "snow.threshold = %d; must be in 1..1000000 flakes", p->threshold);
    if (p->erosion_efficiency > 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                        "snow.erosion_efficiency = %g; must be in (0, 1]", p->erosion_efficiency);
    return SQ_OK;
}

double sq__snow_flakes_per_top_cell(const sq__snow_params *p)
{
    const double mass = p->snow_density_kgm3 * p->dx_m * p->dx_m * p->dx_m / p->threshold;
    /* R mm/h of water = R kg m⁻² h⁻¹ */
    return p->speedup * p->snowfall_mmh / 3600.0 * p->dx_m * p->dx_m * p->dt_s / mass;
}

void sq__snow_destroy(sq__snow *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    sq_free(ctx, s->air);
    sq_free(ctx, s->air_next);
    sq_free(ctx, s->land);
    sq_free(ctx, s->dep);
    sq_free(ctx, s->kind);
    sq_free(ctx, s->changed);
    sq_free(ctx, s);
}

sq_result sq__snow_create(sq_context *ctx, sq_dims cells, const sq__snow_params *params,
                          sq__snow **out)
{
    if (out) *out = NULL;
    if (!ctx || !out)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowdrift", "sq__snow_create: NULL argument");
    const sq__snow_params p = sq__snow_params_resolve(params);
    sq_result r = validate(ctx, cells, &p);
    if (r != SQ_OK) return r;
    const int64_t n = (int64_t)cells.nx * cells.ny * cells.nz;
    /* 4 × 4 B counts + 2 × 1 B flags per cell */
    r = sq_context_check_memory(ctx, (uint64_t)n * 18, "snow lattice");
    if (r != SQ_OK) return r;
    sq__snow *s = (sq__snow *)sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    s->p = p;
    s->nx = cells.nx;
    s->ny = cells.ny;
    s->nz = cells.nz;
    s->n = n;
    s->air = (uint32_t *)sq_alloc_zero(ctx, (size_t)n * sizeof(uint32_t));
    s->air_next = (uint32_t *)sq_alloc_zero(ctx, (size_t)n * sizeof(uint32_t));
    s->land = (uint32_t *)sq_alloc_zero(ctx, (size_t)n * sizeof(uint32_t));
    s->dep = (uint32_t *)sq_alloc_zero(ctx, (size_t)n * sizeof(uint32_t));
    s->kind = (uint8_t *)sq_alloc_zero(ctx, (size_t)n);
    s->changed = (uint8_t *)sq_alloc_zero(ctx, (size_t)n);
    if (!s->air || !s->air_next || !s->land || !s->dep || !s->kind || !s->changed) {
        sq__snow_destroy(s);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    s->flake_mass_kg = p.snow_density_kgm3 * p.dx_m * p.dx_m * p.dx_m / p.threshold;
    *out = s;
    return SQ_OK;
}

void sq__snow_set_static(sq__snow *s, int i, int j, int k, bool solid)
{
    if (!s || i < 0 || j < 0 || k < 0 || i >= s->nx || j >= s->ny || k >= s->nz) return;
    const int64_t c = i + (int64_t)s->nx * (j + (int64_t)s->ny * k);
    if (solid) {
        /* snow inside a new obstacle stays accounted for as deposited */
        s->dep[c] += s->air[c];
        s->air[c] = 0;
        s->kind[c] = SQ_SNOW_STATIC;
    } else if (s->kind[c] == SQ_SNOW_STATIC) {
        s->kind[c] = SQ_SNOW_AIR;
    }
}

static bool plain_view(const sq_field_view *v, const sq__snow *s)
{
    return v && v->data && v->n.nx == s->nx && v->n.ny == s->ny && v->n.nz == s->nz &&
           v->sx == 1 && v->sy == s->nx && v->sz == (ptrdiff_t)s->nx * s->ny;
}

void sq__snow_kparams_of(const sq__snow *s, sq__snow_kparams *kp)
{
    memset(kp, 0, sizeof *kp);
    kp->nx = s->nx;
    kp->ny = s->ny;
    kp->nz = s->nz;
    kp->dt_over_dx = (float)(s->p.dt_s / s->p.dx_m);
    kp->fall_cells = (float)(s->p.fall_speed_mps * s->p.dt_s / s->p.dx_m);
    kp->periodic[0] = s->p.periodic[0];
    kp->periodic[1] = s->p.periodic[1];
    kp->seed = s->p.seed;
    kp->step = s->step;
    kp->threads = sq_context_threads(s->ctx);
    kp->k0 = kp->kz0 = 0;
    kp->k1 = kp->gnz = s->nz;
}

sq_result sq__snow_step(sq__snow *s, const sq_field_view u[3], const sq_field_view *ustar,
                        sq_lbm *lbm)
{
    if (!s || !u) return sq__set_error(SQ_ERR_INVALID_ARG, "sq__snow_step: NULL argument");
    for (int a = 0; a < 3; a++)
        if (!plain_view(&u[a], s))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                            "wind view %d does not match the snow lattice %dx%dx%d", a, s->nx,
                            s->ny, s->nz);
    if (ustar && !plain_view(ustar, s))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                        "friction-velocity view does not match the snow lattice");
    sq__snow_kparams kp;
    sq__snow_kparams_of(s, &kp);
    const size_t bytes = (size_t)s->n * sizeof(uint32_t);

    double t0 = sq_time_now(), t1;
    /* 1. snowfall at the top (S1 §3.2 initialisation 3) */
    s->fallen += sq__snow_inject(&kp, sq__snow_flakes_per_top_cell(&s->p), s->kind, s->air);
    /* 2. transport by the wind, S1 eqs 8–11 */
    memset(s->air_next, 0, bytes);
    memset(s->changed, 0, (size_t)s->n);
    sq__snow_transport(&kp, u[0].data, u[1].data, u[2].data, s->kind, s->air, s->air_next,
                       s->land, &s->left);
    t1 = sq_time_now();
    s->ms_transport += 1e3 * (t1 - t0);
    t0 = t1;
    /* 3. deposition and solidification at the threshold */
    sq__snow_settle(&kp, s->p.threshold, s->kind, s->land, s->dep, s->air_next, s->changed);
    t1 = sq_time_now();
    s->ms_deposit += 1e3 * (t1 - t0);
    t0 = t1;
    /* 4. erosion where the friction velocity exceeds its threshold, S1 eqs 12–13 */
    s->eroded += sq__snow_erode(&kp, &s->p, ustar ? ustar->data : NULL, s->kind, s->dep,
                                s->air_next, s->changed);
    uint32_t *t = s->air;
    s->air = s->air_next;
    s->air_next = t;
    t1 = sq_time_now();
    s->ms_erode += 1e3 * (t1 - t0);
    t0 = t1;
    /* 5. solid snow obstructs the wind (bounce-back); eroded cells open again */
    if (lbm) {
        for (int64_t c = 0; c < s->n; c++) {
            if (!s->changed[c]) continue;
            const int i = (int)(c % s->nx), j = (int)((c / s->nx) % s->ny);
            const int k = (int)(c / ((int64_t)s->nx * s->ny));
            const sq_result r = sq_lbm_set_solid(lbm, i, j, k, s->kind[c] != SQ_SNOW_AIR);
            if (r != SQ_OK) return r;
        }
    }
    s->ms_couple += 1e3 * (sq_time_now() - t0);
    s->step++;
    return SQ_OK;
}

void sq__snow_get_budget(const sq__snow *s, sq__snow_budget *out)
{
    memset(out, 0, sizeof *out);
    if (!s) return;
    uint64_t a = 0, d = 0;
    int64_t solid = 0;
    for (int64_t c = 0; c < s->n; c++) {
        a += s->air[c];
        d += s->dep[c];
        solid += s->kind[c] == SQ_SNOW_SOLID;
    }
    out->fallen = s->fallen;
    out->airborne = a;
    out->deposited = d;
    out->left = s->left;
    out->eroded = s->eroded;
    out->solid_cells = solid;
}
