/* lbm.c — the D3Q15 wind solver's lifecycle, step recipe, wind control (SPEC §5.5: corrected
 * mass-conserving injection, progressive set-up, gusts by Beaufort level with zero mean), solid
 * cells, macroscopic views, friction velocity and stability checks. */
#include <math.h>
#include <stdio.h>
#include <string.h>
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "lbm_internal.h"
#include "squall/par.h"
#include "squall/rng.h"

#define LBM_KAPPA 0.41                 /* von Kármán constant */
#define LBM_GUST_STREAM 0x4C424D4755535400ull /* RNG stream of the gust phases */
#define LBM_DRIVE_GAIN 0.5             /* BODY_FORCE controller: fraction of the error per step */

static const double PI = 3.14159265358979323846;

/* ---- helpers ---------------------------------------------------------------------------- */

static void cell_coords(const sq_lbm *l, int64_t c, int *x, int *y, int *z)
{
    *z = (int)(c / l->sz) - 1;
    const int64_t r = c % l->sz;
    *y = (int)(r / l->sy) - 1;
    *x = (int)(r % l->sy) - 1;
}

static void update_row_class(sq_lbm *l, int y, int z)
{
    const int64_t r = y + (int64_t)z * l->ny;
    const int32_t n = l->row_solids[r];
    l->row_class[r] = n == 0 ? SQ_LBM_ROW_FLUID : n == l->nx ? SQ_LBM_ROW_SOLID : SQ_LBM_ROW_MIXED;
}

/* Density and velocity (lattice units) of padded cell c in the current layout. */
static void cell_macro(const sq_lbm *l, int64_t c, double *rho, double u[3])
{
    const int parity = (int)(l->step & 1);
    double f[SQ_LBM_Q];
    sq__lbm_gather(l, c, parity, f);
    double r = 0, j[3] = {0, 0, 0};
    for (int i = 0; i < SQ_LBM_Q; i++) {
        r += f[i];
        for (int a = 0; a < 3; a++) j[a] += sq__lbm_c[i][a] * f[i];
    }
    *rho = r;
    /* pre-collision (natural): u = j/ρ + g/2; post-collision (swapped): u = j'/ρ − g/2 */
    const double h = parity == 0 ? 0.5 : -0.5;
    for (int a = 0; a < 3; a++) u[a] = (r != 0 ? j[a] / r : 0.0) + h * l->g_step[a];
}

/* Whether a pass over all cells is worth a parallel region (thread start-up dominates below). */
static bool want_parallel(const sq_lbm *l)
{
    return (int64_t)l->nx * l->ny * l->nz >= 32768;
}

/* Planes of the whole lattice (this slab's in a distributed run: l->nz). */
static int global_nz(const sq_lbm *l) { return l->zdist ? l->nzg : l->nz; }

static void invalidate(sq_lbm *l)
{
    l->nbr_valid = false;
    l->bc_valid = false;
    l->macro_valid = false;
    l->lmacro_valid = false;
    l->ustar_valid = false;
}

static void ensure_boundaries(sq_lbm *l)
{
    if (l->bc_valid) return;
    sq__lbm_boundaries(l);
    l->bc_valid = true;
}

/* ---- lifecycle -------------------------------------------------------------------------- */

void sq_lbm_destroy(sq_lbm *l)
{
    if (!l) return;
    sq_context *ctx = l->ctx;
    sq_free(ctx, l->f);
    sq_free(ctx, l->solid);
    sq_free(ctx, l->row_class);
    sq_free(ctx, l->row_solids);
    sq_free(ctx, l->macro);
    sq_free(ctx, l->ustar);
    sq_free(ctx, l->links);
    sq_free(ctx, l->inflow_cells);
    sq_free(ctx, l->inflow_shape);
    sq__lbm_dist_free(l);
    sq_free(ctx, l);
}

static void wind_vector(const sq_lbm *l, double speed_mps, double v[2])
{
    const double h = l->wind_heading_deg * PI / 180.0;
    const double s = speed_mps / l->units.u;
    v[0] = s * cos(h);
    v[1] = s * sin(h);
}

sq_result sq_lbm_create(sq_context *ctx, const sq_lbm_desc *desc, sq_lbm **out)
{
    if (out) *out = NULL;
    if (!ctx || !desc || !out)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "sq_lbm_create: ctx, desc and out are "
                                                        "required");
    const sq_lbm_desc d = sq_lbm_desc_resolve(desc);
    sq_result r = sq__lbm_validate(ctx, &d);
    if (r != SQ_OK) return r;
    sq__lbm_units units;
    double tau;
    r = sq__lbm_units_make(ctx, &d, &units, &tau);
    if (r != SQ_OK) return r;
    const bool dist = d.decompose && sq_par_size() > 1;
    sq_lbm_desc dl = d; /* one slab's share for the memory check (the views stay global) */
    if (dist) dl.cells.nz = d.cells.nz / sq_par_size() + 1;
    const uint64_t bytes = sq_lbm_memory_bytes(&dl);
    char what[96];
    snprintf(what, sizeof what, "lattice %dx%dx%d", d.cells.nx, d.cells.ny, d.cells.nz);
    r = sq_context_check_memory(ctx, bytes, what);
    if (r != SQ_OK) return r;

    sq_lbm *l = (sq_lbm *)sq_alloc_zero(ctx, sizeof *l);
    if (!l) return SQ_ERR_OUT_OF_MEMORY;
    l->ctx = ctx;
    l->desc = d;
    l->units = units;
    l->tau = tau;
    l->nu_lu = (tau - 0.5) / 3.0;
    l->collision = d.collision;
    l->drive = d.wind.drive;
    l->nx = d.cells.nx;
    l->ny = d.cells.ny;
    l->nz = d.cells.nz;
    l->sy = l->nx + 2;
    l->sz = l->sy * (l->ny + 2);
    for (int a = 0; a < 3; a++) {
        const sq_lbm_bc b = d.bc[2 * a];
        l->periodic[a] = b == SQ_LBM_BC_PERIODIC || b == SQ_LBM_BC_RECYCLE;
    }
    if (dist) { /* this rank's slab: l->nz becomes its plane count */
        r = sq__lbm_dist_setup(l, &d);
        if (r != SQ_OK) {
            sq_lbm_destroy(l);
            return r;
        }
    }
    l->ncell = l->sz * (l->nz + 2);
    l->stride = (l->ncell + 15) / 16 * 16;
    for (int i = 0; i < SQ_LBM_Q; i++)
        l->off[i] = sq__lbm_c[i][0] + sq__lbm_c[i][1] * l->sy + sq__lbm_c[i][2] * l->sz;
    const int64_t cells = (int64_t)l->nx * l->ny * global_nz(l); /* the views: global */
    const int64_t rows = (int64_t)l->ny * l->nz;
    l->f = (float *)sq_alloc(ctx, (size_t)(SQ_LBM_Q * l->stride) * sizeof(float));
    l->solid = (uint8_t *)sq_alloc_zero(ctx, (size_t)l->ncell);
    l->row_class = (uint8_t *)sq_alloc_zero(ctx, (size_t)rows);
    l->row_solids = (int32_t *)sq_alloc_zero(ctx, (size_t)rows * sizeof(int32_t));
    l->macro = (float *)sq_alloc_zero(ctx, (size_t)(4 * cells) * sizeof(float));
    l->ustar = (float *)sq_alloc_zero(ctx, (size_t)cells * sizeof(float));
    if (!l->f || !l->solid || !l->row_class || !l->row_solids || !l->macro || !l->ustar) {
        sq_lbm_destroy(l);
        return SQ_ERR_OUT_OF_MEMORY;
    }
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    /* transparent huge pages for the population arrays: the sweep walks 45 streams (15
     * populations × 3 planes), which thrashes the TLB with 4 KiB pages. Only a hint. */
    {
        const uintptr_t mb2 = (uintptr_t)1 << 21;
        const uintptr_t a = ((uintptr_t)l->f + mb2 - 1) & ~(mb2 - 1);
        const uintptr_t e = ((uintptr_t)(l->f + SQ_LBM_Q * l->stride)) & ~(mb2 - 1);
        if (e > a) (void)madvise((void *)a, (size_t)(e - a), MADV_HUGEPAGE);
    }
