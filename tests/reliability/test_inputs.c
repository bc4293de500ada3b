/* test_inputs.c — untrusted input (issue 17): 64-bit keys and values that do not fit their C
 * type are refused (no undefined conversion), `--set` accepts only what a scene file could hold
 * and leaves the tree unchanged when it refuses, the YAML writer's output parses back to the same
 * tree for the values that broke it, and inputs that are not regular files (FIFOs, devices,
 * directories) are refused at once instead of blocking. */
#include <fcntl.h>
#include <signal.h>
#include <stddef.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz/fuzz_util.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/mesh.h"
#include "squall/plugin.h"
#include "squall/scene.h"

SQ_LABEL(unit)

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.log_level = SQ_LOG_NONE};
    sq_context_create(&d, &ctx);
    return ctx;
}

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

/* A seed is a 64-bit unsigned whole number written in digits: 1e30 was accepted and converted
 * to uint64_t with undefined behaviour. */
SQ_TEST(u64_keys_take_digits_only)
{
    sq_context *ctx = mkctx();
    const char *ok[] = {"seed: 0\n", "seed: 18446744073709551615\n",
                        "world: {terrain: {seed: 18446744073709551615, kind: flat, "
                        "resolution: [5, 5]}}\n"};
    for (size_t i = 0; i < sizeof ok / sizeof ok[0]; i++)
        SQ_CHECK_MSG(try_scene(ctx, ok[i]) == SQ_OK, "%s: %s", ok[i], sq_last_error());
    const char *bad[] = {"1e30", "18446744073709551616", "-1", "1.0", "0x10", "1e3", " ", "+5",
                         "99999999999999999999999"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char t[256];
        snprintf(t, sizeof t, "world: {terrain: {kind: flat, resolution: [5, 5], seed: \"%s\"}}\n",
                 bad[i]);
        SQ_CHECK_ERR(try_scene(ctx, t), SQ_ERR_INVALID_ARG, "world.terrain.seed");
        SQ_CHECK_MSG(strstr(sq_last_error(), "18446744073709551615") != NULL, "%s", sq_last_error());
        snprintf(t, sizeof t, "seed: \"%s\"\n", bad[i]);
        SQ_CHECK_ERR(try_scene(ctx, t), SQ_ERR_INVALID_ARG, "t.yaml:1:1: seed");
    }
    sq_context_destroy(ctx);
}

typedef struct wide_desc {
    float f;
    int i;
    float v[3];
} wide_desc;

/* Keys without a range still refuse values their C type cannot hold (double -> float or int
 * conversion out of range is undefined behaviour). */
SQ_TEST(unbounded_keys_fit_their_type)
{
    const sq_param t[] = {
        {"f", SQ_PARAM_FLOAT, "m", offsetof(wide_desc, f), 0, 0, 0, NULL, NULL, 0, 0, 0, "f"},
        {"i", SQ_PARAM_INT, "1", offsetof(wide_desc, i), 0, 0, 0, NULL, NULL, 0, 0, 0, "i"},
        {"v", SQ_PARAM_VEC3, "m", offsetof(wide_desc, v), 0, 0, 0, "0 0 0", NULL, 0, 0, 0, "v"},
    };
    wide_desc d;
    sq_params_defaults(t, 3, &d);
    SQ_CHECK_OK(sq_params_set(t, 3, &d, "s", "f", "3e38", NULL));
    SQ_CHECK_ERR(sq_params_set(t, 3, &d, "s", "f", "1e300", NULL), SQ_ERR_INVALID_ARG,
                 "s.f = 1e300 m: must be finite");
    SQ_CHECK_OK(sq_params_set(t, 3, &d, "s", "i", "2147483647", NULL));
    SQ_CHECK_ERR(sq_params_set(t, 3, &d, "s", "i", "1e30", NULL), SQ_ERR_INVALID_ARG, "s.i");
    SQ_CHECK_ERR(sq_params_set(t, 3, &d, "s", "v", "[1, 1e39, 2]", NULL), SQ_ERR_INVALID_ARG, "s.v");
    SQ_CHECK(d.i == 2147483647);
}

