/* test_avalanche.c — the snow avalanche phenomenon (SPEC §7): the mountain terrain's C1 toe, the
 * release slab's particle count against its volume, bad input (messages name the key, value and
 * rule; a release too large for the memory limit is refused before anything is allocated), mass
 * conservation and the terrain and obstacle colliders, a slab that flows downhill and comes to
 * rest on the run-out with the Coulomb bound on the centre-of-mass α angle, the deposit map
 * integrating to the released volume, S2's claim that the Cross rheology does not splash like
 * water (at S2's scale), blow-up as SQ_ERR_UNSTABLE, sub-stepping logged once, and the plug-in's
 * metrics, fields and drawables. */
#include "sq_test.h"
#include "phen/avalanche/avalanche_internal.h"
#include "squall/avalanche.h"
#include "squall/plugin.h"
#include "squall/sph.h"

SQ_LABEL(physics)

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.threads = 1};
    sq_context_create(&d, &ctx);
    return ctx;
}

/* The mountain terrain scaled to length L (m): a 35° slope from x = -L/2 down to the toe at
 * x = 0.05 L, smoothed over ±0.1 L, then a flat plain; width 0.3 L; samples every L/160 m.
 * relief_m tiny: a planar slope without ridges or gully. */
static sq_world *slope_world(sq_context *ctx, float L, float relief)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_MOUNTAIN;
    wd.terrain.size_m[0] = L;
    wd.terrain.size_m[1] = 0.3f * L;
    wd.terrain.resolution[0] = 161;
    wd.terrain.resolution[1] = 49;
    wd.terrain.relief_m = relief;
    wd.terrain.feature_m = L;
    wd.terrain.slope_deg = 35.0f;
    wd.terrain.seed = 3;
    sq_world *w = NULL;
    sq_world_create(ctx, &wd, &w);
    return w;
}

/* A slab 14 m above the plain on the 160 m slope world (release centre x = -12 m). */
static sq_avalanche_desc slab_desc(void)
{
    sq_avalanche_desc d = {0};
    d.spacing_m = 0.5;
    d.release_x_m = -12.0;
    d.release_y_m = 0.0;
    d.release_length_m = 8.0;
    d.release_width_m = 8.0;
    d.release_depth_m = 1.5;
    return d;
}

/* The mountain terrain is C1 across its toe (src/world/world.c): adjacent samples differ by at
 * most the slope times the spacing (tan 35° = 0.700, plus 0.1 for the ridges and the gully at
 * relief 60 m; measured 0.758), and the second difference stays bounded as the spacing halves
 * (measured 0.0089 1/m at 1 m and at 0.5 m; the toe fillet alone has tan 35° / (0.2 L) =
 * 0.0035 1/m). Before the fix the gully depth jumped by 0.175 relief = 10.5 m at the toe
 * (|Δh|/dx = 10.5) and the slope broke from 19° to 0° (|Δ²h|/dx² = 0.35/dx). */
SQ_TEST(mountain_terrain_has_no_step_or_kink_at_the_toe)
{
    sq_context *ctx = mkctx();
    const double tanb = tan(35.0 * SQ_PI / 180.0);
    for (int r = 0; r < 2; r++) {
        sq_world_desc wd = {0};
        wd.terrain.kind = SQ_TERRAIN_MOUNTAIN;
        wd.terrain.slope_deg = 35.0f;
        wd.terrain.relief_m = 60.0f;
        wd.terrain.size_m[0] = 1000.0f;
        wd.terrain.size_m[1] = 300.0f;
        wd.terrain.resolution[0] = r ? 2001 : 1001;
        wd.terrain.resolution[1] = r ? 601 : 301;
        wd.terrain.seed = 4;
        sq_world *w = NULL;
        SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
        if (!w) break;
        sq_world_terrain t;
        sq_world_get_terrain(w, &t);
        double slope = 0.0, curv = 0.0;
        for (int j = 0; j < t.ny; j++) {
            const float *h = t.heights + (size_t)j * (size_t)t.nx;
            for (int i = 1; i + 1 < t.nx; i++) {
                slope = fmax(slope, fabs((double)h[i + 1] - (double)h[i]) / (double)t.dx);
                curv = fmax(curv, fabs((double)h[i + 1] - 2.0 * (double)h[i] + (double)h[i - 1]) /
                                      ((double)t.dx * (double)t.dx));
            }
        }
        printf("dx = %.2f m: max |dh|/dx = %.4f (tan 35 = %.4f), max |d2h|/dx2 = %.5f 1/m\n",
               (double)t.dx, slope, tanb, curv);
        SQ_CHECK(slope <= tanb + 0.1);
        SQ_CHECK(curv <= 0.02);
        sq_world_destroy(ctx, w);
    }
    sq_context_destroy(ctx);
}

