/* cli.h — shared pieces of the squall command line: exit codes, option helpers, the JSON line
 * printer, the benchmark timing harness (median/min/max after warm-up, STREAM triad) and the
 * tables of `squall bench` and `squall validate` cases. Apps use only include/squall/. */
#ifndef SQ_CLI_H
#define SQ_CLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "squall/core.h"

enum { SQ_EXIT_OK = 0, SQ_EXIT_RUNTIME = 1, SQ_EXIT_USAGE = 2 };

#define sq__cli_set_error sq_set_error

/* Maps a library result to an exit code: input/usage problems -> 2, runtime -> 1. */
int sq_cli_exit_code(sq_result r);

/* Prints "squall: <msg>" on stderr as one line. */
void sq_cli_error(const char *fmt, ...) SQ_PRINTF(1, 2);

/* Option helpers over argv[0..argc): sq_cli_flag finds "--name"; sq_cli_value finds
 * "--name VALUE" or "--name=VALUE" and returns VALUE (NULL if absent). */
bool sq_cli_flag(int argc, char **argv, const char *name);
const char *sq_cli_value(int argc, char **argv, const char *name);
/* Parses an int/double option with a default; returns false (and prints an error naming the
 * option, value and rule) if present but malformed or outside [min, max]. */
bool sq_cli_int(int argc, char **argv, const char *name, int def, int min, int max, int *out);
bool sq_cli_double(int argc, char **argv, const char *name, double def, double min, double max,
                   double *out);

/* A context configured from the common options (--threads N, --quiet, --verbose) with a
 * stderr logger; its interrupt callback reads the flag of sq_cli_catch_interrupts. */
sq_result sq_cli_context(int argc, char **argv, sq_context **out);
/* Installs the SIGINT/SIGTERM handler: the first signal sets the flag (sq_cli_interrupted, the
 * context's interrupt callback) so that long stages stop cleanly; a second one ends at once. */
void sq_cli_catch_interrupts(void);
bool sq_cli_interrupted(void);
extern volatile int sq_cli_interrupted_flag;

/* ---- one JSON object per line ------------------------------------------------------------ */
typedef struct sq_json {
    char buf[8192];
    size_t len;
    int fields;
} sq_json;
void sq_json_begin(sq_json *j);
void sq_json_str(sq_json *j, const char *key, const char *value);
void sq_json_num(sq_json *j, const char *key, double value); /* NaN/inf -> null */
void sq_json_int(sq_json *j, const char *key, long long value);
void sq_json_bool(sq_json *j, const char *key, bool value);
void sq_json_raw(sq_json *j, const char *key, const char *raw_json);
void sq_json_end(sq_json *j, FILE *out); /* writes "}\n" and flushes */

/* ---- benchmark harness ------------------------------------------------------------------- */
typedef struct sq_bench_stats {
    double median_ms, min_ms, max_ms;
    int reps;
} sq_bench_stats;

/* Calls fn(user) `warmup` times untimed, then `reps` times timed; fn returns non-zero to abort
 * (the stats then hold reps = number completed). */
sq_bench_stats sq_bench_time(int (*fn)(void *user), void *user, int warmup, int reps);

/* Median of v[0..n) (sorts v in place); NaN for n <= 0. */
double sq_bench_median(double *v, int n);

/* Under mpirun (collective): every rank's (cells, ms per step, bytes sent per step) gathered on
 * every rank; json gets the array of per-rank objects {"rank", "cells", keys->ms, keys->rate
 * (Mcells/s of the rank's cells), keys->bytes}, *slowest_ms the slowest rank's ms and
 * *bytes_total the bytes of all ranks. */
typedef struct sq_bench_rank_keys {
    const char *ms, *rate, *bytes;
} sq_bench_rank_keys;
sq_result sq_bench_per_rank(const double mine[3], const sq_bench_rank_keys *keys, char *json,
                            size_t size, double *slowest_ms, double *bytes_total);

/* STREAM triad a[i] = b[i] + s*c[i] over arrays much larger than the caches, best of several
 * runs, in GB/s (counting 3 x 8 bytes per element, as STREAM does for doubles). */
double sq_bench_stream_triad_gbps(int threads);

typedef struct sq_bench_args {
    int argc;        /* options after the case name, e.g. --size 128 */
    char **argv;
    int threads;     /* --threads (0 = all) resolved to the actual count */
    int reps;        /* --reps, default 10 */
    int warmup;      /* --warmup, default 2 */
    double stream_gbps; /* measured in this run before the case */
    sq_context *ctx;
} sq_bench_args;

/* Adds the keys every bench line carries: case, threads, ms_per_step (median), min/max,
 * steps_per_s, stream_gbps, reps. */
void sq_bench_json_common(sq_json *j, const char *case_name, const sq_bench_args *a,
                          const sq_bench_stats *s);

/* ---- case tables (apps/cli/registry.c) --------------------------------------------------- */
typedef int (*sq_bench_fn)(const sq_bench_args *a); /* prints JSON lines, returns exit code */
typedef int (*sq_validate_fn)(int argc, char **argv); /* prints CSV, returns exit code */

typedef struct sq_cli_case {
    const char *name;
    const char *summary;
    const char *usage; /* options, for --help */
    int (*bench)(const sq_bench_args *a);
    int (*validate)(int argc, char **argv);
    const char *details; /* optional: one line per option, shown by `CASE --help` */
} sq_cli_case;

extern const sq_cli_case sq_cli_bench_cases[];    /* NULL-name terminated */
extern const sq_cli_case sq_cli_validate_cases[]; /* NULL-name terminated */

#endif
