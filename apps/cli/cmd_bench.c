/* cmd_bench.c — `squall bench CASE [options]` and `squall validate CASE [options]`. Bench cases
 * print one JSON line per measurement, with the STREAM triad bandwidth measured in the same
 * run so results can be read as fractions of the memory-bandwidth roofline. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"

static const char *case_usage(const sq_cli_case *c)
{
    return c->usage ? c->usage : "";
}

static void list_cases(FILE *f, const sq_cli_case *cases)
{
    for (const sq_cli_case *c = cases; c->name; c++) {
        const char *u = case_usage(c);
        fprintf(f, "  %-16s %s%s%s\n", c->name, c->summary, *u ? "  options: " : "", u);
    }
}

static const sq_cli_case *find_case(const sq_cli_case *cases, const char *name)
{
    for (const sq_cli_case *c = cases; c->name; c++)
        if (strcmp(c->name, name) == 0) return c;
    return NULL;
}

int sq_cmd_bench(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0) {
        FILE *f = argc < 2 ? stderr : stdout;
        fprintf(f, "usage: squall bench CASE [--reps N] [--warmup N] [--threads N] [case options]\n\n"
                   "Prints one JSON line per measurement: case, threads, ms_per_step (median over "
                   "reps after warm-up),\nms_min, ms_max, steps_per_s, stream_gbps (STREAM triad "
                   "measured in the same run) and case-specific keys.\nPerformance is measured here, "
                   "never in tests. Run on a quiet machine.\n\ncases:\n");
        list_cases(f, sq_cli_bench_cases);
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    const sq_cli_case *c = find_case(sq_cli_bench_cases, argv[1]);
    if (!c) {
        sq_cli_error("unknown bench case '%s' (see squall bench --help)", argv[1]);
        return SQ_EXIT_USAGE;
    }
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("squall bench %s: %s\noptions: %s --reps N --warmup N --threads N\n", c->name,
               c->summary, case_usage(c));
        if (c->details) printf("%s", c->details);
        return SQ_EXIT_OK;
    }
    sq_bench_args a;
    memset(&a, 0, sizeof a);
    a.argc = argc - 2;
    a.argv = argv + 2;
    if (!sq_cli_int(argc, argv, "--reps", 10, 1, 100000, &a.reps) ||
        !sq_cli_int(argc, argv, "--warmup", 2, 0, 100000, &a.warmup))
        return SQ_EXIT_USAGE;
    if (sq_cli_context(argc, argv, &a.ctx) != SQ_OK) return SQ_EXIT_USAGE;
    a.threads = sq_context_threads(a.ctx);
    a.stream_gbps = sq_bench_stream_triad_gbps(a.threads);
    int rc = c->bench(&a);
    sq_context_destroy(a.ctx);
    return rc;
}

int sq_cmd_validate(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0) {
        FILE *f = argc < 2 ? stderr : stdout;
        fprintf(f, "usage: squall validate CASE [options]\n\nRuns a validation case and prints CSV "
                   "(header line, then rows) for comparison with the literature.\n\ncases:\n");
        list_cases(f, sq_cli_validate_cases);
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    const sq_cli_case *c = find_case(sq_cli_validate_cases, argv[1]);
    if (!c) {
        sq_cli_error("unknown validation case '%s' (see squall validate --help)", argv[1]);
        return SQ_EXIT_USAGE;
    }
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("squall validate %s: %s\noptions: %s\n", c->name, c->summary, case_usage(c));
        if (c->details) printf("%s", c->details);
        return SQ_EXIT_OK;
    }
    return c->validate(argc - 2, argv + 2);
}