SQ_TEST(release_count_follows_volume)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    SQ_CHECK(w != NULL);
    sq_avalanche_desc d = slab_desc();
    d.release_x_m = -30.0; /* mid-slope: planar at 35° */
    d.release_length_m = 10.0;
    double vol = 0.0;
    const double v_exact = 10.0 * 8.0 * 1.5 / cos(35.0 * SQ_PI / 180.0);
    for (int k = 0; k < 2; k++) {
        d.spacing_m = k ? 0.25 : 0.5;
        size_t n = sq_avalanche_release_count(&d, w, &vol);
        SQ_CHECK_REL(vol, v_exact, 1e-3);
        const double dx3 = d.spacing_m * d.spacing_m * d.spacing_m;
        SQ_CHECK_REL((double)n * dx3, v_exact, 0.02);
        fprintf(stderr, "dx = %g m: %zu particles, N dx^3 = %.2f m3, V = %.2f m3 (exact %.2f)\n",
                d.spacing_m, n, (double)n * dx3, vol, v_exact);
    }
    /* the created avalanche holds exactly the planned particles, each dx/2 from the slope */
    d.spacing_m = 0.5;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    sq_avalanche_state st;
    SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
    SQ_CHECK(st.particles == sq_avalanche_release_count(&d, w, NULL));
    SQ_CHECK_REL(st.mass_kg, 300.0 * v_exact, 0.03);
    size_t n = 0;
    const float *p = sq_avalanche_positions(a, &n);
    double dmin = 1e9;
    for (size_t i = 0; i < n; i++) {
        double h = sq_world_height_at(w, p[3 * i], p[3 * i + 1]);
        double dn = (p[3 * i + 2] - h) * cos(35.0 * SQ_PI / 180.0);
        dmin = dn < dmin ? dn : dmin;
    }
    SQ_CHECK_NEAR(dmin, 0.25, 0.01);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(bad_input_is_refused_with_messages)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche *a = NULL;
    sq_avalanche_desc d = slab_desc();
    d.spacing_m = -1.0;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "sq_avalanche_desc.particles.spacing_m = -1; the particle spacing must be > 0");
    d = slab_desc();
    d.support_radius_m = -0.5;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "particles.support_radius_m = -0.5; the kernel support must be > 0");
    d.support_radius_m = 0.3;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG, "must be 1.5 to 4 x the spacing");
    d = slab_desc();
    d.mu0_pa_s = 0.5; /* below mu_inf = 1 */
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "rheology.mu0_pa_s = 0.5 is below sq_avalanche_desc.rheology.mu_inf_pa_s = 1");
    d = slab_desc();
    d.cross_n = -2.0;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "rheology.cross_n = -2; the Cross exponent must be > 0");
    d = slab_desc();
    d.rheology = SQ_AVALANCHE_RHEOLOGY_POWER_LAW;
    d.power_n = -1.0;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG, "rheology.power_n = -1");
    d = slab_desc();
    d.rheology = 9;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG, "rheology.model = 9");
    d = slab_desc();
    d.release_x_m = 75.0; /* the terrain ends at x = 80 m; the slab reaches 79 + ... */
    d.release_length_m = 20.0;
    SQ_CHECK_ERR(sq_avalanche_create(ctx, &d, w, &a), SQ_ERR_INVALID_ARG, "lies outside the terrain");
    SQ_CHECK(a == NULL);
    d = slab_desc();
    d.release_y_m = -30.0;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG, "lies outside the terrain");
    d = slab_desc();
    d.release_depth_m = 0.2; /* thinner than one particle */
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "smaller than one particle spacing");
    d = slab_desc();
    d.friction = -0.1;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG, "terrain.friction = -0.1");
    d = slab_desc();
    d.domain_min_m[0] = 0.0f; /* a box below the slab */
    d.domain_min_m[1] = -20.0f;
    d.domain_min_m[2] = -5.0f;
    d.domain_max_m[0] = 50.0f;
    d.domain_max_m[1] = 20.0f;
    d.domain_max_m[2] = 30.0f;
    SQ_CHECK_ERR(sq_avalanche_validate(ctx, &d, w), SQ_ERR_INVALID_ARG,
                 "does not hold the release slab");
    d = slab_desc();
    SQ_CHECK_ERR(sq_avalanche_create(ctx, &d, NULL, &a), SQ_ERR_INVALID_ARG, "a world is required");
    SQ_CHECK_OK(sq_avalanche_validate(ctx, &d, w));
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(too_many_particles_refused_before_allocating)
{
    sq_context *big = mkctx();
    sq_world *w = slope_world(big, 160.0f, 1e-3f);
    sq_context *small = NULL;
    sq_context_desc cd = {.threads = 1, .memory_limit_bytes = 64u << 20};
    sq_context_create(&cd, &small);
    sq_avalanche_desc d = slab_desc();
    d.spacing_m = 0.04; /* ~1.3 million particles */
    size_t n = sq_avalanche_release_count(&d, w, NULL);
    SQ_CHECK(n > 1000000);
    uint64_t bytes = sq_avalanche_memory_bytes(&d, w);
    SQ_CHECK(bytes > (uint64_t)n * 400u);
    sq_avalanche *a = NULL;
    /* refused from the O(cells) estimate of the count (no particle counted one by one): the
     * message names about as many particles as the exact count */
    SQ_CHECK_ERR(sq_avalanche_create(small, &d, w, &a), SQ_ERR_TOO_LARGE, "particles, which needs");
    SQ_CHECK(strstr(sq_last_error(), "bytes") != NULL);
    const char *about = strstr(sq_last_error(), "makes about ");
    SQ_CHECK(about != NULL);
    if (about) SQ_CHECK_REL(atof(about + 12), (double)n, 0.01);
    SQ_CHECK(a == NULL);
    SQ_CHECK(sq_context_bytes_peak(small) == 0);
    sq_context_destroy(small);
    sq_world_destroy(big, w);
    sq_context_destroy(big);
}

