/* fuzz_set.c — the `--set path=value` parser (sq_cfg_set) on the built-in presets. The input is
 * lines: the first byte picks a preset, each line (up to 16) is one assignment. Invariants: an assignment
 * is applied or refused with a message, and a refused one leaves the tree unchanged; text that
 * is not UTF-8, or holds control characters, is refused; after every assignment the tree
 * survives the YAML writer (written and parsed back it is the same tree); the scene built from
 * the result is accepted or refused with a message (validate_only); nothing leaks. */
#include "fuzz_util.h"
#include "squall/io.h"

static sq_cfg *copy_of(sq_context *ctx, const sq_cfg *cfg)
{
    char *yaml = sq_cfg_to_yaml(cfg);
    FUZZ_CHECK(yaml != NULL, "sq_cfg_to_yaml: %s", sq_last_error());
    sq_cfg *c = NULL;
    FUZZ_CHECK(sq_cfg_parse(ctx, yaml, strlen(yaml), "copy", &c) == SQ_OK, "%s", sq_last_error());
    free(yaml);
    return c;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    sq_context *ctx = sq_fuzz_context(16u << 20);
    if (size < 1 || size > 4096) return 0;
    const int np = sq_preset_count();
    sq_cfg *cfg = NULL;
    FUZZ_CHECK(sq_cfg_load_preset(ctx, sq_preset_name(data[0] % np), &cfg) == SQ_OK, "%s",
               sq_last_error());
    char *text = (char *)malloc(size);
    if (!text) abort();
    memcpy(text, data + 1, size - 1);
    text[size - 1] = 0;
    char *save = NULL;
    int lines = 0; /* at most 16 assignments: each costs two YAML round trips of the preset */
    for (char *line = strtok_r(text, "\n", &save); line && lines < 16;
         line = strtok_r(NULL, "\n", &save), lines++) {
        sq_cfg *before = copy_of(ctx, cfg);
        sq_result r = sq_cfg_set(cfg, line);
        if (r != SQ_OK) {
            FUZZ_CHECK(sq_last_error()[0], "refused without a message");
            FUZZ_CHECK(sq_fuzz_cfg_equal(before->root->child, cfg->root->child),
                       "a refused assignment changed the tree");
        } else {
            FUZZ_CHECK(sq_cfg_text_ok(line), "accepted text that is not printable UTF-8");
        }
        sq_cfg_destroy(before);
        sq_fuzz_check_round_trip(ctx, cfg);
    }
    free(text);
    sq_fuzz_small_terrain(cfg);
    sq_scene_desc sd = {.cfg = cfg, .validate_only = true};
    sq_scene *scene = NULL;
    sq_result r = sq_scene_create(ctx, &sd, &scene);
    if (r != SQ_OK) FUZZ_CHECK(scene == NULL && sq_last_error()[0], "failure without a message");
    sq_scene_destroy(scene);
    sq_cfg_destroy(cfg);
    sq_fuzz_context_clean(ctx, "--set");
    return 0;
}
