/* test_snowcover.c — the snow-cover phenomenon (squall/snowcover.h, SPEC §6):
 *   - depth on exposed flat ground after t of snowfall = rate t ρ_water / ρ_snow within 1 %,
 *     in the accumulation grid too, and the named levels' depths (2, 10, 30 cm);
 *   - no deeper than the deepest snow cover ever measured (refused at set-up, failed in a step);
 *   - falling snow: terminal speed and drag relaxation against the analytic solution of
 *     dv/dt = k (w + v_t - v), k = g / v_t, for any step length; the noise's stationary
 *     standard deviation is the requested one for two different steps (scaled by √Δt);
 *   - the pool recycles: flakes never end below the ground, the count stays;
 *   - the drawn layers: hidden nearer than near_m, sizes from S2 eq 2.4;
 *   - with a snowdrift layer: its depth and wind are read (blended into the model's depth at
 *     its edge), and the scene draws one snow surface and one snowfall. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "phen/snowcover/snowcover_internal.h"
#include "snow_fixtures.h"
#include "sq_test.h"
#include "squall/snowcover.h"
#include "squall/io.h"
#include "squall/scene.h"
#include "squall/world.h"

SQ_LABEL(physics)

SQ_TEST(depth_flat_ground)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = snow_test_world(ctx, 400.0f, NULL);
    sq_snowcover_desc d;
    memset(&d, 0, sizeof d);
    d.snowfall_mmh = 2.0;
    d.density_kgm3 = 150.0;
    sq_snowcover *s = NULL;
    SQ_CHECK(sq_snowcover_create(ctx, &d, w, &s) == SQ_OK);
    SQ_CHECK(sq_snowcover_depth_m(s) == 0.0);
    /* 3 h in uneven steps */
    double t = 0.0;
    for (int k = 0; t < 3 * 3600.0 - 1e-9; k++) {
        const double dt = fmin(37.0 + (k % 5) * 11.0, 3 * 3600.0 - t);
        SQ_CHECK(sq_snowcover_step(s, dt) == SQ_OK);
        t += dt;
    }
    const double expect = 2.0e-3 * 3.0 * 1000.0 / 150.0; /* rate x t x rho_w / rho_s = 4 cm */
    SQ_CHECK_MSG(fabs(sq_snowcover_depth_m(s) - expect) < 0.01 * expect, "depth %g m, expected %g",
                 sq_snowcover_depth_m(s), expect);
    /* the grid the renderer reads holds it everywhere */
    sq_named_field f;
    SQ_CHECK(sq__snowcover_fields(s, &f, 1) == 1);
    int bad = 0;
    for (int i = 0; i < f.nx * f.ny; i++) bad += fabs((double)f.data[i] - expect) > 0.01 * expect;
    SQ_CHECK_MSG(bad == 0, "%d of %d grid cells off", bad, f.nx * f.ny);
    sq_snowcover_destroy(s);
    /* levels: presets of the same model at 100 kg/m3 */
    const double level_depth[5] = {0, 0, 0.02, 0.10, 0.30};
    for (int l = SQ_SNOWCOVER_NONE; l <= SQ_SNOWCOVER_HEAVY; l++) {
        memset(&d, 0, sizeof d);
        d.level = l;
        SQ_CHECK(sq_snowcover_create(ctx, &d, w, &s) == SQ_OK);
        SQ_CHECK_MSG(fabs(sq_snowcover_depth_m(s) - level_depth[l]) < 1e-9, "level %d: %g m", l,
                     sq_snowcover_depth_m(s));
        sq_snowcover_destroy(s);
    }
    /* negative rate or density: refused, naming the key */
    memset(&d, 0, sizeof d);
    d.snowfall_mmh = -1.0;
    SQ_CHECK(sq_snowcover_validate(ctx, &d, w) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "snowfall.rate_mmh") != NULL);
    d.snowfall_mmh = 1.0;
    d.density_kgm3 = -5.0;
    SQ_CHECK(sq_snowcover_validate(ctx, &d, w) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "snowfall.density_kgm3") != NULL);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Deeper than the deepest snow cover ever measured (11.82 m, Mount Ibuki 1927): a prior depth
 * beyond it is refused before anything is allocated, and a step that would reach it fails with
 * the state unchanged, naming the keys; up to it the depth is the model's. */