/* Mass conservation and the colliders: the particle count stays the release count, no particle
 * ends up below the terrain surface (beyond a quarter spacing) or inside the box obstacle that
 * stands in the flow's path. */
SQ_TEST(mass_conserved_nothing_below_terrain_or_inside_obstacles)
{
    sq_context *ctx = mkctx();
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_MOUNTAIN;
    wd.terrain.size_m[0] = 160.0f;
    wd.terrain.size_m[1] = 48.0f;
    wd.terrain.resolution[0] = 161;
    wd.terrain.resolution[1] = 49;
    wd.terrain.relief_m = 2.0f; /* ridges and a gully */
    wd.terrain.feature_m = 60.0f;
    wd.terrain.slope_deg = 35.0f;
    sq_obstacle box = {0};
    box.kind = SQ_OBSTACLE_BOX;
    box.center_m = sq_v3(-4.0f, 0.0f, NAN);
    box.size_m = sq_v3(2.0f, 3.0f, 3.0f);
    wd.obstacles = &box;
    wd.obstacle_count = 1;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    sq_avalanche_desc d = slab_desc();
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    const sq_obstacle *o = &sq_world_obstacles(w)[0];
    const size_t n0 = sq_avalanche_release_count(&d, w, NULL);
    double worst_below = 0.0, worst_inside = 0.0;
    int hit = 0;
    for (int f = 0; f < 25; f++) {
        SQ_CHECK_OK(sq_avalanche_step(a, 0.1));
        sq_avalanche_state st;
        SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
        SQ_CHECK(st.particles == n0);
        SQ_CHECK(st.removed == 0);
        worst_below = st.below_terrain_m > worst_below ? st.below_terrain_m : worst_below;
        size_t n = 0;
        const float *p = sq_avalanche_positions(a, &n);
        for (size_t i = 0; i < n; i++) {
            float dx = fabsf(p[3 * i] - o->center_m.x) - 0.5f * o->size_m.x;
            float dy = fabsf(p[3 * i + 1] - o->center_m.y) - 0.5f * o->size_m.y;
            float dz = p[3 * i + 2] - (o->center_m.z + o->size_m.z);
            float depth = -(dx > dy ? (dx > dz ? dx : dz) : (dy > dz ? dy : dz));
            if (dx < 0.5f && dy < 0.5f && dz < 0.5f) hit = 1; /* within a spacing: it touched */
            if (depth > worst_inside) worst_inside = depth;
        }
    }
    fprintf(stderr, "deepest below terrain %.3f m, inside the box %.3f m, box touched %d\n",
            worst_below, worst_inside, hit);
    SQ_CHECK(worst_below < 0.25 * d.spacing_m);
    SQ_CHECK(worst_inside < 0.25 * d.spacing_m);
    SQ_CHECK(hit);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* A slab released 14 m above the plain accelerates down the 35° slope and comes to rest on the
 * run-out. Bound: with kinetic Coulomb friction mu at the base, the centre of mass cannot travel
 * further than the sliding block's tan(alpha_cm) = mu (all other losses only shorten it). */
SQ_TEST(slab_flows_downhill_and_stops_on_the_runout)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = slab_desc();
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    size_t n = 0;
    const float *p = sq_avalanche_positions(a, &n);
    double c0[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) c0[k] += p[3 * i + k] / (double)n;
    sq_avalanche_state st;
    double t_stop = -1.0, v_peak = 0.0, vmean_peak = 0.0;
    for (int f = 1; f <= 200 && t_stop < 0.0; f++) {
        SQ_CHECK_OK(sq_avalanche_step(a, 0.1));
        SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
        v_peak = st.max_speed_mps > v_peak ? st.max_speed_mps : v_peak;
        vmean_peak = st.mean_speed_mps > vmean_peak ? st.mean_speed_mps : vmean_peak;
        if (f == 20) {
            SQ_CHECK_MSG(st.runout_m > 2.0 && st.front_speed_mps > 2.0,
                         "after 2 s: runout %.2f m, front speed %.2f m/s", st.runout_m,
                         st.front_speed_mps);
        }
        if (f > 20 && st.moving_fraction < 0.05) t_stop = st.time_s;
    }
    SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
    p = sq_avalanche_positions(a, &n);
    double c1[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) c1[k] += p[3 * i + k] / (double)n;
    const double alpha_cm = atan2(c0[2] - c1[2], hypot(c1[0] - c0[0], c1[1] - c0[1])) * 180.0 / SQ_PI;
    fprintf(stderr,
            "stopped at t = %.1f s (moving %.3f), peak speed %.1f (mean %.1f) m/s, run-out %.1f m, front alpha "
            "%.1f deg, centre-of-mass alpha %.1f deg (Coulomb bound %.1f), deposit mean %.2f max "
            "%.2f m\n",
            t_stop, st.moving_fraction, v_peak, vmean_peak, st.runout_m, st.alpha_deg, alpha_cm,
            atan(0.2) * 180.0 / SQ_PI, st.deposit_mean_m, st.deposit_max_m);
    SQ_CHECK_MSG(t_stop > 0.0 && t_stop <= 20.0, "the flow has not stopped within 20 s");
    SQ_CHECK(st.particles == sq_avalanche_release_count(&d, w, NULL));
    /* the mean speed stays below the free fall of the centre of mass to the plain (z = 0) */
    SQ_CHECK(vmean_peak > 5.0 && vmean_peak < sqrt(2.0 * 9.81 * c0[2]));
    SQ_CHECK(c1[0] > 8.0);                                       /* on the flat run-out */
    SQ_CHECK(alpha_cm >= atan(0.2) * 180.0 / SQ_PI - 0.5);
    SQ_CHECK(st.runout_m > 20.0);
    /* the deposit map holds the released volume (packing: rho/rho0 <= 1 + Ma² ~ 1.04) */
    SQ_CHECK_REL(st.deposit_volume_m3, st.release_volume_m3, 0.04);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(deposit_depth_integrates_to_released_volume)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = slab_desc();
    d.deposit_cell_m = 1.5;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    for (int f = 0; f < 3; f++) {
        if (f) SQ_CHECK_OK(sq_avalanche_step(a, 0.5));
        int nx = 0, ny = 0;
        double o[2], cell;
        const float *dep = sq_avalanche_deposit(a, &nx, &ny, o, &cell);
        SQ_CHECK(dep != NULL && cell == 1.5);
        double sum = 0.0, mx = 0.0;
        for (size_t c = 0; c < (size_t)nx * ny; c++) {
            sum += dep[c] * cell * cell;
            mx = dep[c] > mx ? dep[c] : mx;
        }
        sq_avalanche_state st;
        SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
        fprintf(stderr, "t = %.1f s: integral %.2f m3, release %.2f m3, max depth %.2f m\n",
                st.time_s, sum, st.release_volume_m3, mx);
        SQ_CHECK_REL(sum, st.release_volume_m3, 0.04);
        SQ_CHECK_REL(sum, st.deposit_volume_m3, 1e-5);
        /* the slab is 1.5 m thick normal to the slope: 1.83 m vertically */
        if (f == 0) SQ_CHECK_NEAR(mx, 1.5 / cos(35.0 * SQ_PI / 180.0), 0.5);
    }
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* S2 §3.6: the Newtonian fluid "spreads fast and splashes" and was rejected for avalanches; the
 * Cross fluid advances as a coherent mass. The comparison runs where S2's parameters act — its
 * own scale (S2's stable steps dt = 1 ms at mu = 100 Pa s imply a smoothing length of a few
 * cm, SPEC §7.5) — with S2's numerics (XSPH 0.5, no artificial viscosity): the same slab of
 * 0.8 m x 0.6 m x 0.15 m released 2 m above the plain of a 35° slope, Cross (S2 Fig. 3.20)
 * against water at 0 °C, compared 1.4 s later as it spreads onto the plain. */
static void lab_run(int model, double *hmax, double *spread_x, double *spread_y, double *runout)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 20.0f, 1e-4f);
    sq_avalanche_desc d = {0};
    d.spacing_m = 0.05;
    d.release_x_m = -2.0;
    d.release_length_m = 0.8;
    d.release_width_m = 0.6;
    d.release_depth_m = 0.15;
    d.rheology = model;
    d.mu_pa_s = 1.79e-3;
    d.no_artificial_viscosity = true;
    d.domain_min_m[0] = -4.0f;
    d.domain_min_m[1] = -2.5f;
    d.domain_min_m[2] = -0.5f;
    d.domain_max_m[0] = 10.0f;
    d.domain_max_m[1] = 2.5f;
    d.domain_max_m[2] = 5.0f;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    *hmax = 0.0;
    sq_avalanche_state st;
    for (int f = 0; f < 7; f++) {
        SQ_CHECK_OK(sq_avalanche_step(a, 0.2));
        SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
        *hmax = st.max_height_m > *hmax ? st.max_height_m : *hmax;
    }
    /* spread: the 1 %-99 % ranges of x and y */
    size_t n = 0;
    const float *p = sq_avalanche_positions(a, &n);
    float *s = (float *)malloc(n * sizeof(float));
    for (int ax = 0; ax < 2; ax++) {
        for (size_t i = 0; i < n; i++) s[i] = p[3 * i + (size_t)ax];
        float lo = sq__aval_select(s, n, n / 100), hi = sq__aval_select(s, n, n - 1 - n / 100);
        *(ax ? spread_y : spread_x) = hi - lo;
    }
    free(s);
    *runout = st.runout_m;
    SQ_CHECK(st.particles == n && st.removed == 0);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(cross_flow_spreads_less_than_water)
{
    double hc, xc, yc, rc, hw, xw, yw, rw;
    lab_run(SQ_AVALANCHE_RHEOLOGY_CROSS, &hc, &xc, &yc, &rc);
    lab_run(SQ_AVALANCHE_RHEOLOGY_NEWTONIAN, &hw, &xw, &yw, &rw);
    fprintf(stderr,
            "Cross: spread %.3f x %.3f m, run-out %.3f m, max height %.3f m\n"
            "water: spread %.3f x %.3f m, run-out %.3f m, max height %.3f m\n",
            xc, yc, rc, hc, xw, yw, rw, hw);
    SQ_CHECK(xc < 0.9 * xw);
    SQ_CHECK(yc < 0.9 * yw);
    SQ_CHECK(rc < rw);
    SQ_CHECK(hc <= hw + 0.01);
}

