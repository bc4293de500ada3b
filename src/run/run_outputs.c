/* run_outputs.c — the files of a run (the scene's output section) under the output-safety rules
 * of src/io/output.c, which this file only calls. The rules (docs/reliability.md):
 *   - before any work every final name is checked: directory there, absent unless overwrite, not
 *     an input of the run (sq_output_check_inputs), and temporaries that a killed run left next
 *     to it are removed (sq_output_remove_stale);
 *   - every file is written to a temporary name: the video and the metrics stream into theirs,
 *     the per-frame files (PNG frames, NetCDF/VTK fields, depth PNGs) are complete files under
 *     hidden staging names; commit renames them all to their final names (replacing only with
 *     overwrite) and writes the .pvd indices;
 *   - abort (an error, SIGINT/SIGTERM) removes every temporary and staged file and a frames
 *     directory the run made: nothing of the run stays, whether the directory existed or not,
 *     and no file the run did not create is touched; the metrics rows so far are kept as a
 *     complete "NAME.partial.csv" (never replacing a file), because they show what happened;
 *   - a full disk fails with SQ_ERR_NO_SPACE ("no space left on device").
 * Also the metrics table that gives the per-metric statistics. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "io/io_internal.h"
#include "run/run_internal.h"
#include "squall/image.h"
#include "squall/io.h"

#define PATH_MAX_RUN 1100

/* Inputs are never written, and temporaries of killed runs go: for one output, a numbered series
 * (prefix) or nothing (NULL). */
static sq_result protect(sq__run_outputs *o, const char *path, const char *suffix, bool prefix)
{
    if (!path) return SQ_OK;
    char p[PATH_MAX_RUN];
    snprintf(p, sizeof p, "%s%s", path, suffix);
    sq_result r = sq_output_check_inputs(o->ctx, p, prefix);
    if (r == SQ_OK) sq_output_remove_stale(o->ctx, p, prefix);
    return r;
}

sq_result sq__run_outputs_check(sq__run_outputs *o, bool rendering)
{
    sq_result r = protect(o, o->video, "", false);
    if (r == SQ_OK) r = protect(o, o->metrics, "", false);
    if (r == SQ_OK) r = protect(o, o->frames_dir, "/frame_", true);
    if (r == SQ_OK) r = protect(o, o->fields, "_", true);
    if (r == SQ_OK) r = protect(o, o->fields, ".pvd", false);
    if (r == SQ_OK) r = protect(o, o->fields, "_maps.pvd", false);
    if (r != SQ_OK) return r;
    if (o->video) {
        if (o->width % 2 || o->height % 2)
            return sq__set_error(SQ_ERR_INVALID_ARG,
                                 "output size %dx%d: MP4 (yuv420p) needs even width and height",
                                 o->width, o->height);
        r = sq_output_check(o->video, o->overwrite);
    }
    if (r == SQ_OK && o->frames_dir)
        r = sq_output_check_dir(o->frames_dir, "frame_00000.png", o->overwrite,
                                &o->frames_dir_created);
    if (r == SQ_OK && o->metrics) r = sq_output_check(o->metrics, o->overwrite);
    if (r == SQ_OK && o->fields) {
        char first[PATH_MAX_RUN];
        snprintf(first, sizeof first, "%s_%05d.%s", o->fields, o->fields_every ? 0 : o->frames - 1,
                 o->fields_format == SQ_FIELDS_VTK ? "vti" : "nc");
        r = sq_output_check(first, o->overwrite);
    }
    (void)rendering;
    return r;
}

