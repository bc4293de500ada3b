/* test_scene.c — scene files: parameter tables, YAML errors with file:line:column, unknown keys
 * with suggestions, wrong types, ranges with units, --set overrides, presets. */
#include "sq_config.h"
#include "sq_test.h"
#include "squall/geo.h"
#include "squall/io.h"
#include "squall/scene.h"
#include "squall/wrf.h"

SQ_LABEL(unit)

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    return ctx;
}

/* Parses text and creates the scene in validate-only mode; returns the result. */
static sq_result try_scene(sq_context *ctx, const char *text)
{
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_parse(ctx, text, strlen(text), "t.yaml", &cfg);
    if (r != SQ_OK) return r;
    sq_scene_desc d = {.cfg = cfg, .validate_only = true};
    sq_scene *s = NULL;
    r = sq_scene_create(ctx, &d, &s);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    return r;
}

SQ_TEST(minimal_scene_defaults)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL;
    const char *t = "name: t\nworld:\n  terrain: {kind: flat, size_m: [100, 100], resolution: [5, 5]}\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg));
    sq_scene_desc d = {.cfg = cfg};
    sq_scene *s = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &d, &s));
    const sq_scene_output *o = sq_scene_output_settings(s);
    SQ_CHECK(o->width == 640 && o->height == 360 && o->fps == 24);
    SQ_CHECK(sq_scene_frame_count(s) == 240); /* 10 s at 24 fps */
    sq_world_terrain terr;
    sq_world_get_terrain(sq_scene_world(s), &terr);
    SQ_CHECK(terr.nx == 5);
    SQ_CHECK_OK(sq_scene_step(s, 0.1));
    SQ_CHECK_NEAR(sq_scene_time(s), 0.1, 1e-12);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

SQ_TEST(unknown_key_suggests)
{
    sq_context *ctx = mkctx();
    SQ_CHECK_ERR(try_scene(ctx, "output:\n  widht: 100\n"), SQ_ERR_NOT_FOUND,
                 "t.yaml:2:3: unknown key 'output.widht'; did you mean 'output.width'?");
    SQ_CHECK_ERR(try_scene(ctx, "world:\n  terrain:\n    releif_m: 3\n"), SQ_ERR_NOT_FOUND,
                 "did you mean 'world.terrain.relief_m'?");
    SQ_CHECK_ERR(try_scene(ctx, "camra:\n  fov_deg: 30\n"), SQ_ERR_NOT_FOUND,
                 "t.yaml:1:1: unknown key 'camra'; did you mean 'camera'?");
    sq_context_destroy(ctx);
}

SQ_TEST(wrong_type)
{
    sq_context *ctx = mkctx();
    SQ_CHECK_ERR(try_scene(ctx, "output:\n  fps: fast\n"), SQ_ERR_INVALID_ARG,
                 "t.yaml:2:3: output.fps = 'fast': expected a whole number");
    SQ_CHECK_ERR(try_scene(ctx, "camera:\n  position: 12\n"), SQ_ERR_INVALID_ARG,
                 "camera.position = '12': expected 3 numbers [x, y, z] in m");
    SQ_CHECK_ERR(try_scene(ctx, "output:\n  volume_noise: maybe\n"), SQ_ERR_INVALID_ARG,
                 "expected true or false");
    SQ_CHECK_ERR(try_scene(ctx, "world:\n  terrain: {kind: lava}\n"), SQ_ERR_INVALID_ARG,
                 "world.terrain.kind = 'lava': expected one of");
    SQ_CHECK_ERR(try_scene(ctx, "world:\n  terrain: 5\n"), SQ_ERR_INVALID_ARG,
                 "expected a section");
    SQ_CHECK_ERR(try_scene(ctx, "layers:\n  type: x\n"), SQ_ERR_INVALID_ARG,
                 "layers: expected a list");
    sq_context_destroy(ctx);
}

SQ_TEST(out_of_range_names_range_and_unit)
{
    sq_context *ctx = mkctx();
    SQ_CHECK_ERR(try_scene(ctx, "camera:\n  fov_deg: 200\n"), SQ_ERR_INVALID_ARG,
                 "t.yaml:2:3: camera.fov_deg = 200 deg: outside the range [1, 170] deg");
    SQ_CHECK_ERR(try_scene(ctx, "output:\n  width: 0\n"), SQ_ERR_INVALID_ARG,
                 "output.width = 0 px: outside the range [16, 65536] px");
    SQ_CHECK_ERR(try_scene(ctx, "world:\n  sun: {latitude_deg: 91}\n"), SQ_ERR_INVALID_ARG,
                 "outside the range [-90, 90] deg");
    sq_context_destroy(ctx);
}

