/* test_live.c — live changes of a running scene (sq_scene_apply_live): a live key applies
 * between two steps without resetting the clock and changes the following steps as the physics
 * says; a non-live key is reported as needing a rebuild and nothing is applied; a refused value
 * gives the message the CLI gives (the scene loader's) and nothing is applied. */
#include "sq_test.h"
#include "squall/io.h"
#include "squall/run.h"
#include "squall/sandstorm.h"
#include "squall/scene.h"

SQ_LABEL(unit)

/* A small desert sandstorm on flat ground: 16 x 16 x 8 cells of 40 m, no inflow dust, emission
 * from the surface (u* ~ 0.68 m/s at 18 m/s over z0 = 0.5 mm, above u*_t = 0.25 m/s). */
static const char *const SCENE =
    "name: live\n"
    "seed: 3\n"
    "world:\n"
    "  terrain: {kind: flat, size_m: [1200, 1200], resolution: [61, 61]}\n"
    "camera: {position: [-500, -500, 60], target: [0, 0, 40]}\n"
    "layers:\n"
    "  - type: sandstorm\n"
    "    name: storm\n"
    "    domain: {nx: 16, ny: 16, nz: 8, cell_size_m: 40}\n"
    "    surface: {emission_coeff: 2.0e-4}\n"
    "output: {width: 64, height: 36, fps: 10, duration_s: 10, video: \"\"}\n";

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    return ctx;
}

static sq_cfg *parse(sq_context *ctx, const char *text)
{
    sq_cfg *cfg = NULL;
    if (sq_cfg_parse(ctx, text, strlen(text), "live.yaml", &cfg) != SQ_OK) return NULL;
    return cfg;
}

static sq_scene *make_scene(sq_context *ctx, const sq_cfg *cfg)
{
    sq_scene_desc d = {.cfg = cfg};
    sq_scene *s = NULL;
    if (sq_scene_create(ctx, &d, &s) != SQ_OK) return NULL;
    return s;
}

/* The scene's configuration with one more "key=value" (as a front end edits it). */
static sq_cfg *edited(sq_context *ctx, const char *assignment)
{
    sq_cfg *c = parse(ctx, SCENE);
    if (c && sq_cfg_set(c, assignment) != SQ_OK) {
        sq_cfg_destroy(c);
        return NULL;
    }
    return c;
}

static sq_result apply(sq_context *ctx, sq_scene *s, const char *assignment, sq_live_result *res)
{
    sq_cfg *c = edited(ctx, assignment);
    if (!c) return SQ_ERR_INTERNAL;
    sq_scene_desc d = {.cfg = c};
    const sq_result r = sq_scene_apply_live(s, &d, res);
    sq_cfg_destroy(c);
    return r;
}

static double emitted_kg(sq_scene *s)
{
    sq_sandstorm *st = (sq_sandstorm *)sq_phenomenon_typed(sq_scene_layer(s, 0), "sandstorm");
    sq_sandstorm_budget b;
    sq_sandstorm_get_budget(st, &b);
    return b.emitted_kg;
}

static const sq_sandstorm_desc *storm_desc(sq_scene *s)
{
    return (const sq_sandstorm_desc *)sq_phenomenon_desc_get(sq_scene_layer(s, 0));
}

/* The emission flux F = C u*^3 (1 - u*_t^2 / u*^2) (S0 eq. 2.33) is proportional to C: doubling
 * surface.emission_coeff between two steps doubles the mass emitted by the next step (the air
 * at the emission stage of that step is still the same in both runs: dust acts on the air only
 * through what was emitted before), and the clock goes on from where it was. */
