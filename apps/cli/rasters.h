/* rasters.h — `--rasters DIR` of squall simulate/render: the scene's 2D maps as georeferenced
 * rasters and a summary.json at the end of the run (rasters.c). */
#ifndef SQ_CLI_RASTERS_H
#define SQ_CLI_RASTERS_H

#include <stdbool.h>

#include "squall/scene.h"

/* Checks every output name before the run (the maps the scene publishes now, their .prj,
 * summary.json): existing files need overwrite, inputs of the run (ctx) are refused, and none
 * may be one of the run's other outputs (others: NULL-terminated pairs of what and path, e.g.
 * "--metrics", "out/m.csv"; a NULL path is skipped); then creates DIR if missing (*created).
 * format: sq_raster_format. */
sq_result sq_cli_rasters_check(sq_context *ctx, sq_scene *scene, const char *dir, int format,
                               bool overwrite, const char *const (*others)[2], bool *created);
/* Writes the maps and summary.json (metrics: the last frame's); *seconds: the time it took. */
sq_result sq_cli_rasters_write(sq_context *ctx, sq_scene *scene, const char *dir, int format,
                               bool overwrite, const sq_metric *metrics, int nmetrics,
                               double *seconds);
/* Removes what a failed run wrote into a directory it created. */
void sq_cli_rasters_discard(const char *dir, sq_scene *scene, int format);

#endif
