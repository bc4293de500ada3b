/* bench_sandstorm.c — `squall bench sandstorm --grid 64|128|NXxNYxNZ [--world dunes|flat] [--detail M]`:
 * the full two-phase desert-sandstorm step (sq_sandstorm_step: MacCormack wind advection, dust
 * loading, buoyancy, helicity confinement, mixing-length diffusion, MGPCG projection to the
 * desc's tolerance 1e-3, emission, inflow dust, MacCormack transport of 4 dust bins and the
 * temperature, mass fix, settling with deposition) on a 2560 m wide domain over a dune or flat
 * world, with emission, inflow dust and confinement on. The step dt is a frame step at the
 * sandstorm's own CFL limit (0.95 x sq_sandstorm_max_stable_dt, so nothing is sub-stepped).
 * After a spin-up (--spinup, default 10 steps: the first projections of the Bernoulli
 * initial wind are not representative) and --warmup steps, --reps steps are timed (median,
 * min, max). One JSON line: the common keys plus the per-stage means over the timed steps from
 * sq_sandstorm_get_stats (ms_advect: wind and scalar advection; ms_forces: dust loading,
 * buoyancy, confinement; ms_diffuse; ms_project; ms_emission; ms_dust: inflow, outflow, mass
 * fix, settling; ms_detail: with --detail M, the flow-following detail's advection of its
 * noise coordinates, display only, amplitude M metres; the stats are read outside the timed
 * calls; --turbulence smagorinsky|tke: that closure instead of the mixing length, its cost in
 * ms_diffuse), the last projection's residual
 * and iterations, and the memory per cell. Under mpirun the grid is split in slabs along x
 * (docs/mpi.md): rank 0 prints the line, with the slowest rank's step time as ms_step_slowest,
 * the total throughput (all cells / slowest step), the bytes all ranks sent per step and a
 * per_rank list (cells, median ms per step, Mcells/s, bytes sent per step). SPEC §1.11 (step
 * recipe). */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/resource.h>

#include "cases.h"
#include "squall/par.h"
#include "squall/sandstorm.h"
#include "squall/world.h"

enum { ST_ADVECT, ST_FORCES, ST_DIFFUSE, ST_PROJECT, ST_EMISSION, ST_DUST, ST_DETAIL, ST_COUNT };

typedef struct sand_bench {
    sq_sandstorm *s;
    sq_result err;
} sand_bench;

static void stage_ms(const sq_sandstorm_stats *st, double out[ST_COUNT])
{
    out[ST_ADVECT] = st->ms_advect;
    out[ST_FORCES] = st->ms_forces;
    out[ST_DIFFUSE] = st->ms_diffuse;
    out[ST_PROJECT] = st->ms_project;
    out[ST_EMISSION] = st->ms_emission;
    out[ST_DUST] = st->ms_dust;
    out[ST_DETAIL] = st->ms_detail;
}

/* CPU time of this process (all its threads), ms: under mpirun on shared cores the wall time
 * includes waits for descheduled partners, the CPU time does not (an MPI rank that waits
 * polls, so waiting shows as CPU time too unless Open MPI yields) */