SQ_TEST(depth_beyond_the_measured_record_is_refused)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = snow_test_world(ctx, 400.0f, NULL);
    sq_snowcover_desc d;
    memset(&d, 0, sizeof d);
    d.snowfall_mmh = 10.0;   /* 10 mm/h of water at 100 kg/m3: 10 cm of snow an hour */
    d.density_kgm3 = 100.0;
    d.prior_h = 118.0;       /* 11.8 m: allowed */
    SQ_CHECK(sq_snowcover_validate(ctx, &d, w) == SQ_OK);
    d.prior_h = 119.0;       /* 11.9 m */
    SQ_CHECK(sq_snowcover_validate(ctx, &d, w) == SQ_ERR_INVALID_ARG);
    SQ_CHECK_MSG(strstr(sq_last_error(), "snowfall.prior_h") != NULL &&
                     strstr(sq_last_error(), "11.9 m") != NULL,
                 "message: %s", sq_last_error());
    d.prior_h = 110.0;       /* 11 m, then 1 h a step */
    sq_snowcover *s = NULL;
    SQ_CHECK(sq_snowcover_create(ctx, &d, w, &s) == SQ_OK);
    if (s) {
        SQ_CHECK(sq_snowcover_step(s, 3600.0) == SQ_OK); /* 11.1 m */
        SQ_CHECK_MSG(fabs(sq_snowcover_depth_m(s) - 11.1) < 1e-9, "%g m", sq_snowcover_depth_m(s));
        SQ_CHECK(sq_snowcover_step(s, 8 * 3600.0) == SQ_ERR_TOO_LARGE); /* would be 11.9 m */
        SQ_CHECK_MSG(strstr(sq_last_error(), "snowfall.rate_mmh") != NULL &&
                         strstr(sq_last_error(), "snowfall.speedup") != NULL,
                     "message: %s", sq_last_error());
        SQ_CHECK_MSG(fabs(sq_snowcover_depth_m(s) - 11.1) < 1e-9, "state changed: %g m",
                     sq_snowcover_depth_m(s));
        sq_named_field f;
        SQ_CHECK(sq__snowcover_fields(s, &f, 1) == 1);
        SQ_CHECK(fabs((double)f.data[0] - 11.1) < 1e-4);
        sq_snowcover_destroy(s);
    }
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(terminal_speed_and_drag)
{
    const double vt = 0.8, k = 9.80665 / vt;
    const double wind[3] = {3.0, -1.0, 0.0};
    /* from rest, steps of 1 ms and of 50 ms: the analytic v(t) = (w + v_t)(1 - e^{-kt}) */
    const double steps[2] = {0.001, 0.05};
    for (int c = 0; c < 2; c++) {
        double p[3] = {0, 0, 100}, v[3] = {0, 0, 0};
        const int n = (int)lround(0.5 / steps[c]);
        for (int i = 0; i < n; i++) sq_snowcover_flake_update(wind, vt, steps[c], p, v);
        const double t = n * steps[c], e = exp(-k * t);
        const double mean[3] = {wind[0], wind[1], -vt};
        for (int a = 0; a < 3; a++) {
            const double va = mean[a] * (1.0 - e);
            const double xa = (a == 2 ? 100.0 : 0.0) + mean[a] * t - mean[a] * (1.0 - e) / k;
            SQ_CHECK_MSG(fabs(v[a] - va) < 1e-9, "dt %g axis %d: v %.12g, analytic %.12g", steps[c],
                         a, v[a], va);
            SQ_CHECK_MSG(fabs(p[a] - xa) < 1e-9, "dt %g axis %d: x %.12g, analytic %.12g", steps[c],
                         a, p[a], xa);
        }
        /* relaxation time 1/k: after one, 1 - 1/e of the way */
        double q[3] = {0, 0, 0}, u[3] = {0, 0, 0};
        sq_snowcover_flake_update(wind, vt, 1.0 / k, q, u);
        SQ_CHECK(fabs(u[2] + vt * (1.0 - exp(-1.0))) < 1e-12);
    }
    /* terminal: long after, falling at v_t and drifting with the wind */
    double p[3] = {0, 0, 0}, v[3] = {0, 0, 2.0};
    for (int i = 0; i < 1000; i++) sq_snowcover_flake_update(wind, vt, 0.02, p, v);
    SQ_CHECK(fabs(v[2] + vt) < 1e-9 && fabs(v[0] - wind[0]) < 1e-9 && fabs(v[1] - wind[1]) < 1e-9);
}

/* Runs a pool of flakes over flat ground with camera c, returns the std of the horizontal
 * velocity about the wind after settling. */