#endif
    /* air at rest: f_i = w_i, stored shifted as 0 (first touch by the sweeping threads) */
    const int nt = sq_context_threads(ctx);
    for (int i = 0; i < SQ_LBM_Q; i++) {
        float *fi = l->f + (int64_t)i * l->stride;
        const int64_t n = l->stride;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int64_t c = 0; c < n; c++) fi[c] = 0.0f;
    }
    r = sq__lbm_links_build(l);
    if (r != SQ_OK) {
        sq_lbm_destroy(l);
        return r;
    }
    /* wind */
    l->seed = sq_context_seed(ctx);
    l->wind_speed_mps = d.wind.speed_mps;
    l->wind_heading_deg = d.wind.heading_deg;
    l->beaufort = d.wind.beaufort;
    l->max_wind_lu = sq__lbm_max_wind_mps(&d) / units.u;
    int kr = (int)floor(d.wind.ref_height_m / units.dx);
    l->k_ref = kr < 0 ? 0 : kr >= d.cells.nz ? d.cells.nz - 1 : kr;
    if (d.wind.ramp_mps2 == 0 && d.wind.speed_mps > 0) {
        double v[2];
        wind_vector(l, d.wind.speed_mps, v);
        l->setpoint[0] = v[0];
        l->setpoint[1] = v[1];
        l->pending[0] = v[0];
        l->pending[1] = v[1];
    }
    for (int a = 0; a < 3; a++) l->g_step[a] = d.body_accel_mps2[a] / units.a;
    sq_log(ctx, SQ_LOG_DEBUG, "lbm",
           "lattice %dx%dx%d, dx %g m, dt %.4g s, tau %.6g, collision %s, %.1f MiB",
           l->nx, l->ny, l->nz, units.dx, units.dt, tau, sq_lbm_collision_name(l->collision),
           (double)bytes / 1048576.0);
    *out = l;
    return SQ_OK;
}

sq_lbm_info sq_lbm_get_info(const sq_lbm *l)
{
    sq_lbm_info in;
    memset(&in, 0, sizeof in);
    if (!l) return in;
    in.cells = l->desc.cells;
    in.cell_size_m = l->units.dx;
    in.dt_s = l->units.dt;
    in.tau = l->tau;
    in.viscosity_lu = l->nu_lu;
    in.velocity_scale = l->units.u;
    in.max_wind_lu = l->max_wind_lu;
    in.mach = l->max_wind_lu * sqrt(3.0);
    in.bytes_per_cell_update = 2.0 * SQ_LBM_Q * sizeof(float);
    in.memory_bytes = sq_lbm_memory_bytes(&l->desc);
    in.step = l->step;
    in.time_s = (double)l->step * l->units.dt;
    const double sp = hypot(l->setpoint[0], l->setpoint[1]) * l->units.u;
    in.wind_speed_mps = sp;
    in.wind_heading_deg = l->wind_heading_deg;
    in.collision = l->collision;
    in.drive = l->drive;
    return in;
}

/* ---- wind control ----------------------------------------------------------------------- */

/* Gust factor in [−1, 1] at time t: sin α with α uniform in [0, 2π) (SPEC §5.5 fix: zero
 * mean), redrawn every gust period and blended with a smoothstep so the wind stays smooth. */
static double gust_factor(const sq_lbm *l, double t)
{
    const double T = l->desc.wind.gust_period_s;
    const double q = t / T;
    const double k = floor(q);
    const double s = q - k, w = s * s * (3.0 - 2.0 * s);
    const uint64_t ik = (uint64_t)(int64_t)k;
    const double a0 = sin(2.0 * PI * sq_rng_uniform_d(l->seed, LBM_GUST_STREAM, ik));
    const double a1 = sin(2.0 * PI * sq_rng_uniform_d(l->seed, LBM_GUST_STREAM, ik + 1));
    return a0 + (a1 - a0) * w;
}

/* The plane BODY_FORCE measures: the reference plane, or where fewer than half of its cells
 * are fluid (buried under deposited snow, say) the first plane above it that is at least half
 * fluid; -1 when there is none. In a buried plane the few fluid cells left are stagnant pockets:
 * measuring there (0 when none is left) made the controller add half the set-point to the
 * whole flow every step until it blew up. Global flags: every rank agrees. */
static int measured_plane(const sq_lbm *l)
{
    const int gnz = global_nz(l);
    const int64_t half = ((int64_t)l->nx * l->ny + 1) / 2;
    for (int k = l->k_ref; k < gnz; k++) {
        int64_t n = 0;
        for (int y = 0; y < l->ny && n < half; y++)
            for (int x = 0; x < l->nx; x++) n += sq__lbm_gsolid(l, x, y, k) == 0;
        if (n >= half) return k;
    }
    return -1;
}

/* Mean horizontal velocity (l.u.) of the fluid cells in the measured plane (vectorised rows,
 * the same moments as the density/velocity views). Returns false when there is no such plane
 * (nothing to measure: the drive then adds no correction). */