SQ_TEST(live_emission_applies_without_reset)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, SCENE);
    SQ_CHECK(cfg != NULL);
    sq_scene *a = make_scene(ctx, cfg), *b = make_scene(ctx, cfg);
    SQ_CHECK(a && b);
    if (!a || !b) return;
    for (int i = 0; i < 5; i++) {
        SQ_CHECK_OK(sq_scene_step(a, 0.5));
        SQ_CHECK_OK(sq_scene_step(b, 0.5));
    }
    const double t0 = sq_scene_time(b), ph_t0 = sq_phenomenon_time(sq_scene_layer(b, 0));
    const double ea0 = emitted_kg(a), eb0 = emitted_kg(b);
    SQ_CHECK_MSG(ea0 > 0.0, "no emission before the change (%g kg): the test says nothing", ea0);
    SQ_CHECK_NEAR(eb0, ea0, 1e-12 * ea0);

    sq_live_result res;
    SQ_CHECK_OK(apply(ctx, b, "layers.storm.surface.emission_coeff=4.0e-4", &res));
    SQ_CHECK(!res.rebuild);
    SQ_CHECK_MSG(res.changed == 1, "changed %d entries, expected 1", res.changed);
    SQ_CHECK_NEAR(storm_desc(b)->emission_coeff, 4.0e-4, 1e-18);
    SQ_CHECK_NEAR(sq_scene_time(b), t0, 0.0); /* not restarted */
    SQ_CHECK_NEAR(sq_phenomenon_time(sq_scene_layer(b, 0)), ph_t0, 0.0);
    SQ_CHECK_NEAR(emitted_kg(b), eb0, 0.0);   /* the state is untouched */

    SQ_CHECK_OK(sq_scene_step(a, 0.5));
    SQ_CHECK_OK(sq_scene_step(b, 0.5));
    const double da = emitted_kg(a) - ea0, db = emitted_kg(b) - eb0;
    SQ_CHECK_MSG(da > 0.0, "no emission in the step after the change");
    SQ_CHECK_REL(db / da, 2.0, 1e-4);
    SQ_CHECK_NEAR(sq_scene_time(b), t0 + 0.5, 1e-12);

    /* the same change again: nothing to do */
    SQ_CHECK_OK(apply(ctx, b, "layers.storm.surface.emission_coeff=4.0e-4", &res));
    SQ_CHECK(!res.rebuild && res.changed == 0);
    sq_scene_destroy(a);
    sq_scene_destroy(b);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* Mean eastward wind (m/s) of the air above the log layer (z > 150 m above the ground). */
static double upper_wind(sq_scene *s)
{
    sq_named_field f;
    if (sq_phenomenon_field_find(sq_scene_layer(s, 0), "u", &f) != SQ_OK) return NAN;
    double sum = 0.0;
    int n = 0;
    for (int k = 0; k < f.nz; k++) {
        if (f.origin_m.z + k * f.spacing_m.z < 150.0f) continue;
        for (int j = 0; j < f.ny; j++)
            for (int i = 0; i < f.nx; i++) {
                sum += f.data[((size_t)k * f.ny + j) * f.nx + i];
                n++;
            }
    }
    return n ? sum / n : NAN;
}

/* The wind speed where the pressure wave vanishes is |v| = sqrt(2 C_B / rho) (S0 eq. 2.19;
 * rho = 1.2 kg/m3): 18.26 m/s for the default C_B = 200 Pa. Halving it live (C_B = 50 Pa, or
 * wind.speed_mps = 9.13 where the key is a speed) sets the inflow face at once; the projection
 * and the advection carry it through the domain, so after 100 s (the 640 m domain crossed ~1.5
 * times) the air above the log layer runs at the new speed, while the unchanged run keeps the
 * old one (both within 3 %). */