sq_result sq__run_outputs_distinct(const sq__run_outputs *o, const char *checkpoint)
{
    char pvd[PATH_MAX_RUN] = "", maps_pvd[PATH_MAX_RUN] = "";
    if (o->fields) {
        snprintf(pvd, sizeof pvd, "%s.pvd", o->fields);
        snprintf(maps_pvd, sizeof maps_pvd, "%s_maps.pvd", o->fields);
    }
    const struct {
        const char *what, *path;
    } out[] = {{"output.video", o->video},     {"output.frames_dir", o->frames_dir},
               {"output.metrics", o->metrics}, {"the fields' index", o->fields ? pvd : NULL},
               {"the maps' index", o->fields ? maps_pvd : NULL},
               {"the checkpoint", checkpoint}};
    const int n = (int)(sizeof out / sizeof out[0]);
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++)
            if (out[i].path && out[j].path && sq_output_same_file(out[i].path, out[j].path))
                return sq__fail(o->ctx, SQ_ERR_INVALID_ARG, "run",
                                "%s '%s' and %s '%s' are the same file: the one written later "
                                "would replace the other; give each output its own name",
                                out[i].what, out[i].path, out[j].what, out[j].path);
    return SQ_OK;
}

sq_result sq__run_outputs_open(sq__run_outputs *o)
{
    if (o->video) {
        sq_video_desc vd = {o->video, o->width, o->height, o->fps, 0, o->overwrite};
        sq_result r = sq_video_open(o->ctx, &vd, &o->vw);
        if (r != SQ_OK) return r;
    }
    if (o->metrics) {
        int fd = -1;
        sq_result r = sq__output_open_temp(o->metrics, o->overwrite, o->metrics_tmp,
                                           sizeof o->metrics_tmp, &fd);
        if (r != SQ_OK) return r;
        o->metrics_file = fdopen(fd, "w");
        if (!o->metrics_file) {
            close(fd);
            sq__output_discard(o->metrics_tmp);
            o->metrics_tmp[0] = 0;
            return sq__write_error(NULL, o->metrics, errno, NULL);
        }
    }
    return SQ_OK;
}

/* The staging name of a per-frame file (a temporary name of this process, which a later run
 * recognises as stale if this one is killed), recorded with its final name. */
static sq_result stage(sq__run_outputs *o, const char *final, char *staged, size_t size)
{
    char prefix[PATH_MAX_RUN];
    sq_result r = sq_output_temp_name(final, prefix, sizeof prefix);
    if (r != SQ_OK) return r;
    if (snprintf(staged, size, "%s-0", prefix) >= (int)size)
        return sq__set_error(SQ_ERR_INVALID_ARG, "output name '%.80s' is too long", final);
    if (o->staged_count == o->staged_cap) {
        const int cap = o->staged_cap ? 2 * o->staged_cap : 64;
        struct sq__run_staged *n =
            (struct sq__run_staged *)realloc(o->staged, sizeof *n * (size_t)cap);
        if (!n) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory (staged outputs)");
        o->staged = n;
        o->staged_cap = cap;
    }
    struct sq__run_staged *e = &o->staged[o->staged_count];
    e->staged = strdup(staged);
    e->final = strdup(final);
    if (!e->staged || !e->final) {
        free(e->staged);
        free(e->final);
        return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory (staged outputs)");
    }
    o->staged_count++;
    return SQ_OK;
}

/* Forgets (and removes) the last staged file after its writer failed with r, and returns r with
 * the error text naming the file the user asked for instead of its staging name. */
static sq_result unstage_last(sq__run_outputs *o, sq_result r)
{
    if (o->staged_count == 0) return r;
    struct sq__run_staged *e = &o->staged[--o->staged_count];
    (void)unlink(e->staged);
    char text[2 * PATH_MAX_RUN + 512];
    snprintf(text, sizeof text, "%s", sq_last_error());
    const char *at = strstr(text, e->staged);
    if (at)
        sq__set_error(r, "%.*s%s%s", (int)(at - text), text, e->final, at + strlen(e->staged));
    free(e->staged);
    free(e->final);
    return r;
}