SQ_TEST(blow_up_is_an_error_naming_the_particle)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = slab_desc();
    d.spacing_m = 1.0;
    d.speed_of_sound_mps = 0.3; /* the flow outruns 3 c_s within a second */
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    sq_result r = SQ_OK;
    for (int f = 0; f < 30 && r == SQ_OK; f++) r = sq_avalanche_step(a, 0.1);
    SQ_CHECK(r == SQ_ERR_UNSTABLE);
    fprintf(stderr, "%s\n", sq_last_error());
    SQ_CHECK(strstr(sq_last_error(), "particle") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "step") != NULL);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

static int substep_logs;
static void count_logs(void *user, sq_log_level level, const char *module, const char *msg)
{
    (void)user;
    (void)level;
    if (strcmp(module, "sph") == 0 && strstr(msg, "sub-stepping")) substep_logs++;
}

SQ_TEST(cfl_substeps_are_logged_once)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.threads = 1, .log = count_logs};
    sq_context_create(&cd, &ctx);
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = slab_desc();
    d.spacing_m = 1.0;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    const double dt = sq_avalanche_max_stable_dt(a);
    SQ_CHECK(dt > 0.0 && dt < 0.05);
    for (int f = 0; f < 3; f++) SQ_CHECK_OK(sq_avalanche_step(a, 0.05));
    sq_avalanche_state st;
    SQ_CHECK_OK(sq_avalanche_get_state(a, &st));
    SQ_CHECK(st.substeps >= 3 * (int)floor(0.05 / dt));
    SQ_CHECK(st.dt_s > 0.0 && st.dt_s <= dt * 1.5);
    SQ_CHECK(substep_logs == 1);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Through the plug-in table: the table's defaults are what desc_resolve gives, and the instance
 * publishes metrics (finite), the deposit map for export and its drawables. */