static sq_cfg *parse(sq_context *ctx, const char *t)
{
    sq_cfg *cfg = NULL;
    if (sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg) != SQ_OK) return NULL;
    return cfg;
}

/* --set is held to what a scene file can say; a refused assignment changes nothing. */
SQ_TEST(set_refuses_what_a_file_cannot_say)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = parse(ctx, "camera: {position: [1, 2, 3]}\nlayers:\n  - {type: sandstorm}\n");
    SQ_CHECK(cfg != NULL);
    char *before = sq_cfg_to_yaml(cfg);
    SQ_CHECK_ERR(sq_cfg_set(cfg, "camera.position=[1, 2, 3"), SQ_ERR_INVALID_ARG, "not closed");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "camera.position=[1, [2], 3]"), SQ_ERR_INVALID_ARG, "inside a list");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "camera.position=[1, , 3]"), SQ_ERR_INVALID_ARG, "empty element");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "camera..fov_deg=3"), SQ_ERR_INVALID_ARG, "empty part");
    SQ_CHECK_ERR(sq_cfg_set(cfg, ".camera=3"), SQ_ERR_INVALID_ARG, "empty part");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "name=caf\xc3"), SQ_ERR_INVALID_ARG, "byte 9 (0xC3) is not valid UTF-8");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "name=\xc0\xaf"), SQ_ERR_INVALID_ARG, "not valid UTF-8");      /* overlong */
    SQ_CHECK_ERR(sq_cfg_set(cfg, "name=\xed\xa0\x80"), SQ_ERR_INVALID_ARG, "not valid UTF-8");  /* surrogate */
    SQ_CHECK_ERR(sq_cfg_set(cfg, "name=a\x01" "b"), SQ_ERR_INVALID_ARG, "control character (0x01)");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "name=a\tb"), SQ_ERR_INVALID_ARG, "control character");
    SQ_CHECK_ERR(sq_cfg_set(cfg, "layers.7.x=1"), SQ_ERR_NOT_FOUND, "no element '7'");
    char *after = sq_cfg_to_yaml(cfg);
    SQ_CHECK(before && after && strcmp(before, after) == 0);
    /* a list becomes a list node, as the same text in a file would */
    SQ_CHECK_OK(sq_cfg_set(cfg, "camera.position=[4, 5 , 6]"));
    const sq_cfg_node *p = sq_cfg_get(sq_cfg_get(cfg->root, "camera"), "position");
    SQ_CHECK(p && p->kind == SQ_CFG_SEQ && p->child && strcmp(p->child->next->value, "5") == 0);
    SQ_CHECK_OK(sq_cfg_set(cfg, "name=caf\xc3\xa9 \xe2\x80\xa8 ok"));
    free(before);
    free(after);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}

/* The values the issue lists made the writer produce YAML that did not parse back (or parsed to
 * something else). Each is set on a tree and the tree is written and read back. */
