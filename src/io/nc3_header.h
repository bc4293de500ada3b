/* nc3_header.h — a bounds check of a netCDF-3 file's header before libnetcdf opens it
 * (nc3_header.c). */
#ifndef SQ_NC3_HEADER_H
#define SQ_NC3_HEADER_H

#include "core/core_internal.h"

/* SQ_OK for a netCDF-3 file whose header fits in the file, and for any file that is not
 * netCDF-3 (left to libnetcdf); SQ_ERR_PARSE naming the path, the header item and the byte
 * offset when the header declares more than the file holds or is malformed. */
sq_result sq__nc3_check_header(sq_context *ctx, const char *module, const char *path);

#endif
