/* fuzz_checkpoint.c — checkpoint restore (src/io/checkpoint.c and every layer's state loader)
 * against damaged state records.
 *
 * A checkpoint carries a checksum over the whole file, so random bytes never get past the first
 * check. This harness fuzzes what lies behind it: every input is an edit script applied to a real
 * checkpoint, after which the checksum is made right again, as a file damaged before it was
 * summed (or written by a broken build) would be. Byte 0 picks the scene (a small sandstorm,
 * haboob, snowdrift, avalanche, snow cover or WRF clouds scene, made once per process and
 * checkpointed after one short step); the rest is a list of 6-byte edits of the state records (the
 * part after the header and the configuration):
 *   op (1 byte), offset (4 bytes, little-endian, modulo the records' length), value (1 byte)
 *   op % 4: 0 = XOR the byte, 1 = set the byte, 2 = set the 32-bit word there to one of
 *   0, 1, 0x7fffffff, 0x80000000, 0xffffffff, value (a count or size gone wrong), 3 = cut the
 *   records at offset (the end marker and checksum are kept).
 * Contract: sq_checkpoint_restore either succeeds, after which one more short step runs without a
 * crash (an error result is allowed, NaN state must be reported, not drawn), or fails with a
 * message naming the checkpoint; nothing leaks through the context.
 * Seeds (tests/fuzz/corpus/checkpoint/): one byte per scene (no edit: the pristine restore) and a
 * few edits of the record headers. */
#include <stdbool.h>

#include "fuzz_util.h"
#include "sq_config.h"
#include "squall/wrf.h"

#define N_SCENES 6
#define TRAILER_BYTES 16 /* "SQEND\0\0\0" + u64 FNV-1a */

typedef struct pristine {
    bool tried, ok;
    uint8_t *bytes;
    size_t size, records; /* file size; offset of the records */
} pristine;

static char g_dir[64];
static pristine g_scene[N_SCENES];

static sq_result load_cfg(sq_context *ctx, int which, sq_cfg **cfg)
{
    static const char *const cover_yaml =
        "seed: 4\n"
        "world:\n"
        "  terrain: {kind: hills, size_m: [300, 300], resolution: [33, 33], relief_m: 5}\n"
        "  obstacles:\n"
        "    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}\n"
        "camera: {position: [30, -40, 8], target: [0, 0, 2]}\n"
        "layers:\n"
        "  - type: snowcover\n"
        "    name: cover\n"
        "    snowfall: {rate_mmh: 3, speedup: 600}\n"
        "    flakes: {count: 300, turbulence_mps: 0.5, spin_rad_s: 2}\n"
        "output: {fps: 4, frames: 8}\n";
    static const char *const snow_yaml =
        "seed: 3\n"
        "world:\n"
        "  terrain: {kind: flat, material: snow, size_m: [100, 100], resolution: [17, 17]}\n"
        "  obstacles:\n"
        "    - {kind: house, center: [0, 0], size: [10, 8, 5], roof_m: 2}\n"
        "layers:\n"
        "  - type: snowdrift\n"
        "    name: snow\n"
        "    domain: {nx: 16, ny: 12, nz: 8, cell_size_m: 3}\n"
        "    wind: {speed_mps: 6, beaufort: 3}\n"
        "    snow: {snowfall_mmh: 4, speedup: 2000}\n"
        "    draw: {flakes: 50}\n"
        "output: {fps: 4, frames: 8}\n";
    sq_result r;
    switch (which) {
    case 0:
        r = sq_cfg_load_preset(ctx, "desert-sandstorm", cfg);
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.nx=12");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.ny=12");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.nz=6");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "world.terrain.resolution=[33, 33]");
        return r;
    case 1:
        r = sq_cfg_load_preset(ctx, "haboob", cfg);
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.nx=16");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.ny=8");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.domain.nz=8");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.coldpool.depth_m=300");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.coldpool.length_m=300");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.storm.near.particles=50");
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "world.terrain.resolution=[33, 33]");
        return r;
    case 2:
        return sq_cfg_parse(ctx, snow_yaml, strlen(snow_yaml), "snowdrift.yaml", cfg);
    case 3: {
        char path[1024];
        const char *src = getenv("SQ_SOURCE_DIR");
        snprintf(path, sizeof path, "%s/tests/cli/data/slope-avalanche.yaml", src ? src : ".");
        r = sq_cfg_load_file(ctx, path, cfg);
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.slide.particles.spacing_m=2"); /* ~340 */
        return r;
    }
    case 4:
        return sq_cfg_parse(ctx, cover_yaml, strlen(cover_yaml), "cover.yaml", cfg);
    default:
        r = sq_cfg_load_preset(ctx, "wrf-clouds", cfg);
        if (r == SQ_OK) r = sq_cfg_set(*cfg, "layers.clouds.particles.count=300");
        return r;
    }
}

static sq_result make_scene(sq_context *ctx, sq_cfg *cfg, sq_scene **scene)
{
    sq_scene_desc sd = {.cfg = cfg,
                        .load_heightmap = sq_scene_heightmap_loader,
                        .load_wrf_world = sq_scene_wrf_world_loader,
                        .load_mesh = sq_scene_mesh_loader};
    return sq_scene_create(ctx, &sd, scene);
}

/* One short step (a few solver sub-steps): enough to run every loop over the restored state. */
static double step_dt(const sq_scene *scene)
{
    const double dt = sq_scene_frame_dt(scene);
    return dt < 0.02 ? dt : 0.02;
}

