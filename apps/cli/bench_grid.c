/* bench_grid.c — `squall bench grid`: one fluid step of the MAC-grid solver (MacCormack
 * advection of the face velocities + MGPCG projection, warm-started) on an N^3 box with a
 * smooth swirling wind, inflow/outflow sides, a terrain layer and an open top; plus the
 * MacCormack advection of two cell-centred scalars as the sandstorm will do. Prints one JSON
 * line with the per-stage medians. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/grid.h"

typedef struct grid_bench {
    sq_grid *g;
    double dt;
    double *t_adv, *t_proj, *t_scal;
    int rep, cap;
    sq_grid_project_stats last;
    sq_result err;
} grid_bench;

static void fill_wind(sq_grid *g, int n)
{
    const double tau = 6.283185307179586;
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = sq_grid_velocity_field(g, c);
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++)
                for (int i = 0; i < f->n.nx; i++) {
                    double x = (double)i / n, y = (double)j / n, z = (double)k / n;
                    double v = c == 0   ? 6.0 + 2.0 * sin(tau * y) * cos(tau * z)
                               : c == 1 ? 2.0 * sin(tau * x) * cos(2.0 * tau * z)
                                        : 1.0 * sin(tau * x) * sin(tau * y);
                    *sq_field3_at(f, i, j, k) = (float)v;
                }
    }
    for (int s = 0; s < 2; s++) {
        sq_field3 *f = sq_grid_scalar_field(g, s);
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++)
                    *sq_field3_at(f, i, j, k) = (float)(s == 0 ? (k < n / 4 ? 1.0 : 0.0)
                                                               : 300.0 + 0.01 * i);
    }
    sq_grid_apply_boundary(g);
}

static int step(void *user)
{
    grid_bench *b = (grid_bench *)user;
    double t0 = sq_time_now();
    b->err = sq_grid_advect_velocity(b->g, b->dt);
    double t1 = sq_time_now();
    if (b->err == SQ_OK) b->err = sq_grid_project(b->g, b->dt, &b->last);
    double t2 = sq_time_now();
    for (int s = 0; s < 2 && b->err == SQ_OK; s++) b->err = sq_grid_advect_scalar(b->g, s, b->dt);
    double t3 = sq_time_now();
    if (b->err != SQ_OK) return 1;
    if (b->rep < b->cap) {
        b->t_adv[b->rep] = (t1 - t0) * 1e3;
        b->t_proj[b->rep] = (t2 - t1) * 1e3;
        b->t_scal[b->rep] = (t3 - t2) * 1e3;
    }
    b->rep++;
    return 0;
}

int sq_bench_grid(const sq_bench_args *a)
{
    int n;
    if (!sq_cli_int(a->argc, a->argv, "--grid", 64, 8, 1024, &n)) return SQ_EXIT_USAGE;
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    d.cells = (sq_dims){n, n, n};
    d.cell_size_m = 4.0;
    d.scalar_count = 2;
    d.scalar_nonnegative = 1;
    d.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_INFLOW;
    d.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_OUTFLOW;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    grid_bench b;
    memset(&b, 0, sizeof b);
    sq_result r = sq_grid_create(a->ctx, &d, &b.g);
    if (r != SQ_OK) {
        sq_cli_error("bench grid: %s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    sq_grid_set_inflow_uniform(b.g, SQ_FACE_XMIN, 6.0, 0.0, 0.0);
    for (int j = 0; j < n; j++) /* a terrain layer with a ridge */
        for (int i = 0; i < n; i++) {
            int hgt = 1 + (int)(n / 16.0 * exp(-pow((i - n / 2) / (n / 8.0), 2)));
            for (int k = 0; k < hgt; k++) sq_grid_set_solid(b.g, i, j, k, true);
        }
    fill_wind(b.g, n);
    b.dt = 0.8 * sq_grid_cfl_dt(b.g, 1.0); /* CFL 0.8 */
    sq_grid_project(b.g, b.dt, NULL);     /* the initial field is not divergence-free */
    b.cap = a->warmup + a->reps + 1;
    b.t_adv = (double *)calloc((size_t)b.cap, sizeof(double));
    b.t_proj = (double *)calloc((size_t)b.cap, sizeof(double));
    b.t_scal = (double *)calloc((size_t)b.cap, sizeof(double));
    if (!b.t_adv || !b.t_proj || !b.t_scal) {
        free(b.t_adv);
        free(b.t_proj);
        free(b.t_scal);
        sq_grid_destroy(b.g);
        sq_cli_error("bench grid: out of memory");
        return SQ_EXIT_RUNTIME;
    }
    sq_bench_stats st = sq_bench_time(step, &b, a->warmup, a->reps);
    int code = SQ_EXIT_OK;
    if (b.err != SQ_OK) {
        sq_cli_error("bench grid: %s", sq_last_error());
        code = sq_cli_exit_code(b.err);
    } else {
        /* medians over the timed reps only */
        int w = a->warmup < b.rep ? a->warmup : b.rep, m = b.rep - w;
        if (m > b.cap - w) m = b.cap - w;
        sq_grid_info info = sq_grid_get_info(b.g);
        sq_json j;
        sq_json_begin(&j);
        sq_bench_json_common(&j, "grid", a, &st);
        sq_json_int(&j, "grid", n);
        sq_json_num(&j, "ms_advect", sq_bench_median(b.t_adv + w, m));
        sq_json_num(&j, "ms_project", sq_bench_median(b.t_proj + w, m));
        sq_json_num(&j, "ms_advect_2_scalars", sq_bench_median(b.t_scal + w, m));
        sq_json_num(&j, "residual", b.last.residual);
        sq_json_int(&j, "vcycles", b.last.iterations);
        sq_json_num(&j, "cfl", 0.8);
        sq_json_num(&j, "bytes_per_cell", (double)info.memory_bytes / ((double)n * n * n));
        sq_json_int(&j, "mg_levels", info.mg_levels);
        sq_json_end(&j, stdout);
    }
    free(b.t_adv);
    free(b.t_proj);
    free(b.t_scal);
    sq_grid_destroy(b.g);
    return code;
}
