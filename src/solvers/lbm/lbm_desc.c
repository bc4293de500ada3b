/* lbm_desc.c — D3Q15 solver desc: defaults, validation (messages name field, value and rule),
 * memory cost, and the one place where SI meets lattice units (SPEC §5.3: τ = ½ + 3νΔt/Δx²
 * must exceed ½; wind speeds map to U Δt/Δx and must stay well below the lattice sound speed
 * c_s = 1/√3). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "lbm_internal.h"

#define LBM_MACH_REFUSE 0.3   /* refuse above this Mach number (compressibility error ~Ma²) */
#define LBM_U_WARN 0.1        /* warn above this lattice velocity (Ma 0.17, SPEC §5.3) */
#define LBM_U_AUTO 0.08       /* automatic Δt puts the fastest wind here */

static const char *const face_names[6] = {"XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"};

const char *sq_lbm_collision_name(sq_lbm_collision c)
{
    switch (c) {
    case SQ_LBM_COLLISION_DEFAULT: return "default";
    case SQ_LBM_COLLISION_BGK: return "bgk";
    case SQ_LBM_COLLISION_TRT: return "trt";
    case SQ_LBM_COLLISION_SMAGORINSKY: return "smagorinsky";
    }
    return "?";
}

const char *sq_lbm_bc_name(sq_lbm_bc bc)
{
    switch (bc) {
    case SQ_LBM_BC_DEFAULT: return "default";
    case SQ_LBM_BC_PERIODIC: return "periodic";
    case SQ_LBM_BC_WALL: return "wall";
    case SQ_LBM_BC_FREE_SLIP: return "free_slip";
    case SQ_LBM_BC_INFLOW: return "inflow";
    case SQ_LBM_BC_OUTFLOW: return "outflow";
    case SQ_LBM_BC_RECYCLE: return "recycle";
    }
    return "?";
}

static bool is_wrap(sq_lbm_bc b) { return b == SQ_LBM_BC_PERIODIC || b == SQ_LBM_BC_RECYCLE; }

sq_lbm_desc sq_lbm_desc_resolve(const sq_lbm_desc *desc)
{
    sq_lbm_desc d;
    memset(&d, 0, sizeof d);
    if (desc) d = *desc;
    if (d.cell_size_m == 0) d.cell_size_m = 1.0;
    if (d.viscosity_m2s == 0) d.viscosity_m2s = 1.5e-5;
    if (d.air_density_kgm3 == 0) d.air_density_kgm3 = 1.225;
    if (d.collision == SQ_LBM_COLLISION_DEFAULT) d.collision = SQ_LBM_COLLISION_SMAGORINSKY;
    if (d.smagorinsky_c == 0) d.smagorinsky_c = 0.16;
    if (d.trt_magic == 0) d.trt_magic = 3.0 / 16.0;
    bool inflow = false, recycle = false;
    for (int f = 0; f < 6; f++) {
        if (d.bc[f] == SQ_LBM_BC_DEFAULT) d.bc[f] = SQ_LBM_BC_PERIODIC;
        inflow |= d.bc[f] == SQ_LBM_BC_INFLOW;
        recycle |= d.bc[f] == SQ_LBM_BC_RECYCLE;
    }
    if (d.wind.ref_height_m == 0) d.wind.ref_height_m = 10.0;
    if (d.wind.roughness_m == 0) d.wind.roughness_m = 0.01;
    if (d.wind.gust_period_s == 0) d.wind.gust_period_s = 3.0;
    if (d.wind.drive == SQ_LBM_DRIVE_DEFAULT)
        d.wind.drive = inflow    ? SQ_LBM_DRIVE_INFLOW
                       : recycle ? SQ_LBM_DRIVE_BODY_FORCE
                                 : SQ_LBM_DRIVE_NONE;
    if (d.check_interval == 0) d.check_interval = 64;
    return d;
}

double sq__lbm_log_shape(double h_m, double z0_m, double zref_m)
{
    if (h_m < 0) h_m = 0;
    return log((h_m + z0_m) / z0_m) / log((zref_m + z0_m) / z0_m);
}