/* The powder cloud's diffusion between air cells conserves mass exactly up to rounding — no
 * flux through the ground (a sloping floor of ground cells) or the box's faces — and its
 * decay removes exp(-n dt/T) of it, all of which is reported as settled. A shift by whole
 * cells keeps what stays inside and reports the rest as left behind. */
SQ_TEST(powder_diffusion_conserves_and_settles_exponentially)
{
    const int nn[3] = {12, 10, 8};
    const size_t nv = 12 * 10 * 8;
    float a[12 * 10 * 8], b[12 * 10 * 8];
    int ground[12 * 10];
    for (int j = 0; j < nn[1]; j++)
        for (int i = 0; i < nn[0]; i++) ground[j * nn[0] + i] = i / 3; /* a staircase slope */
    double m0 = 0.0;
    for (size_t c = 0; c < nv; c++) {
        const int kz = (int)(c / (12 * 10)), col = (int)(c % (12 * 10));
        a[c] = kz >= ground[col] ? (float)((c * 7919u) % 13u) : 0.0f;
        m0 += a[c];
    }
    /* pure diffusion (decay 1): mass constant, nothing settles, nothing enters the ground */
    float *src = a, *dst = b;
    double settled = 0.0;
    for (int s = 0; s < 200; s++) {
        settled += sq__aval_powder_diffuse(src, dst, nn, ground, 1.0f / 6.0f, 1.0f);
        float *t = src;
        src = dst;
        dst = t;
    }
    double m1 = 0.0, in_ground = 0.0, lo = 0.0;
    for (size_t c = 0; c < nv; c++) {
        m1 += src[c];
        lo = fmin(lo, src[c]);
        if ((int)(c / 120) < ground[c % 120]) in_ground += src[c];
    }
    printf("powder diffusion: mass %.6f -> %.6f after 200 steps, settled %.3g, in ground %.3g\n",
           m0, m1, settled, in_ground);
    SQ_CHECK_REL(m1, m0, 1e-5);
    SQ_CHECK(settled == 0.0 && in_ground == 0.0 && lo >= 0.0);
    /* and spread: the top corner far from the initial values' pattern is no longer uniform 0 */
    /* with decay: the mass falls as decay^n, the difference is the settled sum */
    const float decay = (float)exp(-0.1 / 6.0);
    settled = 0.0;
    for (int s = 0; s < 60; s++) {
        settled += sq__aval_powder_diffuse(src, dst, nn, ground, 0.1f, decay);
        float *t = src;
        src = dst;
        dst = t;
    }
    double m2 = 0.0;
    for (size_t c = 0; c < nv; c++) m2 += src[c];
    printf("powder settling: %.6f -> %.6f (exp(-1) x = %.6f), settled %.6f\n", m1, m2,
           m1 * exp(-1.0), settled);
    SQ_CHECK_REL(m2, m1 * exp(-1.0), 1e-4);
    SQ_CHECK_REL(m2 + settled, m1, 1e-5);
    /* a shift by (2, -1, 1) cells: what stays is moved, the rest is reported */
    const int shift[3] = {2, -1, 1};
    const double left = sq__aval_powder_shift(src, dst, nn, shift);
    double kept = 0.0, moved_ok = 1.0;
    for (size_t c = 0; c < nv; c++) kept += dst[c];
    const size_t at = (size_t)3 * 120 + 4 * 12 + 5; /* cell (5, 4, 3) holds old (7, 3, 4) */
    moved_ok = dst[at] == src[(size_t)4 * 120 + 3 * 12 + 7];
    SQ_CHECK(moved_ok == 1.0);
    SQ_CHECK(left > 0.0);
    SQ_CHECK_REL(kept + left, m2, 1e-5);
}

