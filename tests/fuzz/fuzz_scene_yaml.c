/* fuzz_scene_yaml.c — the YAML scene reader (src/io/scene_yaml.c) and everything a scene file
 * reaches before any simulation: the configuration tree, the section and plug-in parameter
 * tables (types, ranges, 64-bit seeds), the world built from them (validate_only: phenomena are
 * resolved and checked, not created). Invariants: a refused input names "fuzz.yaml:LINE:COL" or
 * at least the file; an accepted tree survives the YAML writer (written and parsed back it is
 * the same tree); nothing leaks. */
#include "fuzz_util.h"
#include "squall/io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* 16 MiB: enough for any small scene, refuses huge terrains quickly */
    sq_context *ctx = sq_fuzz_context(16u << 20);
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_parse(ctx, (const char *)data, size, "fuzz.yaml", &cfg);
    if (r != SQ_OK) {
        FUZZ_CHECK(cfg == NULL, "tree returned on failure");
        FUZZ_CHECK(strstr(sq_last_error(), "fuzz.yaml") != NULL, "error does not name the file: %s",
                   sq_last_error());
        return 0;
    }
    sq_fuzz_check_round_trip(ctx, cfg);
    sq_fuzz_small_terrain(cfg);
    sq_scene_desc sd = {.cfg = cfg, .validate_only = true};
    sq_scene *scene = NULL;
    r = sq_scene_create(ctx, &sd, &scene);
    if (r == SQ_OK)
        FUZZ_CHECK(scene != NULL, "no scene on success");
    else
        FUZZ_CHECK(scene == NULL && sq_last_error()[0], "failure without a message");
    sq_scene_destroy(scene);
    sq_cfg_destroy(cfg);
    sq_fuzz_context_clean(ctx, "a scene file");
    return 0;
}
