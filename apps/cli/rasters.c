/* rasters.c — `squall simulate|render --rasters DIR`: every 2D map the scene's layers publish
 * (nz == 1 fields: an avalanche's peak flow depth, peak speed, peak pressure, deposit depth,
 * travel angle; a snow depth map, ...) written once at the end of the run as a georeferenced
 * raster in the world's CRS (GeoTIFF, or ESRI ASCII grid + .prj with --raster-format asc), and
 * DIR/summary.json with the last value and unit of every metric and the list of rasters.
 * World (x, y) + the world's crs_offset_m = the CRS's (easting, northing). Every output name is
 * checked before the run starts; each file goes through a temporary name. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "rasters.h"
#include "squall/geo.h"
#include "squall/io.h"

#define MAX_MAPS 32

static const char *ext_of(int format) { return format == SQ_RASTER_ASCII ? "asc" : "tif"; }

/* The 2D fields of the scene (pointers valid until the next scene call). */
static int maps_of(sq_scene *scene, sq_named_field *out)
{
    sq_named_field all[MAX_MAPS];
    const int nf = sq_scene_fields(scene, all, MAX_MAPS);
    int n = 0;
    for (int i = 0; i < nf; i++)
        if (all[i].nz == 1 && all[i].name) out[n++] = all[i];
    return n;
}

/* A raster's name that is also another output of the run: refused before any work. */
static sq_result not_another_output(const char *dir, const char *path,
                                    const char *const (*others)[2])
{
    for (int i = 0; others && others[i][0]; i++)
        if (others[i][1] && sq_output_same_file(path, others[i][1]))
            return sq_set_error(SQ_ERR_INVALID_ARG,
                                "--rasters '%s' writes '%s', which is also %s '%s': give each "
                                "output its own name",
                                dir, path, others[i][0], others[i][1]);
    return SQ_OK;
}

sq_result sq_cli_rasters_check(sq_context *ctx, sq_scene *scene, const char *dir, int format,
                               bool overwrite, const char *const (*others)[2], bool *created)
{
    *created = false;
    struct stat st;
    if (stat(dir, &st) == 0) {
        if (!S_ISDIR(st.st_mode))
            return sq_set_error(SQ_ERR_IO, "--rasters '%s': exists and is not a directory", dir);
    } else {
        char parent[1024];
        snprintf(parent, sizeof parent, "%s", dir);
        size_t len = strlen(parent);
        while (len > 1 && parent[len - 1] == '/') parent[--len] = 0;
        char *slash = strrchr(parent, '/');
        if (slash && slash != parent) {
            *slash = 0;
            if (stat(parent, &st) != 0 || !S_ISDIR(st.st_mode))
                return sq_set_error(SQ_ERR_IO,
                                    "--rasters '%s': directory '%s' does not exist", dir, parent);
        }
    }
    sq_named_field maps[MAX_MAPS];
    const int n = maps_of(scene, maps);
    if (n == 0)
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "--rasters '%s': no layer of '%s' publishes a 2D map (e.g. an "
                            "avalanche's hazard maps)", dir, sq_scene_name(scene));
    char path[1200];
    sq_result r = SQ_OK;
    const bool exists = stat(dir, &st) == 0;
    /* every file the end of the run writes (a DEM named peak_speed.tif in DIR is an input:
     * refused now, not after the run with half the maps written) */
    for (int i = 0; i < n && r == SQ_OK; i++) {
        snprintf(path, sizeof path, "%s/%s.%s", dir, maps[i].name, ext_of(format));
        r = not_another_output(dir, path, others);
        if (r == SQ_OK && exists) r = sq_output_check(path, overwrite);
        if (r == SQ_OK && exists) r = sq_output_check_inputs(ctx, path, false);
        if (r == SQ_OK && format == SQ_RASTER_ASCII) {
            snprintf(path, sizeof path, "%s/%s.prj", dir, maps[i].name);
            r = not_another_output(dir, path, others);
            if (r == SQ_OK && exists) r = sq_output_check(path, overwrite);
            if (r == SQ_OK && exists) r = sq_output_check_inputs(ctx, path, false);
        }
    }
    if (r == SQ_OK) {
        snprintf(path, sizeof path, "%s/summary.json", dir);
        r = not_another_output(dir, path, others);
        if (r == SQ_OK && exists) r = sq_output_check(path, overwrite);
        if (r == SQ_OK && exists) r = sq_output_check_inputs(ctx, path, false);
    }
    if (r == SQ_OK && !exists) {
        if (mkdir(dir, 0777) != 0)
            return sq_set_error(SQ_ERR_IO, "--rasters '%s': cannot create it: %s", dir,
                                strerror(errno));
        *created = true;
    }
    return r;
}

/* JSON string escaping of s into j's buffer (names and units are plain ASCII here). */
static void json_text(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; s++) {
        if (*s == '"' || *s == '\\') fputc('\\', f);
        if ((unsigned char)*s >= 0x20) fputc(*s, f);
    }
    fputc('"', f);
}

static void json_num(FILE *f, double v)
{
    if (isfinite(v)) fprintf(f, "%.10g", v);
    else fputs("null", f);
}