static uint8_t *read_all(const char *path, size_t *size)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    const long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    uint8_t *b = n > 0 ? (uint8_t *)malloc((size_t)n) : NULL;
    if (b && fread(b, 1, (size_t)n, fp) != (size_t)n) {
        free(b);
        b = NULL;
    }
    fclose(fp);
    *size = b ? (size_t)n : 0;
    return b;
}

/* The scene's checkpoint after one frame, made once per process. */
static const pristine *get_pristine(sq_context *ctx, int which)
{
    pristine *p = &g_scene[which];
    if (p->tried) return p->ok ? p : NULL;
    p->tried = true;
    if (!g_dir[0]) {
        snprintf(g_dir, sizeof g_dir, "/tmp/sq_fuzz_ckpt_XXXXXX");
        if (!mkdtemp(g_dir)) abort();
    }
    char path[128];
    snprintf(path, sizeof path, "%s/pristine%d.ckpt", g_dir, which);
    sq_cfg *cfg = NULL;
    sq_scene *scene = NULL;
    sq_result r = load_cfg(ctx, which, &cfg);
    if (r == SQ_OK) r = make_scene(ctx, cfg, &scene);
    if (r == SQ_OK) r = sq_scene_step(scene, step_dt(scene));
    if (r == SQ_OK) r = sq_checkpoint_write(ctx, path, true, scene, cfg, 1);
    if (scene) sq_scene_destroy(scene);
    if (cfg) sq_cfg_destroy(cfg);
    if (r != SQ_OK) {
        fprintf(stderr, "fuzz_checkpoint: scene %d unavailable: %s\n", which, sq_last_error());
        return NULL;
    }
    /* where the records start: magic, format, marker, then two length-prefixed blocks */
    p->bytes = read_all(path, &p->size);
    unlink(path);
    if (!p->bytes || p->size < 32 + TRAILER_BYTES) return NULL;
    uint64_t hl = 0, yl = 0;
    memcpy(&hl, p->bytes + 16, 8);
    if (hl > p->size) return NULL;
    memcpy(&yl, p->bytes + 24 + hl, 8);
    p->records = 24 + (size_t)hl + 8 + (size_t)yl;
    if (p->records + TRAILER_BYTES > p->size) return NULL;
    p->ok = true;
    return p;
}

static uint64_t fnv1a(const uint8_t *b, size_t n)
{
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; i++) {
        h ^= b[i];
        h *= 0x100000001b3ull;
    }
    return h;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) return 0;
    sq_context *ctx = sq_fuzz_context(256u << 20);
    const int which = data[0] % N_SCENES;
    const pristine *p = get_pristine(ctx, which);
    if (!p) return 0;
    /* apply the edits to a copy of the records */
    size_t nrec = p->size - TRAILER_BYTES - p->records;
    uint8_t *file = (uint8_t *)malloc(p->size);
    if (!file) abort();
    memcpy(file, p->bytes, p->size);
    uint8_t *rec = file + p->records;
    for (size_t i = 1; i + 6 <= size && nrec > 0; i += 6) {
        uint32_t off = 0;
        memcpy(&off, data + i + 1, 4);
        off %= (uint32_t)nrec;
        const uint8_t v = data[i + 5];
        switch (data[i] % 4) {
        case 0: rec[off] ^= v; break;
        case 1: rec[off] = v; break;
        case 2: {
            static const uint32_t words[5] = {0u, 1u, 0x7fffffffu, 0x80000000u, 0xffffffffu};
            const uint32_t w = v < 5 * 40 ? words[v % 5] : v;
            for (int b = 0; b < 4 && off + (uint32_t)b < nrec; b++)
                rec[off + (uint32_t)b] = (uint8_t)(w >> (8 * b));
            break;
        }
        default: nrec = off; break;
        }
    }
    /* end marker and checksum after the (possibly cut) records */
    const size_t len = p->records + nrec;
    memcpy(file + len, "SQEND\0\0\0", 8);
    const uint64_t sum = fnv1a(file, len + 8);
    memcpy(file + len + 8, &sum, 8);
    const char *path = sq_fuzz_file(file, len + TRAILER_BYTES);
    free(file);

    sq_checkpoint_info info;
    sq_cfg *cfg = NULL;
    sq_result r = sq_checkpoint_read_header(ctx, path, &info, &cfg);
    FUZZ_CHECK(r == SQ_OK, "the header was not edited but does not read: %s", sq_last_error());
    sq_scene *scene = NULL;
    r = make_scene(ctx, cfg, &scene);
    FUZZ_CHECK(r == SQ_OK, "the checkpoint's scene does not build again: %s", sq_last_error());
    r = sq_checkpoint_restore(ctx, path, scene, &info);
    if (r == SQ_OK) {
        /* a restored state steps: an error result is allowed, a crash is not */
        (void)sq_scene_step(scene, step_dt(scene));
        sq_metric m[64];
        (void)sq_scene_metrics(scene, m, 64);
    } else {
        FUZZ_CHECK(strstr(sq_last_error(), path) != NULL || strstr(sq_last_error(), "checkpoint"),
                   "the refusal does not name the checkpoint: %s", sq_last_error());
    }
    sq_scene_destroy(scene);
    sq_cfg_destroy(cfg);
    sq_fuzz_context_clean(ctx, "a restore");
    return 0;
}