SQ_TEST(yaml_writer_round_trips_awkward_text)
{
    sq_context *ctx = mkctx();
    const char *values[] = {"[", "]", "{", "}", "*x", "&x", "@x", "%x", "`x", "!x", "|x", ">x",
                            "'x", "\"x", "#x", "a #b", "a: b", "a:b", "- x", "-", "? x", "?", ":",
                            ",x", "", " lead", "trail ", "~", "null", "true", "---", "...",
                            "caf\xc3\xa9", "line\xe2\x80\xa8sep", "\xef\xbb\xbf" "bom",
                            "nel\xc2\x85x", "c1\xc2\x9fx", "nc\xef\xbf\xbe", "\xf0\x9f\x98\x80",
                            "back\\slash", "a  b", "1e30", "-5", "-.5", ".5", "x,y", "(a)"};
    for (size_t i = 0; i < sizeof values / sizeof values[0]; i++) {
        sq_cfg *cfg = parse(ctx, "world: {}\n");
        SQ_CHECK(cfg != NULL);
        sq_cfg_node *w = sq_cfg_get(cfg->root, "world");
        /* as key and as value, at two depths, and as a sequence item */
        sq_cfg_node_append(cfg->root, sq_cfg_node_new(SQ_CFG_SCALAR, values[i], values[i], 0, 0));
        sq_cfg_node_append(w, sq_cfg_node_new(SQ_CFG_SCALAR, values[i], "v", 0, 0));
        sq_cfg_node *seq = sq_cfg_node_new(SQ_CFG_SEQ, "list", NULL, 0, 0);
        sq_cfg_node_append(seq, sq_cfg_node_new(SQ_CFG_SCALAR, NULL, values[i], 0, 0));
        sq_cfg_node_append(w, seq);
        char *y = sq_cfg_to_yaml(cfg);
        SQ_CHECK_MSG(y != NULL, "value %zu: %s", i, sq_last_error());
        sq_cfg *back = y ? parse(ctx, y) : NULL;
        SQ_CHECK_MSG(back != NULL, "value %zu '%s': written YAML does not parse: %s\n%s", i,
                     values[i], sq_last_error(), y ? y : "");
        if (back)
            SQ_CHECK_MSG(sq_fuzz_cfg_equal(cfg->root->child, back->root->child),
                         "value %zu '%s': parses to another tree:\n%s", i, values[i], y);
        free(y);
        sq_cfg_destroy(back);
        sq_cfg_destroy(cfg);
    }
    /* control characters reach the tree through YAML escapes; they must survive the writer */
    sq_cfg *cfg = parse(ctx, "name: \"a\\x01b\\tc\\x7fd\\ne\"\n\"\\x02\": 1\n");
    SQ_CHECK(cfg != NULL);
    char *y = cfg ? sq_cfg_to_yaml(cfg) : NULL;
    sq_cfg *back = y ? parse(ctx, y) : NULL;
    SQ_CHECK(back && sq_fuzz_cfg_equal(cfg->root->child, back->root->child));
    free(y);
    sq_cfg_destroy(back);
    sq_cfg_destroy(cfg);
    /* a tree with invalid UTF-8 (only possible through the C API) is refused, not mis-written */
    cfg = parse(ctx, "world: {}\n");
    sq_cfg_node_append(cfg->root, sq_cfg_node_new(SQ_CFG_SCALAR, "k", "\xff", 0, 0));
    SQ_CHECK(sq_cfg_to_yaml(cfg) == NULL && strstr(sq_last_error(), "UTF-8"));
    sq_cfg_destroy(cfg);
    /* an empty tree writes "{}", which parses back */
    sq_cfg *empty = NULL;
    SQ_CHECK_OK(sq_cfg_create(&empty));
    y = sq_cfg_to_yaml(empty);
    SQ_CHECK(y && (back = parse(ctx, y)) != NULL && back->root->child == NULL);
    free(y);
    sq_cfg_destroy(back);
    sq_cfg_destroy(empty);
    sq_context_destroy(ctx);
}

/* A YAML NUL escape would silently cut a value short; anchors and tags are refused on every node. */
SQ_TEST(yaml_reader_refuses_nul_anchor_tag)
{
    sq_context *ctx = mkctx();
    sq_cfg *cfg = NULL;
    const char *t = "name: \"a\\0b\"\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg), SQ_ERR_PARSE, "t.yaml:1:7: a value holds a NUL");
    t = "world: &w {}\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg), SQ_ERR_PARSE, "anchors");
    t = "world: !!map {}\n";
    SQ_CHECK_ERR(sq_cfg_parse(ctx, t, strlen(t), "t.yaml", &cfg), SQ_ERR_PARSE, "tags");
    sq_context_destroy(ctx);
}

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "FAIL: reading a non-regular file blocked for 5 s\n";
    if (write(2, msg, sizeof msg - 1) < 0) _exit(1);
    _exit(1);
}

/* A FIFO as scene file or heightmap blocked the open forever; /dev/zero as heightmap is endless.
 * Both must be refused at once (the alarm turns a block into a failure). */
