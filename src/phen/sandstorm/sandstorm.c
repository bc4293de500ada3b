/* sandstorm.c — lifecycle and the step recipe of the sandstorm (S0 §2.5.2 / Fig. 2.9, as
 * corrected in SPEC §1.11): wind stages on the grid solver, then dust emission, transport,
 * settling and deposition, with the dust budget kept every step. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sandstorm_internal.h"
#include "squall/par.h"
#include "squall/rng.h"

/* ---- optics of the size bins -------------------------------------------------------------- */
static sq_result build_optics(sq_sandstorm *s)
{
    sq_lognormal ln;
    sq_result r = sq_lognormal_make(s->d.median_radius_m, s->d.sigma_g, &ln);
    if (r != SQ_OK) return sq__fail(s->ctx, r, "sandstorm", "%s", "invalid size distribution");
    r = sq_lognormal_bins(&ln, s->nbins, 0, 0, s->bins);
    if (r != SQ_OK) return sq__fail(s->ctx, r, "sandstorm", "size bins: %s", "failed");
    const double wl[4] = {650e-9, 550e-9, 450e-9, 550e-9};
    for (int b = 0; b < s->nbins; b++) {
        s->w_settle[b] = sq_dust_terminal_speed(s->bins[b].radius_m, s->d.grain_density_kg_m3,
                                                SQ_SAND_AIR_DENSITY, SQ_SAND_AIR_VISCOSITY);
        for (int c = 0; c < 4; c++) {
            sq_bulk_optics_desc od;
            memset(&od, 0, sizeof od);
            od.size = ln;
            od.wavelength_m = wl[c];
            od.n_real = s->d.n_real;
            od.n_imag = s->d.n_real > 0.0 ? s->d.n_imag : 0.0;
            od.density_kg_m3 = s->d.grain_density_kg_m3;
            od.r_min_m = s->bins[b].r_lo_m;
            od.r_max_m = s->bins[b].r_hi_m;
            od.nodes = 200;
            sq_bulk_optics bo;
            r = sq_bulk_optics_compute(&od, &bo);
            if (r != SQ_OK) return sq__fail(s->ctx, r, "sandstorm", "optics: %s", sq_last_error());
            s->k_ext[b][c] = bo.mass_extinction_m2_per_kg;
            s->albedo_b[b][c] = bo.single_scattering_albedo;
        }
    }
    /* drawable optics for the emitted composition (bin mass fractions) */
    double kG = 0.0;
    for (int b = 0; b < s->nbins; b++) kG += s->bins[b].mass_fraction * s->k_ext[b][1];
    s->k_ext_total_550 = 0.0;
    for (int b = 0; b < s->nbins; b++) s->k_ext_total_550 += s->bins[b].mass_fraction * s->k_ext[b][3];
    /* the phase function's asymmetry: irregular dust, not Mie spheres (see the constants) */
    const double g_ns[3] = {SQ_SAND_G_DUST_650, SQ_SAND_G_DUST_550, SQ_SAND_G_DUST_450};
    for (int c = 0; c < 3; c++) {
        double ke = 0, ks = 0;
        for (int b = 0; b < s->nbins; b++) {
            double f = s->bins[b].mass_fraction;
            ke += f * s->k_ext[b][c];
            ks += f * s->k_ext[b][c] * s->albedo_b[b][c];
        }
        s->sigma_rel[c] = (float)(ke / kG);
        s->albedo[c] = (float)(ks / ke);
        s->g[c] = (float)g_ns[c];
    }
    return SQ_OK;
}

/* ---- wind and temperature initialisation (S0 eqs 2.18–2.20, 2.35; SPEC §1.6) -------------- */
static double level_value(const float *amp, int count, double zfrac)
{
    if (count <= 0) return 0.0;
    if (count == 1) return amp[0];
    double x = zfrac * (count - 1);
    if (x <= 0) return amp[0];
    if (x >= count - 1) return amp[count - 1];
    int i = (int)x;
    double t = x - i;
    return (double)amp[i] * (1 - t) + (double)amp[i + 1] * t;
}

/* The pressure perturbation P'(x, y, z) and its horizontal gradient. */
static double pressure_wave(const sq_sandstorm *s, double x, double y, double zfrac, double *gx,
                            double *gy)
{
    double a = level_value(s->d.pressure_amp_pa, s->d.pressure_amp_count, zfrac);
    double ph = s->d.kx_per_m * x + s->d.ky_per_m * y - s->d.phase_rad;
    *gx = a * s->d.kx_per_m * cos(ph);
    *gy = a * s->d.ky_per_m * cos(ph);
    return a * sin(ph);
}

/* The one home of the Bernoulli rule (S0 eq. 2.19 over a hydrostatic background, whose rho g z
 * term cancels, SPEC §1.6 ⚠1): |v| = sqrt(2 (C_B - P') / rho) with the constant derived from
 * the wind-speed key, C_B = rho U^2 / 2, so that |v| = U where P' = 0. */
static double bernoulli_speed(const sq_sandstorm_desc *d, double p_pa)
{
    const double U = d->wind_speed_mps;
    return sqrt(fmax(0.0, U * U - 2.0 * p_pa / SQ_SAND_AIR_DENSITY));
}

/* Log-law factor ln(zg/z0)/ln(z_log/z0) below the log layer (1 above) at zg above the ground. */
static double log_profile(const sq_sandstorm *s, double zg)
{
    if (zg <= s->d.roughness_m) return 0.0;
    return fmin(1.0, log(zg / s->d.roughness_m) / log(s->d.log_layer_m / s->d.roughness_m));
}

/* Share of cold-pool air at zg above the ground: 1 in the pool, 0 above, a smooth step of
 * 0.1 H at its top (the haboob's cold outflow of depth H). */
static double coldpool_fraction(const sq_sandstorm *s, double zg)
{
    if (s->d.coldpool_delta_t_k <= 0.0) return 0.0;
    const double H = s->d.coldpool_depth_m;
    return 0.5 * (1.0 - tanh((zg - H) / (0.1 * H)));
}

/* coldpool.spanwise_variation: the deficit's relative variation xi(y) along y, rms 1 (0 when
 * the key is 0): M equal-amplitude Fourier modes of the domain's width W, wavelengths W/m for
 * m = 1..M down to 8 cells (periodic across the domain), their phases from the seed. */
#define COLDPOOL_MODES_MAX 64
static double coldpool_spanwise(const sq_sandstorm *s, double y)
{
    if (s->d.coldpool_spanwise <= 0.0) return 0.0;
    const double W = s->ny * (double)s->h;
    int M = s->ny / 8;
    if (M < 1) M = 1;
    if (M > COLDPOOL_MODES_MAX) M = COLDPOOL_MODES_MAX;
    double xi = 0.0;
    for (int m = 1; m <= M; m++) {
        float u[4];
        sq_rng_uniform4(s->d.seed, 0xC01D, (uint64_t)m, u);
        xi += cos(2.0 * SQ_PI * m * (y - s->origin[1]) / W + 2.0 * SQ_PI * (double)u[0]);
    }
    return xi * sqrt(2.0 / M); /* each mode's mean square is 1/2 */
}

/* The deficit at y: dT (1 + a xi(y)) (a = coldpool.spanwise_variation). */
static double coldpool_deficit(const sq_sandstorm *s, double y)
{
    return s->d.coldpool_delta_t_k * (1.0 + s->d.coldpool_spanwise * coldpool_spanwise(s, y));
}

/* The cold air's inflow speed: the key, or the density current's velocity scale sqrt(g' H),
 * g' = g dT / theta_s. */
static double coldpool_speed(const sq_sandstorm_desc *d)
{
    if (d->coldpool_speed_mps > 0.0) return d->coldpool_speed_mps;
    return sqrt(SQ_SAND_GRAVITY * d->coldpool_delta_t_k / d->surface_temperature_k *
                d->coldpool_depth_m);
}

/* Initial wind at a point (m/s): Bernoulli speed, direction -grad P (or along the isobars),
 * and a log profile in the surface layer. */
static sq_vec3 initial_wind(const sq_sandstorm *s, double x, double y, double z_abs, double ramp)
{
    double zfrac = (z_abs - s->origin[2]) / (s->nz * (double)s->h);
    double gx, gy;
    double p = pressure_wave(s, x, y, zfrac, &gx, &gy);
    double speed = bernoulli_speed(&s->d, p);
    double gl = sqrt(gx * gx + gy * gy);
    double dx, dy;
    if (gl > 1e-9) {
        dx = -gx / gl;
        dy = -gy / gl;
        if (s->d.geostrophic) { /* northern hemisphere: low pressure on the left */
            double t = dx;
            dx = -dy;
            dy = t;
        }
    } else {
        double a = s->d.prevailing_dir_deg * SQ_PI / 180.0;
        dx = cos(a);
        dy = sin(a);
    }
    double zg = z_abs - (double)sq_world_height_at(s->world, (float)x, (float)y);
    double v = speed * log_profile(s, zg) * ramp;
    return sq_v3((float)(v * dx), (float)(v * dy), 0.0f);
}

static double ramp_factor(const sq_sandstorm *s, double t)
{
    if (s->d.ramp_s <= 0.0) return 1.0;
    double u = t / s->d.ramp_s;
    if (u >= 1.0) return 1.0;
    return u * u * (3.0 - 2.0 * u);
}

/* The west face: the ambient wind, and below the cold pool's top the cold outflow entering at
 * its own speed along wind.prevailing_dir_deg (log profile near the ground); above it, with
 * coldpool.return_flow, the ambient wind less the return speed (air leaving aloft). */
static void inflow_fn(void *user, double x, double y, double z, float vel[3])
{
    const sq_sandstorm *s = (const sq_sandstorm *)user;
    sq_vec3 v = initial_wind(s, x, y, z, ramp_factor(s, s->time_s));
    double zg = z - (double)sq_world_height_at(s->world, (float)x, (float)y);
    double f = coldpool_fraction(s, zg);
    if (f > 0.0 || s->return_mps != 0.0) {
        const double a = s->d.prevailing_dir_deg * SQ_PI / 180.0;
        const double uc = coldpool_speed(&s->d) * log_profile(s, zg);
        v = sq_v3((float)((1.0 - f) * ((double)v.x - s->return_mps) + f * uc * cos(a)),
                  (float)((1.0 - f) * (double)v.y + f * uc * sin(a)),
                  v.z);
    }
    vel[0] = v.x;
    vel[1] = v.y;
    vel[2] = v.z;
}

/* coldpool.return_flow: the speed R of the outflow through the west face above the cold pool
 * that carries out what the cold inflow brings in beyond the ambient wind, so that the face's
 * net volume flux is the ambient wind's (the storm's inflow aloft feeding its downdraft). Over
 * the face's fluid cells of the column at its centre (heights zg_k above the ground),
 * sum_k f_k (u_c,k - v_k) = R sum_k (1 - f_k): u_c the cold inflow's x component, v the ambient
 * wind's, f the share of cold air (the inflow's own profiles). */
static double coldpool_return_speed(const sq_sandstorm *s)
{
    if (!s->d.coldpool_return_flow || s->d.coldpool_delta_t_k <= 0.0) return 0.0;
    const double x = s->origin[0], y = s->origin[1] + 0.5 * s->ny * s->h;
    const double zs = (double)sq_world_height_at(s->world, (float)x, (float)y);
    const double a = s->d.prevailing_dir_deg * SQ_PI / 180.0, ramp = ramp_factor(s, s->time_s);
    double excess = 0.0, above = 0.0;
    for (int k = 0; k < s->nz; k++) {
        const double z = s->origin[2] + (k + 0.5) * s->h, zg = z - zs;
        if (zg <= 0.0) continue;
        const double f = coldpool_fraction(s, zg);
        const double uc = coldpool_speed(&s->d) * log_profile(s, zg) * cos(a);
        excess += f * (uc - (double)initial_wind(s, x, y, z, ramp).x);
        above += 1.0 - f;
    }
    return above > 0.0 ? excess / above : 0.0;
}

/* The views of the grid (the whole grid; under mpirun rank 0's gathered copy, the other ranks
 * their slab, whose views they never publish). */
static inline const sq_grid *view_grid(const sq_sandstorm *s) { return s->whole ? s->whole : s->grid; }

