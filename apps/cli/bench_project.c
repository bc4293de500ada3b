/* bench_project.c — `squall bench project --size 128x64x64`: the MAC-grid pressure projection
 * alone (MGPCG to the sandstorm's tolerance 1e-3, cold start) of a divergent swirling wind over
 * a ridge, inflow at x-, outflow at x+, open top. Each repetition refills the same divergent
 * wind (not timed) and projects it. Under mpirun the grid is split in slabs along the longer
 * horizontal axis (sq_grid_desc.decompose): ms_project is the slowest rank's, mcells_per_s the
 * whole grid per that time, per_rank lists each rank's cells, time, throughput and bytes sent
 * per projection (halo planes + its share of the coarse-level sums; comm_bytes_per_project: all
 * ranks together), and only rank 0 prints. One JSON line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/grid.h"
#include "squall/par.h"

typedef struct project_bench {
    sq_grid *g;
    int lo[3];
    sq_dims global;
    double dt;
    double *t;
    int rep, cap;
    sq_grid_project_stats last;
    sq_result err;
} project_bench;

/* the divergent wind, a function of the global face index (the same field at any rank count) */
static void fill_wind(project_bench *b)
{
    const double tau = 6.283185307179586;
    const sq_dims G = b->global;
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = sq_grid_velocity_field(b->g, c);
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++)
                for (int i = 0; i < f->n.nx; i++) {
                    const double x = (double)(i + b->lo[0]) / G.nx,
                                 y = (double)(j + b->lo[1]) / G.ny, z = (double)(k + b->lo[2]) / G.nz;
                    const double v = c == 0   ? 6.0 + 2.0 * sin(tau * y) * cos(tau * z)
                                     : c == 1 ? 2.0 * sin(tau * x) * cos(2.0 * tau * z)
                                              : 1.0 * sin(tau * x) * sin(tau * y);
                    *sq_field3_at(f, i, j, k) = (float)v;
                }
    }
    sq_grid_apply_boundary(b->g);
}

static int step(void *user)
{
    project_bench *b = (project_bench *)user;
    fill_wind(b);
    const double t0 = sq_time_now();
    b->err = sq_grid_project(b->g, b->dt, &b->last);
    const double t1 = sq_time_now();
    if (b->err != SQ_OK) return 1;
    if (b->rep < b->cap) b->t[b->rep] = (t1 - t0) * 1e3;
    b->rep++;
    return 0;
}