SQ_TEST(malformed_yaml_has_position)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL;
    const char *t = "world:\n  terrain: {kind: flat\ncamera:\n  fov_deg: 3\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t, strlen(t), "bad.yaml", &cfg), SQ_ERR_PARSE, "bad.yaml:");
    SQ_CHECK(cfg == NULL);
    const char *t2 = "a: 1\n b: 2\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t2, strlen(t2), "bad.yaml", &cfg), SQ_ERR_PARSE,
                 "bad.yaml:2:");
    const char *t3 = "output:\n  fps: 2\n  fps: 3\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t3, strlen(t3), "dup.yaml", &cfg), SQ_ERR_PARSE,
                 "dup.yaml:3:3: duplicate key 'fps'");
    const char *t4 = "- 1\n- 2\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t4, strlen(t4), "list.yaml", &cfg), SQ_ERR_PARSE,
                 "must be a map");
    sq_context_destroy(ctx);
}

SQ_TEST(missing_file_named)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL;
    SQ_CHECK_ERR(sq_cfg_load(ctx, "/nonexistent/dir/scene.yaml", &cfg), SQ_ERR_IO,
                 "cannot open scene file '/nonexistent/dir/scene.yaml'");
    SQ_CHECK_ERR(sq_cfg_load(ctx, "no-such-preset", &cfg), SQ_ERR_NOT_FOUND,
                 "'no-such-preset' is neither a scene file nor a preset");
    sq_context_destroy(ctx);
}

SQ_TEST(set_overrides)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL;
    const char *t = "world:\n  terrain: {kind: flat, resolution: [5, 5]}\noutput:\n  fps: 10\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg));
    SQ_CHECK_OK(sq_cfg_set(cfg, "output.fps=30"));
    SQ_CHECK_OK(sq_cfg_set(cfg, "output.duration_s=2"));
    SQ_CHECK_OK(sq_cfg_set(cfg, "camera.fov_deg=35"));
    SQ_CHECK_OK(sq_cfg_set(cfg, "world.terrain.size_m=[300, 200]"));
    sq_scene_desc d = {.cfg = cfg, .validate_only = true};
    sq_scene *s = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &d, &s));
    SQ_CHECK(sq_scene_output_settings(s)->fps == 30);
    SQ_CHECK(sq_scene_frame_count(s) == 60);
    sq_world_terrain terr;
    sq_world_get_terrain(sq_scene_world(s), &terr);
    SQ_CHECK_NEAR(terr.dx, 75.0, 1e-4);
    sq_scene_destroy(s);
    SQ_CHECK_ERR(sq_cfg_set(cfg, "output.fps"), SQ_ERR_INVALID_ARG, "expected path.to.key=value");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "output.fps.x=3"), SQ_ERR_INVALID_ARG, "is a value");
    SQ_CHECK_OK(sq_cfg_set(cfg, "output.fpz=3"));
    SQ_CHECK_ERR(sq_scene_create(ctx, &d, &s), SQ_ERR_NOT_FOUND,
                 "t.yaml (--set): unknown key 'output.fpz'; did you mean 'output.fps'?");
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

SQ_TEST(unknown_layer_type)
{
    sq_context *ctx = mkctx();
    SQ_CHECK_ERR(try_scene(ctx, "layers:\n  - type: tornado\n"), SQ_ERR_NOT_FOUND,
                 "t.yaml:2:5: layers[0].type = 'tornado': no such phenomenon");
    SQ_CHECK_ERR(try_scene(ctx, "layers:\n  - name: x\n"), SQ_ERR_INVALID_ARG, "needs 'type:");
    sq_context_destroy(ctx);
}

SQ_TEST(camera_path_times_increase)
{
    sq_context *ctx = mkctx();
    SQ_CHECK_ERR(try_scene(ctx, "camera:\n  path:\n    - {t: 2}\n    - {t: 1}\n"),
                 SQ_ERR_INVALID_ARG, "camera.path[1].t = 1: key times must increase");
    sq_context_destroy(ctx);
}

SQ_TEST(yaml_round_trip)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL, *cfg2 = NULL;
    const char *t = "name: \"a: b\"\nworld:\n  terrain:\n    kind: dunes\n    size_m: [1, 2]\n"
                    "layers: []\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg));
    char *y = sq_cfg_to_yaml(cfg);
    SQ_CHECK(y != NULL);
    SQ_CHECK_OK(sq_cfg_parse(ctx, y, strlen(y), "round.yaml", &cfg2));
    SQ_CHECK(strcmp(sq_cfg_get(cfg2->root, "name")->value, "a: b") == 0);
    free(y);
    sq_cfg_destroy(cfg);
    sq_cfg_destroy(cfg2);
    sq_context_destroy(ctx);
}