SQ_TEST(live_wind_speed_sets_the_flow)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, SCENE);
    sq_scene *a = make_scene(ctx, cfg), *b = make_scene(ctx, cfg);
    SQ_CHECK(a && b);
    if (!a || !b) return;
    const double v0 = sqrt(2.0 * 200.0 / 1.2), v1 = sqrt(2.0 * 50.0 / 1.2);
    for (int i = 0; i < 4; i++) {
        SQ_CHECK_OK(sq_scene_step(a, 1.0));
        SQ_CHECK_OK(sq_scene_step(b, 1.0));
    }
    SQ_CHECK_REL(upper_wind(b), v0, 0.1);
    const sq_phen_plugin *pl = sq_plugin_find("sandstorm");
    const bool speed_key = sq_params_find(pl->params, pl->param_count, "wind.speed_mps") != NULL;
    char set[96];
    if (speed_key) snprintf(set, sizeof set, "layers.storm.wind.speed_mps=%.6f", v1);
    else snprintf(set, sizeof set, "layers.storm.wind.bernoulli_pa=50");
    const double t0 = sq_scene_time(b);
    sq_live_result res;
    SQ_CHECK_OK(apply(ctx, b, set, &res));
    SQ_CHECK(!res.rebuild && res.changed == 1);
    SQ_CHECK_NEAR(sq_scene_time(b), t0, 0.0);
    for (int i = 0; i < 50; i++) {
        SQ_CHECK_OK(sq_scene_step(a, 2.0));
        SQ_CHECK_OK(sq_scene_step(b, 2.0));
    }
    SQ_CHECK_REL(upper_wind(a), v0, 0.03);
    SQ_CHECK_REL(upper_wind(b), v1, 0.03);
    SQ_CHECK_NEAR(sq_scene_time(b), t0 + 100.0, 1e-9);
    sq_scene_destroy(a);
    sq_scene_destroy(b);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* A key without SQ_PARAM_LIVE (the grid size), alone or with a live one: needs a rebuild,
 * named; nothing is applied, the clock is kept. The world and the seed are fixed too. */
