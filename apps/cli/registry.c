/* registry.c — the cases of `squall bench` and `squall validate`. One line per case;
 * implementations live in apps/cli/bench_<family>.c and apps/cli/validate_<family>.c. */
#include "cli.h"
#include "cases.h"

const sq_cli_case sq_cli_bench_cases[] = {
    {"stream", "STREAM triad memory bandwidth only", "", sq_bench_stream_case, NULL},
    /* helpers: add bench cases here, e.g. {"lbm", "...", "--size 128|256x128x128", sq_bench_lbm, NULL}, */
    {NULL, NULL, NULL, NULL, NULL},
};

const sq_cli_case sq_cli_validate_cases[] = {
    /* helpers: add validate cases here, e.g. {"lbm-cavity", "...", "--re 100 --n 64", NULL, sq_validate_lbm_cavity}, */
    {NULL, NULL, NULL, NULL, NULL},
};