static double velocity_std(sq_context *ctx, const sq_world *w, double dt, int *below, int *count)
{
    sq_snowcover_desc d;
    memset(&d, 0, sizeof d);
    d.flakes = 20000;
    d.turbulence_mps = 0.4;
    d.fall_speed_mps = 1.0;
    d.wind_speed_mps = 2.0;
    d.seed = 11;
    sq_snowcover *s = NULL;
    if (sq_snowcover_create(ctx, &d, w, &s) != SQ_OK) return -1.0;
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0, -30, 10);
    cam.target_m = sq_v3(0, 0, 2);
    sq_snowcover_observe(s, &cam);
    const int n = (int)lround(3.0 / dt);
    for (int i = 0; i < n; i++) sq_snowcover_step(s, dt);
    double sum = 0.0, sum2 = 0.0;
    *below = 0;
    for (int i = 0; i < s->nflakes; i++) {
        const double u = (double)s->vel[3 * i] - 2.0;
        sum += u;
        sum2 += u * u;
        *below += s->pos[3 * i + 2] < sq_world_height_at(w, s->pos[3 * i], s->pos[3 * i + 1]);
    }
    *count = s->nflakes;
    /* layers: none drawn nearer than near_m, sizes from eq 2.4 with A, B, C = 0, 1, 0 */
    sq_drawable dr[2];
    const int nd = sq__snowcover_drawables(s, dr, 2);
    int hidden_ok = 0, near = 0, size_ok = 0, sized = 0;
    for (int k = 0; k < nd; k++) {
        if (dr[k].kind != SQ_DRAWABLE_PARTICLES) continue;
        const sq_particles_view *pv = &dr[k].u.particles;
        const sq_vec3 f = sq_v3_norm(sq_v3_sub(cam.target_m, cam.position_m));
        for (int i = 0; i < pv->count; i++) {
            const sq_vec3 q = sq_v3_sub(sq_v3(pv->position[3 * i], pv->position[3 * i + 1],
                                              pv->position[3 * i + 2]),
                                        cam.position_m);
            const float z = sq_v3_dot(q, f), D = sq_v3_len(q);
            if (z < 1.5f) {
                near++;
                hidden_ok += pv->fade[i] == 0.0f;
            } else if (z < 10.0f) { /* layer 0 or 1 of 4 between 1.5 and 80 m: 1.5..4.05, 4.05..11 m */
                sized++;
                const int l = z < 1.5f * powf(80.0f / 1.5f, 0.25f) ? 0 : 1;
                const float expect = 6e-3f * powf(1.3f, (float)l) * sqrtf(1.0f / D) * D;
                size_ok += fabsf(pv->radius_m[i] - expect) < 1e-4f * expect + 1e-7f;
            }
        }
    }
    SQ_CHECK(near > 0 && hidden_ok == near);
    SQ_CHECK_MSG(sized > 0 && size_ok == sized, "%d of %d flake sizes follow eq 2.4", size_ok, sized);
    sq_snowcover_destroy(s);
    const double m = sum / *count;
    return sqrt(sum2 / *count - m * m);
}

SQ_TEST(noise_and_recycling)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = snow_test_world(ctx, 400.0f, NULL);
    int below = 0, count = 0;
    const double s1 = velocity_std(ctx, w, 0.01, &below, &count);
    SQ_CHECK(below == 0 && count == 20000);
    const double s2 = velocity_std(ctx, w, 0.1, &below, &count);
    SQ_CHECK(below == 0 && count == 20000);
    /* stationary std = turbulence_mps for both steps (noise scaled by sqrt(dt)) */
    SQ_CHECK_MSG(fabs(s1 - 0.4) < 0.03 * 0.4, "std at dt 0.01: %g m/s", s1);
    SQ_CHECK_MSG(fabs(s2 - 0.4) < 0.03 * 0.4, "std at dt 0.1: %g m/s", s2);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* A snowdrift layer's fields as inputs: its depth replaces the model's depth where it covers the
 * grid, and flakes inside its lattice relax to its wind (none in its solid cells). */