/* The powder is carried by the flow beneath it (docs/phen/avalanche.md, Drawables): particles
 * moving at (3, -1, -1) m/s over 2 m cells give their columns (1.5, -0.5, -0.5) cells/s plus the
 * entrainment rise E |u_h| = 0.08 * 1.58 cells/s, and columns far from them stay still. The
 * donor-cell step conserves the mass exactly (what crosses the box's faces is reported), moves
 * the mass centre of a blob by exactly u t (first-order upwind moves the first moment by u dt per
 * step), puts nothing into ground cells and never makes a cell negative. */
SQ_TEST(powder_advection_carries_the_cloud_with_the_flow)
{
    enum { NX = 24, NY = 16, NZ = 12 };
    const int nn[3] = {NX, NY, NZ};
    const double o[3] = {0.0, 0.0, 0.0}, c = 2.0;
    static float vel[4 * NX * NY], work[2 * NX * NY];
    /* 16 particles in the 4 columns (2..3, 5..6), all at (3, -1, -1) m/s */
    float px[16], py[16], vx[16], vy[16], vz[16];
    for (int p = 0; p < 16; p++) {
        px[p] = (float)(2.0 * (2 + (p & 1)) + 0.5);
        py[p] = (float)(2.0 * (5 + ((p >> 1) & 1)) + 0.5);
        vx[p] = 3.0f;
        vy[p] = -1.0f;
        vz[p] = -1.0f;
    }
    sq__aval_powder_velocity(px, py, vx, vy, vz, 16, nn, o, c, 0.08f, vel, work);
    const float *u = &vel[4 * (5 * NX + 2)], *still = &vel[4 * (0 * NX + 20)];
    printf("powder velocity: under the flow (%.4f, %.4f, %.4f) cells/s, far (%g, %g, %g)\n",
           (double)u[0], (double)u[1], (double)u[2], (double)still[0], (double)still[1],
           (double)still[2]);
    SQ_CHECK_REL(u[0], 1.5, 1e-5);
    SQ_CHECK_REL(u[1], -0.5, 1e-5);
    SQ_CHECK_REL(u[2], -0.5 + 0.08 * sqrt(1.5 * 1.5 + 0.5 * 0.5), 1e-5);
    SQ_CHECK(still[0] == 0.0f && still[1] == 0.0f && still[2] == 0.0f);

    /* a uniform carrier over a staircase floor (ground cells in the columns x < 4 up to k = 3) */
    static float a[NX * NY * NZ], b[NX * NY * NZ];
    static int ground[NX * NY];
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            ground[j * NX + i] = i < 4 ? 3 : 0;
            float *v = &vel[4 * (j * NX + i)];
            v[0] = 0.8f;
            v[1] = 0.3f;
            v[2] = 0.1f;
            v[3] = 0.0f;
        }
    const size_t sz = (size_t)NX * NY, nv = sz * NZ;
    double m0 = 0.0, mx0 = 0.0, my0 = 0.0, mz0 = 0.0;
    for (size_t q = 0; q < nv; q++) {
        const int kz = (int)(q / sz), j = (int)(q % sz) / NX, i = (int)(q % NX);
        const double r2 = (i - 8.0) * (i - 8.0) + (j - 4.0) * (j - 4.0) + (kz - 3.0) * (kz - 3.0);
        a[q] = kz >= ground[q % sz] && r2 < 6.0 ? (float)(1.0 + 0.1 * (double)(q % 7)) : 0.0f;
        m0 += a[q];
        mx0 += a[q] * i;
        my0 += a[q] * j;
        mz0 += a[q] * kz;
    }
    float *src = a, *dst = b;
    double left = 0.0, lo = 0.0;
    const int steps = 10;
    const float dt = 0.5f;
    for (int s = 0; s < steps; s++) {
        left += sq__aval_powder_advect(src, dst, nn, ground, vel, dt);
        float *t = src;
        src = dst;
        dst = t;
    }
    double m1 = 0.0, mx1 = 0.0, my1 = 0.0, mz1 = 0.0, in_ground = 0.0;
    for (size_t q = 0; q < nv; q++) {
        const int kz = (int)(q / sz), j = (int)(q % sz) / NX, i = (int)(q % NX);
        m1 += src[q];
        mx1 += src[q] * i;
        my1 += src[q] * j;
        mz1 += src[q] * kz;
        lo = fmin(lo, src[q]);
        if (kz < ground[q % sz]) in_ground += src[q];
    }
    const double T = steps * (double)dt;
    printf("powder advection: mass %.6f -> %.6f (left %.3g), centre moved (%.5f, %.5f, %.5f) "
           "cells, u t = (%.1f, %.1f, %.1f); in ground %g, min %g\n",
           m0, m1, left, mx1 / m1 - mx0 / m0, my1 / m1 - my0 / m0, mz1 / m1 - mz0 / m0, 0.8 * T,
           0.3 * T, 0.1 * T, in_ground, lo);
    SQ_CHECK_REL(m1 + left, m0, 1e-5);
    SQ_CHECK(left < 1e-6 * m0); /* the blob stays inside the box (but for upwind traces) */
    SQ_CHECK_NEAR(mx1 / m1 - mx0 / m0, 0.8 * T, 1e-3);
    SQ_CHECK_NEAR(my1 / m1 - my0 / m0, 0.3 * T, 1e-3);
    SQ_CHECK_NEAR(mz1 / m1 - mz0 / m0, 0.1 * T, 1e-3);
    SQ_CHECK(in_ground == 0.0 && lo >= 0.0);
    /* against the staircase and out of the box: a carrier toward -x pushes the blob into the
     * step (no flux into ground cells) and through the low face (reported as left) */
    for (size_t col = 0; col < sz; col++) {
        vel[4 * col] = -1.0f;
        vel[4 * col + 1] = 0.0f;
        vel[4 * col + 2] = -0.2f;
    }
    left = 0.0;
    for (int s = 0; s < 40; s++) {
        left += sq__aval_powder_advect(src, dst, nn, ground, vel, dt);
        float *t = src;
        src = dst;
        dst = t;
    }
    double m2 = 0.0;
    in_ground = 0.0;
    lo = 0.0;
    for (size_t q = 0; q < nv; q++) {
        m2 += src[q];
        lo = fmin(lo, src[q]);
        if ((int)(q / sz) < ground[q % sz]) in_ground += src[q];
    }
    printf("powder advection against the step: %.6f = %.6f kept + %.6f left, in ground %g\n", m1,
           m2, left, in_ground);
    SQ_CHECK(left > 0.0);
    SQ_CHECK_REL(m2 + left, m1, 1e-5);
    SQ_CHECK(in_ground == 0.0 && lo >= 0.0);
}

