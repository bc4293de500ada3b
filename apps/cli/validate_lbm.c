/* validate_lbm.c — `squall validate lbm-cavity --re 100|400|1000 --n N [--lid-lu 0.05]`:
 * the 2-D lid-driven cavity on the D3Q15 solver (an n × n × 1 slice, periodic in z, TRT,
 * half-way bounce-back walls, Ladd's moving-wall rule on the lid) run to steady state.
 * Prints CSV: y, u(x=½, y) then x, v(x, y=½), lengths in cavity sizes and velocities in lid
 * speeds, one row per cell centre — the columns of Ghia, Ghia & Shin (1982), Tables I and II. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/lbm.h"

int sq_validate_lbm_cavity(int argc, char **argv)
{
    double re = 100, lid = 0.05;
    int n = 64, max_steps = 0;
    if (!sq_cli_double(argc, argv, "--re", 100, 1, 20000, &re) ||
        !sq_cli_int(argc, argv, "--n", 64, 8, 1024, &n) ||
        !sq_cli_double(argc, argv, "--lid-lu", 0.05, 0.001, 0.15, &lid) ||
        !sq_cli_int(argc, argv, "--max-steps", 4000000, 1000, 100000000, &max_steps))
        return SQ_EXIT_USAGE;
    sq_context *ctx = NULL;
    sq_result r = sq_cli_context(argc, argv, &ctx);
    if (r != SQ_OK) return SQ_EXIT_USAGE;
    sq_lbm_desc d;
    memset(&d, 0, sizeof d);
    d.cells = (sq_dims){n, n, 1};
    d.cell_size_m = 1;
    d.dt_s = 1;
    d.air_density_kgm3 = 1;
    d.tau = 0.5 + 3.0 * lid * n / re; /* Re = U L / ν in lattice units */
    d.collision = SQ_LBM_COLLISION_TRT;
    d.bc[SQ_LBM_FACE_XMIN] = d.bc[SQ_LBM_FACE_XMAX] = SQ_LBM_BC_WALL;
    d.bc[SQ_LBM_FACE_YMIN] = d.bc[SQ_LBM_FACE_YMAX] = SQ_LBM_BC_WALL;
    d.wall_velocity_mps[SQ_LBM_FACE_YMAX][0] = lid;
    sq_lbm *l = NULL;
    r = sq_lbm_create(ctx, &d, &l);
    if (r != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        sq_context_destroy(ctx);
        return sq_cli_exit_code(r);
    }
    float *prev = (float *)calloc((size_t)2 * n * n, sizeof(float));
    if (!prev) {
        sq_lbm_destroy(l);
        sq_context_destroy(ctx);
        sq_cli_error("out of memory");
        return SQ_EXIT_RUNTIME;
    }
    /* steady state: the largest change of u, v over 1000 steps below 1e-6 lid speeds (float
     * round-off keeps a noise floor near 1e-7) */
    sq_lbm_views v;
    int steps = 0;
    double change = INFINITY;
    const int chunk = 1000;
    while (steps < max_steps) {
        r = sq_lbm_step(l, chunk);
        if (r == SQ_OK) r = sq_lbm_get_views(l, &v);
        if (r != SQ_OK) {
            sq_cli_error("%s", sq_last_error());
            free(prev);
            sq_lbm_destroy(l);
            sq_context_destroy(ctx);
            return sq_cli_exit_code(r);
        }
        steps += chunk;
        change = 0;
        for (int c = 0; c < n * n; c++)
            for (int a = 0; a < 2; a++) {
                const float u = v.u[a].data[c];
                change = fmax(change, fabs((double)u - (double)prev[a * n * n + c]));
                prev[a * n * n + c] = u;
            }
        if (change < 1e-6 * lid) break;
    }
    sq_log(ctx, SQ_LOG_INFO, "validate",
           "lbm-cavity Re %g n %d tau %.5f: %d steps, last change %.2e lid speeds", re, n, d.tau,
           steps, change / lid);
    if (change >= 1e-6 * lid)
        sq_log(ctx, SQ_LOG_WARN, "validate", "not converged after %d steps (--max-steps)", steps);
    printf("y,u,x,v\n");
    const int h = n / 2;
    for (int j = 0; j < n; j++) {
        /* centre lines: average of the two middle rows/columns for even n */
        const int i0 = n % 2 ? h : h - 1, i1 = h;
        const double u =
            0.5 * ((double)sq_view_get(&v.u[0], i0, j, 0) + (double)sq_view_get(&v.u[0], i1, j, 0));
        const double w =
            0.5 * ((double)sq_view_get(&v.u[1], j, i0, 0) + (double)sq_view_get(&v.u[1], j, i1, 0));
        const double pos = (j + 0.5) / n;
        printf("%.6f,%.6f,%.6f,%.6f\n", pos, u / lid, pos, w / lid);
    }
    free(prev);
    sq_lbm_destroy(l);
    sq_context_destroy(ctx);
    return SQ_EXIT_OK;
}