double sq__lbm_max_wind_mps(const sq_lbm_desc *d)
{
    double u = d->max_wind_mps;
    if (u <= 0) {
        const double top = d->cells.nz * d->cell_size_m;
        double shape = sq__lbm_log_shape(top, d->wind.roughness_m, d->wind.ref_height_m);
        if (shape < 1) shape = 1;
        u = d->wind.speed_mps * (1.0 + d->wind.beaufort / 20.0) * shape;
    }
    for (int f = 0; f < 6; f++) {
        const double *w = d->wall_velocity_mps[f];
        const double s = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (d->bc[f] == SQ_LBM_BC_WALL && s > u) u = s;
    }
    return u;
}

double sq_lbm_max_wind_mps(const sq_lbm_desc *desc)
{
    if (!desc) return 0.0;
    const sq_lbm_desc d = sq_lbm_desc_resolve(desc);
    return sq__lbm_max_wind_mps(&d);
}

double sq_lbm_time_step_s(const sq_lbm_desc *desc)
{
    if (!desc) return 0.0;
    const sq_lbm_desc d = sq_lbm_desc_resolve(desc);
    if (d.dt_s > 0) return d.dt_s;
    const double umax = sq__lbm_max_wind_mps(&d);
    return LBM_U_AUTO * d.cell_size_m / (umax > 0 ? umax : 10.0);
}

double sq_lbm_mach_limit(void) { return LBM_MACH_REFUSE; }

sq_result sq_lbm_desc_validate(sq_context *ctx, const sq_lbm_desc *desc)
{
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "sq_lbm_desc_validate: desc is NULL");
    const sq_lbm_desc d = sq_lbm_desc_resolve(desc);
    sq_result r = sq__lbm_validate(ctx, &d);
    if (r != SQ_OK) return r;
    sq__lbm_units u;
    double tau;
    return sq__lbm_units_make(ctx, &d, &u, &tau);
}

static bool finite_nonneg(double v) { return isfinite(v) && v >= 0; }