sq_result sq__run_outputs_frame(sq__run_outputs *o, int frame, const uint8_t *rgba,
                                const float *linear_rgb)
{
    sq_result r = SQ_OK;
    if (o->vw) r = sq_video_add_rgba8(o->vw, rgba);
    if (r == SQ_OK && o->frames_dir) {
        char path[PATH_MAX_RUN], staged[PATH_MAX_RUN + 32];
        snprintf(path, sizeof path, "%s/frame_%05d.png", o->frames_dir, frame);
        r = stage(o, path, staged, sizeof staged);
        if (r == SQ_OK) {
            r = sq_png_write_rgba8(staged, o->width, o->height, rgba, false);
            if (r != SQ_OK) r = unstage_last(o, r);
        }
        if (r == SQ_OK) o->frames_written = frame + 1;
        if (r == SQ_OK && linear_rgb) {
            snprintf(path, sizeof path, "%s/frame_%05d.pfm", o->frames_dir, frame);
            r = stage(o, path, staged, sizeof staged);
            if (r == SQ_OK) {
                r = sq_pfm_write(staged, o->width, o->height, linear_rgb, false);
                if (r != SQ_OK) r = unstage_last(o, r);
            }
        }
    }
    return r;
}

sq_result sq__run_outputs_metrics(sq__run_outputs *o, int frame, double time_s,
                                  const sq_metric *m, int n)
{
    if (n > SQ_RUN_MAX_METRICS) n = SQ_RUN_MAX_METRICS;
    if (o->rows == 0) { /* the columns are those of the first row */
        o->metric_count = n;
        for (int i = 0; i < n; i++) {
            snprintf(o->names[i], sizeof o->names[i], "%s", m[i].name);
            snprintf(o->units[i], sizeof o->units[i], "%s", m[i].unit ? m[i].unit : "");
        }
        if (o->metrics_file) {
            fprintf(o->metrics_file, "frame,time_s");
            for (int i = 0; i < n; i++)
                fprintf(o->metrics_file, ",%s%s%s%s", m[i].name, o->units[i][0] ? " [" : "",
                        o->units[i], o->units[i][0] ? "]" : "");
            fprintf(o->metrics_file, "\n");
        }
    }
    /* every row is kept for the summary's medians: metric_count doubles a frame (the columns
     * of the first row), not the table's capacity, so a long run grows by 8 bytes per metric and
     * frame (1.5 MB over 10 000 frames of a sandstorm's 19 metrics) */
    const size_t stride = (size_t)(o->metric_count > 0 ? o->metric_count : 1);
    if (o->rows >= o->cap) {
        const int cap = o->cap ? o->cap * 2 : 256;
        double *v = (double *)realloc(o->values, sizeof(double) * (size_t)cap * stride);
        if (!v) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory for the metrics table");
        o->values = v;
        o->cap = cap;
    }
    for (int i = 0; i < o->metric_count; i++)
        o->values[(size_t)o->rows * stride + (size_t)i] = i < n ? m[i].value : (double)NAN;
    o->rows++;
    if (o->metrics_file) {
        errno = 0;
        /* full precision: times must difference exactly (and a resumed run must match) */
        fprintf(o->metrics_file, "%d,%.17g", frame, time_s);
        for (int i = 0; i < o->metric_count; i++)
            fprintf(o->metrics_file, ",%.9g", i < n ? m[i].value : (double)NAN);
        fprintf(o->metrics_file, "\n");
        if (ferror(o->metrics_file)) return sq__write_error(NULL, o->metrics, errno, NULL);
    }
    return SQ_OK;
}

bool sq__run_outputs_fields_due(const sq__run_outputs *o, int frame)
{
    return o->fields &&
           ((o->fields_every > 0 && frame % o->fields_every == 0) || frame == o->frames - 1);
}

/* A 2D field in metres as a 16-bit grey PNG at 1 mm per unit (0..65.535 m), north up. */
static sq_result write_depth_png(const char *path, const sq_named_field *f, bool overwrite)
{
    uint16_t *g = (uint16_t *)malloc(sizeof(uint16_t) * (size_t)f->nx * (size_t)f->ny);
    if (!g) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory writing '%s'", path);
    for (int j = 0; j < f->ny; j++)
        for (int i = 0; i < f->nx; i++) {
            double v = (double)f->data[(size_t)j * f->nx + i] * 1000.0;
            v = !isfinite(v) || v < 0.0 ? 0.0 : v > 65535.0 ? 65535.0 : v;
            g[(size_t)(f->ny - 1 - j) * f->nx + i] = (uint16_t)(v + 0.5);
        }
    sq_result r = sq_png_write_gray16(path, f->nx, f->ny, g, overwrite);
    free(g);
    return r;
}