/* The powder budget closes on the moving box (docs/phen/avalanche.md, Drawables): a slab on
 * the 35° slope feeds a cloud into a 24 m box of 1 m cells, which has to follow the flow over
 * ~40 m; at every frame the powder entrained equals the powder suspended in the box plus the
 * powder settled plus the powder the box left behind, within 1e-4; no powder sits in a ground
 * cell. */
SQ_TEST(powder_budget_closes_on_the_moving_box)
{
    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = slab_desc();
    d.powder = true;
    d.powder_speed_mps = 3.0;
    d.powder_shed = 5e-3;
    d.powder_cell_m = 1.0;
    d.powder_box_m = 24.0;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    if (!a) return;
    SQ_CHECK(a->plan.pw_n[0] == 24 && a->plan.pw_cell == 1.0);
    const double x0 = a->pw_origin[0];
    int moves = 0;
    double last_x = x0, worst = 0.0, peak_susp = 0.0;
    for (int f = 1; f <= 60; f++) {
        SQ_CHECK_OK(sq_avalanche_step(a, 0.1));
        sq__aval_update_powder(a);
        if (a->pw_origin[0] != last_x) moves++;
        last_x = a->pw_origin[0];
        const double susp = sq__aval_powder_suspended(a);
        peak_susp = fmax(peak_susp, susp);
        const double gap = a->pw_entrained - (susp + a->pw_settled + a->pw_left);
        if (a->pw_entrained > 0.0) worst = fmax(worst, fabs(gap) / a->pw_entrained);
        const size_t nxy = (size_t)a->plan.pw_n[0] * a->plan.pw_n[1];
        double in_ground = 0.0, lo = 0.0;
        for (size_t c = 0; c < nxy * a->plan.pw_n[2]; c++) {
            lo = fmin(lo, a->pw_density[c]);
            if ((int)(c / nxy) < a->pw_ground[c % nxy]) in_ground += a->pw_density[c];
        }
        SQ_CHECK(in_ground == 0.0 && lo >= 0.0);
        if (f % 20 == 0)
            printf("t = %.1f s: box x0 %.0f m (%d moves); entrained %.4g kg = suspended %.4g + "
                   "settled %.4g + left %.4g (gap %.2g)\n", a->time_s, a->pw_origin[0], moves,
                   a->pw_entrained, susp, a->pw_settled, a->pw_left, gap);
    }
    SQ_CHECK(a->pw_entrained > 0.0 && peak_susp > 0.0);
    SQ_CHECK_MSG(moves >= 3 && a->pw_origin[0] - x0 > 15.0, "the box moved %d times, %.1f m",
                 moves, a->pw_origin[0] - x0);
    SQ_CHECK(a->pw_left > 0.0 && a->pw_settled > 0.0);
    SQ_CHECK_MSG(worst < 1e-4, "budget gap %.3g of the entrained powder", worst);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(plugin_metrics_fields_drawables)
{
    const sq_phen_plugin *pl = sq_plugin_find("avalanche");
    SQ_CHECK(pl != NULL);
    if (!pl) return;
    sq_avalanche_desc a0 = {0}, b0 = {0};
    sq_params_defaults(pl->params, pl->param_count, &b0);
    SQ_CHECK_OK(pl->desc_resolve(&a0));
    SQ_CHECK_OK(pl->desc_resolve(&b0));
    SQ_CHECK(memcmp(&a0, &b0, sizeof a0) == 0);

    sq_context *ctx = mkctx();
    sq_world *w = slope_world(ctx, 160.0f, 1e-3f);
    sq_avalanche_desc d = b0;
    d.spacing_m = 1.0;
    d.release_x_m = -12.0;
    d.release_length_m = 8.0;
    d.release_width_m = 8.0;
    d.release_depth_m = 1.5;
    d.powder = true;
    SQ_CHECK_OK(sq_params_validate(pl->params, pl->param_count, &d, "avalanche"));
    SQ_CHECK_OK(pl->validate(ctx, &d, w));
    uint64_t bytes = 0;
    SQ_CHECK_OK(pl->memory_bytes(&d, w, &bytes));
    void *self = NULL;
    SQ_CHECK_OK(pl->create(ctx, &d, w, &self));
    SQ_CHECK(pl->max_stable_dt(self) > 0.0);
    for (int f = 0; f < 2; f++) SQ_CHECK_OK(pl->step(self, 0.2));
    sq_metric m[32];
    int nm = pl->metrics(self, m, 32);
    SQ_CHECK(nm >= 12);
    const char *want[] = {"front_m", "front_speed_mps", "runout_m", "alpha_deg",
                          "moving_fraction", "max_speed_mps", "deposit_depth_mean_m",
                          "deposit_depth_max_m", "particles", "substeps", "dt_s"};
    for (size_t k = 0; k < sizeof want / sizeof want[0]; k++) {
        int found = 0;
        for (int i = 0; i < nm; i++) found |= strcmp(m[i].name, want[k]) == 0;
        SQ_CHECK_MSG(found, "metric %s missing", want[k]);
    }
    for (int i = 0; i < nm; i++) SQ_CHECK_MSG(isfinite(m[i].value), "metric %s = %g", m[i].name, m[i].value);
    sq_named_field fl[8];
    int nf = pl->fields(self, fl, 8);
    SQ_CHECK(nf == 5);
    const char *maps[] = {"deposit_depth", "peak_flow_depth", "peak_speed", "peak_pressure",
                          "travel_angle"};
    const char *units[] = {"m", "m", "m/s", "kPa", "deg"};
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    for (int k = 0; k < nf && k < 5; k++) {
        SQ_CHECK(strcmp(fl[k].name, maps[k]) == 0 && strcmp(fl[k].units, units[k]) == 0);
        /* on the terrain's samples, one map for the whole terrain */
        SQ_CHECK(fl[k].nz == 1 && fl[k].nx == t.nx && fl[k].ny == t.ny);
        SQ_CHECK_NEAR(fl[k].origin_m.x, t.origin.x, 1e-4);
        SQ_CHECK_NEAR(fl[k].spacing_m.x, t.dx, 1e-6);
    }
    sq_drawable dr[4];
    int nd = pl->drawables(self, dr, 4);
    SQ_CHECK(nd == 3);
    size_t alive = 0;
    for (int i = 0; i < nm; i++)
        if (strcmp(m[i].name, "particles") == 0) alive = (size_t)m[i].value;
    SQ_CHECK(alive > 100);
    /* default: the snow surface over all the snow, spheres only for spray above it */
    SQ_CHECK(dr[0].kind == SQ_DRAWABLE_PARTICLES && dr[0].u.particles.sprite == SQ_SPRITE_SPHERE);
    SQ_CHECK((size_t)dr[0].u.particles.count < alive / 10 && dr[0].u.particles.radius_default_m > 0.5f);
    SQ_CHECK_NEAR(dr[0].u.particles.albedo[1], 0.9, 1e-6);
    SQ_CHECK(dr[1].kind == SQ_DRAWABLE_SURFACE &&
             dr[1].u.surface.material == SQ_MATERIAL_SNOW_DEBRIS);
    SQ_CHECK(dr[2].kind == SQ_DRAWABLE_VOLUME && dr[2].u.volume.nz >= 2);
    for (int i = 0; i < dr[0].u.particles.count * 3; i++)
        if (!isfinite(dr[0].u.particles.position[i])) {
            SQ_CHECK(!"non-finite particle position");
            break;
        }
    {
        /* the reconstructed surface holds the snow: its height above the terrain, integrated,
         * is the particles' volume (N dx^3, the release lattice) within 3 %; fully covered
         * somewhere; never below the terrain */
        const sq_surface_view *sv = &dr[1].u.surface;
        double vol = 0.0, cmax = 0.0, below = 0.0;
        for (int j = 0; j < sv->ny; j++)
            for (int i = 0; i < sv->nx; i++) {
                const size_t c = (size_t)j * sv->nx + i;
                const float x = sv->origin_m.x + i * sv->dx_m, y = sv->origin_m.y + j * sv->dy_m;
                const double h = sv->height_m[c] - sq_world_height_at(w, x, y);
                vol += h * sv->dx_m * sv->dy_m;
                below = fmin(below, h);
                cmax = fmax(cmax, sv->coverage[c]);
            }
        const double want_v = (double)alive * d.spacing_m * d.spacing_m * d.spacing_m;
        printf("snow surface: %.1f m3 above the terrain vs %zu particles x dx^3 = %.1f m3; "
               "coverage max %.2f; lowest %.3f m\n", vol, alive, want_v, cmax, below);
        SQ_CHECK_REL(vol, want_v, 0.03);
        SQ_CHECK(cmax == 1.0);
        SQ_CHECK(below > -0.05);
    }
    pl->destroy(self);
    /* render.spheres: every particle a sphere (the surface only over the snow at rest) */
    d.spheres = true;
    SQ_CHECK_OK(pl->create(ctx, &d, w, &self));
    nd = pl->drawables(self, dr, 4);
    SQ_CHECK(nd == 3 && (size_t)dr[0].u.particles.count == alive);
    pl->destroy(self);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}