static bool measure_ref_plane(const sq_lbm *l, double u[2])
{
    const int parity = (int)(l->step & 1);
    const float h = parity == 0 ? 0.5f : -0.5f;
    const float gh[3] = {h * (float)l->g_step[0], h * (float)l->g_step[1],
                         h * (float)l->g_step[2]};
    double s[2] = {0, 0};
    int64_t n = 0;
    const int k = measured_plane(l);
    u[0] = u[1] = 0.0;
    if (k < 0) return false;
    if (l->zdist) { /* the slab holding the plane measures, the others are told */
        const int owner = l->plane_rank[k];
        double v[3] = {0, 0, 0};
        if (owner == sq_par_rank()) {
            sq__lbm_plane_velocity(l, parity, gh, k - l->kz0, s, &n);
            v[0] = s[0], v[1] = s[1], v[2] = (double)n;
        }
        sq_par_broadcast(v, sizeof v, owner);
        s[0] = v[0], s[1] = v[1], n = (int64_t)v[2];
    } else {
        sq__lbm_plane_velocity(l, parity, gh, k, s, &n);
    }
    if (n == 0) return false;
    u[0] = s[0] / (double)n;
    u[1] = s[1] / (double)n;
    return true;
}

/* Adds the velocity v (l.u.) to every fluid cell without changing its density:
 *   linear (S1 one-shot, corrected): ΔF_i = 3 w_i ρ (c_i·v)
 *   equilibrium difference:          ΔF_i = F_i^eq(ρ, u + v) − F_i^eq(ρ, u)
 * Both add exactly ρv of momentum and no mass (Σ w_i c_i = 0, Σ w_i c_i c_i = I/3). The second
 * also moves the second moments with the flow, so a wind set up from rest starts at
 * equilibrium without an acoustic transient (used for the instantaneous set-up). Where a
 * population would turn negative, ΔF is scaled down in that cell. */
static void inject_lu(sq_lbm *l, const double v[3], int64_t *limited, bool equilibrium)
{
    ensure_boundaries(l); /* every cell holds its complete population set */
    const int parity = (int)(l->step & 1);
    const int nt = sq_context_threads(l->ctx);
    const int64_t rows = (int64_t)l->ny * l->nz;
    int64_t lim = 0;
    double k[SQ_LBM_Q];
    for (int i = 0; i < SQ_LBM_Q; i++)
        k[i] = 3.0 * sq__lbm_w[i] *
               (sq__lbm_c[i][0] * v[0] + sq__lbm_c[i][1] * v[1] + sq__lbm_c[i][2] * v[2]);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(want_parallel(l)) reduction(+:lim))
    for (int64_t r = 0; r < rows; r++) {
        if (l->row_class[r] == SQ_LBM_ROW_SOLID) continue;
        const int y = (int)(r % l->ny), z = (int)(r / l->ny);
        for (int x = 0; x < l->nx; x++) {
            const int64_t c = sq__lbm_cell(l, x, y, z);
            if (l->solid[c]) continue;
            double f[SQ_LBM_Q], df[SQ_LBM_Q];
            sq__lbm_gather(l, c, parity, f);
            double rho = 0, j[3] = {0, 0, 0};
            for (int i = 0; i < SQ_LBM_Q; i++) {
                rho += f[i];
                for (int a = 0; a < 3; a++) j[a] += sq__lbm_c[i][a] * f[i];
            }
            if (equilibrium) {
                double u0[3], u1[3], e0[SQ_LBM_Q], e1[SQ_LBM_Q];
                for (int a = 0; a < 3; a++) {
                    u0[a] = j[a] / rho;
                    u1[a] = u0[a] + v[a];
                }
                sq__lbm_feq(rho, u0, e0);
                sq__lbm_feq(rho, u1, e1);
                for (int i = 0; i < SQ_LBM_Q; i++) df[i] = e1[i] - e0[i];
            } else {
                for (int i = 0; i < SQ_LBM_Q; i++) df[i] = k[i] * rho;
            }
            double s = 1.0;
            for (int i = 0; i < SQ_LBM_Q; i++) {
                if (df[i] < 0 && f[i] + df[i] < 0) {
                    const double si = f[i] / -df[i];
                    if (si < s) s = si;
                }
            }
            if (s < 1.0) lim++;
            for (int i = 0; i < SQ_LBM_Q; i++) f[i] += s * df[i];
            sq__lbm_scatter(l, c, parity, f);
        }
    }
    if (l->zdist) sq_par_sum_i64(&lim, 1);
    if (limited) *limited = lim;
    if (parity == 0) sq__lbm_prime_ghosts(l);
    invalidate(l);
}

/* Updates the wind for the coming step: gusts, ramp, drive (inflow velocity or controlled
 * body force), one-shot injections. */
static void update_wind(sq_lbm *l)
{
    const sq_lbm_wind_desc *w = &l->desc.wind;
    /* one-shot injection first, on a state whose boundaries still carry the old wind */
    if (l->pending[0] != 0 || l->pending[1] != 0 || l->pending[2] != 0) {
        inject_lu(l, l->pending, NULL, true);
        l->pending[0] = l->pending[1] = l->pending[2] = 0;
    }
    const double t = (double)l->step * l->units.dt;
    double speed = l->wind_speed_mps;
    if (l->beaufort > 0 && speed > 0) speed *= 1.0 + (l->beaufort / 20.0) * gust_factor(l, t);
    double target[2];
    wind_vector(l, speed, target);
    if (w->ramp_mps2 > 0) {
        const double step = w->ramp_mps2 * l->units.dt / l->units.u; /* l.u. per step */
        const double ex = target[0] - l->setpoint[0], ey = target[1] - l->setpoint[1];
        const double e = hypot(ex, ey);
        const double s = e > step ? step / e : 1.0;
        l->setpoint[0] += s * ex;
        l->setpoint[1] += s * ey;
    } else {
        l->setpoint[0] = target[0];
        l->setpoint[1] = target[1];
    }
    double g[3];
    for (int a = 0; a < 3; a++) g[a] = l->desc.body_accel_mps2[a] / l->units.a;
    if (l->drive == SQ_LBM_DRIVE_INFLOW) {
        if (l->inflow_u[0] != l->setpoint[0] || l->inflow_u[1] != l->setpoint[1]) {
            l->inflow_u[0] = l->setpoint[0];
            l->inflow_u[1] = l->setpoint[1];
            l->inflow_u[2] = 0;
            l->bc_valid = false; /* the boundary pass is idempotent: simply redone */
        }
    } else if (l->drive == SQ_LBM_DRIVE_BODY_FORCE) {
        double u[2];
        ensure_boundaries(l); /* edge cells of the plane need their incoming populations */
        if (measure_ref_plane(l, u)) { /* nothing to measure: no correction */
            g[0] += LBM_DRIVE_GAIN * (l->setpoint[0] - u[0]);
            g[1] += LBM_DRIVE_GAIN * (l->setpoint[1] - u[1]);
        }
    }
    for (int a = 0; a < 3; a++) l->g_step[a] = g[a];
}