/* Remembers a .vti file of the run for the .pvd index of its group (tag: the group's part of
 * the file names). */
static sq_result note_vti(sq__run_outputs *o, int grp, const char *tag, const char *final, double t)
{
    snprintf(o->vti_tag[grp], sizeof o->vti_tag[grp], "%s", tag);
    if (o->vti_count[grp] == o->vti_cap[grp]) {
        const int cap = o->vti_cap[grp] ? 2 * o->vti_cap[grp] : 64;
        char **f = (char **)realloc(o->vti[grp], sizeof *f * (size_t)cap);
        if (f) o->vti[grp] = f;
        double *tt = f ? (double *)realloc(o->vti_t[grp], sizeof *tt * (size_t)cap) : NULL;
        if (!f || !tt) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory (series index)");
        o->vti_t[grp] = tt;
        o->vti_cap[grp] = cap;
    }
    const char *base = strrchr(final, '/');
    o->vti[grp][o->vti_count[grp]] = strdup(base ? base + 1 : final);
    if (!o->vti[grp][o->vti_count[grp]]) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
    o->vti_t[grp][o->vti_count[grp]++] = t;
    return SQ_OK;
}

/* Fields that can share a file: the same cells; 3D ones the same origin and spacing, 2D maps the
 * same x and y (each map may lie at its own level). */
static bool same_grid(const sq_named_field *a, const sq_named_field *b)
{
    if (a->nx != b->nx || a->ny != b->ny || a->nz != b->nz) return false;
    if (a->origin_m.x != b->origin_m.x || a->origin_m.y != b->origin_m.y ||
        a->spacing_m.x != b->spacing_m.x || a->spacing_m.y != b->spacing_m.y)
        return false;
    return a->nz == 1 || (a->origin_m.z == b->origin_m.z && a->spacing_m.z == b->spacing_m.z);
}

sq_result sq__run_outputs_fields(sq__run_outputs *o, int frame, double time_s,
                                 const sq_named_field *fv, int nf)
{
    if (!o->fields || nf <= 0) return SQ_OK;
    char path[PATH_MAX_RUN], staged[PATH_MAX_RUN + 32];
    sq_field_file_desc fd;
    memset(&fd, 0, sizeof fd);
    fd.path = staged;
    if (o->world) fd.crs_wkt = sq_world_crs(o->world, fd.crs_offset_m);
    fd.title = o->title;
    fd.source = "squall " SQ_VERSION_STRING;
    fd.time_s = time_s;
    fd.overwrite = false; /* staged names are new; commit applies overwrite */
    /* a file holds one grid: the 3D fields and the 2D maps go to one file per grid */
    sq_named_field grouped[SQ_RUN_MAX_FIELDS];
    int group_of[SQ_RUN_MAX_FIELDS], first[SQ_RUN_FIELD_GROUPS], ng = 0, n = 0;
    for (int q = 0; q < nf && q < SQ_RUN_MAX_FIELDS; q++) {
        int g = 0;
        while (g < ng && !same_grid(&fv[q], &fv[first[g]])) g++;
        if (g == ng) {
            if (ng == SQ_RUN_FIELD_GROUPS)
                return sq__set_error(SQ_ERR_INVALID_ARG,
                                     "field '%s': the scene's fields lie on more than %d grids "
                                     "(one file each)",
                                     fv[q].name, SQ_RUN_FIELD_GROUPS);
            first[ng++] = q;
        }
        group_of[q] = g;
    }
    sq_result r = SQ_OK;
    for (int g = 0; g < ng && r == SQ_OK; g++) {
        int nfs = 0, rank = 0;
        for (int q = 0; q < nf && q < SQ_RUN_MAX_FIELDS; q++)
            if (group_of[q] == g) grouped[n + nfs++] = fv[q];
        /* the group's tag: "" / "_maps" for the first grid of 3D fields / 2D maps, then "_2",
         * "_3" / "_maps2", "_maps3" in the order the layers publish them */
        const bool maps = fv[first[g]].nz == 1;
        for (int h = 0; h < g; h++) rank += (fv[first[h]].nz == 1) == maps;
        char tag[16];
        if (rank == 0) snprintf(tag, sizeof tag, "%s", maps ? "_maps" : "");
        else snprintf(tag, sizeof tag, "%s%d", maps ? "_maps" : "_", rank + 1);
        const sq_named_field *fs = &grouped[n];
        n += nfs;
        if (o->fields_format != SQ_FIELDS_VTK) {
            snprintf(path, sizeof path, "%s%s_%05d.nc", o->fields, tag, frame);
            r = stage(o, path, staged, sizeof staged);
            if (r == SQ_OK) {
                r = sq_netcdf_write_fields(o->ctx, &fd, fs, nfs);
                if (r != SQ_OK) r = unstage_last(o, r);
            }
        }
        if (r == SQ_OK && o->fields_format != SQ_FIELDS_NETCDF) {
            snprintf(path, sizeof path, "%s%s_%05d.vti", o->fields, tag, frame);
            r = stage(o, path, staged, sizeof staged);
            if (r == SQ_OK) {
                r = sq_vtk_write_fields(o->ctx, &fd, fs, nfs);
                if (r != SQ_OK) r = unstage_last(o, r);
            }
            if (r == SQ_OK) r = note_vti(o, g, tag, path, time_s);
        }
    }
    /* 2D maps in metres (snow depth, deposit depth) also as 16-bit PNG, 1 mm per unit, row 0 =
     * north edge */
    for (int q = 0; r == SQ_OK && q < nf; q++)
        if (fv[q].nz == 1 && fv[q].units && strcmp(fv[q].units, "m") == 0 &&
            strstr(fv[q].name, "depth")) {
            snprintf(path, sizeof path, "%s_%s_%05d.png", o->fields, fv[q].name, frame);
            r = stage(o, path, staged, sizeof staged);
            if (r == SQ_OK) {
                r = write_depth_png(staged, &fv[q], false);
                if (r != SQ_OK) r = unstage_last(o, r);
            }
        }
    return r;
}

