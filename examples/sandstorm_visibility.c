/* sandstorm_visibility.c — step a sandstorm headless and print how far one can see.
 *
 * The smallest complete Squall program: a context, a world (flat desert), one phenomenon made
 * through the generic handle of squall/phenomenon.h from "key=value" settings (the same keys as
 * `squall params sandstorm` and a scene file's layer), stepped for a minute of simulated time,
 * and its metrics read by name with their units. No GPU and no files are needed.
 *
 * Build: see examples/CMakeLists.txt (find_package(Squall)) or
 *        cc -std=c11 sandstorm_visibility.c $(pkg-config --cflags --libs squall)
 * Run:   ./sandstorm_visibility [seconds]        (default 60) */
#include <stdio.h>
#include <stdlib.h>

#include <squall/squall.h>

/* Every Squall call that can fail returns sq_result; the reason is in sq_last_error(). */
static int fail(const char *what)
{
    fprintf(stderr, "sandstorm_visibility: %s: %s\n", what, sq_last_error());
    return 1;
}

int main(int argc, char **argv)
{
    const double duration_s = argc > 1 ? atof(argv[1]) : 60.0;
    if (!(duration_s > 0.0)) {
        fprintf(stderr, "sandstorm_visibility: seconds = %s: must be a number > 0\n", argv[1]);
        return 2;
    }

    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_WARN; /* threads 0: every core; no log callback: silent */
    sq_context *ctx = NULL;
    if (sq_context_create(&cd, &ctx) != SQ_OK) return fail("context");

    /* A flat 2 km square of sand around the origin (zero fields take their defaults). */
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.material = SQ_GROUND_SAND;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 2000.0f;
    sq_world *world = NULL;
    if (sq_world_create(ctx, &wd, &world) != SQ_OK) return fail("world");

    /* A small storm: 24 x 24 x 12 cells of 60 m, dust blown in from the west edge. */
    const char *settings[] = {
        "domain.nx=24", "domain.ny=24", "domain.nz=12", "domain.cell_size_m=60",
        "dust.bins=2", "dust.inflow_kg_m3=0.002", "wind.speed_mps=18",
    };
    sq_phenomenon_desc pd = {0};
    pd.type = "sandstorm";
    pd.settings = settings;
    pd.setting_count = (int)(sizeof settings / sizeof settings[0]);
    sq_phenomenon *storm = NULL;
    if (sq_phenomenon_create(ctx, &pd, world, &storm) != SQ_OK) return fail("sandstorm");

    printf("%8s  %28s  %10s\n", "time_s", "metric", "value");
    const double frame_s = 10.0; /* the handle sub-cycles each call at its stable step */
    for (double t = 0.0; t < duration_s - 1e-9; t += frame_s) {
        if (sq_phenomenon_step(storm, frame_s) != SQ_OK) return fail("step");
        /* the lowest height band's minimum and median visibility (metres) */
        const char *names[] = {"visibility_min_h0_m", "visibility_median_h0_m"};
        for (int i = 0; i < 2; i++) {
            sq_metric m;
            if (sq_phenomenon_metric_find(storm, names[i], &m) != SQ_OK) return fail("metric");
            printf("%8.1f  %28s  %10.1f %s\n", sq_phenomenon_time(storm), m.name, m.value, m.unit);
        }
    }

    /* Everything the storm publishes, for discovery: */
    printf("\nall metrics at t = %.0f s:\n", sq_phenomenon_time(storm));
    for (int i = 0; i < sq_phenomenon_metric_count(storm); i++) {
        sq_metric m;
        if (sq_phenomenon_metric(storm, i, &m) == SQ_OK)
            printf("  %-32s %12.5g %s\n", m.name, m.value, m.unit);
    }

    sq_phenomenon_destroy(storm);
    sq_world_destroy(ctx, world);
    sq_context_destroy(ctx);
    return 0;
}