sq_result sq_lbm_set_wind(sq_lbm *l, double speed_mps, double heading_deg)
{
    if (!l) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_set_wind: lbm is NULL");
    if (!(isfinite(speed_mps) && speed_mps >= 0))
        return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm", "speed_mps = %g m/s; must be >= 0",
                        speed_mps);
    if (!isfinite(heading_deg))
        return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm", "heading_deg = %g; must be finite",
                        heading_deg);
    sq_lbm_desc d = l->desc;
    d.wind.speed_mps = speed_mps;
    d.wind.beaufort = l->beaufort;
    d.max_wind_mps = 0;
    const double umax = sq__lbm_max_wind_mps(&d);
    if (umax > 0) {
        const sq_result r = sq__lbm_check_mach(l->ctx, &l->units, umax, "wind");
        if (r != SQ_OK) return r;
    }
    double old[2], nw[2];
    wind_vector(l, l->wind_speed_mps, old);
    l->wind_speed_mps = speed_mps;
    l->wind_heading_deg = heading_deg;
    wind_vector(l, speed_mps, nw);
    if (l->desc.wind.ramp_mps2 == 0) {
        l->pending[0] += nw[0] - old[0];
        l->pending[1] += nw[1] - old[1];
    }
    if (umax / l->units.u > l->max_wind_lu) l->max_wind_lu = umax / l->units.u;
    return SQ_OK;
}

sq_result sq_lbm_set_gusts(sq_lbm *l, double beaufort)
{
    if (!l) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_set_gusts: lbm is NULL");
    if (!(isfinite(beaufort) && beaufort >= 0 && beaufort <= 12))
        return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm", "beaufort = %g; must be in [0, 12]",
                        beaufort);
    sq_lbm_desc d = l->desc;
    d.wind.speed_mps = l->wind_speed_mps;
    d.wind.beaufort = beaufort;
    d.max_wind_mps = 0;
    const double umax = sq__lbm_max_wind_mps(&d);
    if (umax > 0) {
        const sq_result r = sq__lbm_check_mach(l->ctx, &l->units, umax, "wind with gusts");
        if (r != SQ_OK) return r;
    }
    l->beaufort = beaufort;
    return SQ_OK;
}

sq_result sq_lbm_inject(sq_lbm *l, const double v_mps[3], int64_t *limited_cells)
{
    if (limited_cells) *limited_cells = 0;
    if (!l || !v_mps) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_inject: NULL argument");
    double v[3];
    for (int a = 0; a < 3; a++) {
        if (!isfinite(v_mps[a]))
            return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm", "injected v[%d] is not finite",
                            a);
        v[a] = v_mps[a] / l->units.u;
    }
    const double s = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) * l->units.u;
    if (s > 0) {
        const sq_result r = sq__lbm_check_mach(l->ctx, &l->units, s, "injected wind");
        if (r != SQ_OK) return r;
    }
    inject_lu(l, v, limited_cells, false);
    return SQ_OK;
}

/* ---- stepping --------------------------------------------------------------------------- */

static sq_result check_stability(sq_lbm *l)
{
    const int nt = sq_context_threads(l->ctx);
    const int64_t rows = (int64_t)l->ny * l->nz;
    int64_t bad = INT64_MAX;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(want_parallel(l)) reduction(min:bad))
    for (int64_t r = 0; r < rows; r++) {
        if (l->row_class[r] == SQ_LBM_ROW_SOLID) continue;
        const int y = (int)(r % l->ny), z = (int)(r / l->ny);
        for (int x = 0; x < l->nx; x++) {
            const int64_t c = sq__lbm_cell(l, x, y, z);
            if (l->solid[c]) continue;
            double rho, u[3];
            cell_macro(l, c, &rho, u);
            const double u2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
            if (!(isfinite(rho) && rho > 0 && u2 < 1.0 / 3.0)) {
                if (c < bad) bad = c;
                break;
            }
        }
    }
    /* the first bad cell of the whole lattice (global x-fastest index) and its state */
    const int64_t plane = (int64_t)l->nx * l->ny;
    int x, y, z;
    int64_t g = INT64_MAX;
    if (bad != INT64_MAX) {
        cell_coords(l, bad, &x, &y, &z);
        g = x + (int64_t)l->nx * y + plane * (z + l->kz0);
    }
    if (l->zdist) sq_par_min_i64(&g, 1);
    if (g == INT64_MAX) return SQ_OK;
    x = (int)(g % l->nx);
    y = (int)((g / l->nx) % l->ny);
    z = (int)(g / plane);
    double rho = 0, u[3] = {0, 0, 0};
    const int owner = l->zdist ? l->plane_rank[z] : 0;
    if (!l->zdist || owner == sq_par_rank())
        cell_macro(l, sq__lbm_cell(l, x, y, z - l->kz0), &rho, u);
    if (l->zdist) {
        double v[4] = {rho, u[0], u[1], u[2]};
        sq_par_broadcast(v, sizeof v, owner);
        rho = v[0], u[0] = v[1], u[1] = v[2], u[2] = v[3];
    }
    return sq__fail(l->ctx, SQ_ERR_UNSTABLE, "lbm",
                    "step %lld: density %g, velocity (%g, %g, %g) l.u. at cell (%d, %d, %d): the "
                    "flow blew up (density must stay positive, speed below c_s = 0.577 l.u.); "
                    "lower dt_s (now %g s), the wind or the forcing, or raise the viscosity%s",
                    (long long)l->step, rho, u[0], u[1], u[2], x, y, z, l->units.dt,
                    l->collision == SQ_LBM_COLLISION_SMAGORINSKY
                        ? ""
                        : " (viscosity_m2s), or use collision = smagorinsky");
}

static void kernel_params(const sq_lbm *l, sq__lbm_kparams *p)
{
    const double tau = l->tau, lam = l->desc.trt_magic;
    const double d0 = tau - 0.5;
    p->omega_p = (float)(1.0 / tau);
    if (l->collision == SQ_LBM_COLLISION_BGK)
        p->omega_m = p->omega_p;
    else
        p->omega_m = (float)(d0 / (0.5 * d0 + lam));
    p->src = 1.0f - 0.5f * p->omega_m;
    for (int a = 0; a < 3; a++) p->g[a] = (float)l->g_step[a];
    p->d0 = (float)(3.0 * l->nu_lu);
    p->tau0 = (float)tau;
    p->smag_k = (float)(18.0 * l->desc.smagorinsky_c * l->desc.smagorinsky_c);
    p->magic = (float)lam;
    p->smagorinsky = l->collision == SQ_LBM_COLLISION_SMAGORINSKY;
}