sq_result sq__run_outputs_commit(sq__run_outputs *o)
{
    if (o->vw) {
        sq_result r = sq_video_close(o->vw);
        o->vw = NULL;
        if (r != SQ_OK) return r;
    }
    if (o->metrics_file) {
        errno = 0;
        const bool bad = (ferror(o->metrics_file) | fclose(o->metrics_file)) != 0;
        const int e = errno;
        o->metrics_file = NULL;
        if (bad) return sq__write_error(NULL, o->metrics, e, NULL);
        sq_result r = sq_output_commit(o->metrics_tmp, o->metrics, o->overwrite);
        if (r != SQ_OK) return r;
        o->metrics_tmp[0] = 0;
    }
    /* the staged per-frame files under their final names, then the time-series indices */
    while (o->staged_count > 0) {
        struct sq__run_staged *e = &o->staged[0];
        sq_result r = sq_output_commit(e->staged, e->final, o->overwrite);
        if (r != SQ_OK) return r; /* abort removes what is still staged */
        free(e->staged);
        free(e->final);
        memmove(o->staged, o->staged + 1, sizeof *o->staged * (size_t)(--o->staged_count));
    }
    for (int grp = 0; grp < SQ_RUN_FIELD_GROUPS; grp++) {
        if (!o->vti_count[grp]) continue;
        char pvd[PATH_MAX_RUN];
        snprintf(pvd, sizeof pvd, "%s%s.pvd", o->fields, o->vti_tag[grp]);
        sq_result r = sq_vtk_write_series(o->ctx, pvd, (const char *const *)o->vti[grp],
                                          o->vti_t[grp], o->vti_count[grp], o->overwrite);
        if (r != SQ_OK) return r;
    }
    o->frames_dir_created = false; /* the frames are kept */
    return SQ_OK;
}