SQ_TEST(live_non_live_key_needs_rebuild)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, SCENE);
    sq_scene *s = make_scene(ctx, cfg);
    SQ_CHECK(s != NULL);
    if (!s) return;
    SQ_CHECK_OK(sq_scene_step(s, 0.5));
    sq_live_result res;
    SQ_CHECK_OK(apply(ctx, s, "layers.storm.domain.nx=20", &res));
    SQ_CHECK(res.rebuild);
    SQ_CHECK_MSG(strstr(res.reason, "layers.storm.domain.nx") != NULL, "reason: %s", res.reason);
    sq_cfg *c = edited(ctx, "layers.storm.surface.emission_coeff=4.0e-4");
    SQ_CHECK(c && sq_cfg_set(c, "layers.storm.domain.nz=10") == SQ_OK);
    sq_scene_desc d = {.cfg = c};
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK(res.rebuild && res.changed == 0);
    SQ_CHECK_NEAR(storm_desc(s)->emission_coeff, 2.0e-4, 1e-18); /* not applied */
    sq_cfg_destroy(c);
    SQ_CHECK_OK(apply(ctx, s, "world.terrain.relief_m=30", &res));
    SQ_CHECK(res.rebuild && strstr(res.reason, "world.terrain.relief_m"));
    SQ_CHECK_OK(apply(ctx, s, "seed=4", &res));
    SQ_CHECK(res.rebuild && strstr(res.reason, "seed"));
    SQ_CHECK_OK(apply(ctx, s, "output.width=128", &res));
    SQ_CHECK(res.rebuild && strstr(res.reason, "output.width"));
    SQ_CHECK_NEAR(sq_scene_time(s), 0.5, 1e-12);
    /* live scene keys: exposure (rendering) and the camera, two entries */
    c = edited(ctx, "output.exposure=2.5");
    SQ_CHECK(c && sq_cfg_set(c, "camera.fov_deg=30") == SQ_OK);
    d.cfg = c;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK_MSG(!res.rebuild && res.changed == 2, "rebuild %d (%s), changed %d", res.rebuild,
                 res.reason, res.changed);
    sq_cfg_destroy(c);
    SQ_CHECK_NEAR(sq_scene_output_settings(s)->exposure, 2.5, 1e-6);
    SQ_CHECK_NEAR(sq_scene_camera(s).fov_y_deg, 30.0, 1e-5);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* A refused value: the message `squall simulate --set` gives (the scene loader's, through the
 * parameter table or the phenomenon's own rule), and nothing applied. */
static void check_refused(sq_context *ctx, sq_scene *s, const char *assignment, const char *needle)
{
    sq_cfg *c = edited(ctx, assignment);
    SQ_CHECK(c != NULL);
    if (!c) return;
    sq_scene_desc d = {.cfg = c, .validate_only = true};
    sq_scene *v = NULL;
    const sq_result rc = sq_scene_create(ctx, &d, &v); /* what the CLI does with --set */
    char cli[1024];
    snprintf(cli, sizeof cli, "%s", sq_last_error());
    SQ_CHECK(rc == SQ_ERR_INVALID_ARG && v == NULL);
    sq_live_result res;
    d.validate_only = false;
    const sq_result rl = sq_scene_apply_live(s, &d, &res);
    SQ_CHECK_MSG(rl == rc, "apply_live returned %d, the scene loader %d", (int)rl, (int)rc);
    SQ_CHECK_MSG(strcmp(sq_last_error(), cli) == 0, "live: '%s'\ncli:  '%s'", sq_last_error(), cli);
    SQ_CHECK_MSG(strstr(cli, needle) != NULL, "message '%s' lacks '%s'", cli, needle);
    SQ_CHECK_NEAR(storm_desc(s)->emission_coeff, 2.0e-4, 1e-18);
    sq_cfg_destroy(c);
}

SQ_TEST(live_out_of_range_refused_as_cli)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, SCENE);
    sq_scene *s = make_scene(ctx, cfg);
    SQ_CHECK(s != NULL);
    if (!s) return;
    check_refused(ctx, s, "layers.storm.surface.emission_coeff=5",
                  "layers.storm.surface.emission_coeff = 5 kg s2/m5: outside the range [0, 1]");
    check_refused(ctx, s, "output.exposure=0", "output.exposure = 0");
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* A phenomenon without the apply_live hook (NULL: "no live change") has its live keys applied by
 * a rebuild: the scene reports it, naming the key, and applies nothing. Checked on every such
 * plug-in of the build that can run on a small flat world with its defaults (snowcover today);
 * a plug-in with the hook applies the same change live. */
