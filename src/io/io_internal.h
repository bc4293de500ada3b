/* io_internal.h — helpers shared by the file writers and readers of src/io/: the temporary-file
 * protocol of safe outputs (ARCHITECTURE.md "Files and data safety") and field-file checks. */
#ifndef SQ_IO_INTERNAL_H
#define SQ_IO_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

#include "core/core_internal.h"
#include "squall/drawable.h"
#include "squall/io.h"

/* Largest temporary name the writers build (the path plus ".tmp-PID-N"). */
#define SQ__TEMP_NAME_MAX 4096

/* Checks path (sq_output_check), then creates its temporary "dir/.name.tmp-PID-N" exclusively
 * (O_EXCL, the first free N) and returns the open descriptor in *fd_out and the name in tmp.
 * On failure nothing is left on disk, *fd_out = -1 and the error text is set. */
sq_result sq__output_open_temp(const char *path, bool overwrite, char *tmp, size_t size,
                               int *fd_out);
/* Flushes tmp to disk and renames it to path (sq_output_commit). On failure tmp is removed. */
sq_result sq__output_finish(const char *tmp, const char *path, bool overwrite);
/* Removes a temporary (ignores a missing one). Accepts NULL and "". */
void sq__output_discard(const char *tmp);

/* Logs the current error text (set by a context-free function) on ctx under "io" and returns r
 * unchanged; SQ_OK passes through silently. */
sq_result sq__io_relog(sq_context *ctx, sq_result r);

/* Opens path for reading as *out ("rb") without ever blocking: anything but a regular file
 * (directory, FIFO, socket, device) is refused with SQ_ERR_IO naming what (e.g. "scene file"),
 * the path and its kind; a missing file names the system's reason. */
sq_result sq__input_open(sq_context *ctx, const char *module, const char *what, const char *path,
                         FILE **out);
/* For paths another library opens and reports on itself (GDAL, libnetcdf): a path that does
 * not exist (or names a library-virtual file) passes, to be reported by the library; one that
 * exists must be a regular file and is recorded as an input. */
sq_result sq__input_guard(sq_context *ctx, const char *module, const char *what, const char *path);
/* The same check for a path another library will open (follows symlinks). */
sq_result sq__input_check(sq_context *ctx, const char *module, const char *what,
                          const char *path);

/* True when a write of path failed because the disk or quota is full: err is ENOSPC or
 * EDQUOT, or (for libraries that lose errno) the filesystem of path has no free blocks left. */
bool sq__io_no_space(const char *path, int err);
/* Fails for a write of path that failed with errno err: SQ_ERR_NO_SPACE "cannot write 'path':
 * no space left on device ..." when the disk is full (a runtime error, exit 1), else SQ_ERR_IO
 * with detail (or strerror(err)). ctx may be NULL (then nothing is logged). */
sq_result sq__write_error(sq_context *ctx, const char *path, int err, const char *detail);

/* Validates a set of fields for one field file: count >= 1, names [A-Za-z_][A-Za-z0-9_.-]*
 * unique and none of x, y, z, time; data non-NULL; sizes >= 1 and equal; origin and spacing
 * equal, spacing > 0 and finite. Also checks desc and desc->path. Messages name the field. */
sq_result sq__field_file_check(sq_context *ctx, const sq_field_file_desc *desc,
                               const sq_named_field *fields, int count, const char *what);

/* Decodes PNG bytes held in memory (an embedded texture) to 8-bit RGBA, rows top first; name is
 * used in messages. Free with sq_free. */
sq_result sq__png_decode_rgba8(sq_context *ctx, const void *data, size_t size, const char *name,
                               uint8_t **rgba_out, int *width, int *height);

/* netCDF-4 files are built in memory and written whole through sq_output_write_file
 * (nc_memory.c): HDF5 never writes to disk itself. A flush that fails inside HDF5 (a disk that
 * fills up while the file is written) leaves its file open after nc_close, and HDF5 then
 * crashes at exit flushing it again; in memory, the write fails in output.c's loop instead
 * (temporary removed, "no space left on device"). */
#if SQ_HAVE_NETCDF
/* nc_create_mem with mode; size_hint (bytes) sizes the first buffer. A netCDF status. */
int sq__nc_create_memory(const char *path, int mode, size_t size_hint, int *ncid);
/* Closes ncid (from sq__nc_create_memory) and writes its bytes to path (temporary + rename;
 * overwrite as in sq_output_check). On failure nothing is left at path or its temporary and the
 * error (naming path) is logged on ctx under module. */
sq_result sq__nc_write_memory(sq_context *ctx, int ncid, const char *path, bool overwrite,
                              const char *module);
#endif

#endif