static void fill_velocity(sq_sandstorm *s, double ramp)
{
    for (int axis = 0; axis < 3; axis++) {
        sq_field3 *f = sq_grid_velocity_field(s->grid, axis);
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++)
                for (int i = 0; i < f->n.nx; i++) {
                    double x = s->origin[0] + (i + s->lo[0] + (axis == 0 ? 0.0 : 0.5)) * s->h;
                    double y = s->origin[1] + (j + s->lo[1] + (axis == 1 ? 0.0 : 0.5)) * s->h;
                    double z = s->origin[2] + (k + (axis == 2 ? 0.0 : 0.5)) * s->h;
                    sq_vec3 v = initial_wind(s, x, y, z, ramp);
                    *sq_field3_at(f, i, j, k) = axis == 0 ? v.x : axis == 1 ? v.y : v.z;
                }
    }
}

/* Potential temperature theta (K) of the initial state at (x, y) and height zr above the
 * domain base: the background theta_bar(z) = T_s + (Gamma_d - Gamma) z (T falls with the lapse
 * rate Gamma; dry adiabatic motion conserves theta) plus the temperature wave T0(z) sin(kx x +
 * ky y - sigma + sigma0) (S0 eq. 2.35). The interior and the inflow face both take it. */
static double theta_background(const sq_sandstorm *s, double zr)
{
    return s->d.surface_temperature_k + (SQ_SAND_DRY_LAPSE - s->d.lapse_k_per_m) * zr;
}

static double theta_initial(const sq_sandstorm *s, double x, double y, double zr)
{
    double zfrac = zr / (s->nz * (double)s->h);
    double a = level_value(s->d.temperature_amp_k, s->d.temperature_amp_count, zfrac);
    double tp = a * sin(s->d.kx_per_m * x + s->d.ky_per_m * y - s->d.phase_rad +
                        s->d.temperature_lag_rad);
    return theta_background(s, zr) + tp;
}

static void fill_temperature(sq_sandstorm *s)
{
    sq_field3 *T = sq_grid_scalar_field(s->grid, s->temp_idx);
    for (int k = 0; k < s->nz; k++) {
        s->theta_ref[k] = (float)theta_background(s, (k + 0.5) * s->h);
        for (int j = 0; j < s->ln[1]; j++)
            for (int i = 0; i < s->ln[0]; i++) {
                const int gi = i + s->lo[0], gj = j + s->lo[1];
                double x = s->origin[0] + (gi + 0.5) * s->h, y = s->origin[1] + (gj + 0.5) * s->h;
                double th = theta_initial(s, x, y, (k + 0.5) * s->h);
                if ((gi + 0.5) * s->h < s->d.coldpool_length_m) { /* the outflow so far */
                    double zg = s->origin[2] + (k + 0.5) * s->h -
                                (double)sq_world_height_at(s->world, (float)x, (float)y);
                    th -= coldpool_deficit(s, y) * coldpool_fraction(s, zg);
                }
                *sq_field3_at(T, i, j, k) = (float)th;
            }
    }
}

/* The air entering through the west face has the interior's temperature profile (the ghost
 * cells just outside the face, x = origin - h/2), less the cold pool's deficit below its top. */
static bool has_west_inflow(const sq_grid *g)
{
    return g && sq_grid_get_desc(g).boundary[SQ_FACE_XMIN] == SQ_BOUNDARY_INFLOW;
}

static sq_result grid_temperature_inflow(sq_sandstorm *s, sq_grid *g, int jlo)
{
    if (!has_west_inflow(g)) return SQ_OK; /* a slab away from the west face */
    int na = 0, nb = 0;
    float *t = sq_grid_scalar_inflow_data(g, SQ_FACE_XMIN, s->temp_idx, &na, &nb);
    if (!t) return SQ_ERR_OUT_OF_MEMORY;
    const double x = s->origin[0] - 0.5 * s->h;
    for (int k = 0; k < nb; k++)
        for (int j = 0; j < na; j++) {
            const double y = s->origin[1] + (j + jlo + 0.5) * s->h;
            const double zg = s->origin[2] + (k + 0.5) * s->h -
                              (double)sq_world_height_at(s->world, (float)x, (float)y);
            t[(size_t)k * na + j] = (float)(theta_initial(s, x, y, (k + 0.5) * s->h) -
                                            coldpool_deficit(s, y) * coldpool_fraction(s, zg));
        }
    return SQ_OK;
}

/* The air entering through the west face (the slab that holds it, and the whole grid's copy
 * so that its boundary values are the slab's). */
static sq_result set_temperature_inflow(sq_sandstorm *s)
{
    sq_result r = grid_temperature_inflow(s, s->grid, s->lo[1]);
    if (r == SQ_OK && s->whole) r = grid_temperature_inflow(s, s->whole, 0);
    return r;
}

static sq_result set_wind_inflow(sq_sandstorm *s)
{
    s->return_mps = coldpool_return_speed(s);
    sq_result r = has_west_inflow(s->grid) ? sq_grid_set_inflow(s->grid, SQ_FACE_XMIN, inflow_fn, s) : SQ_OK;
    if (r == SQ_OK && s->whole) r = sq_grid_set_inflow(s->whole, SQ_FACE_XMIN, inflow_fn, s);
    return r;
}

/* Under mpirun: the slabs' wind, dust and temperature into the whole grid on rank 0
 * (collective), its boundary values as the slabs'. */
static sq_result gather_whole(sq_sandstorm *s)
{
    if (!s->dist) return SQ_OK;
    sq_result r = sq_grid_gather_root(s->grid, s->whole);
    if (r == SQ_OK && s->whole) sq_grid_apply_boundary(s->whole);
    return r;
}

/* Under mpirun: every rank's slab (lo x, lo y, n x, n y) and the neighbours along the split
 * axis (slabs in rank order along it: sq_par_decompose). */
static sq_result find_slabs(sq_sandstorm *s)
{
    const int nr = sq_par_size(), me = sq_par_rank(), ax = s->ln[0] != s->nx ? 0 : 1;
    const int n = ax == 0 ? s->nx : s->ny;
    s->nb_lo = s->lo[ax] > 0 ? me - 1 : -1;
    s->nb_hi = s->lo[ax] + s->ln[ax] < n ? me + 1 : -1;
    int64_t *cnt = (int64_t *)sq_alloc(s->ctx, (size_t)nr * sizeof(int64_t));
    double *all = (double *)sq_alloc(s->ctx, (size_t)nr * 4 * sizeof(double));
    s->blocks = (int *)sq_alloc(s->ctx, (size_t)nr * 4 * sizeof(int));
    sq_result r = cnt && all && s->blocks ? SQ_OK : SQ_ERR_OUT_OF_MEMORY;
    r = sq_par_agree(r);
    if (r == SQ_OK) {
        const double mine[4] = {s->lo[0], s->lo[1], s->ln[0], s->ln[1]};
        for (int q = 0; q < nr; q++) cnt[q] = 4;
        r = sq_par_allgather_f64(mine, cnt, all);
        for (int q = 0; q < 4 * nr && r == SQ_OK; q++) s->blocks[q] = (int)all[q];
    }
    sq_free(s->ctx, cnt);
    sq_free(s->ctx, all);
    return r;
}

/* ---- create / destroy --------------------------------------------------------------------- */
static void *xalloc(sq_sandstorm *s, size_t bytes, bool *ok)
{
    void *p = sq_alloc_zero(s->ctx, bytes);
    if (!p) *ok = false;
    return p;
}

