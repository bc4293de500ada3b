/* fuzz_dem.c — the DEM reader (src/io/geo_dem.c, GDAL): every input is handed to sq_dem_load as
 * the file of world.terrain.dem, at its own resolution (cell_m = 0, so a header that declares a
 * huge raster asks for a huge grid) and, for files without a CRS, with one assigned. The reader
 * must never crash, leak or read out of bounds, and never allocate what a header merely declares:
 * it either succeeds with a grid within max_samples whose heights are finite, or fails with the
 * outputs cleared and a message naming the file or the key. GDAL is the packaged, uninstrumented library: a
 * crash inside GDAL itself is GDAL's (report it upstream), a crash in squall's use of it is ours.
 * Seeds: tests/fuzz/corpus/dem/ (scripts/reliability/make_dem_seeds.py). Build and run: see
 * tests/fuzz/CMakeLists.txt (`make fuzz`). */
#include <math.h>

#include "fuzz_util.h"
#include "sq_config.h"
#include "squall/geo.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
#if !SQ_HAVE_GDAL
    (void)data, (void)size; /* built without GDAL: there is no DEM reader to fuzz */
    return 0;
#else
    sq_context *ctx = sq_fuzz_context(256u << 20);
    const char *path = sq_fuzz_file(data, size);
    sq_dem_desc d;
    memset(&d, 0, sizeof d);
    d.path = path;
    d.key = "world.terrain";
    d.assign_crs = "EPSG:32632";
    d.max_samples = 1 << 18;
    sq_dem dem;
    memset(&dem, 0xa5, sizeof dem); /* failure must clear it */
    if (sq_dem_load(ctx, &d, &dem) == SQ_OK) {
        FUZZ_CHECK(dem.nx >= 1 && dem.ny >= 1 && (int64_t)dem.nx * dem.ny <= d.max_samples,
                   "%dx%d samples (limit %lld)", dem.nx, dem.ny, (long long)d.max_samples);
        FUZZ_CHECK(dem.heights_m && dem.crs_wkt, "no heights or no CRS");
        FUZZ_CHECK(dem.dx > 0.0 && dem.dy > 0.0 && isfinite(dem.x0) && isfinite(dem.y0),
                   "spacing %g x %g at (%g, %g)", dem.dx, dem.dy, dem.x0, dem.y0);
        /* every sample is read (a short buffer shows under ASan) and finite: voids are filled */
        size_t bad = 0, voids = 0;
        for (size_t i = 0; i < (size_t)dem.nx * (size_t)dem.ny; i++) {
            bad += !isfinite(dem.heights_m[i]);
            if (dem.void_mask) voids += dem.void_mask[i] != 0;
        }
        FUZZ_CHECK(bad == 0, "%zu heights are not finite", bad);
        FUZZ_CHECK(!dem.void_mask || voids == dem.void_count, "void mask %zu, void_count %zu",
                   voids, dem.void_count);
        FUZZ_CHECK(dem.height_min_m <= dem.height_max_m, "heights %g..%g", dem.height_min_m,
                   dem.height_max_m);
        sq_dem_release(ctx, &dem);
    } else {
        FUZZ_CHECK(!dem.heights_m && !dem.void_mask && !dem.crs_wkt && !dem.nx && !dem.ny,
                   "outputs not cleared on failure");
        FUZZ_CHECK(strstr(sq_last_error(), path) != NULL ||
                       strstr(sq_last_error(), "world.terrain") != NULL,
                   "error names neither the file nor the key: %s", sq_last_error());
    }
    sq_fuzz_context_clean(ctx, "reading a DEM");
    return 0;
#endif
}