SQ_TEST(inputs_from_snowdrift)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = snow_test_world(ctx, 400.0f, NULL);
    sq_snowcover_desc d;
    memset(&d, 0, sizeof d);
    d.snowfall_mmh = 1.0;
    d.flakes = 2000;
    d.wind_speed_mps = 1.0; /* toward +x outside the lattice */
    sq_snowcover *s = NULL;
    SQ_CHECK(sq_snowcover_create(ctx, &d, w, &s) == SQ_OK);
    /* depth: 4 x 4 cells of 10 m centred on the origin, 0.5 m deep (a drift) */
    float depth[16], u[4 * 4 * 4], v[4 * 4 * 4], wz[4 * 4 * 4];
    uint8_t solid[4 * 4 * 4];
    for (int i = 0; i < 16; i++) depth[i] = 0.5f;
    for (int i = 0; i < 64; i++) u[i] = 0.0f, v[i] = -4.0f, wz[i] = 0.0f, solid[i] = 0;
    solid[0] = 1;
    sq_named_field fd = {"snow_depth", "m", "", NULL, depth, 4, 4, 1, sq_v3(-15, -15, 0),
                         sq_v3(10, 10, 10), NULL, SQ_FIELD_LEVEL_SURFACE};
    sq_named_field fu = {"u", "m s-1", "", NULL, u, 4, 4, 4, sq_v3(-15, -15, 5), sq_v3(10, 10, 10),
                         solid, SQ_FIELD_LEVEL_ALTITUDE};
    sq_named_field fv = fu, fw = fu;
    fv.data = v;
    fw.data = wz;
    sq_snowcover_set_inputs(s, &fd, &fu, &fv, &fw);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0, -30, 10);
    cam.target_m = sq_v3(0, 0, 2);
    sq_snowcover_observe(s, &cam);
    SQ_CHECK(sq_snowcover_step(s, 60.0) == SQ_OK);
    sq_named_field f;
    SQ_CHECK(sq__snowcover_fields(s, &f, 1) == 1);
    const double model = 1e-3 / 60.0 * 1000.0 / 100.0; /* 1 mm/h for a minute */
    /* the drift's depth beyond the blend band (a quarter of its 40 m side: 10 m inside its
     * edge), the model's outside it, strictly between the two in the band */
    int inside = 0, outside = 0, band = 0, in_ok = 0, out_ok = 0, band_ok = 0;
    for (int j = 0; j < f.ny; j++)
        for (int i = 0; i < f.nx; i++) {
            const double x = f.origin_m.x + i * f.spacing_m.x, y = f.origin_m.y + j * f.spacing_m.y;
            const double r = fmax(fabs(x), fabs(y));
            const float val = f.data[(size_t)j * (size_t)f.nx + (size_t)i];
            if (r < 9.5) {
                inside++;
                in_ok += val == 0.5f;
            } else if (r > 10.5 && r < 19.5) {
                band++;
                band_ok += val > model && val < 0.5f;
            } else if (r > 21.0) {
                outside++;
                out_ok += fabs(val - model) < 1e-6 * model + 1e-9;
            }
        }
    SQ_CHECK_MSG(inside > 0 && in_ok == inside, "%d of %d cells in the drift take its depth", in_ok,
                 inside);
    SQ_CHECK_MSG(band > 0 && band_ok == band, "%d of %d cells of the band blend the two", band_ok,
                 band);
    SQ_CHECK_MSG(outside > 0 && out_ok == outside, "%d of %d cells outside keep the model's", out_ok,
                 outside);
    /* wind: a flake in the lattice relaxes to (0, -4, 0), one outside to (1, 0, 0) */
    double wl[3];
    const float pin[3] = {5.0f, 5.0f, 12.0f}, pout[3] = {100.0f, 0.0f, 12.0f}, psolid[3] = {-14, -14, 1};
    SQ_CHECK(sq__snowcover_input_wind(s, pin, wl) && wl[0] == 0.0 && wl[1] == -4.0);
    SQ_CHECK(!sq__snowcover_input_wind(s, pout, wl));
    SQ_CHECK(sq__snowcover_input_wind(s, psolid, wl) && wl[1] == 0.0);
    /* a fresh pool (the minute above brought every flake down and back to the top of the box) */
    sq_snowcover_destroy(s);
    SQ_CHECK(sq_snowcover_create(ctx, &d, w, &s) == SQ_OK);
    sq_snowcover_set_inputs(s, &fd, &fu, &fv, &fw);
    sq_snowcover_observe(s, &cam);
    for (int k = 0; k < 20; k++) sq_snowcover_step(s, 0.05);
    int in_lattice = 0, relaxed = 0;
    for (int i = 0; i < s->nflakes; i++) {
        const float *p = &s->pos[3 * i];
        if (!sq__snowcover_input_wind(s, p, wl) || p[2] < 8.0f) continue;
        in_lattice++;
        relaxed += fabsf(s->vel[3 * i + 1] + 4.0f) < 0.2f;
    }
    SQ_CHECK(in_lattice > 10);
    SQ_CHECK_MSG(relaxed > in_lattice * 8 / 10, "%d of %d flakes in the lattice move at its wind",
                 relaxed, in_lattice);
    /* a lattice blowing up between its stability checks hands out NaN winds: the flakes there
     * are re-born at the top of the box (finite), none reads the terrain at NaN (it crashed) */
    for (int i = 0; i < 64; i++) u[i] = NAN;
    sq_snowcover_set_inputs(s, &fd, &fu, &fv, &fw);
    for (int k = 0; k < 5; k++) SQ_CHECK(sq_snowcover_step(s, 0.05) == SQ_OK);
    int finite = 0;
    for (int i = 0; i < 3 * s->nflakes; i++) finite += isfinite(s->pos[i]) && isfinite(s->vel[i]);
    SQ_CHECK_MSG(finite == 3 * s->nflakes, "%d of %d flake coordinates finite", finite,
                 3 * s->nflakes);
    sq_snowcover_destroy(s);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* One snow surface and one snowfall when a scene has both layers (src/scene/scene_couple.c):
 * the cover draws the drift's depth, so the snowdrift's heightfield is left out, and the
 * cover's flakes replace the snowdrift's drawn ones only when the cover has flakes. */