static sq_result create_grid(sq_sandstorm *s)
{
    const sq_sandstorm_desc *d = &s->d;
    s->nx = d->cells[0];
    s->ny = d->cells[1];
    s->nz = d->cells[2];
    s->h = d->cell_size_m;
    s->origin[0] = d->center_m[0] - 0.5 * s->nx * s->h;
    s->origin[1] = d->center_m[1] - 0.5 * s->ny * s->h;
    /* the domain's base: the lowest terrain under it, minus half a cell */
    float zmin = 1e30f;
    for (int j = 0; j <= s->ny; j++)
        for (int i = 0; i <= s->nx; i++) {
            float zt = sq_world_height_at(s->world, (float)(s->origin[0] + i * s->h),
                                          (float)(s->origin[1] + j * s->h));
            zmin = zt < zmin ? zt : zmin;
        }
    s->origin[2] = (double)zmin - 0.5 * s->h;
    sq_grid_desc g;
    memset(&g, 0, sizeof g);
    g.cells = (sq_dims){s->nx, s->ny, s->nz};
    g.cell_size_m = s->h;
    for (int a = 0; a < 3; a++) g.origin_m[a] = s->origin[a];
    g.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_INFLOW;
    g.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_OUTFLOW;
    g.boundary[SQ_FACE_YMIN] = d->side_boundary == 1 ? SQ_BOUNDARY_PERIODIC : SQ_BOUNDARY_OPEN;
    g.boundary[SQ_FACE_YMAX] = g.boundary[SQ_FACE_YMIN];
    g.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    g.boundary[SQ_FACE_ZMAX] = d->top_boundary == 1 ? SQ_BOUNDARY_FREE_SLIP : SQ_BOUNDARY_OPEN;
    g.pressure = d->pressure_solver == 2   ? SQ_PRESSURE_JACOBI
                 : d->pressure_solver == 1 ? SQ_PRESSURE_MULTIGRID
                                           : SQ_PRESSURE_MGPCG;
    g.jacobi_iterations = d->jacobi_iterations;
    g.tolerance = d->pressure_tolerance;
    g.advection = d->advection == 1 ? SQ_ADVECT_SEMI_LAGRANGIAN : SQ_ADVECT_MACCORMACK;
    g.mixing_length_max_m = SQ_SAND_MIXING_LENGTH_MAX;
    /* the mixing length's ground: the wind 0 half a cell below (S0), or the log law's stress */
    g.wall_roughness_m = d->log_law_ground ? d->roughness_m : 0.0;
    /* scalars: the dust bins, theta, and with solver.turbulence = tke the subgrid energy e */
    const bool tke = d->turbulence == 2;
    g.scalar_count = s->nbins + 1 + (tke ? 1 : 0);
    g.scalar_nonnegative = (1ull << g.scalar_count) - 1ull;
    s->temp_idx = s->nbins;
    /* under mpirun the grid is split in slabs (docs/mpi.md); the whole grid's copy holds the
     * gathered fields for everything that is not the step */
    g.decompose = true;
    sq_result r = sq_grid_create(s->ctx, &g, &s->grid);
    if (r != SQ_OK) return r;
    {
        int lo[3];
        sq_dims whole;
        r = sq_grid_get_block(s->grid, lo, &whole);
        const sq_dims n = sq_grid_get_info(s->grid).cells;
        s->lo[0] = lo[0];
        s->lo[1] = lo[1];
        s->ln[0] = n.nx;
        s->ln[1] = n.ny;
        s->synced_step = -1;
        if (r == SQ_OK && (n.nx != s->nx || n.ny != s->ny)) {
            s->dist = true;
            g.decompose = false;
            if (sq_par_rank() == 0) r = sq_grid_create(s->ctx, &g, &s->whole);
        }
        r = sq_par_agree(r);
        if (r == SQ_OK && s->dist) r = find_slabs(s);
        if (r != SQ_OK) return r;
    }
    /* the mixing-length closure also carries the dust and the heat (K = nu_t / Pr_t), and with
     * buoyancy it feels the stratification of theta (Lilly 1962) */
    r = sq_grid_set_eddy_scalars(s->grid, SQ_SAND_PRANDTL_T,
                                 d->buoyancy_gain > 0.0 ? s->temp_idx : -1,
                                 SQ_SAND_GRAVITY * d->buoyancy_gain);
    if (r != SQ_OK) return r;
    /* or the Smagorinsky-Lilly subgrid closure (grid_sgs.c) with the same Pr_t and the log-law
     * stress of the ground's roughness, or Deardorff's TKE closure (grid_tke.c) with e in the
     * last scalar (0 at first: the floor seeds it; the inflow brings e = 0 too) */
    memset(&s->sgs, 0, sizeof s->sgs);
    s->sgs.closure = tke ? SQ_SGS_TKE : SQ_SGS_SMAGORINSKY;
    s->sgs.tke_idx = tke ? s->nbins + 1 : 0;
    s->sgs.smagorinsky_c = d->smagorinsky_c;
    s->sgs.prandtl_t = SQ_SAND_PRANDTL_T;
    s->sgs.kappa = SQ_SAND_KARMAN;
    s->sgs.roughness_m = d->roughness_m;
    s->sgs.stratified = d->buoyancy_gain > 0.0;
    s->sgs.theta_idx = s->temp_idx;
    s->sgs.gravity_mps2 = SQ_SAND_GRAVITY * d->buoyancy_gain;
    /* solid cells: terrain, obstacles and closed meshes at cell centres */
    size_t n = (size_t)s->nx * s->ny * s->nz, cols = (size_t)s->nx * s->ny;
    uint8_t *mask = (uint8_t *)sq_alloc_zero(s->ctx, n);
    bool ok = mask != NULL;
    s->ground_k = (int *)xalloc(s, cols * sizeof(int), &ok);
    s->ground_z1 = (float *)xalloc(s, cols * sizeof(float), &ok);
    /* under mpirun the ranks other than 0 hold the slab's 3-D scratch and no whole-grid views */
    const bool views = !s->dist || s->whole;
    const size_t slab = (size_t)s->ln[0] * s->ln[1] * s->nz;
    s->accel_z = (float *)xalloc(s, slab * sizeof(float), &ok);
    s->theta_ref = (float *)xalloc(s, (size_t)s->nz * sizeof(float), &ok);
    s->keep = (float *)xalloc(s, cols * sizeof(float), &ok);
    s->row_acc = (double *)xalloc(s, (size_t)s->ny * 4 * sizeof(double), &ok);
    s->plane_mass = (double *)xalloc(s, (size_t)s->nz * SQ_SANDSTORM_MAX_BINS * sizeof(double), &ok);
    s->mix_f = (float *)xalloc(s, (size_t)s->ln[1] * 4 * s->nz * sizeof(float), &ok);
    s->mix_d = (double *)xalloc(s, (size_t)s->ln[1] * 2 * s->nz * sizeof(double), &ok);
    s->density = (float *)xalloc(s, (views ? n : slab) * sizeof(float), &ok);
    for (int v = 0; v < d->vis_height_count; v++) s->vis[v] = (float *)xalloc(s, cols * sizeof(float), &ok);
    for (int e = 0; e < 6 && views; e++) s->export_buf[e] = (float *)xalloc(s, n * sizeof(float), &ok);
    if (!ok) {
        sq_free(s->ctx, mask);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    const int dims[3] = {s->nx, s->ny, s->nz};
    r = sq_world_voxelise(s->world, s->origin, s->h, dims, SQ_SOLID_ALL, mask);
    if (r != SQ_OK) {
        sq_free(s->ctx, mask);
        return r;
    }
    for (int j = 0; j < s->ny; j++)
        for (int i = 0; i < s->nx; i++) {
            double x = s->origin[0] + (i + 0.5) * s->h, y = s->origin[1] + (j + 0.5) * s->h;
            int k0 = -1;
            for (int k = 0; k < s->nz && k0 < 0; k++)
                if (!mask[((size_t)k * s->ny + j) * s->nx + i]) k0 = k;
            s->ground_k[(size_t)j * s->nx + i] = k0;
            float zt = sq_world_surface_at(s->world, (float)x, (float)y);
            float z1 = k0 >= 0 ? (float)(s->origin[2] + (k0 + 0.5) * s->h) - zt : 0.0f;
            s->ground_z1[(size_t)j * s->nx + i] = z1 > (float)(0.1 * s->h) ? z1 : (float)(0.1 * s->h);
        }
    if (s->dist) { /* the whole mask to rank 0's copy, the slab's part to the slab */
        const size_t lc = (size_t)s->ln[0] * s->ln[1];
        s->slab_gk = (int *)xalloc(s, lc * sizeof(int), &ok);
        s->slab_gz1 = (float *)xalloc(s, lc * sizeof(float), &ok);
        s->slab_vis = (float *)xalloc(s, lc * (size_t)(d->vis_height_count + 1) * sizeof(float), &ok);
        s->tau = (double *)xalloc(s, (size_t)s->ny * s->nz * sizeof(double), &ok);
        s->vis_all = (float *)xalloc(s, cols * (size_t)(d->vis_height_count + 1) * sizeof(float), &ok);
        for (int j = 0; ok && j < s->ln[1]; j++)
            for (int i = 0; i < s->ln[0]; i++) {
                const size_t col = (size_t)(j + s->lo[1]) * s->nx + (size_t)(i + s->lo[0]);
                s->slab_gk[(size_t)j * s->ln[0] + i] = s->ground_k[col];
                s->slab_gz1[(size_t)j * s->ln[0] + i] = s->ground_z1[col];
            }
        r = !ok ? SQ_ERR_OUT_OF_MEMORY : s->whole ? sq_grid_set_solid_mask(s->whole, mask) : SQ_OK;
        const size_t ln = (size_t)s->ln[0] * s->ln[1] * s->nz;
        uint8_t *sm = r == SQ_OK ? (uint8_t *)sq_alloc(s->ctx, ln) : NULL;
        if (r == SQ_OK && !sm) r = SQ_ERR_OUT_OF_MEMORY;
        for (int k = 0; sm && k < s->nz; k++)
            for (int j = 0; j < s->ln[1]; j++)
                memcpy(sm + ((size_t)k * s->ln[1] + j) * s->ln[0],
                       mask + ((size_t)k * s->ny + j + s->lo[1]) * s->nx + s->lo[0], (size_t)s->ln[0]);
        sq_free(s->ctx, mask);
        mask = sm;
        r = sq_par_agree(r);
        if (r != SQ_OK) {
            sq_free(s->ctx, mask);
            return r;
        }
    }
    r = sq_grid_set_solid_mask(s->grid, mask);
    sq_free(s->ctx, mask);
    if (r != SQ_OK) return r;
    fill_velocity(s, ramp_factor(s, 0.0));
    fill_temperature(s);
    r = set_wind_inflow(s);
    if (r != SQ_OK) return r;
    r = set_temperature_inflow(s);
    if (r != SQ_OK) return r;
    sq_grid_apply_boundary(s->grid);
    /* SPEC §1.6 ⚠3: the initial field is not divergence-free: project once */
    sq_grid_project_stats ps;
    r = sq_grid_project(s->grid, 1.0, &ps);
    if (r == SQ_OK) r = gather_whole(s);
    return r;
}

static sq_result create_near_field(sq_sandstorm *s)
{
    if (!s->d.near_field) return SQ_OK;
    s->np = s->d.near_particles;
    bool ok = true;
    size_t n = (size_t)s->np;
    s->p_pos = (float *)xalloc(s, n * 3 * sizeof(float), &ok);
    s->p_radius = (float *)xalloc(s, n * sizeof(float), &ok);
    s->p_rot = (float *)xalloc(s, n * sizeof(float), &ok);
    s->p_spin = (float *)xalloc(s, n * sizeof(float), &ok);
    s->p_tau = (float *)xalloc(s, n * sizeof(float), &ok);
    s->p_fade = (float *)xalloc(s, n * sizeof(float), &ok);
    s->p_age = (float *)xalloc(s, n * sizeof(float), &ok);
    if (!ok) return SQ_ERR_OUT_OF_MEMORY;
    for (int i = 0; i < s->np; i++) s->p_age[i] = -1.0f; /* spawn on first camera */
    return SQ_OK;
}

sq_result sq_sandstorm_create(sq_context *ctx, const sq_sandstorm_desc *desc, const sq_world *world,
                              sq_sandstorm **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "sandstorm", "out is NULL");
    *out = NULL;
    if (!world) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "sandstorm", "a world is required");
    sq_result r = sq_sandstorm_validate(ctx, desc, world);
    if (r != SQ_OK) return r;
    sq_sandstorm_desc d;
    sq_sandstorm_desc_resolve(desc, &d);
    uint64_t bytes = sq_sandstorm_memory_bytes(&d);
    char what[96];
    snprintf(what, sizeof what, "sandstorm grid %dx%dx%d", d.cells[0], d.cells[1], d.cells[2]);
    r = sq_context_check_memory(ctx, bytes, what);
    if (r != SQ_OK) return r;
    sq_sandstorm *s = (sq_sandstorm *)sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    s->d = d;
    s->world = world;
    s->nbins = d.bins;
    s->memory_bytes = bytes;
    s->u_star_t = (double)d.u_star_t0_mps * d.roughness_factor * d.moisture_factor * d.compactness_factor;
    r = build_optics(s);
    if (r == SQ_OK && d.mode == SQ_SANDSTORM_DESERT) r = create_grid(s);
    if (r == SQ_OK && d.mode == SQ_SANDSTORM_URBAN) {
        sq_vec3 lo, hi;
        sq_world_bounds(world, &lo, &hi);
        s->urban_origin = sq_v3(lo.x, lo.y, lo.z - 1.0f);
        s->urban_size = sq_v3(hi.x - lo.x, hi.y - lo.y, (hi.z - lo.z) + (float)d.urban_height_m + 1.0f);
        s->urban_conc = d.urban_conc_kg_m3[0];
    }
    if (r == SQ_OK) r = create_near_field(s);
    s->mirror_sides_m = (float)d.detail_mirror_sides_m;
    if (r == SQ_OK && s->grid && d.detail_amplitude_m > 0.0 && (!s->dist || s->whole)) {
        r = sq__sand_detail_init(&s->detail, ctx, s->nx, s->ny, s->nz, s->h, d.detail_amplitude_m,
                                 d.detail_scale_m, d.detail_period_s, d.seed);
        s->detail_out = r == SQ_OK
                            ? sq_alloc(ctx, (size_t)s->nx * s->ny * s->nz * sizeof(float))
                            : NULL;
        if (r == SQ_OK && !s->detail_out)
            r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "sandstorm", "no memory for the detail");
    }
    if (r != SQ_OK) {
        sq_sandstorm_destroy(s);
        return r;
    }
    s->derived_dirty = true;
    s->version = 1;
    s->stats.memory_bytes = bytes;
    *out = s;
    return SQ_OK;
}

void sq_sandstorm_destroy(sq_sandstorm *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    sq_grid_destroy(s->grid);
    sq_grid_destroy(s->whole);
    sq_free(ctx, s->blocks);
    sq_free(ctx, s->slab_gk);
    sq_free(ctx, s->slab_gz1);
    sq_free(ctx, s->slab_vis);
    sq_free(ctx, s->tau);
    sq_free(ctx, s->vis_all);
    sq_free(ctx, s->ground_k);
    sq_free(ctx, s->ground_z1);
    sq_free(ctx, s->accel_z);
    sq_free(ctx, s->theta_ref);
    sq_free(ctx, s->keep);
    sq_free(ctx, s->row_acc);
    sq_free(ctx, s->plane_mass);
    sq_free(ctx, s->mix_f);
    sq_free(ctx, s->mix_d);
    sq_free(ctx, s->density);
    sq__sand_detail_free(&s->detail, ctx);
    sq_free(ctx, s->detail_out);
    for (int v = 0; v < SQ_SANDSTORM_MAX_VIS; v++) sq_free(ctx, s->vis[v]);
    for (int e = 0; e < 6; e++) sq_free(ctx, s->export_buf[e]);
    float *pp[] = {s->p_pos, s->p_radius, s->p_rot, s->p_spin, s->p_tau, s->p_fade, s->p_age};
    for (size_t i = 0; i < sizeof pp / sizeof pp[0]; i++) sq_free(ctx, pp[i]);
    sq_free(ctx, s);
}

/* ---- the step ------------------------------------------------------------------------------ */
/* The per-step dust passes below run on sq_context_threads() threads (OpenMP over z-planes or
 * y-rows) with their reductions kept as per-plane / per-row partial sums in double that are
 * added in a fixed order, so budgets do not depend on the thread count. */

/* Global sums of a distributed run (no-op on one rank); every rank passes the same n. */
static void sum_ranks(const sq_sandstorm *s, double *v, int n)
{
    if (s->dist) sq_par_sum_f64(v, n);
}

/* Suspended mass of every bin (kg) in grid g (nx x ny columns) in one pass. */
static void dust_masses(const sq_sandstorm *s, const sq_grid *g, int nx, int ny, double *mass)
{
    const int nz = s->nz, nb = s->nbins;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    sq_field_view c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) c[b] = sq_grid_scalar_view(g, b);
    double *pm = s->plane_mass;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int b = 0; b < nb; b++) {
            double acc = 0.0;
            for (int j = 0; j < ny; j++)
                acc += sq__sand_dsum(c[b].data + (ptrdiff_t)j * c[b].sy + (ptrdiff_t)k * c[b].sz, nx);
            pm[(size_t)k * SQ_SANDSTORM_MAX_BINS + b] = acc;
        }
    const double vol = s->h * s->h * s->h;
    for (int b = 0; b < nb; b++) {
        double m = 0.0;
        for (int k = 0; k < nz; k++) m += pm[(size_t)k * SQ_SANDSTORM_MAX_BINS + b];
        mass[b] = m * vol;
    }
}

/* Dust carried out through the open faces during dt by the face velocities (upwind), per
 * bin (a slab counts the domain faces it holds; the step sums them over the ranks). */