sq_result sq_lbm_step(sq_lbm *l, int steps)
{
    if (!l) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_step: lbm is NULL");
    if (steps < 0)
        return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm", "steps = %d; must be >= 0", steps);
    for (int s = 0; s < steps; s++) {
        update_wind(l);                 /* gusts, ramp, drive, one-shot injection (§5.5) */
        ensure_boundaries(l);           /* faces: walls, free slip, inflow, outflow, periodic */
        sq__lbm_kparams p;
        kernel_params(l, &p);
        if (l->zdist) /* the same, the slab faces' fold overlapped (lbm_dist.c) */
            sq__lbm_dist_sweep(l, (int)(l->step & 1), &p);
        else
            sq__lbm_sweep(l, (int)(l->step & 1), &p); /* fused collide + stream, AA in place */
        l->step++;
        invalidate(l);
        if (l->step % l->desc.check_interval == 0) {
            const sq_result r = check_stability(l); /* SQ_ERR_UNSTABLE naming step and cell */
            if (r != SQ_OK) return r;
        }
    }
    return SQ_OK;
}

/* ---- fields and solids ------------------------------------------------------------------ */

sq_result sq_lbm_init_fields(sq_lbm *l, const float *density, const float *ux, const float *uy,
                             const float *uz)
{
    if (!l) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_init_fields: lbm is NULL");
    const int parity = (int)(l->step & 1);
    const double inv_u = 1.0 / l->units.u, inv_rho = 1.0 / l->units.rho;
    sq_result res = SQ_OK;
    /* the arrays are global: this slab's cells start at plane kz0 */
    int64_t idx = (int64_t)l->kz0 * l->nx * l->ny;
    for (int z = 0; z < l->nz && res == SQ_OK; z++)
        for (int y = 0; y < l->ny && res == SQ_OK; y++)
            for (int x = 0; x < l->nx; x++, idx++) {
                const int64_t c = sq__lbm_cell(l, x, y, z);
                if (l->solid[c]) continue;
                const double rho = density ? (double)density[idx] * inv_rho : 1.0;
                const double u[3] = {ux ? (double)ux[idx] * inv_u : 0.0,
                                     uy ? (double)uy[idx] * inv_u : 0.0,
                                     uz ? (double)uz[idx] * inv_u : 0.0};
                if (!(isfinite(rho) && rho > 0 && isfinite(u[0]) && isfinite(u[1]) &&
                      isfinite(u[2]))) {
                    res = sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm",
                                   "init_fields: cell (%d, %d, %d) has density %g kg/m3 and "
                                   "velocity (%g, %g, %g) m/s; density must be > 0 and all "
                                   "finite",
                                   x, y, z + l->kz0, rho * l->units.rho, u[0] * l->units.u,
                                   u[1] * l->units.u, u[2] * l->units.u);
                    break;
                }
                double feq[SQ_LBM_Q];
                /* the stored velocity is shifted by ∓g/2 (see cell_macro) */
                double us[3];
                for (int a = 0; a < 3; a++)
                    us[a] = u[a] - (parity == 0 ? 0.5 : -0.5) * l->g_step[a];
                sq__lbm_feq(rho, us, feq);
                sq__lbm_scatter(l, c, parity, feq);
            }
    /* a bad value in one slab stops every rank with its message */
    if (l->zdist) res = sq_par_agree(res);
    if (res != SQ_OK) return res;
    if (parity == 0) sq__lbm_prime_ghosts(l);
    invalidate(l);
    return SQ_OK;
}

bool sq_lbm_is_solid(const sq_lbm *l, int i, int j, int k)
{
    if (!l || i < 0 || j < 0 || k < 0 || i >= l->nx || j >= l->ny || k >= global_nz(l))
        return false;
    return sq__lbm_gsolid(l, i, j, k) != 0;
}

/* Density and velocity of the planes beyond this slab's faces, from the neighbouring slabs
 * (collective; see reinit_from_neighbours). */
void sq__lbm_dist_neighbour_planes(sq_lbm *l)
{
    const int64_t plane = (int64_t)l->nx * l->ny;
    double *snd = (double *)sq_alloc(l->ctx, (size_t)(8 * plane) * sizeof(double));
    if (!snd) return; /* the buffer keeps its last values; memory is checked at create */
    for (int s = 0; s < 2; s++) {
        const int z = s == 0 ? 0 : l->nz - 1;
        for (int y = 0; y < l->ny; y++)
            for (int x = 0; x < l->nx; x++) {
                double *m = snd + 4 * (s * plane + x + (int64_t)l->nx * y);
                cell_macro(l, sq__lbm_cell(l, x, y, z), &m[0], m + 1);
            }
    }
    const void *sb[2] = {snd, snd + 4 * plane};
    void *rb[2] = {l->nbr, l->nbr + 4 * plane};
    const size_t bytes[2] = {(size_t)(4 * plane) * sizeof(double),
                             (size_t)(4 * plane) * sizeof(double)};
    (void)sq_par_exchange_pair(l->znb, sb, bytes, rb, bytes);
    sq_free(l->ctx, snd);
}

/* Whether global plane k touches a plane of another slab (its cells' neighbours then come
 * from sq__lbm_dist_neighbour_planes). */
static bool near_slab_face(const sq_lbm *l, int k)
{
    if (!l->zdist) return false;
    const int n = l->nzg, me = l->plane_rank[k];
    const bool per = l->periodic[2];
    const int below = k > 0 ? k - 1 : per ? n - 1 : -1;
    const int above = k < n - 1 ? k + 1 : per ? 0 : -1;
    return (below >= 0 && l->plane_rank[below] != me) ||
           (above >= 0 && l->plane_rank[above] != me);
}

static void ensure_neighbour_planes(sq_lbm *l)
{
    if (l->nbr_valid) return;
    sq__lbm_dist_neighbour_planes(l);
    l->nbr_valid = true;
}

/* Equilibrium from the mean ρ, u of the neighbours whose flag is 0 (fluid before the edit).
 * Returns the cell's density and velocity (lattice units, as the views report them).
 * (x, y, z) is a cell of this slab; neighbours in other slabs come from l->nbr. */
