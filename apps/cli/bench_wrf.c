/* bench_wrf.c — `squall bench wrf [--file PATH]...`: the WRF reader on a wrfout series (default
 * the sample data/wrf/wrf_d01_allvars_cropped.nc under $SQ_SOURCE_DIR or the current
 * directory). One JSON line per measurement:
 *   read-all     open the files, read and derive every field of every stored time, close
 *                (ms_per_step = one whole pass; the budget is < 1 s for the sample)
 *   read-time    read and derive one stored time on an open series (alternating two times, so
 *                the cache never answers)
 *   interpolate  a time between two cached stored times (the per-frame cost of an animation)
 * Keys: the common ones plus files, nx, ny, nz, times, cells, mb_per_time (bytes read per time). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/wrf.h"

typedef struct wrf_bench {
    sq_context *ctx;
    const char *const *paths;
    int count;
    sq_wrf *w;
    int time_count;
    int next;
    double duration;
    sq_result err;
} wrf_bench;

static int read_all(void *user)
{
    wrf_bench *b = (wrf_bench *)user;
    sq_wrf *w = NULL;
    b->err = sq_wrf_open(b->ctx, b->paths, b->count, &w);
    if (b->err != SQ_OK) return 1;
    sq_wrf_info in;
    sq_wrf_get_info(w, &in);
    sq_wrf_state s;
    for (int t = 0; t < in.time_count && b->err == SQ_OK; t++)
        b->err = sq_wrf_read_index(w, t, &s);
    sq_wrf_close(w);
    return b->err != SQ_OK;
}

static int read_time(void *user)
{
    wrf_bench *b = (wrf_bench *)user;
    sq_wrf_state s;
    /* three distinct times in turn: the two-slot cache holds the previous two, so each call
     * reads from the file (with one stored time, the cache would answer) */
    b->next = (b->next + 1) % (b->time_count < 3 ? 1 : 3);
    b->err = sq_wrf_read_index(b->w, b->next, &s);
    return b->err != SQ_OK;
}

static int interpolate(void *user)
{
    wrf_bench *b = (wrf_bench *)user;
    sq_wrf_state s;
    b->next = (b->next + 1) % 7;
    const double t = b->duration > 0 ? b->duration * (0.05 + 0.01 * b->next) : 0.0;
    b->err = sq_wrf_read(b->w, t, &s);
    return b->err != SQ_OK;
}

int sq_bench_wrf(const sq_bench_args *a)
{
    const char *paths[64];
    int count = 0;
    for (int i = 0; i < a->argc; i++) {
        if (strcmp(a->argv[i], "--file") == 0 && i + 1 < a->argc && count < 64)
            paths[count++] = a->argv[++i];
        else if (strncmp(a->argv[i], "--file=", 7) == 0 && count < 64)
            paths[count++] = a->argv[i] + 7;
    }
    static char sample[1024];
    if (count == 0) {
        const char *src = getenv("SQ_SOURCE_DIR");
        snprintf(sample, sizeof sample, "%s/data/wrf/wrf_d01_allvars_cropped.nc",
                 src && *src ? src : ".");
        paths[count++] = sample;
    }
    wrf_bench b = {a->ctx, paths, count, NULL, 0, 0, 0.0, SQ_OK};
    b.err = sq_wrf_open(a->ctx, paths, count, &b.w);
    if (b.err != SQ_OK) {
        sq_cli_error("%s", sq_last_error());
        return sq_cli_exit_code(b.err);
    }
    sq_wrf_info in;
    sq_wrf_get_info(b.w, &in);
    b.time_count = in.time_count;
    b.duration = in.duration_s;
    const double cells = (double)in.nx * in.ny * in.nz;
    /* bytes read per stored time: 8 mass fields + species + 3 w-level fields + U, V, HGT */
    int species = 0;
    for (int s = 0; s < SQ_WRF_SPECIES_COUNT; s++) species += in.has_species[s];
    species += in.has_ice_number + in.has_rain_number;
    const double bytes = 4.0 * ((4 + species) * cells + 3.0 * in.nx * in.ny * (in.nz + 1) +
                                2.0 * cells + in.nx * in.ny);
    struct {
        const char *name;
        int (*fn)(void *);
    } cases[3] = {{"read-all", read_all}, {"read-time", read_time}, {"interpolate", interpolate}};
    int rc = SQ_EXIT_OK;
    for (int c = 0; c < 3; c++) {
        b.next = 0;
        if (c == 2) { /* prime the cache with the first two times */
            sq_wrf_state s;
            sq_wrf_read(b.w, b.duration * 0.05, &s);
        }
        sq_bench_stats st = sq_bench_time(cases[c].fn, &b, a->warmup, a->reps);
        if (b.err != SQ_OK) {
            sq_cli_error("%s", sq_last_error());
            rc = sq_cli_exit_code(b.err);
            break;
        }
        sq_json j;
        sq_json_begin(&j);
        char name[48];
        snprintf(name, sizeof name, "wrf-%s", cases[c].name);
        sq_bench_json_common(&j, name, a, &st);
        sq_json_str(&j, "file", paths[0]);
        sq_json_int(&j, "files", count);
        sq_json_int(&j, "nx", in.nx);
        sq_json_int(&j, "ny", in.ny);
        sq_json_int(&j, "nz", in.nz);
        sq_json_int(&j, "times", in.time_count);
        sq_json_num(&j, "cells", cells);
        sq_json_num(&j, "mb_per_time", bytes / 1e6);
        sq_json_end(&j, stdout);
    }
    sq_wrf_close(b.w);
    return rc;
}