static void boundary_outflow(const sq_sandstorm *s, double dt, double *out)
{
    sq_field_view u = sq_grid_velocity_view(s->grid, 0), v = sq_grid_velocity_view(s->grid, 1),
                  w = sq_grid_velocity_view(s->grid, 2);
    const int nx = s->ln[0], ny = s->ln[1], nz = s->nz;
    const bool west = s->lo[0] == 0, east = s->lo[0] + nx == s->nx;
    const bool south = s->lo[1] == 0, north = s->lo[1] + ny == s->ny;
    for (int b = 0; b < s->nbins; b++) {
        sq_field_view c = sq_grid_scalar_view(s->grid, b);
        double o = 0.0;
        for (int k = 0; k < nz; k++)
            for (int j = 0; j < ny; j++) {
                if (east) o += fmax(0.0, (double)sq_view_get(&u, nx, j, k)) * (double)sq_view_get(&c, nx - 1, j, k);
                if (west) o += fmax(0.0, -(double)sq_view_get(&u, 0, j, k)) * (double)sq_view_get(&c, 0, j, k);
            }
        for (int k = 0; k < nz && s->d.side_boundary == 0; k++) { /* periodic: no faces */
            const float *vl = v.data + (ptrdiff_t)k * v.sz, *vh = vl + (ptrdiff_t)ny * v.sy;
            const float *cl = c.data + (ptrdiff_t)k * c.sz, *ch = cl + (ptrdiff_t)(ny - 1) * c.sy;
            for (int i = 0; i < nx; i++) {
                if (north) o += fmax(0.0, (double)vh[i]) * (double)ch[i];
                if (south) o += fmax(0.0, -(double)vl[i]) * (double)cl[i];
            }
        }
        for (int j = 0; j < ny; j++) {
            const float *wt = w.data + (ptrdiff_t)j * w.sy + (ptrdiff_t)nz * w.sz;
            const float *ct = c.data + (ptrdiff_t)j * c.sy + (ptrdiff_t)(nz - 1) * c.sz;
            for (int i = 0; i < nx; i++) o += fmax(0.0, (double)wt[i]) * (double)ct[i];
        }
        out[b] = o * dt * (double)s->h * s->h;
    }
}

/* Cell-centred wind of cell (i,j,k) of g, ghost cells included (sq_grid_cell_velocity's
 * arithmetic): a slab reads its neighbours' cells next to it. */
static sq_vec3 cell_wind(const sq_grid *g, int i, int j, int k)
{
    const sq_field_view u = sq_grid_velocity_view(g, 0), v = sq_grid_velocity_view(g, 1),
                        w = sq_grid_velocity_view(g, 2);
    sq_vec3 r;
    r.x = 0.5f * (sq_view_get(&u, i, j, k) + sq_view_get(&u, i + 1, j, k));
    r.y = 0.5f * (sq_view_get(&v, i, j, k) + sq_view_get(&v, i, j + 1, k));
    r.z = 0.5f * (sq_view_get(&w, i, j, k) + sq_view_get(&w, i, j, k + 1));
    return r;
}

/* Dust emission in the ground layer (SPEC §1.9) with the momentum the new grains take from the
 * air (two-way exchange); returns the emitted mass (kg). Every column's friction velocity is
 * taken from the wind before any of this step's emission (phase 1, per column); then the
 * momentum factors are applied to the faces (phase 2, per face row: a face between two
 * emitting columns takes both factors). The slab's part of the totals goes to part: the
 * emitted concentration, emitting and ground columns, the largest friction velocity
 * (emission_totals turns the sums over the ranks into the mass and the stats). */
static void emit_dust(sq_sandstorm *s, double dt, double part[4])
{
    part[0] = part[1] = part[2] = part[3] = 0.0;
    if (s->d.emission_coeff <= 0.0) return;
    /* the slab's columns (local i, j; global column index col), and on a side toward a
     * neighbouring slab one column more: its momentum factor acts on the face between them */
    const int nx = s->ln[0], ny = s->ln[1], NX = s->nx, nb = s->nbins;
    const int ox = s->lo[0], oy = s->lo[1];
    const int i0 = ox > 0 ? -1 : 0, i1 = ox + nx < NX ? nx + 1 : nx;
    const int j0 = oy > 0 ? -1 : 0, j1 = oy + ny < s->ny ? ny + 1 : ny;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    sq_field3 *fu = sq_grid_velocity_field(s->grid, 0), *fv = sq_grid_velocity_field(s->grid, 1);
    sq_field3 *c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) c[b] = sq_grid_scalar_field(s->grid, b);
    double *acc = s->row_acc;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = j0; j < j1; j++) {
        double total = 0.0, max_us = 0.0;
        int emitting = 0, cols = 0;
        for (int i = i0; i < i1; i++) {
            const bool own = i >= 0 && i < nx && j >= 0 && j < ny;
            const size_t col = (size_t)(j + oy) * NX + (size_t)(i + ox);
            const int k0 = s->ground_k[col];
            s->keep[col] = 1.0f;
            if (k0 < 0) continue;
            cols += own;
            sq_vec3 uc = cell_wind(s->grid, i, j, k0);
            double uh = sqrt((double)uc.x * (double)uc.x + (double)uc.y * (double)uc.y);
            double us = sq_friction_velocity(uh, s->ground_z1[col], s->d.roughness_m);
            if (us > max_us && own) max_us = us;
            double F = sq_dust_emission_flux(us, s->u_star_t, s->d.emission_coeff);
            if (F <= 0.0) continue;
            double dc = F * dt / s->h; /* kg/m³ added to the ground cell */
            if (own) {
                emitting++;
                for (int b = 0; b < nb; b++)
                    *sq_field3_at(c[b], i, j, k0) += (float)(dc * s->bins[b].mass_fraction);
                total += dc;
            }
            /* grains start at rest: the air gives them momentum dc*u (exact mixing) */
            s->keep[col] = (float)(1.0 - 0.5 * dc / (SQ_SAND_AIR_DENSITY + dc));
        }
        acc[4 * (j - j0)] = total;
        acc[4 * (j - j0) + 1] = max_us;
        acc[4 * (j - j0) + 2] = emitting;
        acc[4 * (j - j0) + 3] = cols;
    }
    /* u faces: a row's faces belong to that row only; face f takes the factor of column f - 1
     * (its east face), then of column f (its west face) */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < ny; j++)
        for (int f = 0; f <= nx; f++) {
            const int g = f + ox;
            const size_t row = (size_t)(j + oy) * NX;
            if (g > 0 && s->keep[row + g - 1] != 1.0f)
                *sq_field3_at(fu, f, j, s->ground_k[row + g - 1]) *= s->keep[row + g - 1];
            if (g < NX && s->keep[row + g] != 1.0f)
                *sq_field3_at(fu, f, j, s->ground_k[row + g]) *= s->keep[row + g];
        }
    /* v faces: face row jf takes the factors of columns jf - 1 (its upper face) and jf */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int jf = 0; jf <= ny; jf++)
        for (int i = 0; i < nx; i++) {
            const int g = jf + oy;
            if (g > 0) {
                const size_t col = (size_t)(g - 1) * NX + (size_t)(i + ox);
                if (s->keep[col] != 1.0f) *sq_field3_at(fv, i, jf, s->ground_k[col]) *= s->keep[col];
            }
            if (g < s->ny) {
                const size_t col = (size_t)g * NX + (size_t)(i + ox);
                if (s->keep[col] != 1.0f) *sq_field3_at(fv, i, jf, s->ground_k[col]) *= s->keep[col];
            }
        }
    double total = 0.0, max_us = 0.0, emitting = 0.0, cols = 0.0;
    for (int j = 0; j < j1 - j0; j++) {
        total += acc[4 * j];
        max_us = acc[4 * j + 1] > max_us ? acc[4 * j + 1] : max_us;
        emitting += acc[4 * j + 2];
        cols += acc[4 * j + 3];
    }
    part[0] = total;
    part[1] = emitting;
    part[2] = cols;
    part[3] = max_us;
}

/* The emitted mass (kg) and the emission stats from the totals of emit_dust (over the ranks). */
static double emission_totals(sq_sandstorm *s, const double part[4])
{
    s->stats.max_u_star_mps = part[3];
    if (s->d.emission_coeff <= 0.0) return 0.0;
    s->stats.emitting_fraction = part[2] > 0.0 ? part[1] / part[2] : 0.0;
    return part[0] * (double)s->h * s->h * s->h;
}

/* The weight of the settling dust acts on the air through drag (SPEC §1.8: F_air = -F_cell):
 * a_z = -g sum_b c_b / rho_air. The same pass measures the slab's suspended mass of every bin
 * (before[b], kg) for the budget. */
static sq_result add_dust_loading(sq_sandstorm *s, double dt, double *before)
{
    const int nx = s->ln[0], ny = s->ln[1], nz = s->nz, nb = s->nbins;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    const float gr = (float)(SQ_SAND_GRAVITY / SQ_SAND_AIR_DENSITY);
    sq_field_view c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) c[b] = sq_grid_scalar_view(s->grid, b);
    double *pm = s->plane_mass;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        double m[SQ_SANDSTORM_MAX_BINS] = {0};
        for (int j = 0; j < ny; j++) {
            float *az = s->accel_z + ((size_t)k * ny + j) * nx;
            for (int i = 0; i < nx; i++) az[i] = 0.0f;
            for (int b = 0; b < nb; b++) {
                const float *row = c[b].data + (ptrdiff_t)j * c[b].sy + (ptrdiff_t)k * c[b].sz;
                for (int i = 0; i < nx; i++) az[i] -= gr * row[i];
                m[b] += sq__sand_dsum(row, nx);
            }
        }
        for (int b = 0; b < nb; b++) pm[(size_t)k * SQ_SANDSTORM_MAX_BINS + b] = m[b];
    }
    const double vol = s->h * s->h * s->h;
    for (int b = 0; b < nb; b++) {
        double m = 0.0;
        for (int k = 0; k < nz; k++) m += pm[(size_t)k * SQ_SANDSTORM_MAX_BINS + b];
        before[b] = m * vol; /* this slab's (the step sums them over the ranks) */
    }
    sq_field_view az = {s->accel_z, {nx, ny, nz}, 1, nx, (ptrdiff_t)nx * ny};
    return sq_grid_add_acceleration_field(s->grid, NULL, NULL, &az, dt);
}

/* The upwind dust entering with the inflow: the westmost cell layer holds the inflow profile.
 * Returns the concentration added by this slab (kg/m³ summed over cells; times the cell
 * volume, summed over the ranks: the mass). */
static double inflow_dust(sq_sandstorm *s)
{
    if (s->d.inflow_dust_kg_m3 <= 0.0) return 0.0;
    /* the slab that holds the west face (its rows j, global row j + oy) */
    const int nx = s->nx, ny = s->lo[0] == 0 ? s->ln[1] : 0, oy = s->lo[1], nz = s->nz, nb = s->nbins;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    const double ramp = ramp_factor(s, s->time_s);
    sq_field3 *c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) c[b] = sq_grid_scalar_field(s->grid, b);
    double *acc = s->row_acc;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < ny; j++) {
        double added = 0.0;
        const size_t col = (size_t)(j + oy) * nx;
        const int k0 = s->ground_k[col];
        if (k0 >= 0) {
            double lateral = 1.0;
            if (s->d.inflow_dust_width_m > 0.0) {
                double yc = (j + oy + 0.5 - 0.5 * s->ny) * s->h / s->d.inflow_dust_width_m;
                lateral = exp(-0.5 * yc * yc);
            }
            for (int k = k0; k < nz; k++) {
                const double zg = (k - k0) * (double)s->h + (double)s->ground_z1[col];
                const double prof =
                    ramp * lateral * s->d.inflow_dust_kg_m3 * exp(-zg / s->d.inflow_dust_height_m);
                for (int b = 0; b < nb; b++) {
                    const float want = (float)(prof * s->bins[b].mass_fraction);
                    float *v = sq_field3_at(c[b], 0, j, k);
                    if (want > *v) {
                        added += (double)(want - *v);
                        *v = want;
                    }
                }
            }
        }
        acc[4 * j] = added;
    }
    double added = 0.0;
    for (int j = 0; j < ny; j++) added += acc[4 * j];
    return added;
}

/* Mass fix (global conservation for the non-conservative semi-Lagrangian/MacCormack transport:
 * each bin is rescaled so its suspended mass equals the budget's prediction), then settling
 * at the terminal speed with deposition, per y-row over all bins. scale[b]: the factors.
 * Returns the deposited mass (kg). */
