/* cmd_bench.c — `squall bench CASE [options]` and `squall validate CASE [options]`. Bench cases
 * print one JSON line per measurement, with the STREAM triad bandwidth measured in the same
 * run so results can be read as fractions of the memory-bandwidth roofline. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"

/* Full option lists and descriptions of bench cases whose registry line (registry.c) gives only
 * the common options; `squall bench --help` shows the option list, `squall bench CASE --help`
 * both. */
typedef struct bench_help {
    const char *name, *usage, *details;
} bench_help;

static const bench_help bench_helps[] = {
    {"render-volume",
     "--width 1280 --height 720 --size 128 --slices 128 --light 256 --particles 100000 "
     "--only volume|particles|base",
     "  --width W, --height H  frame size in pixels (default 1280 x 720; 16..16384)\n"
     "  --size N               dust volume of N^3 cells (default 128; 4..1024), fBm noise\n"
     "  --slices K             half-angle slices through the volume (default 128; 1..4096)\n"
     "  --light L              light-buffer texels per side (default 256; 8..4096); the light\n"
     "                         array holds one L^2 RGBA16F layer per slice (128 slices at 256:\n"
     "                         68 MB) and is swept in chunks above 256 MB (or a quarter of\n"
     "                         the context's memory limit, 80 % of RAM by default)\n"
     "  --particles P          soft particles in the particle configuration (default 100000)\n"
     "  --only WHAT            measure one configuration: volume (the dust volume alone),\n"
     "                         particles (the soft particles alone) or base (sky and terrain\n"
     "                         only: the base renderer's share); default: all three, one JSON\n"
     "                         line each\n"
     "Each frame is draw + 8-bit read-back (which waits for the GL work). The JSON carries the\n"
     "GL renderer string: figures from llvmpipe (CPU) and from a GPU are not comparable.\n"},
    {NULL, NULL, NULL},
};

static const bench_help *find_help(const char *name)
{
    for (const bench_help *h = bench_helps; h->name; h++)
        if (strcmp(h->name, name) == 0) return h;
    return NULL;
}

static const char *case_usage(const sq_cli_case *c, bool bench)
{
    const bench_help *h = bench ? find_help(c->name) : NULL;
    return h ? h->usage : (c->usage ? c->usage : "");
}

static void list_cases(FILE *f, const sq_cli_case *cases, bool bench)
{
    for (const sq_cli_case *c = cases; c->name; c++) {
        const char *u = case_usage(c, bench);
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
        list_cases(f, sq_cli_bench_cases, true);
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    const sq_cli_case *c = find_case(sq_cli_bench_cases, argv[1]);
    if (!c) {
        sq_cli_error("unknown bench case '%s' (see squall bench --help)", argv[1]);
        return SQ_EXIT_USAGE;
    }
    if (sq_cli_flag(argc, argv, "--help")) {
        const bench_help *h = find_help(c->name);
        printf("squall bench %s: %s\noptions: %s --reps N --warmup N --threads N\n", c->name,
               c->summary, case_usage(c, true));
        if (h && h->details) printf("%s", h->details);
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
        list_cases(f, sq_cli_validate_cases, false);
        return argc < 2 ? SQ_EXIT_USAGE : SQ_EXIT_OK;
    }
    const sq_cli_case *c = find_case(sq_cli_validate_cases, argv[1]);
    if (!c) {
        sq_cli_error("unknown validation case '%s' (see squall validate --help)", argv[1]);
        return SQ_EXIT_USAGE;
    }
    if (sq_cli_flag(argc, argv, "--help")) {
        printf("squall validate %s: %s\noptions: %s\n", c->name, c->summary, c->usage ? c->usage : "");
        return SQ_EXIT_OK;
    }
    return c->validate(argc - 2, argv + 2);
}