SQ_TEST(live_without_hook_needs_rebuild)
{
    sq_context *ctx = mkctx();
    const sq_phen_plugin *pl = sq_plugin_find("snowcover");
    if (!pl) { /* not in this build */
        sq_context_destroy(ctx);
        return;
    }
    static const char *const text =
        "name: cover\n"
        "world:\n"
        "  terrain: {kind: flat, size_m: [400, 400], resolution: [21, 21]}\n"
        "layers:\n"
        "  - type: snowcover\n"
        "    name: snow\n"
        "    flakes: {count: 100}\n"
        "output: {width: 64, height: 36, video: \"\"}\n";
    sq_cfg *cfg = parse(ctx, text);
    sq_scene *s = cfg ? make_scene(ctx, cfg) : NULL;
    SQ_CHECK(s != NULL);
    if (!s) {
        fprintf(stderr, "%s\n", sq_last_error());
        sq_cfg_destroy(cfg);
        sq_context_destroy(ctx);
        return;
    }
    SQ_CHECK_OK(sq_scene_step(s, 0.5));
    sq_cfg *c = parse(ctx, text);
    SQ_CHECK(c && sq_cfg_set(c, "layers.snow.look.albedo=0.5") == SQ_OK);
    sq_scene_desc d = {.cfg = c};
    sq_live_result res;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    const sq_param *albedo = sq_params_find(pl->params, pl->param_count, "look.albedo");
    SQ_CHECK(albedo && (albedo->flags & SQ_PARAM_LIVE));
    if (!pl->apply_live) {
        SQ_CHECK(res.rebuild && res.changed == 0);
        SQ_CHECK_MSG(strstr(res.reason, "layers.snow.look.albedo") &&
                         strstr(res.reason, "takes no live change"),
                     "reason: %s", res.reason);
    } else {
        SQ_CHECK(!res.rebuild && res.changed == 1);
    }
    SQ_CHECK_NEAR(sq_scene_time(s), 0.5, 1e-12);
    sq_cfg_destroy(c);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* The sun and the sky are live: a running scene given sky.turbidity = 8 and sun.hour = 7 has the
 * sun direction, the sun's radiance and the sky's radiances of a scene built with them (the one
 * model, sq_world_create's), and keeps its clock; the sun is lower than at 15 h (the default, at
 * 40 deg N in June: 8 h from noon against 3), and the aerosol's optical depth dims it. */
SQ_TEST(live_sky_equals_rebuilt)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, SCENE);
    sq_scene *s = make_scene(ctx, cfg);
    sq_cfg *c2 = edited(ctx, "world.sky.turbidity=8");
    SQ_CHECK(c2 && sq_cfg_set(c2, "world.sun.hour=7") == SQ_OK);
    sq_scene *ref = c2 ? make_scene(ctx, c2) : NULL;
    SQ_CHECK(s && ref);
    if (!s || !ref) return;
    SQ_CHECK_OK(sq_scene_step(s, 0.5));
    sq_world_light w0, w, r;
    sq_world_get_light(sq_scene_world(s), &w0);
    sq_scene_desc d = {.cfg = c2};
    sq_live_result res;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK_MSG(!res.rebuild && res.changed == 2, "rebuild %d (%s), changed %d", res.rebuild,
                 res.reason, res.changed);
    SQ_CHECK_NEAR(sq_scene_time(s), 0.5, 1e-12);
    sq_world_get_light(sq_scene_world(s), &w);
    sq_world_get_light(sq_scene_world(ref), &r);
    SQ_CHECK_NEAR(w.turbidity, 8.0, 1e-6);
    SQ_CHECK_NEAR(w.sun_dir.x, r.sun_dir.x, 1e-6);
    SQ_CHECK_NEAR(w.sun_dir.y, r.sun_dir.y, 1e-6);
    SQ_CHECK_NEAR(w.sun_dir.z, r.sun_dir.z, 1e-6);
    SQ_CHECK_NEAR(w.sun_radiance.x, r.sun_radiance.x, 1e-6);
    SQ_CHECK_NEAR(w.sun_radiance.z, r.sun_radiance.z, 1e-6);
    SQ_CHECK_NEAR(w.sky_zenith.y, r.sky_zenith.y, 1e-6);
    SQ_CHECK_NEAR(w.sky_horizon.x, r.sky_horizon.x, 1e-6);
    SQ_CHECK(w.sun_dir.z < w0.sun_dir.z); /* 7 h is lower than 15 h */
    /* the same sun height with more haze: a dimmer direct sun (the aerosol's optical depth) */
    SQ_CHECK_OK(apply(ctx, s, "world.sky.turbidity=8", &res)); /* back to 15 h, turbidity 8 */
    SQ_CHECK(!res.rebuild && res.changed == 1);
    sq_world_get_light(sq_scene_world(s), &w);
    SQ_CHECK_NEAR(w.sun_dir.z, w0.sun_dir.z, 1e-6);
    SQ_CHECK(w.sun_radiance.y < w0.sun_radiance.y);
    sq_scene_destroy(ref);
    sq_scene_destroy(s);
    sq_cfg_destroy(c2);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* ---- the sun is drawn with its frame ---------------------------------------------------------
 * The simulation side changes the world's sun between two frames (a live sky change, or every
 * step for a sun following the clock) while the drawing side may be drawing the frame before.
 * A frame is drawn with the sun and sky it was made with: a change on the scene that is not yet
 * published leaves the picture of the frame shown byte-identical; the frame published after a
 * live change (sq_run_apply_live) is the picture of a scene built with the new key. The CPU
 * reference renderer (deterministic: one thread, the seed of the frame) draws the pictures. */