static double settle_dust(sq_sandstorm *s, double dt, const float *scale)
{
    const uint8_t *solid = sq_grid_solid(s->grid);
    const int nx = s->ln[0], ny = s->ln[1], nz = s->nz, nb = s->nbins;
    const ptrdiff_t plane = (ptrdiff_t)nx * ny;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    int sub[SQ_SANDSTORM_MAX_BINS];
    double frac[SQ_SANDSTORM_MAX_BINS];
    sq_field3 *c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) {
        const double frac_total = s->w_settle[b] * dt / s->h;
        sub[b] = (int)ceil(frac_total);
        if (sub[b] < 1) sub[b] = 1;
        frac[b] = frac_total / sub[b];
        c[b] = sq_grid_scalar_field(s->grid, b);
    }
    double *acc = s->row_acc;
    /* blocks of 8 rows, each settled plane by plane (per-row sums: thread-count independent) */
    const int nblk = (ny + 7) / 8;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int bk = 0; bk < nblk; bk++) {
        const int j0 = 8 * bk, nr = ny - j0 < 8 ? ny - j0 : 8;
        double dep[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        for (int b = 0; b < nb; b++)
            sq__sand_block_settle(sq_field3_at(c[b], 0, j0, 0), c[b]->sy, c[b]->sz,
                                  solid + (size_t)j0 * nx, nx, plane, nx, nr, nz, scale[b], sub[b],
                                  frac[b], dep);
        for (int r = 0; r < nr; r++) acc[4 * (j0 + r)] = dep[r];
    }
    double dep = 0.0;
    for (int j = 0; j < ny; j++) dep += acc[4 * j];
    sum_ranks(s, &dep, 1);
    return dep * (double)s->h * s->h * s->h;
}

/* Surface heating (SPEC §1.10): the sensible heat flux H_s warms the first fluid cell of every
 * column, d theta/dt = H_s / (rho c_p h); the buoyancy then lifts the warm air. */
static void heat_surface(sq_sandstorm *s, double dt)
{
    const float dth = (float)(s->d.surface_heat_flux_w_m2 * dt / (SQ_SAND_AIR_DENSITY * SQ_SAND_CP * s->h));
    sq_field3 *T = sq_grid_scalar_field(s->grid, s->temp_idx);
    for (int j = 0; j < s->ln[1]; j++)
        for (int i = 0; i < s->ln[0]; i++) {
            const int k0 = s->ground_k[(size_t)(j + s->lo[1]) * s->nx + (size_t)(i + s->lo[0])];
            if (k0 >= 0) *sq_field3_at(T, i, j, k0) += dth;
        }
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* The cold pool's front: per row, the distance from the west face to the last ground cell whose
 * potential temperature is below the background by more than dT/2 (interpolated to the
 * crossing); the median over the rows (0 where no cold air). A slab finds the last cold cell
 * of its part of each row (the crossing with the next slab's first column, whose ground
 * temperature that slab sends); the row's front is the largest over the slabs, as on one
 * rank (a cold cell further east always gives a larger x). */
static double coldpool_front(sq_sandstorm *s)
{
    sq_field_view t = sq_grid_scalar_view(s->grid, s->temp_idx);
    const double half = 0.5 * s->d.coldpool_delta_t_k;
    const int NX = s->nx, lx = s->ln[0], ly = s->ln[1], ox = s->lo[0], oy = s->lo[1];
    double *xs = s->row_acc, *first = s->row_acc + s->ny, *east = s->row_acc + 2 * s->ny;
    if (s->dist && lx != NX) { /* split along x: the first column's ground temperature west */
        for (int j = 0; j < ly; j++) {
            const int k0 = s->ground_k[(size_t)(j + oy) * NX + ox];
            first[j] = k0 >= 0 ? (double)sq_view_get(&t, 0, j, k0) : 0.0;
        }
        double none = 0.0;
        const int nb[2] = {s->nb_lo, s->nb_hi};
        const void *const sb[2] = {first, &none};
        void *const rb[2] = {&none, east};
        const size_t bytes[2] = {s->nb_lo >= 0 ? (size_t)ly * sizeof(double) : 0, 0},
                     rbytes[2] = {0, s->nb_hi >= 0 ? (size_t)ly * sizeof(double) : 0};
        (void)sq_par_exchange_pair(nb, sb, bytes, rb, rbytes);
    }
    for (int j = 0; j < s->ny; j++) xs[j] = 0.0;
    for (int j = 0; j < ly; j++) {
        const size_t row = (size_t)(j + oy) * NX;
        double x = 0.0;
        for (int i = lx - 1; i >= 0; i--) {
            const int k0 = s->ground_k[row + i + ox];
            if (k0 < 0) continue;
            const double a = (double)sq_view_get(&t, i, j, k0) - (double)s->theta_ref[k0] + half;
            if (a < 0.0) { /* cold: find the crossing with the next column east */
                double f = 0.5;
                if (i + ox + 1 < NX && s->ground_k[row + i + ox + 1] >= 0) {
                    const int k1 = s->ground_k[row + i + ox + 1];
                    const double tb = i + 1 < lx ? (double)sq_view_get(&t, i + 1, j, k1) : east[j];
                    const double b = tb - (double)s->theta_ref[k1] + half;
                    f = b > a ? (0.0 - a) / (b - a) : 0.5;
                }
                x = (i + ox + 0.5 + f) * s->h;
                break;
            }
        }
        xs[j + oy] = x;
    }
    if (s->dist) sq_par_max_f64(xs, s->ny);
    qsort(xs, (size_t)s->ny, sizeof *xs, cmp_d);
    return s->ny % 2 ? xs[s->ny / 2] : 0.5 * (xs[s->ny / 2 - 1] + xs[s->ny / 2]);
}

/* Records the front and its speed over the last ~30 s (the oldest sample within 30 s). */
static void track_front(sq_sandstorm *s)
{
    if (s->d.coldpool_delta_t_k <= 0.0) return;
    const double x = coldpool_front(s), t = s->time_s;
    s->front_head = (s->front_head + 1) % SQ_SAND_FRONT_HISTORY;
    s->front_t[s->front_head] = t;
    s->front_x[s->front_head] = x;
    if (s->front_n < SQ_SAND_FRONT_HISTORY) s->front_n++;
    int old = s->front_head;
    for (int n = 1; n < s->front_n; n++) {
        const int q = (s->front_head - n + SQ_SAND_FRONT_HISTORY) % SQ_SAND_FRONT_HISTORY;
        if (t - s->front_t[q] > 30.0) break;
        old = q;
    }
    s->stats.front_m = x;
    if (t - s->front_t[old] > 1.0)
        s->stats.front_speed_mps = (x - s->front_x[old]) / (t - s->front_t[old]);
}

static sq_result step_desert(sq_sandstorm *s, double dt)
{
    sq_result r = SQ_OK;
    double t0 = sq_time_now();
    double before[SQ_SANDSTORM_MAX_BINS], out[SQ_SANDSTORM_MAX_BINS], after[SQ_SANDSTORM_MAX_BINS];
    /* wind (W1–W5; SPEC §1.11) */
    if (s->d.ramp_s > 0.0 && s->time_s < s->d.ramp_s + dt)
        r = set_wind_inflow(s);                                            /* the trough arrives */
    if (r == SQ_OK) r = sq_grid_advect_velocity(s->grid, dt);             /* MacCormack + limiter */
    double t1 = sq_time_now();
    if (r == SQ_OK) r = add_dust_loading(s, dt, before);                   /* dust weight on air */
    if (r == SQ_OK && s->d.surface_heat_flux_w_m2 != 0.0) heat_surface(s, dt); /* sunlit ground */
    if (r == SQ_OK && s->d.buoyancy_gain > 0.0)                            /* thermal updraft */
        r = sq_grid_add_buoyancy(s->grid, s->temp_idx, s->theta_ref, s->d.buoyancy_gain,
                                 SQ_SAND_GRAVITY, dt);
    if (r == SQ_OK && s->d.confinement > 0.0)                              /* helicity confinement */
        r = sq_grid_confine_vorticity(s->grid, s->d.confinement, !s->d.plain_confinement, dt);
    double t2 = sq_time_now();
    if (r == SQ_OK)                                                        /* turbulence */
        r = s->d.turbulence >= 1 ? sq_grid_diffuse_sgs(s->grid, &s->sgs, dt) /* subgrid (LES) */
                                 : sq_grid_diffuse_eddy(s->grid, SQ_SAND_NU_AIR, SQ_SAND_KARMAN, dt);
    double t3 = sq_time_now();
    sq_grid_project_stats ps;
    memset(&ps, 0, sizeof ps);
    if (r == SQ_OK) r = sq_grid_project(s->grid, dt, &ps);                 /* divergence-free */
    double t4 = sq_time_now();
    if (r != SQ_OK) return r;
    /* dust (D1–D5) */
    double em[4];
    emit_dust(s, dt, em);                                                  /* u* > u*_t: F ~ u*^3 */
    double t5 = sq_time_now();
    double inflow = inflow_dust(s);                                        /* storm from upwind */
    boundary_outflow(s, dt, out);
    if (s->dist) { /* the budget's slab parts over the ranks, and the largest u*: one meeting */
        const int nb = s->nbins;
        double v[2 * SQ_SANDSTORM_MAX_BINS + 5];
        memcpy(v, before, (size_t)nb * sizeof *v);
        memcpy(v + nb, out, (size_t)nb * sizeof *v);
        double *e = v + 2 * nb; /* emitted, emitting, ground columns, inflow; then the max */
        e[0] = em[0];
        e[1] = em[1];
        e[2] = em[2];
        e[3] = inflow;
        e[4] = em[3];
        sq_par_sum_max_f64(v, 2 * nb + 4, 1);
        memcpy(before, v, (size_t)nb * sizeof *v);
        memcpy(out, v + nb, (size_t)nb * sizeof *v);
        em[0] = e[0];
        em[1] = e[1];
        em[2] = e[2];
        inflow = e[3];
        em[3] = e[4];
    }
    const double emitted = emission_totals(s, em);
    inflow = inflow * (double)s->h * s->h * s->h; /* the one-rank rounding order */
    double t6 = sq_time_now();
    r = sq_grid_advect_scalars(s->grid, dt);                               /* dust bins and T */
    if (r != SQ_OK) return r;
    double t7 = sq_time_now();
    dust_masses(s, s->grid, s->ln[0], s->ln[1], after);
    sum_ranks(s, after, s->nbins);
    double corr = 0.0, outflow = 0.0;
    float scale[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < s->nbins; b++) {
        double expected = before[b] + emitted * s->bins[b].mass_fraction +
                          inflow * s->bins[b].mass_fraction - out[b];
        scale[b] = 1.0f;
        if (!s->d.no_mass_fix && after[b] > 0.0 && expected >= 0.0) {
            scale[b] = (float)(expected / after[b]);
            corr += expected - after[b];
        }
        outflow += out[b];
    }
    double deposited = settle_dust(s, dt, scale);                          /* terminal speed per bin */
    sq__sand_mix_dust(s, dt);                               /* the ground's turbulence lifts it */
    double t8 = sq_time_now();
    s->budget.emitted_kg += emitted;
    s->budget.inflow_kg += inflow;
    s->budget.outflow_kg += outflow;
    s->budget.deposited_kg += deposited;
    s->budget.advection_correction_kg += corr;
    s->stats.ms_advect += (t1 - t0 + t7 - t6) * 1e3;
    s->stats.ms_forces += (t2 - t1) * 1e3;
    s->stats.ms_diffuse += (t3 - t2) * 1e3;
    s->stats.ms_project += (t4 - t3) * 1e3;
    s->stats.ms_emission += (t5 - t4) * 1e3;
    s->stats.ms_dust += (t6 - t5 + t8 - t7) * 1e3;
    s->stats.pressure_residual = ps.residual;
    s->stats.pressure_iterations = ps.iterations;
    r = sq_grid_check_finite(s->grid, s->step);
    s->time_s += dt;
    if (r == SQ_OK) track_front(s);
    return r;
}

/* Near-field particles (S3, SPEC §4): spawn in the upwind sector of a disc around the camera,
 * drift with the local wind, fade in with age and out near the region's edge. */
static sq_vec3 local_wind(const sq_sandstorm *s, sq_vec3 p)
{
    if (s->grid) return sq_grid_sample_velocity(view_grid(s), p);
    double a = s->d.prevailing_dir_deg * SQ_PI / 180.0;
    double v = bernoulli_speed(&s->d, 0.0) * 0.3;
    return sq_v3((float)(v * cos(a)), (float)(v * sin(a)), 0.0f);
}

static void spawn_particle(sq_sandstorm *s, int i, bool anywhere)
{
    float u[4], u2[4];
    uint64_t id = s->spawn_counter++;
    sq_rng_uniform4(s->d.seed, 0x5A11D, id, u);
    sq_rng_uniform4(s->d.seed, 0x5A11E, id, u2);
    const float R = (float)s->d.near_radius_m;
    sq_vec3 w = local_wind(s, s->cam_pos);
    float up = atan2f(-w.y, -w.x); /* upwind azimuth */
    float half = anywhere ? SQ_PI_F : (float)(SQ_PI / 3.0);
    float az = up + (2.0f * u[0] - 1.0f) * half;
    float rr = R * sqrtf(anywhere ? u[1] : 0.6f + 0.4f * u[1]);
    float x = s->cam_pos.x + rr * cosf(az), y = s->cam_pos.y + rr * sinf(az);
    float zg = sq_world_height_at(s->world, x, y);
    float z = zg + 1.0f + u[2] * 0.5f * R;
    s->p_pos[3 * i] = x;
    s->p_pos[3 * i + 1] = y;
    s->p_pos[3 * i + 2] = z;
    s->p_radius[i] = (float)s->d.near_particle_radius_m * (0.6f + 0.8f * u[3]);
    s->p_rot[i] = 2.0f * SQ_PI_F * u2[0];
    s->p_spin[i] = (u2[1] - 0.5f) * 1.2f;
    s->p_age[i] = 0.0f;
}

static void step_near_field(sq_sandstorm *s, double dt)
{
    /* under mpirun rank 0 draws them (in the wind of the last gathered frame) */
    if (!s->np || !s->have_camera || (s->dist && !s->whole)) return;
    const float R = (float)s->d.near_radius_m;
    for (int i = 0; i < s->np; i++) {
        if (s->p_age[i] < 0.0f) {
            spawn_particle(s, i, true);
            s->p_age[i] = 10.0f; /* initial fill: already faded in */
        }
        sq_vec3 p = sq_v3(s->p_pos[3 * i], s->p_pos[3 * i + 1], s->p_pos[3 * i + 2]);
        sq_vec3 w = local_wind(s, p);
        p = sq_v3_add(p, sq_v3_scale(w, (float)dt)); /* motion = wind x dt */
        s->p_pos[3 * i] = p.x;
        s->p_pos[3 * i + 1] = p.y;
        s->p_pos[3 * i + 2] = p.z;
        s->p_rot[i] += s->p_spin[i] * (float)dt;
        s->p_age[i] += (float)dt;
        sq_vec3 d = sq_v3_sub(p, s->cam_pos);
        if (sqrtf(d.x * d.x + d.y * d.y) > R) spawn_particle(s, i, false);
    }
}

sq_result sq_sandstorm_step(sq_sandstorm *s, double dt)
{
    if (!(dt > 0.0) || !isfinite(dt))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "sandstorm", "step dt = %g s; must be > 0", dt);
    sq_result r = SQ_OK;
    if (s->d.mode == SQ_SANDSTORM_DESERT) {
        double lim = sq_sandstorm_max_stable_dt(s);
        int n = lim > 0.0 && dt > lim ? (int)ceil(dt / lim) : 1;
        if (n > 100)
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "sandstorm",
                            "step %g s at a wind of %g m/s is %d times the CFL sub-step limit "
                            "%g s (solver.cfl = %g, cell %g m), more than 100: lower "
                            "wind.speed_mps, wave.pressure_amp_pa or coldpool.delta_t_k, or the "
                            "frame step (output.time_scale)", dt, s->d.cfl * s->h / lim, n,
                            lim, s->d.cfl, s->h);
        if (n > 1 && s->step == 0)
            sq_log(s->ctx, SQ_LOG_INFO, "sandstorm",
                   "step %g s exceeds the CFL limit %g s: sub-stepping %d times", dt, lim, n);
        for (int k = 0; k < n && r == SQ_OK; k++) {
            r = step_desert(s, dt / n);
            s->step++;
            s->stats.steps++;
            if (r == SQ_OK && s->detail.enabled && s->dist) { /* at the next gathered frame */
                s->detail_pending_s += dt / n;
                s->detail_pending_n++;
            } else if (r == SQ_OK && s->detail.enabled) { /* display only: it follows the wind */
                const double t0 = sq_time_now();
                sq__sand_detail_advect(&s->detail, view_grid(s), dt / n, sq_context_threads(s->ctx));
                s->stats.ms_detail += (sq_time_now() - t0) * 1e3;
            }
        }
    } else {
        s->time_s += dt;
        s->step++;
        int stage = (int)(s->time_s / s->d.urban_stage_s);
        if (stage >= s->d.urban_conc_count) stage = s->d.urban_conc_count - 1;
        float c = s->d.urban_conc_kg_m3[stage];
        if (c != s->urban_conc) {
            s->urban_conc = c;
            s->version++;
        }
    }
    step_near_field(s, dt);
    s->derived_dirty = true;
    return r;
}