static void count_drawn(const char *cover, int *surfaces, int *covers, int *flake_counts,
                        int *particles)
{
    char text[2048];
    snprintf(text, sizeof text,
             "name: t\n"
             "world:\n"
             "  terrain: {kind: flat, material: snow, size_m: [120, 120], resolution: [31, 31]}\n"
             "  obstacles:\n"
             "    - {kind: house, center: [0, 0], size: [8, 6, 4], roof_m: 2}\n"
             "camera:\n"
             "  path:\n"
             "    - {t: 0, position: [-30, -30, 10], target: [0, 0, 2]}\n"
             "layers:\n"
             "  - type: snowdrift\n"
             "    name: drift\n"
             "    domain: {nx: 32, ny: 32, nz: 16, cell_size_m: 1}\n"
             "    wind: {speed_mps: 5}\n"
             "    snow: {snowfall_mmh: 4, speedup: 1000}\n"
             "    draw: {flakes: 700}\n"
             "%s",
             cover);
    sq_context *ctx = snow_test_ctx();
    sq_cfg *cfg = NULL;
    SQ_CHECK(sq_cfg_parse(ctx, text, strlen(text), "t.yaml", &cfg) == SQ_OK);
    sq_scene_desc d = {.cfg = cfg};
    sq_scene *s = NULL;
    SQ_CHECK(sq_scene_create(ctx, &d, &s) == SQ_OK);
    (void)sq_scene_camera(s);
    for (int k = 0; k < 3; k++) SQ_CHECK(sq_scene_step(s, 0.05) == SQ_OK);
    (void)sq_scene_camera(s);
    sq_drawable dr[16];
    const int n = sq_scene_drawables(s, dr, 16);
    *surfaces = *covers = *particles = 0;
    for (int i = 0; i < n; i++) {
        *surfaces += dr[i].kind == SQ_DRAWABLE_SURFACE;
        *covers += dr[i].kind == SQ_DRAWABLE_SNOW_COVER;
        if (dr[i].kind == SQ_DRAWABLE_PARTICLES) flake_counts[(*particles)++] = dr[i].u.particles.count;
    }
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

SQ_TEST(drawn_once_with_snowdrift)
{
    int surf, cov, part, counts[16];
    count_drawn("", &surf, &cov, counts, &part);
    SQ_CHECK_MSG(surf == 1 && cov == 0 && part == 1 && counts[0] == 700,
                 "snowdrift alone: %d surfaces, %d covers, %d flake sets", surf, cov, part);
    const char *cover_flakes = "  - type: snowcover\n"
                               "    name: cover\n"
                               "    snowfall: {rate_mmh: 4, speedup: 1000}\n"
                               "    flakes: {count: 500}\n";
    count_drawn(cover_flakes, &surf, &cov, counts, &part);
    SQ_CHECK_MSG(surf == 0 && cov == 1 && part == 1 && counts[0] == 500,
                 "with a cover with flakes: %d surfaces, %d covers, %d flake sets (first %d)",
                 surf, cov, part, part > 0 ? counts[0] : -1);
    /* no snowfall of its own: the cover still draws the drift's depth */
    const char *cover_only = "  - type: snowcover\n"
                             "    name: cover\n";
    count_drawn(cover_only, &surf, &cov, counts, &part);
    SQ_CHECK_MSG(surf == 0 && cov == 1 && part == 1 && counts[0] == 700,
                 "with a cover without flakes or snowfall: %d surfaces, %d covers, %d flake sets",
                 surf, cov, part);
}