SQ_TEST(non_regular_inputs_refused)
{
    sq_context *ctx = mkctx();
    signal(SIGALRM, on_alarm);
    alarm(5);
    char dir[] = "/tmp/sq-test-inputs-XXXXXX";
    SQ_CHECK(mkdtemp(dir) != NULL);
    char fifo[128];
    snprintf(fifo, sizeof fifo, "%s/scene.yaml", dir);
    SQ_CHECK(mkfifo(fifo, 0600) == 0);
    sq_cfg *cfg = NULL;
    SQ_CHECK_ERR(sq_cfg_load_file(ctx, fifo, &cfg), SQ_ERR_IO, "is a FIFO (named pipe)");
    SQ_CHECK(strstr(sq_last_error(), fifo) != NULL);
    uint16_t *hm = NULL;
    int w = 0, h = 0;
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, fifo, 0, &hm, &w, &h), SQ_ERR_IO, "FIFO");
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, "/dev/zero", 0, &hm, &w, &h), SQ_ERR_IO,
                 "'/dev/zero': it is a character device");
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, dir, 0, &hm, &w, &h), SQ_ERR_IO, "a directory");
    SQ_CHECK_ERR(sq_cfg_load_file(ctx, "/dev/null", &cfg), SQ_ERR_IO, "character device");
    alarm(0);
    unlink(fifo);
    rmdir(dir);
    sq_context_destroy(ctx);
}

/* Ctrl-C reaches the generation of a procedural place (seconds for a town of millions of faces):
 * it stops at the next mesh, leaks nothing and returns no place; cleared, the same desc
 * generates. */
SQ_TEST(cancel_stops_place_generation)
{
    sq_context *ctx = mkctx();
    sq_place_desc d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_PLACE_SUBURB;
    d.size_m[0] = d.size_m[1] = 300.0f;
    sq_place *p = NULL;
    sq_context_cancel(ctx);
    SQ_CHECK_ERR(sq_place_generate(ctx, &d, &p), SQ_ERR_CANCELLED,
                 "interrupted while generating the place's meshes");
    SQ_CHECK(p == NULL);
    sq_context_cancel_clear(ctx);
    SQ_CHECK_OK(sq_place_generate(ctx, &d, &p));
    SQ_CHECK(p && p->mesh_count > 0 && p->houses > 0);
    sq_place_destroy(ctx, p);
    sq_context_destroy(ctx);
}

/* Ctrl-C reaches the library through sq_context_cancel: building a scene with a large terrain
 * and stepping stop with SQ_ERR_CANCELLED instead of running on. */
SQ_TEST(cancel_stops_building_and_stepping)
{
    sq_context *ctx = mkctx();
    const char *big = "world: {terrain: {kind: hills, resolution: [4097, 4097], octaves: 12}}\n";
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, big, strlen(big), "t.yaml", &cfg));
    sq_context_cancel(ctx);
    SQ_CHECK(sq_context_cancelled(ctx));
    sq_scene_desc d = {.cfg = cfg};
    sq_scene *s = NULL;
    SQ_CHECK_ERR(sq_scene_create(ctx, &d, &s), SQ_ERR_CANCELLED, "interrupted while generating");
    SQ_CHECK(s == NULL);
    sq_cfg_destroy(cfg);
    sq_context_cancel_clear(ctx);
    const char *small = "world: {terrain: {kind: flat, resolution: [5, 5]}}\n"
                        "layers:\n  - {type: snowdrift, domain: {nx: 8, ny: 8, nz: 8}}\n";
    SQ_CHECK_OK(sq_cfg_parse(ctx, small, strlen(small), "t.yaml", &cfg));
    d.cfg = cfg;
    SQ_CHECK_OK(sq_scene_create(ctx, &d, &s));
    if (s) {
        SQ_CHECK_OK(sq_scene_step(s, 0.05));
        sq_context_cancel(ctx);
        SQ_CHECK_ERR(sq_scene_step(s, 0.05), SQ_ERR_CANCELLED, "interrupted while stepping");
    }
    sq_scene_destroy(s);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
}
