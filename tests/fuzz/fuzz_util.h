/* fuzz_util.h — what every harness in tests/fuzz needs: a quiet context with a small memory
 * budget, the input as a file (readers take paths), an invariant check that aborts (libFuzzer
 * and replay_main.c both report an abort as a finding), and a configuration-tree comparison.
 *
 * Adding a harness for a new reader (WRF NetCDF, a mesh, a DEM, a checkpoint ...):
 *   1. tests/fuzz/fuzz_<name>.c: define LLVMFuzzerTestOneInput; write the bytes with
 *      sq_fuzz_file(), call the reader on the path, FUZZ_CHECK its contract (success gives sane
 *      outputs; failure clears them and names the file in sq_last_error(); nothing leaks through
 *      the context, sq_fuzz_context_clean()).
 *   2. tests/fuzz/corpus/<name>/: a few small valid and near-valid inputs.
 * tests/fuzz/CMakeLists.txt picks both up: a replay test in every build, a libFuzzer target and
 * a `make fuzz` / CI run in the clang build. */
#ifndef SQ_FUZZ_UTIL_H
#define SQ_FUZZ_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "squall/core.h"
#include "squall/io.h"
#include "squall/scene.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_CHECK(cond, ...)                                                                  \
    do {                                                                                       \
        if (!(cond)) {                                                                         \
            fprintf(stderr, "%s:%d: invariant broken: %s: ", __FILE__, __LINE__, #cond);       \
            fprintf(stderr, __VA_ARGS__);                                                      \
            fprintf(stderr, "\n");                                                             \
            abort();                                                                           \
        }                                                                                      \
    } while (0)

/* One context for the process: one thread, silent, memory_limit_bytes as given the first time. */
static inline sq_context *sq_fuzz_context(uint64_t memory_limit_bytes)
{
    static sq_context *ctx;
    if (!ctx) {
        sq_context_desc d = {.threads = 1,
                             .memory_limit_bytes = memory_limit_bytes,
                             .log_level = SQ_LOG_NONE};
        if (sq_context_create(&d, &ctx) != SQ_OK) abort();
    }
    return ctx;
}

/* Nothing allocated through the context is left over after a call. */
static inline void sq_fuzz_context_clean(sq_context *ctx, const char *after)
{
    FUZZ_CHECK(sq_context_bytes_in_use(ctx) == 0, "%llu bytes still allocated after %s",
               (unsigned long long)sq_context_bytes_in_use(ctx), after);
}

/* The input as a file: one in-memory file (memfd) rewritten for every input, named by a path
 * the readers can open; a /tmp file where memfd is missing. Returns the path. */
static inline const char *sq_fuzz_file(const uint8_t *data, size_t size)
{
    static int fd = -1;
    static char path[64];
    if (fd < 0) {
#if defined(MFD_CLOEXEC)
        fd = memfd_create("squall-fuzz", MFD_CLOEXEC);
        if (fd >= 0) snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
#endif
        if (fd < 0) {
            snprintf(path, sizeof path, "/tmp/squall-fuzz-XXXXXX");
            fd = mkstemp(path);
            if (fd < 0) abort();
        }
    }
    if (ftruncate(fd, 0) != 0) abort();
    size_t done = 0;
    while (done < size) {
        ssize_t n = pwrite(fd, data + done, size - done, (off_t)done);
        if (n <= 0) abort();
        done += (size_t)n;
    }
    return path;
}

/* Same kinds, keys, values and order. */
static inline int sq_fuzz_cfg_equal(const sq_cfg_node *a, const sq_cfg_node *b)
{
    for (; a && b; a = a->next, b = b->next) {
        if (a->kind != b->kind) return 0;
        if ((a->key == NULL) != (b->key == NULL) || (a->key && strcmp(a->key, b->key))) return 0;
        if (a->kind == SQ_CFG_SCALAR) {
            const char *va = a->value ? a->value : "", *vb = b->value ? b->value : "";
            if (strcmp(va, vb)) return 0;
        }
        if (!sq_fuzz_cfg_equal(a->child, b->child)) return 0;
    }
    return a == NULL && b == NULL;
}

/* The writer's contract: sq_cfg_to_yaml(cfg) parses back to the same tree. */
static inline void sq_fuzz_check_round_trip(sq_context *ctx, const sq_cfg *cfg)
{
    char *yaml = sq_cfg_to_yaml(cfg);
    FUZZ_CHECK(yaml != NULL, "sq_cfg_to_yaml failed on a tree of valid text: %s", sq_last_error());
    sq_cfg *back = NULL;
    sq_result r = sq_cfg_parse(ctx, yaml, strlen(yaml), "round-trip", &back);
    if (r != SQ_OK) fprintf(stderr, "---- written YAML ----\n%s----\n", yaml);
    FUZZ_CHECK(r == SQ_OK, "the YAML writer's output does not parse: %s", sq_last_error());
    if (!sq_fuzz_cfg_equal(cfg->root->child, back->root->child))
        fprintf(stderr, "---- written YAML ----\n%s----\n", yaml);
    FUZZ_CHECK(sq_fuzz_cfg_equal(cfg->root->child, back->root->child),
               "the YAML writer's output parses to another tree");
    sq_cfg_destroy(back);
    free(yaml);
}

/* Terrain generation dominates scene validation (fBm noise on 257 x 257 samples: a second per
 * input); the harnesses are about reading, so the terrain is made small before validating. A
 * tree whose world cannot take the key keeps its own value. */
static inline void sq_fuzz_small_terrain(sq_cfg *cfg)
{
    (void)sq_cfg_set(cfg, "world.terrain.resolution=[9, 9]");
    (void)sq_cfg_set(cfg, "world.terrain.octaves=1");
}

#endif