sq_result sq__lbm_validate(sq_context *ctx, const sq_lbm_desc *d)
{
    const sq_dims n = d->cells;
    if (n.nx < 1 || n.ny < 1 || n.nz < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "cells = %dx%dx%d; every axis needs at least 1 cell", n.nx, n.ny, n.nz);
    const double padded = (double)(n.nx + 2) * (n.ny + 2) * (n.nz + 2);
    if (padded > 2147483647.0)
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, "lbm",
                        "cells = %dx%dx%d; the padded lattice may hold at most 2^31-1 cells",
                        n.nx, n.ny, n.nz);
    if (!(isfinite(d->cell_size_m) && d->cell_size_m > 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "cell_size_m = %g; must be > 0",
                        d->cell_size_m);
    if (!finite_nonneg(d->dt_s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "dt_s = %g; must be > 0 (or 0 to choose it from the wind)", d->dt_s);
    if (!isfinite(d->viscosity_m2s))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "viscosity_m2s = %g; must be finite",
                        d->viscosity_m2s);
    if (!isfinite(d->tau) || d->tau < 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "tau = %g; must be > 0.5 (BGK is unstable at zero viscosity)", d->tau);
    if (!(isfinite(d->air_density_kgm3) && d->air_density_kgm3 > 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "air_density_kgm3 = %g; must be > 0",
                        d->air_density_kgm3);
    if (!finite_nonneg(d->max_wind_mps))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "max_wind_mps = %g; must be >= 0",
                        d->max_wind_mps);
    if (d->collision < SQ_LBM_COLLISION_DEFAULT || d->collision > SQ_LBM_COLLISION_SMAGORINSKY)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "collision = %d; must be bgk, trt or smagorinsky", (int)d->collision);
    if (!(isfinite(d->smagorinsky_c) && d->smagorinsky_c > 0 && d->smagorinsky_c <= 1))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "smagorinsky_c = %g; must be in (0, 1]",
                        d->smagorinsky_c);
    if (!(isfinite(d->trt_magic) && d->trt_magic > 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "trt_magic = %g; must be > 0",
                        d->trt_magic);
    for (int f = 0; f < 6; f++) {
        if (d->bc[f] < SQ_LBM_BC_DEFAULT || d->bc[f] > SQ_LBM_BC_RECYCLE)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "bc[%s] = %d; unknown boundary kind",
                            face_names[f], (int)d->bc[f]);
        const double *w = d->wall_velocity_mps[f];
        if (!(isfinite(w[0]) && isfinite(w[1]) && isfinite(w[2])))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "wall_velocity_mps[%s] is not finite", face_names[f]);
        if (w[f / 2] != 0)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "wall_velocity_mps[%s] has a normal component %g m/s; a wall may "
                            "only move along itself",
                            face_names[f], w[f / 2]);
        if ((w[0] != 0 || w[1] != 0 || w[2] != 0) && d->bc[f] != SQ_LBM_BC_WALL)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "wall_velocity_mps[%s] is set but bc[%s] = %s; only WALL faces move",
                            face_names[f], face_names[f], sq_lbm_bc_name(d->bc[f]));
    }
    for (int a = 0; a < 3; a++) {
        const bool w0 = is_wrap(d->bc[2 * a]), w1 = is_wrap(d->bc[2 * a + 1]);
        if (w0 != w1)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "bc[%s] = %s but bc[%s] = %s; periodic/recycle faces come in pairs",
                            face_names[2 * a], sq_lbm_bc_name(d->bc[2 * a]),
                            face_names[2 * a + 1], sq_lbm_bc_name(d->bc[2 * a + 1]));
    }
    for (int a = 0; a < 3; a++)
        if (!isfinite(d->body_accel_mps2[a]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "body_accel_mps2[%d] is not finite",
                            a);
    const sq_lbm_wind_desc *w = &d->wind;
    if (!finite_nonneg(w->speed_mps))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.speed_mps = %g; must be >= 0",
                        w->speed_mps);
    if (!isfinite(w->heading_deg))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.heading_deg = %g; must be finite",
                        w->heading_deg);
    if (!(isfinite(w->ref_height_m) && w->ref_height_m > 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.ref_height_m = %g; must be > 0",
                        w->ref_height_m);
    if (!(isfinite(w->roughness_m) && w->roughness_m > 0 && w->roughness_m < w->ref_height_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "wind.roughness_m = %g; must be > 0 and below ref_height_m = %g",
                        w->roughness_m, w->ref_height_m);
    if (!(isfinite(w->beaufort) && w->beaufort >= 0 && w->beaufort <= 12))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.beaufort = %g; must be in [0, 12]",
                        w->beaufort);
    if (!(isfinite(w->gust_period_s) && w->gust_period_s > 0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.gust_period_s = %g; must be > 0",
                        w->gust_period_s);
    if (!finite_nonneg(w->ramp_mps2))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "wind.ramp_mps2 = %g; must be >= 0 (0 = instantaneous set-up)",
                        w->ramp_mps2);
    if (w->drive < SQ_LBM_DRIVE_DEFAULT || w->drive > SQ_LBM_DRIVE_BODY_FORCE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm", "wind.drive = %d; unknown drive",
                        (int)w->drive);
    if (w->drive == SQ_LBM_DRIVE_INFLOW) {
        bool any = false;
        for (int f = 0; f < 6; f++) any |= d->bc[f] == SQ_LBM_BC_INFLOW;
        if (!any)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "wind.drive = inflow but no face has bc = inflow");
    }
    if (d->check_interval < 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "check_interval = %d; must be >= 1 (0 = default 64)", d->check_interval);
    return SQ_OK;
}

sq_result sq__lbm_check_mach(sq_context *ctx, const sq__lbm_units *u, double speed_mps,
                             const char *what)
{
    const double ulu = speed_mps / u->u;
    const double mach = ulu * sqrt(3.0);
    if (mach > LBM_MACH_REFUSE) {
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                        "%s %.3g m/s is %.3g lattice units (Mach %.2f > %.1f) with cell_size_m = "
                        "%g and dt_s = %g: lower dt_s to at most %.3g s, raise cell_size_m to at "
                        "least %.3g m, or lower the wind",
                        what, speed_mps, ulu, mach, LBM_MACH_REFUSE, u->dx, u->dt,
                        LBM_U_WARN * u->dx / speed_mps, speed_mps * u->dt / LBM_U_WARN);
    }
    if (ulu > LBM_U_WARN)
        sq_log(ctx, SQ_LOG_WARN, "lbm",
               "%s %.3g m/s is %.3g lattice units (Mach %.2f): above %.1f l.u. the "
               "compressibility error grows (~Ma^2); consider dt_s <= %.3g s",
               what, speed_mps, ulu, mach, LBM_U_WARN, LBM_U_WARN * u->dx / speed_mps);
    return SQ_OK;
}

