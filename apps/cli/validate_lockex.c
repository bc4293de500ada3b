/* validate_lockex.c — `squall validate lock-exchange [--n 32] [--json]`: the full-depth
 * lock-exchange gravity current on the grid solver that carries the sandstorm (include/squall/
 * grid.h: MacCormack advection of velocity and potential temperature, Boussinesq buoyancy
 * g (θ − θ0)/θ0 on the air, MGPCG projection; the sandstorm's stages in its order). A channel of
 * depth H and length 8H (free-slip walls, periodic across a 4-cell slab) holds cold air
 * (θ0 − ΔT) left of the lock at x = 4H and warm air (θ0) right of it; at t = 0 the lock is
 * removed. The cold current runs along the floor with front speed U = Fr √(g′H), g′ = g ΔT/θ0.
 * Theory: Benjamin (1968, J. Fluid Mech. 31, 209–248) — the energy-conserving current fills
 * half the depth and Fr = 1/2; laboratory full-depth lock exchanges: Fr ≈ 0.5 at high
 * Reynolds number (Shin, Dalziel & Linden 2004, J. Fluid Mech. 521, 1–34, their Fig. and §4:
 * U = ½√(g′H) for the full-depth release; Keulegan 1958 ≈ 0.47 at lower Re).
 * Prints CSV t_s,front_m (front: the floor-level crossing of θ0 − ΔT/2, linearly interpolated
 * between cell centres, measured from the lock); --json prints one summary line instead: the
 * front speed fitted by least squares over the constant-speed phase (front between 0.5 H and
 * 3 H from the lock, before the end wall), Fr = U/√(g′H), and its error against 1/2.
 * --closure smagorinsky adds the Smagorinsky–Lilly subgrid closure (grid.h
 * sq_grid_diffuse_sgs: eddy viscosity and diffusivity of the wind and θ, stratified by θ; the
 * walls stay free-slip) after the buoyancy, as the sandstorm's solver.turbulence does;
 * --closure tke Deardorff's TKE closure instead (grid_tke.c; e a second scalar, from 0).
 * --confinement EPS adds the sandstorm's vorticity confinement (solver.confinement: the
 * helicity-adaptive form, or Fedkiw's constant-eps one with --plain-confinement) after the
 * buoyancy, in the sandstorm's order. The helicity u·ω vanishes in a flow without variation
 * across the slab, so to see what the helicity-adaptive form does --spanwise A varies the cold
 * side's deficit across the slab as ΔT (1 + A cos(2π y / W)) (mean ΔT; W the slab's width of
 * --width cells, default 4), as the haboob's coldpool.spanwise_variation does. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/grid.h"
#include "squall/sqmath.h"

#define LOCKEX_FR_THEORY 0.5 /* Benjamin 1968; Shin, Dalziel & Linden 2004 */

/* Floor-level front position (m from the lock): the last crossing of theta_mid going right
 * along the bottom row of cells, averaged over the slab. */
static double front_position(const sq_grid *g, int nx, int ny, double h, double theta_mid)
{
    sq_field_view t = sq_grid_scalar_view((sq_grid *)g, 0);
    double sum = 0.0;
    for (int j = 0; j < ny; j++) {
        double x = 0.0;
        for (int i = 0; i + 1 < nx; i++) {
            const double a = sq_view_get(&t, i, j, 0), b = sq_view_get(&t, i + 1, j, 0);
            if (a < theta_mid && b >= theta_mid) x = (i + 0.5 + (theta_mid - a) / (b - a)) * h;
        }
        sum += x;
    }
    return sum / ny - 0.5 * nx * h;
}