static void reinit_from_neighbours(sq_lbm *l, int x, int y, int z, double *rho_out,
                                   double u_out[3])
{
    const int parity = (int)(l->step & 1);
    const int gnz = global_nz(l);
    const int64_t plane = (int64_t)l->nx * l->ny;
    double rho = 0, u[3] = {0, 0, 0};
    int n = 0;
    for (int i = 1; i < SQ_LBM_Q; i++) {
        const int qx = x + sq__lbm_c[i][0], qy = y + sq__lbm_c[i][1], qz = z + sq__lbm_c[i][2];
        const int qg = qz + l->kz0;
        if (qx < 0 || qy < 0 || qg < 0 || qx >= l->nx || qy >= l->ny || qg >= gnz) continue;
        if (sq__lbm_gsolid(l, qx, qy, qg) != 0) continue;
        double r, v[3];
        if (qz >= 0 && qz < l->nz) {
            cell_macro(l, sq__lbm_cell(l, qx, qy, qz), &r, v);
        } else {
            const double *m = l->nbr + 4 * ((qz < 0 ? 0 : plane) + qx + (int64_t)l->nx * qy);
            r = m[0], v[0] = m[1], v[1] = m[2], v[2] = m[3];
        }
        if (!(isfinite(r) && r > 0)) continue;
        rho += r;
        for (int a = 0; a < 3; a++) u[a] += v[a];
        n++;
    }
    if (n == 0) {
        rho = 1.0;
    } else {
        rho /= n;
        for (int a = 0; a < 3; a++) u[a] /= n;
    }
    *rho_out = rho;
    for (int a = 0; a < 3; a++) {
        u_out[a] = u[a];
        if (n > 0) u[a] -= (parity == 0 ? 0.5 : -0.5) * l->g_step[a];
    }
    double feq[SQ_LBM_Q];
    sq__lbm_feq(rho, u, feq);
    sq__lbm_scatter(l, sq__lbm_cell(l, x, y, z), parity, feq);
}

/* (x, y, z): a cell of this slab. */
static bool on_inflow_face(const sq_lbm *l, int x, int y, int z)
{
    const int p[3] = {x, y, z + l->kz0}, n[3] = {l->nx, l->ny, global_nz(l)};
    for (int a = 0; a < 3; a++) {
        if (p[a] == 0 && l->desc.bc[2 * a] == SQ_LBM_BC_INFLOW) return true;
        if (p[a] == n[a] - 1 && l->desc.bc[2 * a + 1] == SQ_LBM_BC_INFLOW) return true;
    }
    return false;
}

/* The flag of global cell (i, j, k) in this slab's padded array (its ghost planes too). */
static void set_local_flag(sq_lbm *l, int i, int j, int k, uint8_t v)
{
    const int zl = k - l->kz0;
    if (zl >= -1 && zl <= l->nz) l->solid[sq__lbm_cell(l, i, j, zl)] = v;
}

sq_result sq_lbm_set_solid(sq_lbm *l, int i, int j, int k, bool solid)
{
    if (!l) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_set_solid: lbm is NULL");
    const int gnz = global_nz(l);
    if (i < 0 || j < 0 || k < 0 || i >= l->nx || j >= l->ny || k >= gnz)
        return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "set_solid: cell (%d, %d, %d) is outside the lattice %dx%dx%d", i, j, k,
                        l->nx, l->ny, gnz);
    const bool was = sq__lbm_gsolid(l, i, j, k) != 0;
    if (was == solid) return SQ_OK;
    const int zl = k - l->kz0;
    const bool mine = zl >= 0 && zl < l->nz;
    /* a cell turning fluid next to another slab needs that slab's edge plane (collective:
     * every rank makes the same call and knows the global flags) */
    const bool near = near_slab_face(l, k);
    if (!solid && near) ensure_neighbour_planes(l);
    double rho = 0, u[3] = {0, 0, 0};
    if (mine) {
        const int64_t c = sq__lbm_cell(l, i, j, zl);
        const int64_t r = j + (int64_t)zl * l->ny;
        if (solid) {
            l->solid[c] = 1;
            l->row_solids[r]++;
        } else {
            reinit_from_neighbours(l, i, j, zl, &rho, u);
            l->solid[c] = 0;
            l->row_solids[r]--;
        }
        update_row_class(l, j, zl);
        if (on_inflow_face(l, i, j, zl)) l->inflow_dirty = true;
    }
    if (l->zdist) {
        l->gsolid[i + (int64_t)l->nx * (j + (int64_t)l->ny * k)] = solid ? 1 : 0;
        set_local_flag(l, i, j, k, solid ? 1 : 0);
        l->inflow_dirty = true; /* an inflow column may pass through this cell */
        if (near) l->nbr_valid = false;
    }
    /* the density/velocity views stay valid: only this cell changed (0 when solid, the
     * re-initialised equilibrium when fluid); boundaries and u* are redone */
    l->bc_valid = false;
    l->ustar_valid = false;
    if (l->zdist && mine && l->lmacro_valid) { /* this slab's views, as the whole's below */
        const int64_t n = (int64_t)l->nx * l->ny * l->nz;
        const int64_t o = i + (int64_t)l->nx * (j + (int64_t)l->ny * zl);
        l->lmacro[o] = (float)(rho * l->units.rho);
        for (int a = 0; a < 3; a++) l->lmacro[(a + 1) * n + o] = (float)(u[a] * l->units.u);
    }
    if (l->macro_valid) {
        if (l->zdist && !solid) { /* every rank's copy of the views learns the new state */
            double v[4] = {rho, u[0], u[1], u[2]};
            sq_par_broadcast(v, sizeof v, l->plane_rank[k]);
            rho = v[0], u[0] = v[1], u[1] = v[2], u[2] = v[3];
        }
        const int64_t n = (int64_t)l->nx * l->ny * gnz;
        const int64_t o = i + (int64_t)l->nx * (j + (int64_t)l->ny * k);
        l->macro[o] = (float)(rho * l->units.rho);
        for (int a = 0; a < 3; a++) l->macro[(a + 1) * n + o] = (float)(u[a] * l->units.u);
    }
    return SQ_OK;
}

