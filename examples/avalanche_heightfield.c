/* avalanche_heightfield.c — an avalanche on terrain the program supplies as a float heightfield.
 *
 * A user with their own terrain (a game level, a DEM already in memory) passes its heights in
 * metres as an array of floats: sq_terrain_desc.kind = SQ_TERRAIN_GRID (squall/world.h). Sample
 * (i, j) is heights[j * w + i] at (origin.x + i dx, origin.y + j dy), row 0 the SOUTH edge. The
 * array is only borrowed for sq_world_create (the world keeps its own copy).
 *
 * Here the terrain is a 35 degree slope falling toward +x that rounds off into a flat run-out
 * (a softplus profile), and a 1.5 m slab of snow is released high on the slope. The program
 * steps the SPH avalanche and prints where its front is, how fast it moves, and the run-out.
 *
 * Run: ./avalanche_heightfield [seconds]      (default 20) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <squall/squall.h>

#define NX 151 /* 300 m along x at 2 m */
#define NY 61  /* 120 m along y */
#define DX 2.0f

static int fail(const char *what)
{
    fprintf(stderr, "avalanche_heightfield: %s: %s\n", what, sq_last_error());
    return 1;
}

/* Height of the slope at x: tan(35 deg) far up-slope, flat far down-slope, smooth between. */
static float slope_height(float x)
{
    const float rounding_m = 30.0f, toe_x_m = 170.0f;
    return rounding_m * tanf(35.0f * 3.14159265f / 180.0f) *
           log1pf(expf((toe_x_m - x) / rounding_m));
}

int main(int argc, char **argv)
{
    const double duration_s = argc > 1 ? atof(argv[1]) : 20.0;
    if (!(duration_s > 0.0)) {
        fprintf(stderr, "avalanche_heightfield: seconds = %s: must be a number > 0\n", argv[1]);
        return 2;
    }
    /* The caller's heightfield (any source would do: a file, an engine's terrain, ...). */
    float *heights = (float *)malloc(sizeof(float) * NX * NY);
    if (!heights) return 1;
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) heights[j * NX + i] = slope_height((float)i * DX);

    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_WARN;
    sq_context *ctx = NULL;
    if (sq_context_create(&cd, &ctx) != SQ_OK) return fail("context");
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_GRID;
    wd.terrain.material = SQ_GROUND_SNOW;
    wd.terrain.grid_heights_m = heights;
    wd.terrain.grid_w = NX;
    wd.terrain.grid_h = NY;
    wd.terrain.grid_dx_m = wd.terrain.grid_dy_m = DX;
    wd.terrain.origin_m[0] = wd.terrain.origin_m[1] = 0.0f; /* sample (0,0) at x = y = 0 */
    wd.terrain.origin_set = true;
    sq_world *world = NULL;
    const sq_result wr = sq_world_create(ctx, &wd, &world);
    free(heights); /* borrowed only for the call */
    if (wr != SQ_OK) return fail("world");

    /* A 30 m x 20 m slab, 1.5 m thick, centred 50 m down from the top edge; 1 m particles. */
    const char *settings[] = {"release.x_m=50", "release.y_m=60", "release.length_m=30",
                              "release.width_m=20", "release.depth_m=1.5",
                              "particles.spacing_m=1", "terrain.friction=0.25"};
    sq_phenomenon_desc pd = {0};
    pd.type = "avalanche";
    pd.settings = settings;
    pd.setting_count = (int)(sizeof settings / sizeof settings[0]);
    sq_phenomenon *av = NULL;
    if (sq_phenomenon_create(ctx, &pd, world, &av) != SQ_OK) return fail("avalanche");

    const char *names[] = {"front_m", "front_speed_mps", "max_speed_mps", "moving_fraction"};
    printf("%6s", "t_s");
    for (int k = 0; k < 4; k++) printf("  %16s", names[k]);
    printf("\n");
    for (double t = 0.0; t < duration_s - 1e-9; t += 2.0) {
        if (sq_phenomenon_step(av, 2.0) != SQ_OK) return fail("step");
        printf("%6.1f", sq_phenomenon_time(av));
        for (int k = 0; k < 4; k++) {
            sq_metric m;
            if (sq_phenomenon_metric_find(av, names[k], &m) != SQ_OK) return fail("metric");
            printf("  %12.2f %-3s", m.value, m.unit);
        }
        printf("\n");
    }
    sq_metric runout, alpha;
    if (sq_phenomenon_metric_find(av, "runout_m", &runout) != SQ_OK ||
        sq_phenomenon_metric_find(av, "alpha_deg", &alpha) != SQ_OK)
        return fail("metric");
    printf("run-out %.1f %s, travel angle alpha %.1f %s\n", runout.value, runout.unit,
           alpha.value, alpha.unit);

    sq_phenomenon_destroy(av);
    sq_world_destroy(ctx, world);
    sq_context_destroy(ctx);
    return 0;
}