int sq_validate_lock_exchange(int argc, char **argv)
{
    int nz, ny;
    double H, dT, theta0 = 300.0, cfl, t_end_nd, eps, span;
    if (!sq_cli_int(argc, argv, "--n", 32, 8, 256, &nz) ||
        !sq_cli_double(argc, argv, "--depth", 1000.0, 0.01, 1e5, &H) ||
        !sq_cli_double(argc, argv, "--delta-t", 3.0, 0.01, 30.0, &dT) ||
        !sq_cli_double(argc, argv, "--cfl", 0.5, 0.05, 2.0, &cfl) ||
        !sq_cli_double(argc, argv, "--t-end", 7.0, 1.0, 100.0, &t_end_nd) ||
        !sq_cli_double(argc, argv, "--confinement", 0.0, 0.0, 2.0, &eps) ||
        !sq_cli_double(argc, argv, "--spanwise", 0.0, 0.0, 0.9, &span) ||
        !sq_cli_int(argc, argv, "--width", 4, 1, 256, &ny))
        return SQ_EXIT_USAGE;
    const bool json = sq_cli_flag(argc, argv, "--json");
    const bool plain = sq_cli_flag(argc, argv, "--plain-confinement");
    const char *closure = sq_cli_value(argc, argv, "--closure");
    const bool tke = closure && strcmp(closure, "tke") == 0;
    const bool sgs = tke || (closure && strcmp(closure, "smagorinsky") == 0);
    if (closure && !sgs && strcmp(closure, "none") != 0) {
        sq_cli_error("validate lock-exchange: --closure '%s': must be none, smagorinsky or tke",
                     closure);
        return SQ_EXIT_USAGE;
    }
    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) return SQ_EXIT_USAGE;
    const int nx = 8 * nz;
    const double h = H / nz, gr = 9.81, gp = gr * dT / theta0, c = sqrt(gp * H);
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    d.cells = (sq_dims){nx, ny, nz};
    d.cell_size_m = h;
    d.boundary[SQ_FACE_YMIN] = d.boundary[SQ_FACE_YMAX] = SQ_BOUNDARY_PERIODIC;
    d.scalar_count = tke ? 2 : 1; /* theta, and the subgrid energy e of the TKE closure */
    d.scalar_nonnegative = tke ? 2u : 0u;
    d.tolerance = 1e-4;
    sq_grid *g = NULL;
    sq_result r = sq_grid_create(ctx, &d, &g);
    float *tref = (float *)malloc((size_t)nz * sizeof(float));
    if (r != SQ_OK || !tref) {
        sq_cli_error("validate lock-exchange: %s", r != SQ_OK ? sq_last_error() : "out of memory");
        free(tref);
        sq_grid_destroy(g);
        sq_context_destroy(ctx);
        return r != SQ_OK ? sq_cli_exit_code(r) : SQ_EXIT_RUNTIME;
    }
    for (int k = 0; k < nz; k++) tref[k] = (float)theta0;
    sq_field3 *T = sq_grid_scalar_field(g, 0);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                *sq_field3_at(T, i, j, k) =
                    (float)(i < nx / 2
                                ? theta0 - dT * (1.0 + span * cos(2.0 * SQ_PI * (j + 0.5) / ny))
                                : theta0);
    sq_grid_apply_boundary(g);

    if (!json) printf("t_s,front_m\n");
    const double t_end = t_end_nd * H / c, dt_max = cfl * h / c;
    double t = 0.0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    int nfit = 0;
    while (r == SQ_OK && t < t_end - 1e-9) {
        const double front = front_position(g, nx, ny, h, theta0 - 0.5 * dT);
        if (!json) printf("%.3f,%.3f\n", t, front);
        if (front >= 0.5 * H && front <= 3.0 * H) {
            sx += t;
            sy += front;
            sxx += t * t;
            sxy += t * front;
            nfit++;
        }
        if (front >= 3.9 * H) break; /* at the end wall */
        double vmax = sq_grid_max_speed(g);
        double dt = vmax > 1e-9 ? fmin(dt_max, cfl * h / vmax) : dt_max;
        if (t + dt > t_end) dt = t_end - t;
        r = sq_grid_advect_velocity(g, dt);
        if (r == SQ_OK) r = sq_grid_add_buoyancy(g, 0, tref, 1.0, gr, dt);
        if (r == SQ_OK && eps > 0.0) r = sq_grid_confine_vorticity(g, eps, !plain, dt);
        if (r == SQ_OK && sgs) {
            const sq_grid_sgs_desc sd = {.closure = tke ? SQ_SGS_TKE : SQ_SGS_SMAGORINSKY,
                                         .stratified = true, .theta_idx = 0, .gravity_mps2 = gr,
                                         .tke_idx = 1};
            r = sq_grid_diffuse_sgs(g, &sd, dt);
        }
        if (r == SQ_OK) r = sq_grid_project(g, dt, NULL);
        if (r == SQ_OK) r = sq_grid_advect_scalars(g, dt);
        if (r == SQ_OK) r = sq_grid_check_finite(g, (int64_t)(t / dt));
        t += dt;
    }
    int code = SQ_EXIT_OK;
    if (r != SQ_OK) {
        sq_cli_error("validate lock-exchange: %s", sq_last_error());
        code = sq_cli_exit_code(r);
    } else if (nfit < 3) {
        sq_cli_error("validate lock-exchange: the front never ran from 0.5 H to 3 H "
                     "(%d samples; raise --t-end)", nfit);
        code = SQ_EXIT_RUNTIME;
    } else {
        const double U = (nfit * sxy - sx * sy) / (nfit * sxx - sx * sx);
        const double Fr = U / c, err = Fr / LOCKEX_FR_THEORY - 1.0;
        if (json) {
            sq_json j;
            sq_json_begin(&j);
            sq_json_str(&j, "case", "lock-exchange");
            sq_json_str(&j, "closure", tke ? "tke" : sgs ? "smagorinsky" : "none");
            sq_json_num(&j, "confinement", eps);
            sq_json_bool(&j, "plain_confinement", plain);
            sq_json_num(&j, "spanwise", span);
            sq_json_int(&j, "ny", ny);
            sq_json_int(&j, "nz", nz);
            sq_json_int(&j, "nx", nx);
            sq_json_num(&j, "cell_m", h);
            sq_json_num(&j, "depth_m", H);
            sq_json_num(&j, "delta_t_k", dT);
            sq_json_num(&j, "reduced_gravity_mps2", gp);
            sq_json_num(&j, "front_speed_mps", U);
            sq_json_num(&j, "froude", Fr);
            sq_json_num(&j, "froude_theory", LOCKEX_FR_THEORY);
            sq_json_num(&j, "relative_error", err);
            sq_json_bool(&j, "within_10_percent", fabs(err) <= 0.10);
            sq_json_int(&j, "fit_samples", nfit);
            sq_json_end(&j, stdout);
        }
        fprintf(stderr, "lock-exchange: H = %g m, dT = %g K, %d x %d x %d cells, confinement %g%s, "
                "spanwise %g: front speed %.3f m/s, Fr = %.3f (theory %.2f, %+.1f %%)\n", H, dT,
                nx, ny, nz, eps, plain ? " (plain)" : "", span, U, Fr, LOCKEX_FR_THEORY,
                100.0 * err);
    }
    free(tref);
    sq_grid_destroy(g);
    sq_context_destroy(ctx);
    return code;
}