sq_result sq_lbm_set_solid_mask(sq_lbm *l, const uint8_t *mask)
{
    if (!l || !mask)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_set_solid_mask: NULL argument");
    /* pass 1: new solids set, cells turning fluid marked 2 (still not fluid for their
     * neighbours' averages); pass 2: those re-initialised; pass 3: marks cleared. The mask is
     * global; a slab applies its planes (and keeps the whole lattice's flags in gsolid). */
    int64_t nfree = 0;
    if (l->zdist) {
        int64_t idx = 0;
        for (int z = 0; z < l->nzg; z++)
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++, idx++) {
                    const bool want = mask[idx] != 0, was = l->gsolid[idx] != 0;
                    if (want && !was) l->gsolid[idx] = 1;
                    if (!want && was) {
                        l->gsolid[idx] = 2;
                        nfree++;
                    }
                    set_local_flag(l, x, y, z, l->gsolid[idx]);
                }
        if (nfree > 0) {
            l->nbr_valid = false;
            ensure_neighbour_planes(l);
        }
    } else {
        int64_t idx = 0;
        for (int z = 0; z < l->nz; z++)
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++, idx++) {
                    const int64_t c = sq__lbm_cell(l, x, y, z);
                    const bool want = mask[idx] != 0, was = l->solid[c] != 0;
                    if (want && !was) l->solid[c] = 1;
                    if (!want && was) {
                        l->solid[c] = 2;
                        nfree++;
                    }
                }
    }
    if (nfree > 0) {
        for (int z = 0; z < l->nz; z++)
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++)
                    if (l->solid[sq__lbm_cell(l, x, y, z)] == 2) {
                        double rho, u[3];
                        reinit_from_neighbours(l, x, y, z, &rho, u);
                    }
        for (int z = -1; z <= l->nz; z++) {
            if ((z < 0 || z >= l->nz) && !l->zdist) continue;
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++) {
                    uint8_t *s = &l->solid[sq__lbm_cell(l, x, y, z)];
                    if (*s == 2) *s = 0;
                }
        }
        if (l->zdist) {
            const int64_t n = (int64_t)l->nx * l->ny * l->nzg;
            for (int64_t c = 0; c < n; c++)
                if (l->gsolid[c] == 2) l->gsolid[c] = 0;
        }
    }
    for (int z = 0; z < l->nz; z++)
        for (int y = 0; y < l->ny; y++) {
            int32_t n = 0;
            const int64_t c0 = sq__lbm_cell(l, 0, y, z);
            for (int x = 0; x < l->nx; x++) n += l->solid[c0 + x];
            l->row_solids[y + (int64_t)z * l->ny] = n;
            update_row_class(l, y, z);
        }
    l->inflow_dirty = true;
    invalidate(l);
    return SQ_OK;
}

/* ---- views ------------------------------------------------------------------------------ */

static sq_field_view interior_view(const sq_lbm *l, const float *data)
{
    sq_field_view v;
    v.data = data;
    v.n = l->desc.cells;
    v.sx = 1;
    v.sy = l->nx;
    v.sz = (ptrdiff_t)l->nx * l->ny;
    return v;
}

/* This slab's views (the whole lattice's when it is not split). */
static void compute_local(sq_lbm *l)
{
    ensure_boundaries(l);
    const int64_t n = (int64_t)l->nx * l->ny * l->nz;
    const int parity = (int)(l->step & 1);
    const float h = parity == 0 ? 0.5f : -0.5f;
    const float gh[3] = {h * (float)l->g_step[0], h * (float)l->g_step[1],
                         h * (float)l->g_step[2]};
    float *const m = l->zdist ? l->lmacro : l->macro;
    sq__lbm_macro(l, parity, gh, (float)l->units.rho, (float)l->units.u, m, m + n, m + 2 * n,
                  m + 3 * n);
    l->lmacro_valid = true;
    if (!l->zdist) l->macro_valid = true;
}

/* The views of the whole lattice: this slab's (computed, or as sq_lbm_set_solid left them),
 * then gathered on every rank. */
static void compute_macro(sq_lbm *l)
{
    if (!l->lmacro_valid) compute_local(l);
    if (l->zdist) sq__lbm_dist_gather_macro(l);
    l->macro_valid = true;
}

sq_result sq_lbm_get_views(sq_lbm *l, sq_lbm_views *out)
{
    if (!l || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_get_views: NULL argument");
    if (!l->macro_valid) compute_macro(l);
    const int64_t n = (int64_t)l->nx * l->ny * global_nz(l);
    out->density = interior_view(l, l->macro);
    for (int a = 0; a < 3; a++) out->u[a] = interior_view(l, l->macro + (a + 1) * n);
    return SQ_OK;
}

sq_result sq_lbm_get_slab_views(sq_lbm *l, sq_lbm_views *out, int *z0)
{
    if (!l || !out || !z0)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_get_slab_views: NULL argument");
    if (!l->lmacro_valid) compute_local(l);
    const int64_t n = (int64_t)l->nx * l->ny * l->nz;
    const float *m = l->zdist ? l->lmacro : l->macro;
    out->density = interior_view(l, m);
    for (int a = 0; a < 3; a++) out->u[a] = interior_view(l, m + (a + 1) * n);
    out->density.n.nz = l->nz;
    for (int a = 0; a < 3; a++) out->u[a].n.nz = l->nz;
    *z0 = l->kz0;
    return SQ_OK;
}

/* u* of global cell (x, y, z) from the global velocity views u (see
 * sq_lbm_get_friction_velocity): the first wall among the neighbours below, at the sides,
 * above; 0 in solid cells and away from walls. k = κ / ln((Δx/2 + z0)/z0). */
static float friction_velocity_cell(const sq_lbm *l, const float *const u[3], int64_t o0,
                                    float k, int x, int y, int z)
{
    /* neighbour order: below first, then the sides, then above */
    static const int nb[6][3] = {{0, 0, -1}, {-1, 0, 0}, {1, 0, 0},
                                 {0, -1, 0}, {0, 1, 0},  {0, 0, 1}};
    static const int face_of[6] = {SQ_LBM_FACE_ZMIN, SQ_LBM_FACE_XMIN, SQ_LBM_FACE_XMAX,
                                   SQ_LBM_FACE_YMIN, SQ_LBM_FACE_YMAX, SQ_LBM_FACE_ZMAX};
    if (sq__lbm_gsolid(l, x, y, z)) return 0.0f;
    const int gnz = global_nz(l);
    const int64_t o = x + (int64_t)l->nx * (y + (int64_t)l->ny * z) - o0;
    for (int m = 0; m < 6; m++) {
        const int qx = x + nb[m][0], qy = y + nb[m][1], qz = z + nb[m][2];
        const bool outside =
            qx < 0 || qy < 0 || qz < 0 || qx >= l->nx || qy >= l->ny || qz >= gnz;
        const bool wall = outside ? l->desc.bc[face_of[m]] == SQ_LBM_BC_WALL
                                  : sq__lbm_gsolid(l, qx, qy, qz) != 0;
        if (!wall) continue;
        /* tangential velocity: drop the component along the normal */
        float v[3] = {u[0][o], u[1][o], u[2][o]};
        for (int a = 0; a < 3; a++)
            if (nb[m][a] != 0) v[a] = 0.0f;
        return k * sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    }
    return 0.0f;
}

static float friction_factor(const sq_lbm *l)
{
    const double z0 = l->desc.wind.roughness_m;
    return (float)(LBM_KAPPA / log((0.5 * l->units.dx + z0) / z0));
}

sq_result sq_lbm_get_friction_velocity(sq_lbm *l, sq_field_view *out)
{
    if (!l || !out)
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_get_friction_velocity: NULL argument");
    if (!l->ustar_valid) {
        if (!l->macro_valid) compute_macro(l);
        const int gnz = global_nz(l);
        const int64_t n = (int64_t)l->nx * l->ny * gnz;
        const float *const u[3] = {l->macro + n, l->macro + 2 * n, l->macro + 3 * n};
        const float k = friction_factor(l);
        const int nt = sq_context_threads(l->ctx);
        SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(want_parallel(l)))
        for (int z = 0; z < gnz; z++)
            for (int y = 0; y < l->ny; y++)
                for (int x = 0; x < l->nx; x++)
                    l->ustar[x + (int64_t)l->nx * (y + (int64_t)l->ny * z)] =
                        friction_velocity_cell(l, u, 0, k, x, y, z);
        l->ustar_valid = true;
    }
    *out = interior_view(l, l->ustar);
    return SQ_OK;
}