double sq_sandstorm_max_stable_dt(const sq_sandstorm *s)
{
    if (!s->grid) return 0.0;
    /* semi-Lagrangian transport is unconditionally stable; the CFL bound keeps the MacCormack
     * correction and the emission/settling splitting accurate */
    double v = sq_grid_max_speed(s->grid); /* under mpirun: collective, the global largest */
    return v > 1e-6 ? s->d.cfl * s->h / v : 0.0;
}

void sq_sandstorm_get_budget(const sq_sandstorm *s, sq_sandstorm_budget *out)
{
    *out = s->budget;
    out->suspended_kg = 0.0;
    if (s->grid) {
        double m[SQ_SANDSTORM_MAX_BINS];
        dust_masses(s, s->grid, s->ln[0], s->ln[1], m); /* under mpirun: collective */
        sum_ranks(s, m, s->nbins);
        for (int b = 0; b < s->nbins; b++) out->suspended_kg += m[b];
    }
}

void sq_sandstorm_get_stats(const sq_sandstorm *s, sq_sandstorm_stats *out)
{
    *out = s->stats;
    out->max_wind_mps = s->grid ? sq_grid_max_speed(s->grid) : 0.0; /* mpirun: collective */
    out->slab_cells = s->grid ? (int64_t)s->ln[0] * s->ln[1] * s->nz : 0;
    out->bytes_exchanged = s->grid ? sq_grid_bytes_exchanged(s->grid) : 0;
}

/* ---- derived fields: extinction volume, visibility planes --------------------------------- */
static void update_derived(sq_sandstorm *s)
{
    if (!s->derived_dirty) return;
    s->derived_dirty = false;
    s->version++;
    if (!s->grid || (s->dist && !s->whole)) return; /* under mpirun: rank 0, gathered frames */
    const int nx = s->nx, ny = s->ny, nz = s->nz, nb = s->nbins;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    sq_field_view c[SQ_SANDSTORM_MAX_BINS];
    float kb[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) {
        c[b] = sq_grid_scalar_view(view_grid(s), b);
        kb[b] = (float)s->k_ext[b][3];
    }
    /* beta_ext(550 nm) = sum_b k_b c_b, bins added in order (per cell, thread-independent) */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            float *d = s->density + ((size_t)k * ny + j) * nx;
            for (int i = 0; i < nx; i++) d[i] = 0.0f;
            for (int b = 0; b < nb; b++) {
                const float *row = c[b].data + (ptrdiff_t)j * c[b].sy + (ptrdiff_t)k * c[b].sz;
                for (int i = 0; i < nx; i++) d[i] += kb[b] * row[i];
            }
        }
    /* Display only: the drawable fades to zero over the outer 2.5 cells of the open faces (not
     * the ground, nor the north and south faces where the dust is drawn mirrored beyond them)
     * so the finite domain shows no box edges, and the ground cells are filled from
     * above (below); metrics and fields use the unmodified values (the visibility planes are
     * computed before these edits). */
    for (int v = 0; v < s->d.vis_height_count; v++)
        sq__sand_visibility_plane(s->density, nx, ny, nz, s->ground_k, s->ground_z1,
                                  (float)s->h, s->d.vis_heights_m[v], s->d.contrast, s->vis[v]);
    /* the dust wall's height: the top of the highest cell with beta >= SQ_SAND_WALL_BETA, above
     * the ground of its column */
    double wall = 0.0;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const size_t col = (size_t)j * nx + i;
            const int k0 = s->ground_k[col];
            if (k0 < 0) continue;
            for (int k = nz - 1; k >= k0; k--)
                if (s->density[(size_t)k * nx * ny + col] >= (float)SQ_SAND_WALL_BETA) {
                    wall = fmax(wall, (k - k0 + 0.5) * s->h + (double)s->ground_z1[col]);
                    break;
                }
        }
    s->wall_height_m = wall;
    /* and its top as seen from ahead: where the dust along the line of sight hides the sky */
    s->wall_seen_m = sq__sand_wall_seen(s->density, nx, ny, nz, s->ground_k, s->ground_z1,
                                        (float)s->h, s->d.contrast, s->row_acc);
    /* Display only: the ground cells below each column's first fluid cell hold the value of that
     * cell, so that trilinear sampling between the last solid and the first fluid cell centre
     * does not thin the densest, near-ground dust toward zero (the opaque terrain hides what is
     * below its surface; the renderer's depth test does the rest). */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const int k0 = s->ground_k[(size_t)j * nx + i];
            if (k0 <= 0) continue;
            const size_t plane = (size_t)nx * ny, col = (size_t)j * nx + i;
            const float v = s->density[(size_t)k0 * plane + col];
            for (int k = 0; k < k0; k++) s->density[(size_t)k * plane + col] = v;
        }
    /* Display only: the flow-following detail (sandstorm_detail.c) */
    if (s->detail.enabled) {
        const double t0 = sq_time_now();
        sq__sand_detail_apply(&s->detail, s->density, s->detail_out, nt);
        memcpy(s->density, s->detail_out, (size_t)nx * ny * nz * sizeof(float));
        s->stats.ms_detail += (sq_time_now() - t0) * 1e3;
    }
    float mx = 0.0f;
    /* drawn beyond its north and south faces (mirrored), the dust continues there: no fade */
    const bool fade_y = !(s->mirror_sides_m > 0.0f);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(max : mx))
    for (int kk = 0; kk < nz; kk++)
        for (int j = 0; j < ny; j++) {
            float *d = s->density + ((size_t)kk * ny + j) * nx;
            for (int i = 0; i < nx; i++) {
                float dmin = (float)(i < nx - 1 - i ? i : nx - 1 - i);
                float dj = fade_y ? (float)(j < ny - 1 - j ? j : ny - 1 - j) : 1e9f;
                float dk = (float)(nz - 1 - kk);
                dmin = dj < dmin ? dj : dmin;
                dmin = dk < dmin ? dk : dmin;
                if (dmin < 2.5f) {
                    float t = (dmin + 0.5f) / 3.0f;
                    d[i] *= t * t * (3.0f - 2.0f * t);
                }
                mx = d[i] > mx ? d[i] : mx;
            }
        }
    s->density_max = mx;
}

/* The wind a weather station would measure at column (i, j): the horizontal wind of the
 * column's first fluid cell (centre z1 above the surface) carried to the anemometer's height by
 * the log law the ground stress and the emission's u* use, u(z) = (u* / kappa) ln(z / z0)
 * (sq_friction_velocity); 0 for a column without air. A mean over the cell and the step, not a
 * 3-s gust. */
static double station_wind(const sq_sandstorm *s, const sq_grid *g, int i, int j)
{
    int lo[3] = {0, 0, 0};
    sq_dims whole;
    if (g == s->grid) (void)sq_grid_get_block(g, lo, &whole); /* a slab: its columns */
    const size_t col = (size_t)(j + lo[1]) * s->nx + (size_t)(i + lo[0]);
    const int k0 = s->ground_k[col];
    if (k0 < 0) return 0.0;
    const sq_vec3 c = cell_wind(g, i, j, k0);
    const double uh = sqrt((double)c.x * (double)c.x + (double)c.y * (double)c.y);
    const double us = sq_friction_velocity(uh, s->ground_z1[col], s->d.roughness_m);
    return us / SQ_SAND_KARMAN * log(SQ_SAND_ANEMOMETER_M / s->d.roughness_m);
}

/* ---- under mpirun: the frame's reductions over the slabs ----------------------------------- */
/* The wall's top as seen from ahead (sq__sand_wall_seen) over the slabs: each level's optical
 * depth along a row is summed in the one-rank order (x ascending), each slab continuing the sums
 * of the slab before it (split along x: a chain from west to east, ny nz doubles per face); the
 * slab that ends the rows finds their tops, the others add zeros. beta: the slab's extinction. */