sq_result sq_cli_rasters_write(sq_context *ctx, sq_scene *scene, const char *dir, int format,
                               bool overwrite, const sq_metric *metrics, int nmetrics,
                               double *seconds)
{
    const double t0 = sq_time_now();
    double crs_offset[2];
    const char *crs = sq_world_crs(sq_scene_world(scene), crs_offset);
    sq_named_field maps[MAX_MAPS];
    const int n = maps_of(scene, maps);
    char path[1200];
    sq_result r = SQ_OK;
    /* summary.json, built in memory and written through a temporary */
    char *buf = NULL;
    size_t blen = 0;
    FILE *js = open_memstream(&buf, &blen);
    if (!js) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "--rasters: out of memory");
    fprintf(js, "{\n  \"scene\": ");
    json_text(js, sq_scene_name(scene));
    fprintf(js, ",\n  \"time_s\": ");
    json_num(js, sq_scene_time(scene));
    fprintf(js, ",\n  \"crs_wkt\": ");
    json_text(js, crs ? crs : "");
    fprintf(js, ",\n  \"crs_offset_m\": [%.3f, %.3f],\n  \"rasters\": [", crs_offset[0],
            crs_offset[1]);
    for (int i = 0; i < n && r == SQ_OK; i++) {
        const sq_named_field *m = &maps[i];
        snprintf(path, sizeof path, "%s/%s.%s", dir, m->name, ext_of(format));
        sq_raster_desc rd;
        memset(&rd, 0, sizeof rd);
        rd.path = path;
        rd.format = format;
        rd.crs_wkt = crs;
        rd.nx = m->nx;
        rd.ny = m->ny;
        rd.cell_m = (double)m->spacing_m.x;
        rd.x0 = (double)m->origin_m.x - 0.5 * rd.cell_m + crs_offset[0];
        rd.y0 = (double)m->origin_m.y - 0.5 * (double)m->spacing_m.y + crs_offset[1];
        rd.data = m->data;
        rd.nodata = -9999.0;
        rd.description = m->long_name ? m->long_name : m->name;
        rd.units = m->units;
        rd.overwrite = overwrite;
        if (fabsf(m->spacing_m.x - m->spacing_m.y) > 1e-6f * m->spacing_m.x) {
            r = sq_set_error(SQ_ERR_INVALID_ARG, "--rasters: map '%s' has %g x %g m cells; "
                             "rasters need square cells", m->name, (double)m->spacing_m.x,
                             (double)m->spacing_m.y);
            break;
        }
        r = sq_raster_write(ctx, &rd);
        /* the values' range over the written cells */
        double lo = INFINITY, hi = -INFINITY;
        const size_t cells = (size_t)m->nx * (size_t)m->ny;
        for (size_t c = 0; c < cells; c++)
            if (isfinite(m->data[c])) {
                lo = fmin(lo, (double)m->data[c]);
                hi = fmax(hi, (double)m->data[c]);
            }
        fprintf(js, "%s\n    {\"file\": ", i ? "," : "");
        char base[300];
        snprintf(base, sizeof base, "%s.%s", m->name, ext_of(format));
        json_text(js, base);
        fprintf(js, ", \"units\": ");
        json_text(js, m->units);
        fprintf(js, ", \"description\": ");
        json_text(js, m->long_name ? m->long_name : "");
        fprintf(js, ", \"cells\": [%d, %d], \"cell_m\": ", m->nx, m->ny);
        json_num(js, rd.cell_m);
        fprintf(js, ", \"min\": ");
        json_num(js, lo);
        fprintf(js, ", \"max\": ");
        json_num(js, hi);
        fprintf(js, "}");
    }
    fprintf(js, "\n  ],\n  \"metrics\": {");
    for (int i = 0; i < nmetrics; i++) {
        fprintf(js, "%s\n    ", i ? "," : "");
        json_text(js, metrics[i].name);
        fprintf(js, ": {\"value\": ");
        json_num(js, metrics[i].value);
        fprintf(js, ", \"unit\": ");
        json_text(js, metrics[i].unit);
        fprintf(js, "}");
    }
    fprintf(js, "\n  }\n}\n");
    fclose(js);
    if (r == SQ_OK) {
        snprintf(path, sizeof path, "%s/summary.json", dir);
        r = sq_output_write_file(path, buf, blen, overwrite);
    }
    free(buf);
    if (seconds) *seconds = sq_time_now() - t0;
    return r;
}

void sq_cli_rasters_discard(const char *dir, sq_scene *scene, int format)
{
    sq_named_field maps[MAX_MAPS];
    const int n = scene ? maps_of(scene, maps) : 0;
    char path[1200];
    for (int i = 0; i < n; i++) {
        snprintf(path, sizeof path, "%s/%s.%s", dir, maps[i].name, ext_of(format));
        remove(path);
        if (format == SQ_RASTER_ASCII) {
            snprintf(path, sizeof path, "%s/%s.prj", dir, maps[i].name);
            remove(path);
        }
    }
    snprintf(path, sizeof path, "%s/summary.json", dir);
    remove(path);
    rmdir(dir);
}
