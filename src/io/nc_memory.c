/* nc_memory.c — netCDF-4 files built in memory, written whole by output.c (see io_internal.h:
 * HDF5 never touches the disk, so a full disk is met by the same write loop, temporary and
 * message as every other output). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "io/io_internal.h"

#if SQ_HAVE_NETCDF
#include <netcdf.h>
#include <netcdf_mem.h>

/* The end-of-file address an HDF5 superblock records (versions 0-3, 8-byte offsets, base
 * address 0), or 0 when the image is not such a file. libnetcdf returns the core driver's whole
 * buffer (a multiple of 64 KiB); the file HDF5 would have written ends here. */
static size_t hdf5_end_of_file(const unsigned char *b, size_t size)
{
    static const unsigned char signature[8] = {0x89, 'H', 'D', 'F', '\r', '\n', 0x1a, '\n'};
    if (size < 64 || memcmp(b, signature, 8) != 0) return 0;
    size_t offsets, base_at, eof_at;
    switch (b[8]) {
    case 0: offsets = b[13], base_at = 24, eof_at = 40; break;
    case 1: offsets = b[13], base_at = 28, eof_at = 44; break;
    case 2:
    case 3: offsets = b[9], base_at = 12, eof_at = 28; break;
    default: return 0;
    }
    if (offsets != 8) return 0;
    uint64_t base = 0, eof = 0;
    for (int i = 7; i >= 0; i--) {
        base = base << 8 | b[base_at + (size_t)i];
        eof = eof << 8 | b[eof_at + (size_t)i];
    }
    return base == 0 && eof > 0 && eof <= size ? (size_t)eof : 0;
}

int sq__nc_create_memory(const char *path, int mode, size_t size_hint, int *ncid)
{
    return nc_create_mem(path, mode, size_hint, ncid);
}

sq_result sq__nc_write_memory(sq_context *ctx, int ncid, const char *path, bool overwrite,
                              const char *module)
{
    NC_memio image = {0};
    int st = nc_close_memio(ncid, &image);
    if (st != NC_NOERR) {
        free(image.memory);
        return sq__fail(ctx, st == NC_ENOMEM ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_IO, module,
                        "cannot write '%s' (closing): %s", path, nc_strerror(st));
    }
    const size_t end = hdf5_end_of_file((const unsigned char *)image.memory, image.size);
    sq_result r = sq_output_write_file(path, image.memory, end ? end : image.size, overwrite);
    free(image.memory); /* allocated by libnetcdf with malloc */
    return sq__io_relog(ctx, r);
}

#endif
