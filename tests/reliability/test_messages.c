/* test_messages.c — messages name what a scene user can set (issue 17 part 6): a solver's field
 * names in a layer's error become that layer's keys; errors found after parsing keep the
 * file:line of the key they are about (camera below the terrain). The static check that every
 * key named in any message exists is tests/reliability/check_message_keys.py (CTest
 * cli.message_keys). */
#include "scene/scene_internal.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/scene.h"

SQ_LABEL(unit)

static const sq_phen_plugin *plugin(const char *name)
{
    const sq_phen_plugin *p = sq_plugin_find(name);
    SQ_CHECK_MSG(p != NULL, "plug-in %s not built", name);
    return p;
}

SQ_TEST(solver_fields_become_layer_keys)
{
    const sq_phen_plugin *av = plugin("avalanche");
    if (av) {
        sq_set_error(SQ_ERR_UNSTABLE, "step 3: particle 7 runs away; the stable dt was 1e-05 s "
                                      "(cfl). Lower the frame dt or dt_max_s, raise "
                                      "speed_of_sound_mps (now 5 m/s) or lower the viscosity");
        SQ_CHECK(sq__scene_translate_error(av->params, av->param_count, "slide",
                                           SQ_ERR_UNSTABLE) == SQ_ERR_UNSTABLE);
        const char *e = sq_last_error();
        SQ_CHECK_MSG(strncmp(e, "layers.slide: step 3", 20) == 0, "%s", e);
        SQ_CHECK_MSG(strstr(e, "layers.slide.numerics.dt_max_s,") != NULL, "%s", e);
        SQ_CHECK_MSG(strstr(e, "raise layers.slide.numerics.speed_of_sound_mps (now") != NULL, "%s",
                     e);
        SQ_CHECK_MSG(strstr(e, "frame dt or") != NULL, "%s", e); /* plain words stay */
        /* a refusal found after validation names the C desc: it becomes the layer's keys */
        sq_set_error(SQ_ERR_INVALID_ARG, "sq_avalanche_desc.release: the release produces no "
                                         "particles at spacing 100 m");
        sq__scene_translate_error(av->params, av->param_count, "slide", SQ_ERR_INVALID_ARG);
        SQ_CHECK_MSG(strcmp(sq_last_error(), "layers.slide.release: the release produces no "
                                             "particles at spacing 100 m") == 0,
                     "%s", sq_last_error());
    }
    const sq_phen_plugin *sd = plugin("snowdrift");
    if (sd) {
        sq_set_error(SQ_ERR_UNSTABLE, "step 9: density -1: the flow blew up; lower dt_s (now "
                                      "0.01 s), the wind or the forcing, or raise the viscosity");
        sq__scene_translate_error(sd->params, sd->param_count, "snow", SQ_ERR_UNSTABLE);
        SQ_CHECK_MSG(strstr(sq_last_error(), "lower layers.snow.domain.dt_s (now 0.01 s)") != NULL,
                     "%s", sq_last_error());
        /* a message that already names keys is left as it is */
        sq_set_error(SQ_ERR_INVALID_ARG, "layers.snowdrift.domain.dt_s = 5; too large");
        sq__scene_translate_error(sd->params, sd->param_count, "snow", SQ_ERR_INVALID_ARG);
        SQ_CHECK_MSG(strcmp(sq_last_error(), "layers.snowdrift.domain.dt_s = 5; too large") == 0,
                     "%s", sq_last_error());
    }
}

/* Builds the scene (validate_only) and checks its camera as rendering does. */
static sq_result try_scene(sq_context *ctx, const char *text)
{
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_parse(ctx, text, strlen(text), "t.yaml", &cfg);
    if (r != SQ_OK) return r;
    sq_scene_desc d = {.cfg = cfg, .validate_only = true};
    sq_scene *s = NULL;
    r = sq_scene_create(ctx, &d, &s);
    if (r == SQ_OK) r = sq_scene_check_camera(s);
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    return r;
}

/* The renderer used to refuse such a camera at the first frame, naming
 * `camera.position_m.z`, a key that does not exist and without a place in the file. */
SQ_TEST(camera_below_terrain_has_file_line_and_key)
{
    sq_context *ctx = NULL;
    sq_context_desc cd = {.log_level = SQ_LOG_NONE};
    sq_context_create(&cd, &ctx);
    const char *flat = "world:\n  terrain: {kind: flat, base_m: 50, size_m: [400, 400], "
                       "resolution: [9, 9]}\n";
    char t[512];
    snprintf(t, sizeof t, "%scamera:\n  position: [0, 0, 20]\n  target: [10, 0, 60]\n", flat);
    SQ_CHECK_ERR(try_scene(ctx, t), SQ_ERR_INVALID_ARG,
                 "t.yaml:4:3: camera.position = [0, 0, 20] m: the terrain surface there is at "
                 "50.00 m; raise z above 50.10 m");
    snprintf(t, sizeof t,
             "%scamera:\n  path:\n    - {t: 0, position: [0, 0, 80]}\n"
             "    - {t: 1, position: [10, 0, 49]}\n",
             flat);
    SQ_CHECK_ERR(try_scene(ctx, t), SQ_ERR_INVALID_ARG, "t.yaml:6:7: camera.path[1].position");
    snprintf(t, sizeof t, "%scamera:\n  position: [0, 0, 80]\n", flat);
    SQ_CHECK_OK(try_scene(ctx, t));
    sq_context_destroy(ctx);
}