/* Every preset parses and validates (phenomena are created in the smoke tests). */
SQ_TEST(presets_validate)
{
    sq_context *ctx = mkctx();
    SQ_CHECK(sq_preset_count() >= 1);
    SQ_CHECK(sq_preset_text(sq_preset_default()) != NULL);
    for (int i = 0; i < sq_preset_count(); i++) {
        sq_cfg *cfg = NULL;
        SQ_CHECK_OK(sq_cfg_load_preset(ctx, sq_preset_name(i), &cfg));
        /* the loaders the CLI passes: a preset may stand on a DEM (alpine-avalanche) */
        sq_scene_desc d = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                           .load_dem = sq_dem_load, .load_area = sq_area_load,
                           .load_wrf_world = sq_scene_wrf_world_loader, /* wrf-clouds */
                           .validate_only = true};
        sq_scene *s = NULL;
        sq_result r = sq_scene_create(ctx, &d, &s);
        if (!SQ_HAVE_GDAL && r == SQ_ERR_UNSUPPORTED) r = SQ_OK; /* a DEM preset without GDAL */
        SQ_CHECK_MSG(r == SQ_OK, "preset %s: %s", sq_preset_name(i), sq_last_error());
        sq_scene_destroy(s);
        sq_cfg_destroy(cfg);
    }
    sq_context_destroy(ctx);
}

/* A table's formatted defaults parse back to the same values (docs show what the code uses). */
SQ_TEST(section_tables_consistent)
{
    const char *sections[] = {"world", "obstacle", "camera", "camera-key", "output"};
    for (int s = 0; s < 5; s++) {
        size_t n = 0;
        const sq_param *t = sq_scene_section_params(sections[s], &n);
        SQ_CHECK(t && n > 0);
        static char a[1 << 16], b[1 << 16];
        memset(a, 0, sizeof a);
        memset(b, 0, sizeof b);
        sq_params_defaults(t, n, a);
        SQ_CHECK_OK(sq_params_validate(t, n, a, sections[s]));
        for (size_t i = 0; i < n; i++) {
            char v[512], v2[512];
            SQ_CHECK_MSG(t[i].doc && strlen(t[i].doc) > 10, "%s.%s has no doc", sections[s],
                         t[i].key);
            sq_params_format(&t[i], a, v, sizeof v);
            /* strings are formatted quoted; strip quotes for set */
            char raw[512];
            snprintf(raw, sizeof raw, "%s", v);
            if (raw[0] == '"') {
                memmove(raw, raw + 1, strlen(raw));
                raw[strlen(raw) - 1] = 0;
            }
            SQ_CHECK_OK(sq_params_set(t, n, b, sections[s], t[i].key, raw, NULL));
            sq_params_format(&t[i], b, v2, sizeof v2);
            SQ_CHECK_MSG(strcmp(v, v2) == 0, "%s.%s: %s != %s", sections[s], t[i].key, v, v2);
        }
    }
}

/* STYLE: the table's defaults equal what each plug-in's desc_resolve produces from a zero desc,
 * so `squall params`, the docs and the C API agree. */
SQ_TEST(plugin_table_defaults_match_resolve)
{
    for (int i = 0; i < sq_plugin_count(); i++) {
        const sq_phen_plugin *p = sq_plugin_at(i);
        void *a = calloc(1, p->desc_size), *b = calloc(1, p->desc_size);
        SQ_CHECK(a && b);
        sq_params_defaults(p->params, p->param_count, b);
        if (p->desc_resolve) {
            SQ_CHECK_OK(p->desc_resolve(a));
            SQ_CHECK_OK(p->desc_resolve(b));
        }
        SQ_CHECK_OK(sq_params_validate(p->params, p->param_count, b, p->name));
        for (size_t k = 0; k < p->param_count; k++) {
            char va[512], vb[512];
            sq_params_format(&p->params[k], a, va, sizeof va);
            sq_params_format(&p->params[k], b, vb, sizeof vb);
            SQ_CHECK_MSG(strcmp(va, vb) == 0, "%s.%s: resolve gives %s, the table says %s", p->name,
                         p->params[k].key, va, vb);
            SQ_CHECK_MSG(p->params[k].doc && strlen(p->params[k].doc) > 10, "%s.%s has no doc",
                         p->name, p->params[k].key);
        }
        free(a);
        free(b);
    }
}
