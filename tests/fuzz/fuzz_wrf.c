/* fuzz_wrf.c — libFuzzer entry point for the WRF reader (src/io/wrf_*.c): every input is written
 * to a file and opened as a one-file series; when it opens, every stored time is read and
 * derived, one interpolated time is read and the value ranges are scanned. The reader must never
 * crash, leak or read out of bounds; it either succeeds or fails with a message naming the file.
 * libnetcdf and HDF5 are the packaged, uninstrumented libraries: a crash inside them (HDF5 is
 * not hardened against hostile files) is theirs, so seed with netCDF-3 files, whose parsing is
 * small, to exercise squall's checks. tests/fuzz/CMakeLists.txt builds it like every harness:
 * fuzz.wrf.replay runs the seeds (corpus/wrf/: netCDF-3 crops of the real sample made by
 * scripts/reliability/make_wrf_seeds.py) and regress/wrf/ in every build; -DSQ_FUZZ=ON with
 * clang builds the libFuzzer target, run by `make fuzz` (docs/reliability.md). By hand:
 *   build/fuzz/tests/fuzz/fuzz_wrf -max_len=8192 -rss_limit_mb=2048 -timeout=30 \
 *     build/fuzz/wrf_corpus tests/fuzz/corpus/wrf
 * Throughput is low: every input opens a PROJ context, whose first use initialises proj.db
 * (SQLite) through ASan's allocator — about 4 s per input on the loaded 2-core development
 * machine when this harness was written (2 minutes, ~40 inputs from two 2.5 kB netCDF-3 seeds
 * cropped from the sample: no finding). */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "squall/core.h"
#include "squall/wrf.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[] = "/tmp/sq_fuzz_wrf_XXXXXX";
    const int fd = mkstemp(path);
    if (fd < 0) return 0;
    const ssize_t n = write(fd, data, size);
    close(fd);
    if (n != (ssize_t)size) {
        unlink(path);
        return 0;
    }
    sq_context_desc cd = {0};
    cd.threads = 1;
    cd.memory_limit_bytes = 512u << 20; /* hostile sizes are refused, not allocated */
    sq_context *ctx = NULL;
    if (sq_context_create(&cd, &ctx) != SQ_OK) {
        unlink(path);
        return 0;
    }
    const char *paths[1] = {path};
    sq_wrf *w = NULL;
    if (sq_wrf_open(ctx, paths, 1, &w) == SQ_OK) {
        sq_wrf_info in;
        sq_wrf_get_info(w, &in);
        sq_wrf_state s;
        for (int t = 0; t < in.time_count && t < 8; t++)
            if (sq_wrf_read_index(w, t, &s) != SQ_OK) break;
        if (in.time_count > 1) (void)sq_wrf_read(w, 0.5 * in.times_s[1], &s);
        sq_wrf_ranges g;
        (void)sq_wrf_scan(w, &g);
        sq_wrf_close(w);
    }
    if (sq_context_bytes_in_use(ctx) != 0) abort(); /* every failure path frees what it took */
    sq_context_destroy(ctx);
    unlink(path);
    return 0;
}
