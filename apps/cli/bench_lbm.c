/* bench_lbm.c — `squall bench lbm --size 128 | --size 256x128x128 [--collision trt]`: the pure
 * D3Q15 wind step (fused collide + stream, AA pattern in place, periodic box, a gentle
 * sheared flow so the collision does real work). One JSON line: the common keys plus mlups,
 * size, bytes_per_cell_update (memory traffic of one cell update), roofline_mlups (what the
 * measured STREAM bandwidth allows at that traffic) and roofline_fraction (of ranks x that).
 * Under mpirun the lattice is split in slabs along z: mlups is then the whole lattice per step
 * of the slowest rank, per_rank lists each rank's cells, step time, throughput and bytes sent
 * per step (comm_bytes_per_step: all ranks together), and only rank 0 prints. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/lbm.h"
#include "squall/par.h"

typedef struct lbm_bench {
    sq_lbm *l;
    sq_result err;
} lbm_bench;

static int step(void *user)
{
    lbm_bench *b = (lbm_bench *)user;
    b->err = sq_lbm_step(b->l, 1);
    return b->err != SQ_OK;
}

static bool parse_size(const char *s, sq_dims *n)
{
    int a = 0, b = 0, c = 0;
    char tail;
    if (sscanf(s, "%dx%dx%d%c", &a, &b, &c, &tail) == 3) {
        *n = (sq_dims){a, b, c};
    } else if (sscanf(s, "%d%c", &a, &tail) == 1) {
        *n = (sq_dims){a, a, a};
    } else {
        return false;
    }
    return n->nx >= 1 && n->ny >= 1 && n->nz >= 1 && n->nx <= 4096 && n->ny <= 4096 &&
           n->nz <= 4096;
}

int sq_bench_lbm(const sq_bench_args *a)
{
    const char *size = sq_cli_value(a->argc, a->argv, "--size");
    if (!size) size = "128";
    sq_dims n;
    if (!parse_size(size, &n)) {
        sq_cli_error("--size %s: expected N or NXxNYxNZ with every axis in 1..4096", size);
        return SQ_EXIT_USAGE;
    }
    const char *cname = sq_cli_value(a->argc, a->argv, "--collision");
    sq_lbm_collision coll = SQ_LBM_COLLISION_TRT;
    if (cname) {
        if (strcmp(cname, "bgk") == 0)
            coll = SQ_LBM_COLLISION_BGK;
        else if (strcmp(cname, "trt") == 0)
            coll = SQ_LBM_COLLISION_TRT;
        else if (strcmp(cname, "smagorinsky") == 0)
            coll = SQ_LBM_COLLISION_SMAGORINSKY;
        else {
            sq_cli_error("--collision %s: expected bgk, trt or smagorinsky", cname);
            return SQ_EXIT_USAGE;
        }
    }
    sq_lbm_desc d;
    memset(&d, 0, sizeof d);
    d.cells = n;
    d.cell_size_m = 1;
    d.dt_s = 1;
    d.tau = 0.6;
    d.air_density_kgm3 = 1;
    d.max_wind_mps = 0.1;
    d.collision = coll;
    d.decompose = true; /* under mpirun: slabs along z, one per rank */
    lbm_bench b = {NULL, SQ_OK};
    sq_result r = sq_lbm_create(a->ctx, &d, &b.l);
    if (r != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    /* a sheared wind: u = 0.05 + 0.02 sin(2π z/nz), v = 0.01 cos(2π x/nx) */
    const size_t cells = (size_t)n.nx * n.ny * n.nz;
    float *ux = (float *)malloc(cells * sizeof(float));
    float *uy = (float *)malloc(cells * sizeof(float));
    if (!ux || !uy) {
        free(ux);
        free(uy);
        sq_lbm_destroy(b.l);
        sq_cli_error("out of memory for the initial wind");
        return SQ_EXIT_RUNTIME;
    }
    size_t c = 0;
    for (int k = 0; k < n.nz; k++)
        for (int j = 0; j < n.ny; j++)
            for (int i = 0; i < n.nx; i++, c++) {
                ux[c] = (float)(0.05 + 0.02 * sin(6.283185307179586 * k / n.nz));
                uy[c] = (float)(0.01 * cos(6.283185307179586 * i / n.nx));
            }
    r = sq_lbm_init_fields(b.l, NULL, ux, uy, NULL);
    free(ux);
    free(uy);
    if (r != SQ_OK) {
        sq_lbm_destroy(b.l);
        sq_cli_error("%s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    const uint64_t sent0 = sq_par_bytes_sent();
    const sq_bench_stats s = sq_bench_time(step, &b, a->warmup, a->reps);
    const double steps_done = (double)(a->warmup + s.reps);
    if (b.err != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        sq_lbm_destroy(b.l);
        return sq_cli_exit_code(b.err);
    }
    const sq_lbm_info in = sq_lbm_get_info(b.l);
    const double mlups = s.median_ms > 0 ? (double)cells / (s.median_ms * 1e-3) / 1e6 : (double)NAN;
    /* under mpirun: the lattice is split in z slabs; every rank reports its slab's cells and
     * step time and the bytes it sent per step, rank 0 prints the line. Total throughput:
     * the whole lattice per (slowest rank's) step. */
    const int nr = sq_par_size();
    char ranks_json[4096] = "";
    double total_mlups = mlups, comm_bytes = 0;
    if (nr > 1) {
        const int me = sq_par_rank();
        const double plane = (double)n.nx * n.ny;
        const double mine[3] = {plane * (double)((int64_t)(me + 1) * n.nz / nr -
                                                 (int64_t)me * n.nz / nr),
                                s.median_ms,
                                steps_done > 0 ? (double)(sq_par_bytes_sent() - sent0) /
                                                     steps_done : 0.0};
        const sq_bench_rank_keys keys = {"ms_per_step", "mlups", "bytes_sent_per_step"};
        double slowest = 0;
        if (sq_bench_per_rank(mine, &keys, ranks_json, sizeof ranks_json, &slowest,
                              &comm_bytes) == SQ_ERR_OUT_OF_MEMORY) {
            sq_lbm_destroy(b.l);
            sq_cli_error("%s", sq_last_error());
            return SQ_EXIT_RUNTIME;
        }
        total_mlups = slowest > 0 ? (double)cells / (slowest * 1e-3) / 1e6 : (double)NAN;
        if (me != 0) {
            sq_lbm_destroy(b.l);
            return SQ_EXIT_OK;
        }
    }
    const double bpc = in.bytes_per_cell_update;
    const double roof = a->stream_gbps * 1e9 / bpc / 1e6;
    char sz[64];
    snprintf(sz, sizeof sz, "%dx%dx%d", n.nx, n.ny, n.nz);
    sq_json j;
    sq_json_begin(&j);
    sq_bench_json_common(&j, "lbm", a, &s);
    sq_json_str(&j, "size", sz);
    sq_json_str(&j, "collision", sq_lbm_collision_name(coll));
    sq_json_num(&j, "mlups", total_mlups);
    sq_json_int(&j, "ranks", nr);
    if (nr > 1) {
        sq_json_str(&j, "decomposition", "slabs along z");
        sq_json_num(&j, "comm_bytes_per_step", comm_bytes);
        sq_json_raw(&j, "per_rank", ranks_json);
    }
    sq_json_num(&j, "bytes_per_cell_update", bpc);
    sq_json_num(&j, "roofline_mlups", roof);
    sq_json_num(&j, "roofline_fraction", roof > 0 ? total_mlups / (roof * nr) : (double)NAN);
    sq_json_num(&j, "memory_mib", (double)in.memory_bytes / 1048576.0);
    sq_json_end(&j, stdout);
    sq_lbm_destroy(b.l);
    return SQ_EXIT_OK;
}
