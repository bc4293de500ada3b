/* run_internal.h — the frame loop's state (run.c), its output files (run_outputs.c) and its
 * drawable snapshots (run_snapshot.c). */
#ifndef SQ_RUN_INTERNAL_H
#define SQ_RUN_INTERNAL_H

#include <stdio.h>
#include <threads.h>

#include "core/core_internal.h"
#include "squall/io.h"
#include "squall/run.h"

#define SQ_RUN_MAX_DRAWABLES 32
#define SQ_RUN_MAX_METRICS 128
#define SQ_RUN_MAX_FIELDS 64
/* Field files: a file holds one grid; the 3D fields and the 2D maps of a frame each go to as
 * many files as they have grids, at most this many together */
#define SQ_RUN_FIELD_GROUPS 8

/* ---- run_snapshot.c ------------------------------------------------------------------------ */
/* The rendering settings of a frame (output's live keys, read by advance on the simulation side
 * so that a live change reaches the drawing thread with the frame that shows it). */
typedef struct sq__run_look {
    float exposure;
    int volume_slices, light_buffer;
    bool volume_noise;
} sq__run_look;

/* The drawables of one frame: views, and with copies the arrays they point to (owned here). */
typedef struct sq__run_frame_slot {
    int index;          /* frame shown; -1 when empty */
    double time_s;
    sq_camera camera;
    sq__run_look look;
    /* the world as it was when the frame was made: its sun, sky and clock (a step or a live
     * change moves them on the simulation side while the frame is drawn); terrain, obstacles
     * and meshes shared (sq__world_frame_copy); owned memory, NULL when the run draws nothing */
    sq_world *world;
    sq_drawable drawables[SQ_RUN_MAX_DRAWABLES];
    int count;
    /* owned copies (snapshot mode): one growing buffer per drawable */
    float *data[SQ_RUN_MAX_DRAWABLES];
    size_t data_cap[SQ_RUN_MAX_DRAWABLES];
} sq__run_frame_slot;

/* Copies the arrays behind ds[0..n) into slot (keeping the views pointing at the copies). */
sq_result sq__run_snapshot(sq_context *ctx, sq__run_frame_slot *slot, const sq_drawable *ds,
                           int n);
void sq__run_slot_free(sq_context *ctx, sq__run_frame_slot *slot);

/* ---- run_outputs.c ------------------------------------------------------------------------- */
typedef struct sq__run_outputs {
    sq_context *ctx;
    bool overwrite;
    const char *video, *frames_dir, *metrics, *fields; /* NULL when not written */
    int fields_every, fields_format, frames;
    const char *title;
    const sq_world *world; /* for the georeference of field files */
    int width, height, fps;
    bool frames_dir_created;
    int frames_written;     /* PNG frames of this run (removed on abort if the dir was made) */
    sq_video_writer *vw;
    FILE *metrics_file;
    char metrics_tmp[1100];
    /* per-frame files (PNG frames, field files, depth maps) are staged under hidden temporary
     * names ("dir/.NAME.tmp-PID-0") and renamed to their final names by commit, all of them;
     * abort removes them, so an interrupted run leaves nothing (and a killed one only
     * temporaries, which the next run removes) */
    struct sq__run_staged {
        char *staged, *final;
    } *staged;
    int staged_count, staged_cap;
    /* the .vti files of the run (final base names) for the .pvd time-series indices, one per
     * group of fields on one grid, and that group's part of the file names (run_outputs.c) */
    char **vti[SQ_RUN_FIELD_GROUPS];
    double *vti_t[SQ_RUN_FIELD_GROUPS];
    int vti_count[SQ_RUN_FIELD_GROUPS], vti_cap[SQ_RUN_FIELD_GROUPS];
    char vti_tag[SQ_RUN_FIELD_GROUPS][16];
    char partial[1200]; /* where the metrics rows of a failed run were kept ("" = nowhere) */
    /* metric table for the statistics (and the CSV header) */
    int metric_count;
    char names[SQ_RUN_MAX_METRICS][96];
    char units[SQ_RUN_MAX_METRICS][24];
    double *values; /* frames x metric_count */
    int rows, cap;
} sq__run_outputs;

/* Checks every output of the scene's output section for this run (before any work). */
sq_result sq__run_outputs_check(sq__run_outputs *o, bool rendering);
/* No two outputs of the run are the same file (sq_output_same_file): the video, the frames
 * directory, the metrics, the field indices and checkpoint (NULL when none) each need their own
 * name; SQ_ERR_INVALID_ARG naming both otherwise. */
sq_result sq__run_outputs_distinct(const sq__run_outputs *o, const char *checkpoint);
/* Opens the temporaries (video writer, metrics file). */
sq_result sq__run_outputs_open(sq__run_outputs *o);
/* One image: video frame and/or PNG (and PFM for reference frames). */
sq_result sq__run_outputs_frame(sq__run_outputs *o, int frame, const uint8_t *rgba,
                                const float *linear_rgb);
/* One metrics row (CSV and the statistics). */
sq_result sq__run_outputs_metrics(sq__run_outputs *o, int frame, double time_s,
                                  const sq_metric *m, int n);
bool sq__run_outputs_fields_due(const sq__run_outputs *o, int frame);
/* The fields of one frame: NetCDF/VTK files (3D and 2D maps apart) and depth maps as PNG. */
sq_result sq__run_outputs_fields(sq__run_outputs *o, int frame, double time_s,
                                 const sq_named_field *f, int n);
/* Video closed, metrics renamed to their final names. */
sq_result sq__run_outputs_commit(sq__run_outputs *o);
/* Temporaries and staged files removed, a directory this run made removed; nothing of the run
 * stays but the metrics rows so far, committed as "NAME.partial.csv" (o->partial). */
void sq__run_outputs_abort(sq__run_outputs *o);
/* The metrics rows so far as a complete file "NAME.partial.csv" (a free name; never replacing
 * anything); o->partial names it. SQ_OK when there were no metrics. */
sq_result sq__run_outputs_keep_partial(sq__run_outputs *o);
void sq__run_outputs_free(sq__run_outputs *o);
sq_result sq__run_metric_stats(const sq__run_outputs *o, int i, sq_run_metric_stats *out);

/* ---- run.c ----------------------------------------------------------------------------------- */
struct sq_run {
    sq_context *ctx;
    sq_run_desc desc;
    sq_scene *scene;
    const sq_scene_output *out;
    int frames;          /* in the run */
    int next;            /* frames advanced so far */
    double t0;           /* wall clock at create */
    bool finished;
    double next_checkpoint_s; /* simulated time of the next checkpoint */
    bool checkpoint_written;  /* later checkpoints replace the run's own file */
    sq__run_outputs outs;
    /* frames for the drawing side: with snapshots two slots (front = latest complete frame),
     * else slot 0 holds views into the live phenomena */
    sq__run_frame_slot slots[2];
    int front;           /* slot of the latest advanced frame; -1 before the first */
    int drawing;         /* slot being drawn; -1 when none */
    mtx_t lock;
    cnd_t released;
    bool have_lock;
    bool camera_override;
    sq_camera camera;    /* the override */
    /* drawing side */
    sq_renderer *renderer;
    sq__run_look renderer_look; /* the settings the renderer draws with now */
    /* the world drawn: the drawn slot's world copied here on the drawing side (one address for
     * the renderer's caches, which key on it) */
    sq_world *draw_world;
    uint8_t *rgba;
    float *linear;
};

#endif