#define SUN_W 16
#define SUN_H 16
static const char *const SUN_SCENE =
    "name: sunframe\n"
    "seed: 5\n"
    "world:\n"
    "  terrain: {kind: flat, size_m: [400, 400], resolution: [21, 21]}\n"
    "  sun: {hour: 15}\n"
    "camera: {position: [0, -150, 20], target: [0, 0, 40]}\n"
    "output: {width: 16, height: 16, fps: 10, duration_s: 10, video: \"\"}\n";

typedef struct sun_pic {
    uint8_t rgba[SUN_W * SUN_H * 4];
    int frames;
} sun_pic;

static sq_result sun_frame_sink(void *user, const sq_run_frame *f)
{
    sun_pic *p = (sun_pic *)user;
    if (f->width == SUN_W && f->height == SUN_H) memcpy(p->rgba, f->rgba, sizeof p->rgba);
    p->frames++;
    return SQ_OK;
}

static sq_run *sun_run(sq_context *ctx, sq_scene *s, sun_pic *pic)
{
    sq_run_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.scene = s;
    rd.render = SQ_RUN_REFERENCE;
    rd.reference_samples = 1;
    rd.snapshot = true;
    rd.sinks.frame = sun_frame_sink;
    rd.sinks.user = pic;
    sq_run *run = NULL;
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &run));
    return run;
}

static sq_context *mkctx1(void)
{
    sq_context_desc cd = {0};
    cd.threads = 1;
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    sq_context_create(&cd, &ctx);
    return ctx;
}