int sq_bench_project(const sq_bench_args *a)
{
    const char *size = sq_cli_value(a->argc, a->argv, "--size");
    if (!size) size = "128x64x64";
    int nx = 0, ny = 0, nz = 0;
    char tail;
    if (sscanf(size, "%dx%dx%d%c", &nx, &ny, &nz, &tail) != 3 || nx < 8 || ny < 8 || nz < 8 ||
        nx > 2048 || ny > 2048 || nz > 2048) {
        sq_cli_error("--size %s: expected NXxNYxNZ with every axis in 8..2048", size);
        return SQ_EXIT_USAGE;
    }
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    d.cells = (sq_dims){nx, ny, nz};
    d.cell_size_m = 4.0;
    d.tolerance = 1e-3;
    d.cold_start = true;
    d.boundary[SQ_FACE_XMIN] = SQ_BOUNDARY_INFLOW;
    d.boundary[SQ_FACE_XMAX] = SQ_BOUNDARY_OUTFLOW;
    d.boundary[SQ_FACE_ZMIN] = SQ_BOUNDARY_NO_SLIP;
    d.boundary[SQ_FACE_ZMAX] = SQ_BOUNDARY_OPEN;
    d.decompose = true; /* under mpirun: slabs along the longer horizontal axis */
    project_bench b;
    memset(&b, 0, sizeof b);
    sq_result r = sq_grid_create(a->ctx, &d, &b.g);
    if (r != SQ_OK) {
        sq_cli_error("bench project: %s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    (void)sq_grid_get_block(b.g, b.lo, &b.global);
    const sq_dims n = sq_grid_get_info(b.g).cells;
    if (sq_grid_get_desc(b.g).boundary[SQ_FACE_XMIN] == SQ_BOUNDARY_INFLOW)
        (void)sq_grid_set_inflow_uniform(b.g, SQ_FACE_XMIN, 6.0, 0.0, 0.0);
    uint8_t *mask = (uint8_t *)calloc((size_t)n.nx * n.ny * n.nz, 1);
    b.cap = a->warmup + a->reps + 1;
    b.t = (double *)calloc((size_t)b.cap, sizeof(double));
    if (!mask || !b.t) {
        free(mask);
        free(b.t);
        sq_grid_destroy(b.g);
        sq_cli_error("bench project: out of memory");
        return SQ_EXIT_RUNTIME;
    }
    for (int j = 0; j < n.ny; j++) /* a terrain layer with a ridge across x */
        for (int i = 0; i < n.nx; i++) {
            const double gi = i + b.lo[0];
            const int hgt = 1 + (int)(nz / 8.0 * exp(-pow((gi - nx / 2.0) / (nx / 8.0), 2)));
            for (int k = 0; k < hgt && k < n.nz; k++) mask[i + (size_t)n.nx * (j + (size_t)n.ny * k)] = 1;
        }
    r = sq_grid_set_solid_mask(b.g, mask);
    free(mask);
    b.dt = 0.8 * d.cell_size_m / 10.0; /* CFL 0.8 at 10 m/s */
    const uint64_t sent0 = sq_grid_bytes_exchanged(b.g);
    const sq_bench_stats st = r == SQ_OK ? sq_bench_time(step, &b, a->warmup, a->reps) : (sq_bench_stats){0};
    if (r != SQ_OK || b.err != SQ_OK) {
        sq_cli_error("bench project: %s", sq_last_error());
        free(b.t);
        sq_grid_destroy(b.g);
        return sq_cli_exit_code(r != SQ_OK ? r : b.err);
    }
    int w = a->warmup < b.rep ? a->warmup : b.rep, m = b.rep - w;
    if (m > b.cap - w) m = b.cap - w;
    const double ms = sq_bench_median(b.t + w, m);
    const double cells = (double)nx * ny * nz;
    const int nr = sq_par_size(), me = sq_par_rank();
    const double mine[3] = {(double)n.nx * n.ny * n.nz, ms,
                            b.rep > 0 ? (double)(sq_grid_bytes_exchanged(b.g) - sent0) / b.rep : 0.0};
    char ranks_json[4096] = "";
    double slowest = ms, comm = 0.0;
    if (nr > 1) {
        const sq_bench_rank_keys keys = {"ms_project", "mcells_per_s", "bytes_sent_per_project"};
        (void)sq_bench_per_rank(mine, &keys, ranks_json, sizeof ranks_json, &slowest, &comm);
    }
    if (me == 0) {
        sq_json j;
        sq_json_begin(&j);
        sq_bench_json_common(&j, "project", a, &st);
        sq_json_str(&j, "size", size);
        sq_json_num(&j, "ms_project", slowest);
        sq_json_num(&j, "mcells_per_s", slowest > 0 ? cells / (slowest * 1e-3) / 1e6 : (double)NAN);
        sq_json_int(&j, "cg_iterations", b.last.iterations);
        sq_json_num(&j, "residual", b.last.residual);
        sq_json_int(&j, "ranks", nr);
        if (nr > 1) {
            sq_json_str(&j, "decomposition", nx >= ny ? "slabs along x" : "slabs along y");
            sq_json_num(&j, "comm_bytes_per_project", comm);
            sq_json_raw(&j, "per_rank", ranks_json);
        }
        sq_json_end(&j, stdout);
    }
    free(b.t);
    sq_grid_destroy(b.g);
    return SQ_EXIT_OK;
}
