/* cases.h — prototypes of every bench/validate case function (see registry.c). */
#ifndef SQ_CLI_CASES_H
#define SQ_CLI_CASES_H

#include "cli.h"

int sq_bench_stream_case(const sq_bench_args *a);
/* helpers: add prototypes here */
int sq_validate_lock_exchange(int argc, char **argv);
int sq_validate_dam_break(int argc, char **argv);
int sq_bench_sph(const sq_bench_args *a);
int sq_bench_lbm(const sq_bench_args *a);
int sq_validate_lbm_cavity(int argc, char **argv);
int sq_bench_grid(const sq_bench_args *a);
int sq_bench_project(const sq_bench_args *a);
int sq_bench_render_volume(const sq_bench_args *a);
int sq_bench_sandstorm(const sq_bench_args *a);
int sq_bench_snowdrift(const sq_bench_args *a);
int sq_bench_wrf(const sq_bench_args *a);
int sq_bench_clouds(const sq_bench_args *a);
int sq_bench_snowcover(const sq_bench_args *a);

#endif