SQ_TEST(live_sun_drawn_with_its_frame)
{
    sq_context *ctx = mkctx1();
    sq_cfg *cfg = parse(ctx, SUN_SCENE), *low = parse(ctx, SUN_SCENE);
    SQ_CHECK(cfg && low && sq_cfg_set(low, "world.sun.hour=7") == SQ_OK);
    sq_scene *s = cfg ? make_scene(ctx, cfg) : NULL, *ref = low ? make_scene(ctx, low) : NULL;
    SQ_CHECK(s && ref);
    if (!s || !ref) return;
    static sun_pic a, b, c, r;
    sq_run *run = sun_run(ctx, s, &a), *rr = sun_run(ctx, ref, &r);
    if (!run || !rr) return;
    SQ_CHECK_OK(sq_run_advance(run));
    SQ_CHECK_OK(sq_run_draw(run)); /* frame 0 under the 15 h sun */
    b = a;
    /* the scene's sun changes (as on the simulation thread) but no frame is published: the frame
     * shown is drawn again with its own sun */
    sq_scene_desc d = {.cfg = low};
    sq_live_result res;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK(!res.rebuild && res.changed == 1);
    SQ_CHECK_OK(sq_run_draw(run));
    SQ_CHECK_MSG(memcmp(a.rgba, b.rgba, sizeof a.rgba) == 0,
                 "the frame drawn again changed with the scene's unpublished sun");
    /* the change through the frame loop: the frame is published again with the 7 h sun and
     * drawn as a scene built with it draws its frame 0 */
    SQ_CHECK_OK(sq_run_apply_live(run, &d, &res)); /* nothing new for the scene ... */
    SQ_CHECK(!res.rebuild && res.changed == 0);
    sq_cfg *back = parse(ctx, SUN_SCENE);
    sq_scene_desc db = {.cfg = back};
    SQ_CHECK_OK(sq_scene_apply_live(s, &db, &res)); /* ... so: back to 15 h unpublished */
    SQ_CHECK_OK(sq_run_apply_live(run, &d, &res));  /* and 7 h through the loop */
    SQ_CHECK(!res.rebuild && res.changed == 1);
    SQ_CHECK_OK(sq_run_draw(run));
    c = a;
    SQ_CHECK_OK(sq_run_advance(rr));
    SQ_CHECK_OK(sq_run_draw(rr));
    SQ_CHECK_MSG(memcmp(c.rgba, r.rgba, sizeof c.rgba) == 0,
                 "the frame published after the live change differs from a scene built with it");
    SQ_CHECK_MSG(memcmp(c.rgba, b.rgba, sizeof c.rgba) != 0,
                 "the 7 h sun draws the same picture as the 15 h sun: the test shows nothing");
    sq_run_destroy(rr);
    sq_run_destroy(run);
    sq_cfg_destroy(back);
    sq_scene_destroy(ref);
    sq_scene_destroy(s);
    sq_cfg_destroy(low);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* A sun following the clock (sun.date) moves every step: a step made while a frame is drawn
 * (the simulation thread working on the next frame) leaves that frame's picture as it was; the
 * next frame shows the sun moved. */
SQ_TEST(clock_sun_drawn_with_its_frame)
{
    sq_context *ctx = mkctx1();
    static const char *const text =
        "name: sunclock\n"
        "seed: 5\n"
        "world:\n"
        "  terrain: {kind: flat, size_m: [400, 400], resolution: [21, 21]}\n"
        "  sun: {date: \"2026-06-21 06:00:00\", latitude_deg: 40, clock_scale: 3600}\n"
        "camera: {position: [0, -150, 20], target: [0, 0, 40]}\n"
        "output: {width: 16, height: 16, fps: 10, duration_s: 10, video: \"\"}\n";
    sq_cfg *cfg = parse(ctx, text);
    sq_scene *s = cfg ? make_scene(ctx, cfg) : NULL;
    SQ_CHECK(s != NULL);
    if (!s) {
        fprintf(stderr, "%s\n", sq_last_error());
        return;
    }
    static sun_pic a, b;
    sq_run *run = sun_run(ctx, s, &a);
    if (!run) return;
    SQ_CHECK_OK(sq_run_advance(run));
    SQ_CHECK_OK(sq_run_draw(run));
    b = a;
    sq_world_light l0, l1;
    sq_world_get_light(sq_scene_world(s), &l0);
    SQ_CHECK_OK(sq_scene_step(s, 2.0)); /* two hours of sun clock, from 06 h UTC */
    sq_world_get_light(sq_scene_world(s), &l1);
    SQ_CHECK(l1.sun_dir.z > l0.sun_dir.z + 0.1f); /* the morning sun rose */
    SQ_CHECK_OK(sq_run_draw(run));
    SQ_CHECK_MSG(memcmp(a.rgba, b.rgba, sizeof a.rgba) == 0,
                 "a step made during the draw changed the picture of the frame drawn");
    SQ_CHECK_OK(sq_run_advance(run));
    SQ_CHECK_OK(sq_run_draw(run));
    SQ_CHECK_MSG(memcmp(a.rgba, b.rgba, sizeof a.rgba) != 0, "the next frame kept the old sun");
    sq_run_destroy(run);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* ---- snowfall started live draws flakes ----------------------------------------------------
 * A snowdrift scene started without snowfall has no drawn flakes; snow.snowfall_mmh > 0 applied
 * live makes its draw.flakes (allocated then), all in the air of the lattice box, moving with
 * the steps; back to 0 mm/h they are no longer drawn. */
static const sq_particles_view *flakes_of(sq_scene *s)
{
    static sq_drawable ds[16];
    const int n = sq_scene_drawables(s, ds, 16);
    for (int i = 0; i < n; i++)
        if (ds[i].kind == SQ_DRAWABLE_PARTICLES) return &ds[i].u.particles;
    return NULL;
}

static int flakes_outside(const sq_particles_view *v, const float lo[3], const float hi[3])
{
    int bad = 0;
    for (int f = 0; f < v->count; f++)
        for (int k = 0; k < 3; k++) {
            const float p = v->position[3 * f + k];
            if (!(p >= lo[k] && p <= hi[k])) {
                bad++;
                break;
            }
        }
    return bad;
}

SQ_TEST(live_snowfall_draws_flakes)
{
    sq_context *ctx = mkctx1();
    if (!sq_plugin_find("snowdrift")) { /* not in this build */
        sq_context_destroy(ctx);
        return;
    }
    static const char *const text =
        "name: drift\n"
        "seed: 4\n"
        "world:\n"
        "  terrain: {kind: flat, size_m: [200, 200], resolution: [21, 21]}\n"
        "camera: {position: [-60, -60, 20], target: [0, 0, 5]}\n"
        "layers:\n"
        "  - type: snowdrift\n"
        "    name: drift\n"
        "    domain: {nx: 16, ny: 16, nz: 8, cell_size_m: 2}\n"
        "    wind: {speed_mps: 5}\n"
        "    snow: {snowfall_mmh: 0}\n"
        "    draw: {flakes: 300}\n"
        "output: {width: 64, height: 36, video: \"\"}\n";
    sq_cfg *cfg = parse(ctx, text), *on = parse(ctx, text), *off = parse(ctx, text);
    SQ_CHECK(on && sq_cfg_set(on, "layers.drift.snow.snowfall_mmh=5") == SQ_OK);
    sq_scene *s = cfg ? make_scene(ctx, cfg) : NULL;
    SQ_CHECK(s != NULL);
    if (!s) {
        fprintf(stderr, "%s\n", sq_last_error());
        return;
    }
    /* the lattice box: 16 x 16 x 8 cells of 2 m centred on the origin, from the ground up */
    const float lo[3] = {-16.0f, -16.0f, -0.01f}, hi[3] = {16.0f, 16.0f, 16.01f};
    SQ_CHECK_OK(sq_scene_step(s, 0.5));
    SQ_CHECK_MSG(flakes_of(s) == NULL, "flakes drawn without snowfall");
    sq_scene_desc d = {.cfg = on};
    sq_live_result res;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK_MSG(!res.rebuild && res.changed == 1, "rebuild %d (%s), changed %d", res.rebuild,
                 res.reason, res.changed);
    const sq_particles_view *v = flakes_of(s);
    SQ_CHECK_MSG(v != NULL, "snowfall 0 -> 5 mm/h live: no flakes drawn");
    if (v) {
        SQ_CHECK_MSG(v->count == 300, "%d flakes drawn, draw.flakes = 300", v->count);
        SQ_CHECK_MSG(flakes_outside(v, lo, hi) == 0, "%d flakes outside the lattice box",
                     flakes_outside(v, lo, hi));
    }
    static float before[300 * 3];
    if (v && v->count == 300) memcpy(before, v->position, sizeof before);
    SQ_CHECK_OK(sq_scene_step(s, 0.5));
    v = flakes_of(s);
    SQ_CHECK(v != NULL && v->count == 300);
    if (v && v->count == 300) {
        SQ_CHECK(memcmp(before, v->position, sizeof before) != 0); /* they fall */
        SQ_CHECK(flakes_outside(v, lo, hi) == 0);
    }
    SQ_CHECK_NEAR(sq_scene_time(s), 1.0, 1e-9);
    d.cfg = off;
    SQ_CHECK_OK(sq_scene_apply_live(s, &d, &res));
    SQ_CHECK(!res.rebuild && res.changed == 1);
    SQ_CHECK_MSG(flakes_of(s) == NULL, "flakes still drawn at 0 mm/h");
    sq_scene_destroy(s);
    sq_cfg_destroy(off);
    sq_cfg_destroy(on);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}
