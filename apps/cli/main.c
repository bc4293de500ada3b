/* main.c — `squall`: dispatch to the sub-commands. Exit codes: 0 success, 1 runtime failure,
 * 2 usage or input error. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "commands.h"
#include "squall/par.h"

typedef struct command {
    const char *name;
    int (*fn)(int argc, char **argv);
    const char *summary;
} command;

static const command commands[] = {
    {"render", sq_cmd_render, "simulate a scene and render it to MP4 / PNG frames"},
    {"simulate", sq_cmd_render, "the same loop without rendering: metrics and fields only"},
    {"visibility", sq_cmd_visibility, "visibility from dust concentration and size (Mie, Koschmieder)"},
    {"wrf", sq_cmd_wrf, "WRF output: wrf info FILE... | wrf export FILE... --time N -o OUT.nc"},
    {"scenes", sq_cmd_scenes, "list the built-in scene presets"},
    {"scene", sq_cmd_scene, "scene show NAME: print a preset as YAML to start from"},
    {"params", sq_cmd_params, "list every parameter of a layer or section with unit, default, range"},
#ifdef SQ_HAVE_VIEWER
    {"view", sq_cmd_view, "open a scene in a window: live simulation, camera, parameters"},
#endif
    {"info", sq_cmd_info, "version, OpenGL renderer, threads and compiled-in features"},
    {"bench", sq_cmd_bench, "benchmarks: JSON lines with timings and the STREAM bandwidth"},
    {"validate", sq_cmd_validate, "validation cases printing CSV for comparison with literature"},
};

static void usage(FILE *f)
{
    fprintf(f,
            "squall %s — physically based weather phenomena: simulation and rendering\n\n"
            "usage: squall COMMAND [options]   (squall COMMAND --help for details)\n\n"
            "commands:\n",
            sq_version());
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        fprintf(f, "  %-11s %s\n", commands[i].name, commands[i].summary);
    fprintf(f, "\nexamples:\n"
               "  squall render                       render the default demo to out/squall.mp4\n"
               "  squall render village-snowdrift -o snow.mp4 --size 1280x720 --duration 20\n"
               "  squall simulate desert-sandstorm --set output.metrics=out/storm.csv\n"
               "  squall scene show desert-sandstorm > my.yaml; squall render my.yaml\n"
               "  squall params sandstorm\n\n"
               "exit codes: 0 success, 1 runtime failure, 2 usage or input error\n");
}

/* OpenMP workers that busy-wait starve everything else on a shared or oversubscribed machine
 * (measured: `simulate desert-sandstorm --frames 24` 45 s spinning vs 2.1 s passive at load 10).
 * libgomp reads OMP_WAIT_POLICY at start-up, so unless the user chose a policy, squall re-runs
 * itself once with OMP_WAIT_POLICY=passive. `squall bench` keeps the environment as it is:
 * benchmarks are meant for a quiet machine (set OMP_WAIT_POLICY yourself if you like). */
static void prefer_passive_openmp(int argc, char **argv)
{
    if (getenv("OMP_WAIT_POLICY") || getenv("SQ_NO_REEXEC")) return;
    if (argc > 1 && strcmp(argv[1], "bench") == 0) return;
    if (setenv("OMP_WAIT_POLICY", "passive", 1) != 0) return;
    execv("/proc/self/exe", argv); /* returns only on failure: then run as we are */
}

/* Started by mpirun (Open MPI, MPICH / PMI): join the process group (docs/mpi.md). */
static bool under_mpirun(void)
{
    return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMI_SIZE") || getenv("PMIX_RANK");
}

static int run_command(int argc, char **argv);

int main(int argc, char **argv)
{
    prefer_passive_openmp(argc, argv);
    if (under_mpirun()) {
        if (!sq_par_compiled()) {
            if (getenv("OMPI_COMM_WORLD_RANK") && strcmp(getenv("OMPI_COMM_WORLD_RANK"), "0"))
                return SQ_EXIT_USAGE;
            sq_cli_error("started by mpirun, but this squall was built without MPI (configure "
                         "with -DSQ_WITH_MPI=ON and libopenmpi-dev installed)");
            return SQ_EXIT_USAGE;
        }
        if (sq_par_init(&argc, &argv) != SQ_OK) {
            sq_cli_error("%s", sq_last_error());
            return SQ_EXIT_RUNTIME;
        }
    }
    const int rc = run_command(argc, argv);
    sq_par_finalize();
    return rc;
}

static int run_command(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return SQ_EXIT_USAGE;
    }
    if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
        strcmp(argv[1], "help") == 0) {
        usage(stdout);
        return SQ_EXIT_OK;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("squall %s\n", sq_version());
        return SQ_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(argv[1], commands[i].name) == 0) return commands[i].fn(argc - 1, argv + 1);
    sq_cli_error("unknown command '%s' (see squall --help)", argv[1]);
    return SQ_EXIT_USAGE;
}
