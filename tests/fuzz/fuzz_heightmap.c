/* fuzz_heightmap.c — the PNG readers (src/io/png_io.c): every input is handed to
 * sq_png_read_heightmap16 and sq_png_read_rgba8 as a file. The readers must never crash, leak,
 * read out of bounds or make libpng allocate what the file merely declares; they either succeed
 * with a buffer of the size they report or fail with the outputs cleared. Build and run: see
 * tests/fuzz/CMakeLists.txt (`make fuzz`). */
#include "fuzz_util.h"
#include "squall/io.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* A 64 MiB budget: a header that asks for more is refused, as it must be. */
    sq_context *ctx = sq_fuzz_context(64u << 20);
    const char *path = sq_fuzz_file(data, size);
    uint16_t *hm = NULL;
    int w = 0, h = 0;
    if (sq_png_read_heightmap16(ctx, path, 1 << 20, &hm, &w, &h) == SQ_OK) {
        FUZZ_CHECK(hm && w >= 1 && h >= 1 && (int64_t)w * h <= (1 << 20), "%dx%d", w, h);
        /* Touch every sample so a short buffer shows up under ASan. */
        uint32_t acc = 0;
        for (int64_t i = 0; i < (int64_t)w * h; i++) acc += hm[i];
        if (acc == 0xffffffffu) fputs("", stderr);
    } else {
        FUZZ_CHECK(!hm && !w && !h, "outputs not cleared on failure");
        FUZZ_CHECK(strstr(sq_last_error(), path) != NULL, "error does not name the file: %s",
                   sq_last_error());
    }
    sq_free(ctx, hm);
    uint8_t *rgba = NULL;
    if (sq_png_read_rgba8(ctx, path, &rgba, &w, &h) == SQ_OK) {
        uint32_t acc = 0;
        for (int64_t i = 0; i < (int64_t)w * h * 4; i++) acc += rgba[i];
        if (acc == 0xffffffffu) fputs("", stderr);
    } else {
        FUZZ_CHECK(!rgba && !w && !h, "outputs not cleared on failure");
    }
    sq_free(ctx, rgba);
    sq_fuzz_context_clean(ctx, "reading a PNG");
    return 0;
}
