/* squall/image.h — float images on disk: PFM (portable float map) writing and reading, used to
 * keep linear renders (reference path tracer, GL linear read-back) for comparisons. Images in
 * memory are linear RGB floats, width*height*3, top row first; the file stores rows bottom to
 * top as the PFM format requires. The image metrics (SSIM, FLIP) are declared in
 * squall/render.h. */
#ifndef SQ_IMAGE_H
#define SQ_IMAGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes a colour PFM ("PF", little-endian). The file is written under a temporary name
 * (path.tmp-<pid>) and renamed on success, so a failed write never leaves a truncated file at
 * path. An existing path is refused with SQ_ERR_EXISTS unless overwrite is true. */
SQ_API sq_result sq_pfm_write(const char *path, int width, int height, const float *rgb,
                              bool overwrite);

/* Reads a PFM ("PF" colour or "Pf" grey, either byte order) into a new buffer of
 * width*height*3 floats (grey replicated), top row first, allocated through ctx; release it
 * with sq_free(ctx, *rgb). On failure *rgb is NULL and the message names the file and the
 * problem. */
SQ_API sq_result sq_pfm_read(sq_context *ctx, const char *path, int *width, int *height,
                             float **rgb);

#ifdef __cplusplus
}
#endif
#endif