static double wall_seen_slabs(sq_sandstorm *s, const float *beta)
{
    const int NX = s->nx, ny = s->ny, nz = s->nz, lx = s->ln[0], ly = s->ln[1], ox = s->lo[0],
              oy = s->lo[1];
    const bool xsplit = lx != NX;
    const float h = (float)s->h;
    const size_t lc = (size_t)lx * ly, nt = (size_t)ny * nz;
    double *tau = s->tau, none = 0.0, *rows = s->row_acc;
    for (size_t q = 0; q < nt; q++) tau[q] = 0.0;
    if (xsplit && s->nb_lo >= 0) { /* the sums so far, from the west */
        const int nb[2] = {s->nb_lo, -1};
        const void *const sb[2] = {&none, &none};
        void *const rb[2] = {tau, &none};
        const size_t bytes[2] = {0, 0}, rbytes[2] = {nt * sizeof(double), 0};
        (void)sq_par_exchange_pair(nb, sb, bytes, rb, rbytes);
    }
    for (int j = 0; j < ly; j++)
        for (int k = 0; k < nz; k++) {
            double t = tau[(size_t)(j + oy) * nz + k];
            for (int i = 0; i < lx; i++) {
                const int kg = s->ground_k[(size_t)(j + oy) * NX + i + ox];
                if (kg >= 0 && k >= kg) t += (double)beta[(size_t)k * lc + (size_t)j * lx + i] * (double)h;
            }
            tau[(size_t)(j + oy) * nz + k] = t;
        }
    if (xsplit && s->nb_hi >= 0) { /* and on to the east */
        const int nb[2] = {-1, s->nb_hi};
        const void *const sb[2] = {&none, tau};
        void *const rb[2] = {&none, &none};
        const size_t bytes[2] = {0, nt * sizeof(double)}, rbytes[2] = {0, 0};
        (void)sq_par_exchange_pair(nb, sb, bytes, rb, rbytes);
    }
    const double tau_min = log(1.0 / s->d.contrast);
    for (int j = 0; j < ny; j++) rows[j] = 0.0;
    for (int j = 0; j < ly && ox + lx == NX; j++) {
        const int J = j + oy;
        int kg = nz;
        float z1 = 0.5f * h;
        for (int i = 0; i < NX; i++) {
            const int k0 = s->ground_k[(size_t)J * NX + i];
            if (k0 >= 0 && k0 < kg) {
                kg = k0;
                z1 = s->ground_z1[(size_t)J * NX + i];
            }
        }
        double top = 0.0;
        for (int k = nz - 1; k >= kg && top == 0.0; k--)
            if (tau[(size_t)J * nz + k] >= tau_min) top = (k - kg + 0.5) * (double)h + (double)z1;
        rows[J] = top;
    }
    sq_par_sum_f64(rows, ny);
    return sq__sand_median_rows(rows, ny);
}

/* Under mpirun, collective, once per frame (sq_phen_plugin.frame_sync): what the metrics need
 * from every slab — the visibility planes (each slab's columns, gathered on every rank: 4 bytes
 * per column and plane), the wall's height and the largest extinction (maxima), the wall seen
 * from ahead (chained sums), the suspended dust and the largest wind — and with gather the
 * slabs' fields on rank 0 for its drawables and field files. The front is found every step. */
sq_result sq__sandstorm_frame_sync(void *self, bool gather)
{
    sq_sandstorm *s = (sq_sandstorm *)self;
    if (!s->grid || !s->dist) return SQ_OK;
    const int lx = s->ln[0], ly = s->ln[1], nz = s->nz, nb = s->nbins, nv = s->d.vis_height_count;
    const size_t lc = (size_t)lx * ly;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    /* the slab's extinction at 550 nm, per cell as update_derived (the whole grid's buffer) */
    float *beta = s->density;
    sq_field_view c[SQ_SANDSTORM_MAX_BINS];
    float kb[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) {
        c[b] = sq_grid_scalar_view(s->grid, b);
        kb[b] = (float)s->k_ext[b][3];
    }
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ly; j++) {
            float *d = beta + (size_t)k * lc + (size_t)j * lx;
            for (int i = 0; i < lx; i++) d[i] = 0.0f;
            for (int b = 0; b < nb; b++) {
                const float *row = c[b].data + (ptrdiff_t)j * c[b].sy + (ptrdiff_t)k * c[b].sz;
                for (int i = 0; i < lx; i++) d[i] += kb[b] * row[i];
            }
        }
    for (int v = 0; v < nv; v++)
        sq__sand_visibility_plane(beta, lx, ly, nz, s->slab_gk, s->slab_gz1, (float)s->h,
                                  s->d.vis_heights_m[v], s->d.contrast, s->slab_vis + (size_t)v * lc);
    double mx[3] = {0.0, 0.0, 0.0}; /* the wall's height, the largest extinction, ... */
    for (size_t col = 0; col < lc; col++) {
        const int k0 = s->slab_gk[col];
        if (k0 < 0) continue;
        for (int k = nz - 1; k >= k0; k--)
            if (beta[(size_t)k * lc + col] >= (float)SQ_SAND_WALL_BETA) {
                mx[0] = fmax(mx[0], (k - k0 + 0.5) * s->h + (double)s->slab_gz1[col]);
                break;
            }
    }
    for (size_t q = 0; q < lc * (size_t)nz; q++) mx[1] = fmax(mx[1], (double)beta[q]);
    /* the station's wind: its largest, and at the observer's column (the slab holding it) */
    mx[2] = 0.0;
    for (int j = 0; j < ly; j++)
        for (int i = 0; i < lx; i++) mx[2] = fmax(mx[2], station_wind(s, s->grid, i, j));
    double w10 = 0.0;
    {
        int oi = (int)floor((s->d.observer_m[0] - s->origin[0]) / s->h),
            oj = (int)floor((s->d.observer_m[1] - s->origin[1]) / s->h);
        oi = (oi < 0 ? 0 : oi >= s->nx ? s->nx - 1 : oi) - s->lo[0];
        oj = (oj < 0 ? 0 : oj >= s->ny ? s->ny - 1 : oj) - s->lo[1];
        if (oi >= 0 && oi < lx && oj >= 0 && oj < ly) w10 = station_wind(s, s->grid, oi, oj);
    }
    sq_par_max_f64(mx, 3);
    sq_par_sum_f64(&w10, 1); /* one slab's value and zeros */
    s->wall_height_m = mx[0];
    s->sync_beta_max = mx[1];
    s->sync_w10[0] = w10;
    s->sync_w10[1] = mx[2];
    s->wall_seen_m = wall_seen_slabs(s, beta);
    /* the visibility planes of every slab, into the whole planes */
    const int nr = sq_par_size();
    int64_t cnt[64], *cn = nr > 64 ? (int64_t *)sq_alloc(s->ctx, (size_t)nr * sizeof(int64_t)) : cnt;
    float *all = s->vis_all;
    sq_result r = cn ? SQ_OK : SQ_ERR_OUT_OF_MEMORY;
    if (sq_par_agree(r) == SQ_OK && r == SQ_OK) {
        for (int q = 0; q < nr; q++) cn[q] = (int64_t)s->blocks[4 * q + 2] * s->blocks[4 * q + 3] * nv;
        r = sq_par_allgather_f32(s->slab_vis, cn, all);
        size_t off = 0;
        for (int q = 0; q < nr && r == SQ_OK; q++) {
            const int *bq = s->blocks + 4 * q;
            for (int v = 0; v < nv; v++)
                for (int j = 0; j < bq[3]; j++, off += (size_t)bq[2])
                    memcpy(s->vis[v] + (size_t)(j + bq[1]) * s->nx + bq[0], all + off,
                           (size_t)bq[2] * sizeof(float));
        }
    } else if (r == SQ_OK) {
        r = SQ_ERR_OUT_OF_MEMORY;
    }
    if (cn != cnt) sq_free(s->ctx, cn);
    if (r != SQ_OK) return r;
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(s, &b);
    s->sync_suspended_kg = b.suspended_kg;
    s->sync_max_wind = sq_grid_max_speed(s->grid);
    s->synced_step = s->step;
    if (!gather) return SQ_OK;
    /* rank 0 draws or writes this frame: the slabs' fields into its whole grid */
    r = gather_whole(s);
    s->derived_dirty = true;
    if (r == SQ_OK && s->whole && s->detail.enabled && s->detail_pending_n > 0) {
        /* display only: the detail follows the wind since the last gathered frame */
        const double t0 = sq_time_now();
        const double dt = s->detail_pending_s / s->detail_pending_n;
        for (int q = 0; q < s->detail_pending_n; q++)
            sq__sand_detail_advect(&s->detail, s->whole, dt, nt);
        s->stats.ms_detail += (sq_time_now() - t0) * 1e3;
    }
    s->detail_pending_s = 0.0;
    s->detail_pending_n = 0;
    return r;
}

static int cmp_f(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

/* Publishes the volume drawable and the near-field particles. */
int sq__sandstorm_drawables(sq_sandstorm *s, sq_drawable *out, int max)
{
    update_derived(s);
    int n = 0;
    if (max < 1 || (s->dist && !s->whole)) return 0; /* under mpirun: rank 0 draws */
    sq_drawable *d = &out[n++];
    memset(d, 0, sizeof *d);
    d->kind = SQ_DRAWABLE_VOLUME;
    d->name = "dust";
    sq_volume_view *v = &d->u.volume;
    if (s->grid) {
        v->density = s->density;
        v->nx = s->nx;
        v->ny = s->ny;
        v->nz = s->nz;
        v->origin_m = sq_v3((float)s->origin[0], (float)s->origin[1], (float)s->origin[2]);
        v->size_m = sq_v3((float)(s->nx * s->h), (float)(s->ny * s->h), (float)(s->nz * s->h));
        v->density_max = s->density_max;
        /* with the flow-following detail (the look of a haboob's head): the dust's edge
         * against clear air drawn as the sharp interface the 60 m cells blur */
        v->edge_sharpness = s->detail.enabled ? 1.0f : 0.0f;
        v->mirror_y_m = s->mirror_sides_m;
    } else {
        float beta = (float)((double)s->urban_conc * s->k_ext_total_550);
        for (int i = 0; i < 8; i++) s->urban_density[i] = beta;
        v->density = s->urban_density;
        v->nx = v->ny = v->nz = 2;
        v->origin_m = s->urban_origin;
        v->size_m = s->urban_size;
        v->density_max = beta;
    }
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = s->sigma_rel[c]; /* density is beta_ext at 550 nm */
        v->albedo[c] = s->albedo[c];
        v->g[c] = s->g[c];
    }
    v->version = s->version;
    if (s->np && s->have_camera && n < max) {
        /* optical depth per particle so that N particles in the region carry near_fraction of
         * the local extinction: n_p pi r^2 tau = f beta (SPEC §4; same optics as the volume) */
        const float R = (float)s->d.near_radius_m;
        const float vol = SQ_PI_F * R * R * 0.5f * R;
        const float np_density = (float)s->np / vol;
        for (int i = 0; i < s->np; i++) {
            sq_vec3 p = sq_v3(s->p_pos[3 * i], s->p_pos[3 * i + 1], s->p_pos[3 * i + 2]);
            float beta = s->grid ? 0.0f : (float)((double)s->urban_conc * s->k_ext_total_550);
            if (s->grid) {
                int ci = (int)(((double)p.x - s->origin[0]) / s->h),
                    cj = (int)(((double)p.y - s->origin[1]) / s->h),
                    ck = (int)(((double)p.z - s->origin[2]) / s->h);
                if (ci >= 0 && ci < s->nx && cj >= 0 && cj < s->ny && ck >= 0 && ck < s->nz)
                    beta = s->density[((size_t)ck * s->ny + cj) * s->nx + ci];
            }
            float r = s->p_radius[i];
            float tau = (float)s->d.near_fraction * beta / (np_density * SQ_PI_F * r * r);
            s->p_tau[i] = tau < 4.0f ? tau : 4.0f;
            sq_vec3 dd = sq_v3_sub(p, s->cam_pos);
            float dist = sqrtf(dd.x * dd.x + dd.y * dd.y);
            float a = s->p_age[i] / 1.5f, e = (R - dist) / (0.25f * R);
            a = a < 0 ? 0 : a > 1 ? 1 : a;
            e = e < 0 ? 0 : e > 1 ? 1 : e;
            s->p_fade[i] = a * a * (3 - 2 * a) * e * e * (3 - 2 * e);
        }
        sq_drawable *pd = &out[n++];
        memset(pd, 0, sizeof *pd);
        pd->kind = SQ_DRAWABLE_PARTICLES;
        pd->name = "dust-near";
        sq_particles_view *pv = &pd->u.particles;
        pv->count = s->np;
        pv->position = s->p_pos;
        pv->radius_m = s->p_radius;
        pv->rotation_rad = s->p_rot;
        pv->tau = s->p_tau;
        pv->fade = s->p_fade;
        for (int c = 0; c < 3; c++) {
            pv->sigma_rel[c] = s->sigma_rel[c];
            pv->albedo[c] = s->albedo[c];
        }
        pv->g = s->g[1];
        pv->sprite = SQ_SPRITE_PUFF;
        pv->softness_m = (float)(2.0 * s->d.near_particle_radius_m);
        pv->version = s->version;
    }
    return n;
}