sq_result sq_lbm_get_friction_velocity_at(sq_lbm *l, int64_t count, const int64_t *cells,
                                          float *out)
{
    if (!l || count < 0 || (count > 0 && (!cells || !out)))
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "sq_lbm_get_friction_velocity_at: NULL argument or count < 0");
    if (!l->macro_valid) compute_macro(l);
    const int64_t n = (int64_t)l->nx * l->ny * global_nz(l);
    const float *const u[3] = {l->macro + n, l->macro + 2 * n, l->macro + 3 * n};
    const float k = friction_factor(l);
    const int64_t sxy = (int64_t)l->nx * l->ny;
    for (int64_t q = 0; q < count; q++) {
        const int64_t c = cells[q];
        if (c < 0 || c >= n)
            return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "get_friction_velocity_at: cell index %lld is outside the lattice "
                            "(0..%lld)",
                            (long long)c, (long long)(n - 1));
        const int z = (int)(c / sxy), y = (int)((c % sxy) / l->nx), x = (int)(c % l->nx);
        out[q] = friction_velocity_cell(l, u, 0, k, x, y, z);
    }
    return SQ_OK;
}

sq_result sq_lbm_get_slab_friction_velocity_at(sq_lbm *l, int64_t count, const int64_t *cells,
                                               float *out)
{
    if (!l || count < 0 || (count > 0 && (!cells || !out)))
        return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_get_slab_friction_velocity_at: NULL "
                                                 "argument or count < 0");
    if (!l->lmacro_valid) compute_local(l);
    const int64_t sxy = (int64_t)l->nx * l->ny, n = sxy * l->nz;
    const int64_t c0 = sxy * l->kz0; /* the slab's first cell */
    const float *m = l->zdist ? l->lmacro : l->macro;
    const float *const u[3] = {m + n, m + 2 * n, m + 3 * n};
    const float k = friction_factor(l);
    for (int64_t q = 0; q < count; q++) {
        const int64_t c = cells[q];
        if (c < c0 || c >= c0 + n)
            return sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "get_slab_friction_velocity_at: cell index %lld is outside this "
                            "rank's slab (%lld..%lld)",
                            (long long)c, (long long)c0, (long long)(c0 + n - 1));
        const int z = (int)(c / sxy), y = (int)((c % sxy) / l->nx), x = (int)(c % l->nx);
        out[q] = friction_velocity_cell(l, u, c0, k, x, y, z);
    }
    return SQ_OK;
}

sq_result sq_lbm_get_totals(sq_lbm *l, sq_lbm_totals *out)
{
    if (!l || !out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_get_totals: NULL argument");
    ensure_boundaries(l);
    const int parity = (int)(l->step & 1);
    /* per-z partial sums, added in fixed order (result independent of the thread count and,
     * the planes being gathered in order, of the rank count) */
    const int nz = l->nz, gnz = global_nz(l);
    double *part = (double *)sq_alloc_zero(l->ctx, (size_t)(nz + gnz) * 5 * sizeof(double));
    if (!part) return SQ_ERR_OUT_OF_MEMORY;
    const int nt = sq_context_threads(l->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(want_parallel(l)))
    for (int z = 0; z < nz; z++) {
        double m = 0, p[3] = {0, 0, 0}, nf = 0;
        for (int y = 0; y < l->ny; y++)
            for (int x = 0; x < l->nx; x++) {
                const int64_t c = sq__lbm_cell(l, x, y, z);
                if (!l->solid[c]) {
                    double f[SQ_LBM_Q];
                    sq__lbm_gather(l, c, parity, f);
                    for (int i = 0; i < SQ_LBM_Q; i++) {
                        m += f[i];
                        for (int a = 0; a < 3; a++) p[a] += sq__lbm_c[i][a] * f[i];
                    }
                    nf += 1;
                } else {
                    /* populations in flight into this solid cell from fluid neighbours */
                    for (int i = 1; i < SQ_LBM_Q; i++) {
                        const int qx = x - sq__lbm_c[i][0], qy = y - sq__lbm_c[i][1];
                        const int qz = z + l->kz0 - sq__lbm_c[i][2];
                        if (qx < 0 || qy < 0 || qz < 0 || qx >= l->nx || qy >= l->ny ||
                            qz >= gnz)
                            continue;
                        if (sq__lbm_gsolid(l, qx, qy, qz)) continue;
                        const double fi = (double)l->f[(int64_t)i * l->stride + c] + sq__lbm_w[i];
                        m += fi;
                        for (int a = 0; a < 3; a++) p[a] += sq__lbm_c[i][a] * fi;
                    }
                }
            }
        part[5 * z + 0] = m;
        part[5 * z + 1] = p[0];
        part[5 * z + 2] = p[1];
        part[5 * z + 3] = p[2];
        part[5 * z + 4] = nf;
    }
    double *all = part;
    if (l->zdist) {
        all = part + 5 * nz;
        int64_t *cnt = (int64_t *)sq_alloc(l->ctx, (size_t)l->nranks * sizeof(int64_t));
        if (!cnt) {
            sq_free(l->ctx, part);
            return SQ_ERR_OUT_OF_MEMORY;
        }
        for (int q = 0; q < l->nranks; q++)
            cnt[q] = 5 * l->rank_cells[q] / ((int64_t)l->nx * l->ny); /* 5 values per plane */
        (void)sq_par_allgather_f64(part, cnt, all);
        sq_free(l->ctx, cnt);
    }
    double m = 0, p[3] = {0, 0, 0}, nf = 0;
    for (int z = 0; z < gnz; z++) {
        m += all[5 * z];
        for (int a = 0; a < 3; a++) p[a] += all[5 * z + 1 + a];
        nf += all[5 * z + 4];
    }
    sq_free(l->ctx, part);
    const double vol = l->units.dx * l->units.dx * l->units.dx;
    out->mass_kg = m * l->units.rho * vol;
    for (int a = 0; a < 3; a++) out->momentum_kgmps[a] = p[a] * l->units.rho * vol * l->units.u;
    out->fluid_cells = (int64_t)nf;
    return SQ_OK;
}