sq_result sq__lbm_units_make(sq_context *ctx, const sq_lbm_desc *d, sq__lbm_units *u, double *tau)
{
    const double umax = sq__lbm_max_wind_mps(d);
    u->dx = d->cell_size_m;
    u->dt = d->dt_s;
    if (u->dt == 0) u->dt = LBM_U_AUTO * u->dx / (umax > 0 ? umax : 10.0);
    u->rho = d->air_density_kgm3;
    u->u = u->dx / u->dt;
    u->nu = u->dx * u->dx / u->dt;
    u->a = u->dx / (u->dt * u->dt);
    double t;
    if (d->tau > 0) {
        t = d->tau;
        if (!(t > 0.5))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "tau = %g; must be > 0.5 (BGK is unstable at zero viscosity)", t);
    } else {
        t = 0.5 + 3.0 * d->viscosity_m2s / u->nu;
        if (!(t > 0.5))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "lbm",
                            "viscosity_m2s = %g with cell_size_m = %g and dt_s = %g gives tau = "
                            "%.9g; must be > 0.5 (BGK is unstable at zero viscosity)",
                            d->viscosity_m2s, u->dx, u->dt, t);
    }
    if (t < 0.505 && d->collision != SQ_LBM_COLLISION_SMAGORINSKY)
        sq_log(ctx, SQ_LOG_WARN, "lbm",
               "tau = %.6g is very close to 0.5: %s is only stable at tiny Mach numbers; use "
               "collision = smagorinsky for high-Reynolds wind",
               t, sq_lbm_collision_name(d->collision));
    *tau = t;
    if (umax > 0) {
        const sq_result r = sq__lbm_check_mach(ctx, u, umax, "the wind");
        if (r != SQ_OK && d->dt_s > 0) { /* a step the caller chose: name it first */
            char why[768];
            snprintf(why, sizeof why, "%s", sq_last_error());
            return sq__fail(ctx, r, "lbm", "dt_s = %g s: %s", d->dt_s, why);
        }
        return r;
    }
    return SQ_OK;
}

uint64_t sq_lbm_memory_bytes(const sq_lbm_desc *desc)
{
    if (!desc) return 0;
    const sq_lbm_desc d = sq_lbm_desc_resolve(desc);
    const sq_dims n = d.cells;
    if (n.nx < 1 || n.ny < 1 || n.nz < 1) return 0;
    const uint64_t padded = (uint64_t)(n.nx + 2) * (uint64_t)(n.ny + 2) * (uint64_t)(n.nz + 2);
    const uint64_t stride = (padded + 15) / 16 * 16;
    const uint64_t cells = (uint64_t)n.nx * (uint64_t)n.ny * (uint64_t)n.nz;
    const uint64_t rows = (uint64_t)n.ny * (uint64_t)n.nz;
    /* boundary links: at most 5 per cell on each non-periodic face (D3Q15 has 5 velocities
     * crossing a face) */
    uint64_t links = 0, inflow = 0;
    const uint64_t area[3] = {(uint64_t)n.ny * n.nz, (uint64_t)n.nx * n.nz,
                              (uint64_t)n.nx * n.ny};
    for (int f = 0; f < 6; f++) {
        if (!is_wrap(d.bc[f])) links += 5 * area[f / 2];
        if (d.bc[f] == SQ_LBM_BC_INFLOW) inflow += area[f / 2];
    }
    return (uint64_t)SQ_LBM_Q * stride * sizeof(float) /* populations */
           + padded                                   /* solid flags */
           + rows * (1 + sizeof(int32_t))             /* row classes and counts */
           + cells * 4 * sizeof(float)                /* density + velocity views */
           + cells * sizeof(float)                    /* friction velocity view */
           + links * sizeof(sq__lbm_link) + inflow * 8 /* inflow cell, shape */
           + sizeof(struct sq_lbm);
}