sq_result sq__run_outputs_keep_partial(sq__run_outputs *o)
{
    o->partial[0] = 0;
    if (!o->metrics_file) return SQ_OK;
    errno = 0;
    const bool bad = (ferror(o->metrics_file) | fclose(o->metrics_file)) != 0;
    o->metrics_file = NULL;
    if (bad || o->rows == 0) return SQ_OK; /* nothing complete to keep; abort removes it */
    /* "dir/m.csv" -> "dir/m.partial.csv", then m.partial-2.csv ... never replacing a file */
    char base[PATH_MAX_RUN];
    snprintf(base, sizeof base, "%s", o->metrics);
    char *slash = strrchr(base, '/'), *dot = strrchr(base, '.');
    const char *ext = "";
    if (dot && (!slash || dot > slash + 1)) {
        ext = o->metrics + (dot - base);
        *dot = 0;
    }
    for (int k = 1; k <= 100; k++) {
        char name[PATH_MAX_RUN + 32];
        if (k == 1)
            snprintf(name, sizeof name, "%s.partial%s", base, ext);
        else
            snprintf(name, sizeof name, "%s.partial-%d%s", base, k, ext);
        if (sq_output_commit(o->metrics_tmp, name, false) == SQ_OK) {
            o->metrics_tmp[0] = 0;
            snprintf(o->partial, sizeof o->partial, "%s", name);
            return SQ_OK;
        }
    }
    return SQ_OK;
}

void sq__run_outputs_abort(sq__run_outputs *o)
{
    if (o->vw) sq_video_abort(o->vw);
    o->vw = NULL;
    if (o->metrics_file) fclose(o->metrics_file);
    o->metrics_file = NULL;
    if (o->metrics_tmp[0]) sq__output_discard(o->metrics_tmp);
    o->metrics_tmp[0] = 0;
    /* every staged per-frame file: none of them has a final name yet */
    for (int i = 0; i < o->staged_count; i++) {
        (void)unlink(o->staged[i].staged);
        free(o->staged[i].staged);
        free(o->staged[i].final);
    }
    o->staged_count = 0;
    if (o->frames_dir_created) {
        (void)rmdir(o->frames_dir); /* only when empty: nothing of anyone else is removed */
        o->frames_dir_created = false;
    }
}

void sq__run_outputs_free(sq__run_outputs *o)
{
    free(o->values);
    o->values = NULL;
    for (int i = 0; i < o->staged_count; i++) {
        free(o->staged[i].staged);
        free(o->staged[i].final);
    }
    free(o->staged);
    o->staged = NULL;
    o->staged_count = o->staged_cap = 0;
    for (int grp = 0; grp < SQ_RUN_FIELD_GROUPS; grp++) {
        for (int i = 0; i < o->vti_count[grp]; i++) free(o->vti[grp][i]);
        free(o->vti[grp]);
        free(o->vti_t[grp]);
        o->vti[grp] = NULL;
        o->vti_t[grp] = NULL;
        o->vti_count[grp] = o->vti_cap[grp] = 0;
    }
}

static int cmp_d(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

sq_result sq__run_metric_stats(const sq__run_outputs *o, int i, sq_run_metric_stats *out)
{
    memset(out, 0, sizeof *out);
    if (i < 0 || i >= o->metric_count)
        return sq__set_error(SQ_ERR_NOT_FOUND, "metric %d; the run has %d", i, o->metric_count);
    out->name = o->names[i];
    out->unit = o->units[i];
    out->min = out->median = out->max = out->mean = out->last = (double)NAN;
    double *col = (double *)malloc(sizeof(double) * (size_t)(o->rows > 0 ? o->rows : 1));
    if (!col) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory for metric statistics");
    int n = 0;
    double sum = 0.0;
    const size_t stride = (size_t)o->metric_count;
    for (int f = 0; f < o->rows; f++) {
        const double v = o->values[(size_t)f * stride + (size_t)i];
        if (isfinite(v)) {
            col[n++] = v;
            sum += v;
        }
    }
    if (o->rows > 0) out->last = o->values[(size_t)(o->rows - 1) * stride + (size_t)i];
    out->count = n;
    if (n > 0) {
        qsort(col, (size_t)n, sizeof(double), cmp_d);
        out->min = col[0];
        out->max = col[n - 1];
        out->median = n % 2 ? col[n / 2] : 0.5 * (col[n / 2 - 1] + col[n / 2]);
        out->mean = sum / n;
    }
    free(col);
    return SQ_OK;
}