void sq__sandstorm_observe(sq_sandstorm *s, const sq_camera *cam)
{
    bool first = !s->have_camera;
    s->cam_pos = cam->position_m;
    s->have_camera = true;
    if (first) step_near_field(s, 1e-3);
}

int sq__sandstorm_metrics(sq_sandstorm *s, sq_metric *out, int max)
{
    /* under mpirun: the frame's reductions (every rank computes them in frame_sync; a caller
     * that did not sync makes it here, collectively) */
    if (s->dist && s->synced_step != s->step) (void)sq__sandstorm_frame_sync(s, false);
    if (!s->dist) update_derived(s);
    int n = 0;
#define PUT(nm, val, un)                                                                       \
    do {                                                                                       \
        if (n < max) out[n++] = (sq_metric){nm, (double)(val), un};                           \
    } while (0)
    static const char *const vmin[] = {"visibility_min_h0_m", "visibility_min_h1_m",
                                       "visibility_min_h2_m", "visibility_min_h3_m"};
    static const char *const vmed[] = {"visibility_median_h0_m", "visibility_median_h1_m",
                                       "visibility_median_h2_m", "visibility_median_h3_m"};
    if (s->grid) {
        size_t cols = (size_t)s->nx * s->ny;
        float *tmp = (float *)malloc(cols * sizeof(float));
        for (int v = 0; v < s->d.vis_height_count && tmp; v++) {
            size_t m = 0;
            for (size_t c = 0; c < cols; c++)
                if (isfinite(s->vis[v][c])) tmp[m++] = s->vis[v][c];
            qsort(tmp, m, sizeof(float), cmp_f);
            PUT(vmin[v], m ? tmp[0] : NAN, "m");
            PUT(vmed[v], m ? tmp[m / 2] : NAN, "m");
        }
        free(tmp);
        sq_sandstorm_budget b;
        if (s->dist) {
            b = s->budget;
            b.suspended_kg = s->sync_suspended_kg;
        } else {
            sq_sandstorm_get_budget(s, &b);
        }
        PUT("dust_suspended_kg", b.suspended_kg, "kg");
        PUT("dust_emitted_kg", b.emitted_kg, "kg");
        PUT("dust_deposited_kg", b.deposited_kg, "kg");
        PUT("dust_outflow_kg", b.outflow_kg, "kg");
        PUT("dust_inflow_kg", b.inflow_kg, "kg");
        PUT("dust_emitted_share", b.emitted_kg + b.inflow_kg > 0.0
                                      ? b.emitted_kg / (b.emitted_kg + b.inflow_kg) : 1.0, "1");
        /* the visibility at the fixed observer (the first plane, 2 m by default) */
        int oi = (int)floor((s->d.observer_m[0] - s->origin[0]) / s->h),
            oj = (int)floor((s->d.observer_m[1] - s->origin[1]) / s->h);
        oi = oi < 0 ? 0 : oi >= s->nx ? s->nx - 1 : oi;
        oj = oj < 0 ? 0 : oj >= s->ny ? s->ny - 1 : oj;
        PUT("visibility_observer_m", s->vis[0][(size_t)oj * s->nx + oi], "m");
        /* the station's wind: 10 m above the ground at the observer, and the largest anywhere */
        double w10 = s->dist ? s->sync_w10[1] : 0.0;
        for (int j = 0; j < s->ny && !s->dist; j++)
            for (int i = 0; i < s->nx; i++) w10 = fmax(w10, station_wind(s, s->grid, i, j));
        PUT("wind_10m_observer_mps", s->dist ? s->sync_w10[0] : station_wind(s, s->grid, oi, oj), "m/s");
        PUT("max_wind_10m_mps", w10, "m/s");
        PUT("wall_height_m", s->wall_height_m, "m");
        PUT("wall_top_seen_m", s->wall_seen_m, "m");
        if (s->d.coldpool_delta_t_k > 0.0) {
            PUT("front_m", s->stats.front_m, "m");
            PUT("front_speed_mps", s->stats.front_speed_mps, "m/s");
        }
        const double vmax = s->dist ? s->sync_max_wind : sq_grid_max_speed(s->grid);
        if (vmax > 100.0 && !(s->warned & 1)) {
            s->warned |= 1;
            sq_log(s->ctx, SQ_LOG_WARN, "sandstorm",
                   "wind %.0f m/s at t = %g s is above 100 m/s, beyond any dust storm: check "
                   "wind.speed_mps, wave.pressure_amp_pa, coldpool.delta_t_k, coldpool.speed_mps",
                   vmax, s->time_s);
        }
        const double bmax = s->dist ? s->sync_beta_max : (double)s->density_max;
        const double cmax = s->k_ext_total_550 > 0.0 ? bmax / s->k_ext_total_550 : 0.0;
        if (cmax > 1.0 && !(s->warned & 2)) {
            s->warned |= 2;
            sq_log(s->ctx, SQ_LOG_WARN, "sandstorm",
                   "dust concentration ~%.2g kg/m3 at t = %g s is above 1 kg/m3, beyond any dust "
                   "storm: check surface.emission_coeff, dust.inflow_kg_m3", cmax, s->time_s);
        }
        PUT("max_wind_mps", vmax, "m/s");
        PUT("max_friction_velocity_mps", s->stats.max_u_star_mps, "m/s");
        PUT("emitting_fraction", s->stats.emitting_fraction, "1");
        PUT("pressure_residual", s->stats.pressure_residual, "1");
    } else {
        double beta = (double)s->urban_conc * s->k_ext_total_550 + SQ_SAND_BETA_AIR_550;
        double vis = log(1.0 / s->d.contrast) / beta;
        PUT(vmin[0], vis, "m");
        PUT("dust_concentration_kg_m3", s->urban_conc, "kg/m3");
        PUT("extinction_550_per_m", beta, "1/m");
    }
    PUT("mass_extinction_550_m2_per_g", s->k_ext_total_550 * 1e-3, "m2/g");
#undef PUT
    return n;
}

int sq__sandstorm_fields(sq_sandstorm *s, sq_named_field *out, int max)
{
    /* under mpirun: rank 0, from the slabs gathered at this frame (frame_sync with gather) */
    if (!s->grid || max < 6 + s->d.vis_height_count || (s->dist && !s->whole)) return 0;
    update_derived(s);
    size_t n = (size_t)s->nx * s->ny * s->nz;
    float *conc = s->export_buf[0], *u = s->export_buf[1], *v = s->export_buf[2],
          *w = s->export_buf[3], *T = s->export_buf[4];
    float *beta = s->export_buf[5];
    memset(conc, 0, n * sizeof(float));
    memset(beta, 0, n * sizeof(float));
    for (int b = 0; b < s->nbins; b++) {
        sq_field_view c = sq_grid_scalar_view(view_grid(s), b);
        const float kb = (float)s->k_ext[b][3];
        for (int k = 0; k < s->nz; k++)
            for (int j = 0; j < s->ny; j++)
                for (int i = 0; i < s->nx; i++) {
                    size_t id = ((size_t)k * s->ny + j) * s->nx + i;
                    float cv = sq_view_get(&c, i, j, k);
                    conc[id] += cv;
                    beta[id] += kb * cv; /* untapered, unlike the drawable */
                }
    }
    sq_field_view tv = sq_grid_scalar_view(view_grid(s), s->temp_idx);
    for (int k = 0; k < s->nz; k++)
        for (int j = 0; j < s->ny; j++)
            for (int i = 0; i < s->nx; i++) {
                size_t id = ((size_t)k * s->ny + j) * s->nx + i;
                sq_vec3 c = sq_grid_cell_velocity(view_grid(s), i, j, k);
                u[id] = c.x;
                v[id] = c.y;
                w[id] = c.z;
                T[id] = sq_view_get(&tv, i, j, k) - (float)(SQ_SAND_DRY_LAPSE * (k + 0.5) * s->h);
            }
    sq_vec3 o = sq_v3((float)(s->origin[0] + 0.5 * s->h), (float)(s->origin[1] + 0.5 * s->h),
                      (float)(s->origin[2] + 0.5 * s->h));
    sq_vec3 sp = sq_v3((float)s->h, (float)s->h, (float)s->h);
    const struct {
        const char *name, *units, *longn, *stdn;
        const float *data;
    } f[] = {{"dust_mass_concentration", "kg m-3", "mass concentration of suspended dust",
              "mass_concentration_of_dust_dry_aerosol_particles_in_air", conc},
             {"u", "m s-1", "eastward wind", "eastward_wind", u},
             {"v", "m s-1", "northward wind", "northward_wind", v},
             {"w", "m s-1", "upward air velocity", "upward_air_velocity", w},
             {"air_temperature", "K", "air temperature", "air_temperature", T},
             {"extinction_550", "m-1", "dust extinction coefficient at 550 nm",
              "volume_extinction_coefficient_in_air_due_to_ambient_aerosol_particles", beta}};
    int cnt = 0;
    for (int i = 0; i < 6 && cnt < max; i++)
        out[cnt++] = (sq_named_field){f[i].name, f[i].units, f[i].longn, f[i].stdn, f[i].data,
                                      s->nx, s->ny, s->nz, o, sp,
                                      sq_grid_solid(view_grid(s)), /* terrain and obstacles: no air */
                                      SQ_FIELD_LEVEL_ALTITUDE};
    /* visibility planes as 2D maps, each at its height above the terrain */
    for (int q = 0; q < s->d.vis_height_count && cnt < max; q++) {
        snprintf(s->vis_names[q], sizeof s->vis_names[q], "visibility_%gm", (double)s->d.vis_heights_m[q]);
        sq_vec3 ov = sq_v3(o.x, o.y, s->d.vis_heights_m[q]);
        out[cnt++] = (sq_named_field){s->vis_names[q], "m", "horizontal visibility (Koschmieder, 550 nm)",
                                      "visibility_in_air", s->vis[q], s->nx, s->ny, 1, ov, sp,
                                      NULL, SQ_FIELD_LEVEL_HEIGHT};
    }
    return cnt;
}

/* Visibility plane v (nx*ny, metres) for tests and tools; NULL if none. */
const float *sq__sandstorm_visibility_plane(sq_sandstorm *s, int v, int *nx, int *ny)
{
    update_derived(s);
    if (!s->grid || v < 0 || v >= s->d.vis_height_count) return NULL;
    *nx = s->nx;
    *ny = s->ny;
    return s->vis[v];
}

/* ---- live changes (the plug-in's apply_live, sandstorm_plugin.c) ------------------------------
 * d differs from s->d only in live keys: the wind forcing (inflow face), the emission threshold
 * u*_t = R H M u*_t0 (S0 eq. 2.32), the inflow dust, the visibility contrast and the urban dust.
 * The air, dust and clock stay; the inflow face takes the new wind at once and the interior
 * follows as the flow carries it. */
sq_result sq__sandstorm_apply_live(sq_sandstorm *s, const sq_sandstorm_desc *d)
{
    const sq_sandstorm_desc old = s->d;
    s->d = *d;
    s->u_star_t = (double)d->u_star_t0_mps * d->roughness_factor * d->moisture_factor *
                  d->compactness_factor;
    sq_result r = SQ_OK;
    if (s->grid) r = set_wind_inflow(s);
    if (r != SQ_OK) {
        s->d = old;
        s->u_star_t = (double)old.u_star_t0_mps * old.roughness_factor * old.moisture_factor *
                      old.compactness_factor;
        return r;
    }
    if (d->mode == SQ_SANDSTORM_URBAN) {
        int stage = (int)(s->time_s / d->urban_stage_s);
        if (stage >= d->urban_conc_count) stage = d->urban_conc_count - 1;
        s->urban_conc = d->urban_conc_kg_m3[stage < 0 ? 0 : stage];
        sq_vec3 lo, hi;
        sq_world_bounds(s->world, &lo, &hi);
        s->urban_size.z = (hi.z - lo.z) + (float)d->urban_height_m + 1.0f;
    }
    s->derived_dirty = true; /* visibility planes (contrast) and the drawables */
    s->version++;
    return SQ_OK;
}