static double cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * ((double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec) +
           1e-3 * ((double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_usec);
}

/* one frame step at 0.95 of the CFL limit (never sub-stepped) */
static sq_result frame_step(sq_sandstorm *s)
{
    double dt = 0.95 * sq_sandstorm_max_stable_dt(s);
    if (!(dt > 0.0)) dt = 1.0;
    return sq_sandstorm_step(s, dt);
}

static int step(void *user)
{
    sand_bench *b = (sand_bench *)user;
    b->err = frame_step(b->s);
    return b->err != SQ_OK;
}

static bool parse_grid(const char *s, int n[3])
{
    int a = 0, b = 0, c = 0;
    char tail;
    if (sscanf(s, "%dx%dx%d%c", &a, &b, &c, &tail) == 3) {
        n[0] = a;
        n[1] = b;
        n[2] = c;
    } else if (sscanf(s, "%d%c", &a, &tail) == 1) {
        n[0] = n[1] = n[2] = a;
    } else {
        return false;
    }
    for (int q = 0; q < 3; q++)
        if (n[q] < 8 || n[q] > 1024) return false;
    return true;
}

int sq_bench_sandstorm(const sq_bench_args *a)
{
    const char *gs = sq_cli_value(a->argc, a->argv, "--grid");
    if (!gs) gs = "64";
    int n[3];
    if (!parse_grid(gs, n)) {
        sq_cli_error("--grid %s: expected N or NXxNYxNZ with every axis in 8..1024", gs);
        return SQ_EXIT_USAGE;
    }
    const char *wname = sq_cli_value(a->argc, a->argv, "--world");
    if (!wname) wname = "dunes";
    bool dunes = strcmp(wname, "dunes") == 0;
    if (!dunes && strcmp(wname, "flat") != 0) {
        sq_cli_error("--world %s: expected dunes or flat", wname);
        return SQ_EXIT_USAGE;
    }
    int spinup, detail_m;
    if (!sq_cli_int(a->argc, a->argv, "--spinup", 10, 0, 100000, &spinup)) return SQ_EXIT_USAGE;
    if (!sq_cli_int(a->argc, a->argv, "--detail", 0, 0, 10000, &detail_m)) return SQ_EXIT_USAGE;
    /* the closure (the scene's solver.turbulence): the mixing length unless asked */
    const char *tname = sq_cli_value(a->argc, a->argv, "--turbulence");
    static const char *const closures[3] = {"mixing-length", "smagorinsky", "tke"};
    int turbulence = 0;
    if (tname) {
        turbulence = -1;
        for (int q = 0; q < 3; q++)
            if (strcmp(tname, closures[q]) == 0) turbulence = q;
        if (turbulence < 0) {
            sq_cli_error("--turbulence %s: expected mixing-length, smagorinsky or tke", tname);
            return SQ_EXIT_USAGE;
        }
    }

    /* a domain 2560 m wide at any resolution (40 m cells at 64), over a 4 km world */
    const double h = 2560.0 / n[0];
    sq_world_desc wd;
    memset(&wd, 0, sizeof wd);
    wd.terrain.kind = dunes ? SQ_TERRAIN_DUNES : SQ_TERRAIN_FLAT;
    const double extent = h * (n[1] > n[0] ? n[1] : n[0]);
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = (float)(1.6 * extent);
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 257;
    wd.terrain.relief_m = 18.0f;
    wd.terrain.feature_m = 160.0f;
    wd.terrain.seed = 5;
    sq_world *world = NULL;
    sq_result r = sq_world_create(a->ctx, &wd, &world);
    if (r != SQ_OK) {
        sq_cli_error("bench sandstorm: world: %s", sq_last_error());
        return sq_cli_exit_code(r);
    }
    /* the desert-sandstorm preset's storm, without the wind ramp (a steady storm) */
    sq_sandstorm_desc d;
    memset(&d, 0, sizeof d);
    d.mode = SQ_SANDSTORM_DESERT;
    d.seed = 7;
    for (int q = 0; q < 3; q++) d.cells[q] = n[q];
    d.cell_size_m = h;
    d.wind_speed_mps = 18.26; /* C_B = rho U^2 / 2 = 200 Pa */
    d.roughness_m = 5e-4;
    d.median_radius_m = 4e-6;
    d.sigma_g = 2.0;
    d.bins = 4;
    d.inflow_dust_kg_m3 = 4e-4;
    d.inflow_dust_height_m = 250.0;
    d.inflow_dust_width_m = 700.0;
    d.u_star_t0_mps = 0.25;
    d.moisture_factor = 1.6;
    d.emission_coeff = 2e-4;
    d.surface_temperature_k = 310.0;
    d.lapse_k_per_m = 0.0098;
    d.buoyancy_gain = 1.0;
    d.confinement = 0.15;
    d.pressure_tolerance = 1e-3;
    d.detail_amplitude_m = detail_m;
    d.turbulence = turbulence;
    sand_bench b;
    memset(&b, 0, sizeof b);
    r = sq_sandstorm_create(a->ctx, &d, world, &b.s);
    if (r != SQ_OK) {
        sq_cli_error("bench sandstorm: %s", sq_last_error());
        sq_world_destroy(a->ctx, world);
        return sq_cli_exit_code(r);
    }
    for (int q = 0; q < spinup + a->warmup && r == SQ_OK; q++) r = frame_step(b.s);
    int code = SQ_EXIT_OK;
    if (r != SQ_OK) {
        sq_cli_error("bench sandstorm: spin-up: %s", sq_last_error());
        code = sq_cli_exit_code(r);
    } else {
        sq_sandstorm_stats s0, s1;
        sq_sandstorm_get_stats(b.s, &s0);
        const uint64_t meet0 = sq_par_meetings();
        const double cpu0 = cpu_ms();
        sq_bench_stats st = sq_bench_time(step, &b, 0, a->reps);
        const double cpu1 = cpu_ms();
        const uint64_t meet1 = sq_par_meetings();
        sq_sandstorm_get_stats(b.s, &s1);
        /* under mpirun: every rank's figures to rank 0 (collective, before any rank prints) */
        const int nr = sq_par_size(), me = sq_par_rank();
        char ranks_json[4096] = "";
        double slowest = st.median_ms, comm = 0.0;
        if (nr > 1 && b.err == SQ_OK) {
            const double nst = (double)(s1.steps - s0.steps);
            const double mine[3] = {(double)s1.slab_cells, st.median_ms,
                                    nst > 0 ? (double)(s1.bytes_exchanged - s0.bytes_exchanged) / nst : 0.0};
            const sq_bench_rank_keys keys = {"ms_step", "mcells_per_s", "bytes_sent_per_step"};
            (void)sq_bench_per_rank(mine, &keys, ranks_json, sizeof ranks_json, &slowest, &comm);
        }
        if (b.err != SQ_OK) {
            sq_cli_error("bench sandstorm: %s", sq_last_error());
            code = sq_cli_exit_code(b.err);
        } else if (me == 0) {
            const double steps = (double)(s1.steps - s0.steps);
            double m0[ST_COUNT], m1[ST_COUNT];
            stage_ms(&s0, m0);
            stage_ms(&s1, m1);
            const double cells = (double)n[0] * n[1] * n[2];
            char grid[64];
            snprintf(grid, sizeof grid, "%dx%dx%d", n[0], n[1], n[2]);
            static const char *const keys[ST_COUNT] = {"ms_advect",  "ms_forces",   "ms_diffuse",
                                                       "ms_project", "ms_emission", "ms_dust",
                                                       "ms_detail"};
            sq_json j;
            sq_json_begin(&j);
            sq_bench_json_common(&j, "sandstorm", a, &st);
            sq_json_str(&j, "grid", grid);
            sq_json_str(&j, "world", dunes ? "dunes" : "flat");
            sq_json_str(&j, "turbulence", closures[turbulence]);
            sq_json_num(&j, "cells", cells);
            for (int q = 0; q < ST_COUNT; q++)
                sq_json_num(&j, keys[q], steps > 0.0 ? (m1[q] - m0[q]) / steps : (double)NAN);
            sq_json_num(&j, "cpu_ms_step", steps > 0.0 ? (cpu1 - cpu0) / steps : (double)NAN);
            sq_json_num(&j, "pressure_residual", s1.pressure_residual);
            sq_json_int(&j, "pressure_iterations", s1.pressure_iterations);
            sq_json_num(&j, "max_wind_mps", s1.max_wind_mps);
            sq_json_num(&j, "bytes_per_cell", (double)sq_sandstorm_memory_bytes(&d) / cells);
            sq_json_int(&j, "ranks", nr);
            if (nr > 1) {
                sq_json_str(&j, "decomposition", n[0] >= n[1] ? "slabs along x" : "slabs along y");
                sq_json_num(&j, "ms_step_slowest", slowest);
                sq_json_num(&j, "mcells_per_s_total", slowest > 0 ? cells / (slowest * 1e-3) / 1e6 : (double)NAN);
                sq_json_num(&j, "comm_bytes_per_step", comm);
                sq_json_num(&j, "meetings_per_step", steps > 0.0 ? (double)(meet1 - meet0) / steps : 0.0);
                sq_json_raw(&j, "per_rank", ranks_json);
            }
            sq_json_end(&j, stdout);
        }
    }
    sq_sandstorm_destroy(b.s);
    sq_world_destroy(a->ctx, world);
    return code;
}
