/* squall/run.h — the frame loop as a library module: a scene, its clock (warm-up, steps per frame,
 * time scale), its camera path, and sinks for every frame (image), metrics row and field set, with
 * interruption, progress and the output-safety rules in one place. `squall render` and
 * `squall simulate` are thin callers of it; an interactive viewer pumps it frame by frame.
 *
 * Two ways to drive it:
 *   batch:  sq_run_create -> sq_run_execute -> sq_run_finish -> sq_run_destroy
 *   pumped: sq_run_create -> loop { sq_run_advance; sq_run_draw or sq_run_draw_to }
 *           -> sq_run_finish -> sq_run_destroy
 * sq_run_execute is exactly the pumped loop with sq_run_draw (or without drawing for
 * SQ_RUN_SIMULATE).
 *
 * Frames: frame 0 shows the scene after the warm-up (output.warmup_s); every later frame is
 * output.steps_per_frame scene steps further, output.time_scale / output.fps simulated seconds in
 * all. The camera follows the scene's path (camera.path) unless sq_run_set_camera overrides it.
 *
 * Outputs (write_outputs): the scene's output section — MP4 video, PNG frames directory, metrics
 * CSV, field files (NetCDF/VTK, 16-bit PNG of depth maps). Every output is checked before any
 * work (directory exists, file absent unless overwrite, even size for MP4); files are written to
 * temporary names and renamed by sq_run_finish; an existing file is never replaced without
 * overwrite; sq_run_destroy without a successful finish removes the temporaries (and the PNG
 * frames of this run in a directory it created). Inputs are never written.
 *
 * Interruption: cancel_flag / cancel are polled before every scene step, before every draw,
 * encode and field write, inside GL frames between the renderer's passes and parts (on the
 * drawing thread), and within reference path-traced frames; a cancelled call returns
 * SQ_ERR_CANCELLED ("interrupted at frame N of M") and leaves nothing but temporaries, which
 * sq_run_destroy removes.
 *
 * Threads: sq_run_advance (simulation: steps, camera, metrics and fields sinks) runs on one
 * thread, sq_run_draw / sq_run_draw_to (rendering, frame sink) on one thread — the thread whose
 * OpenGL context draws. With desc.snapshot = false they must not overlap (call them in turn, as
 * sq_run_execute does). With desc.snapshot = true sq_run_advance copies the drawables of each new
 * frame into a buffer the run owns, so advance and draw may run at the same time on two threads:
 * draw shows the latest frame advance has completed (advance waits only when the buffer it would
 * fill is being drawn). Every frame carries the world's sun, sky and clock as they were when it
 * was made: a step that moves the sun, or a live sky change, during a draw does not reach it. The renderer is created by the first draw, on the drawing thread; destroy
 * the run on that thread (with the caller's context current for SQ_RUN_GL_CURRENT_CONTEXT).
 * sq_run_set_camera, sq_run_frame_index and sq_run_time may be called from any thread. create,
 * execute, finish and destroy must not overlap anything else. */
#ifndef SQ_RUN_H
#define SQ_RUN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/render.h"
#include "squall/scene.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_run sq_run;

typedef enum sq_run_render {
    SQ_RUN_GL = 0,                 /* OpenGL frames in the renderer's own headless EGL context */
    SQ_RUN_SIMULATE = 1,           /* no frames: steps, metrics and fields only (no GL needed) */
    SQ_RUN_REFERENCE = 2,          /* the CPU reference path tracer (reference_samples > 0) */
    SQ_RUN_GL_CURRENT_CONTEXT = 3  /* OpenGL in the caller's context, current on the draw thread */
} sq_run_render;

/* One finished frame for the frame sink: rows top first. linear_rgb is the radiance before tone
 * mapping (reference frames only; NULL for GL frames). Borrowed for the call. */
typedef struct sq_run_frame {
    int index;
    double time_s;            /* simulated time of the frame */
    int width, height;
    const uint8_t *rgba;      /* width*height*4, sRGB */
    const float *linear_rgb;  /* width*height*3 or NULL */
} sq_run_frame;

/* Optional callbacks; a non-SQ_OK return stops the run with that result (set sq_set_error for a
 * message). Metric names are "<layer>.<metric>"; all pointers are borrowed for the call. */
typedef struct sq_run_sinks {
    sq_result (*frame)(void *user, const sq_run_frame *f);
    sq_result (*metrics)(void *user, int frame, double time_s, const sq_metric *m, int count);
    sq_result (*fields)(void *user, int frame, double time_s, const sq_named_field *f, int count);
    void *user;
} sq_run_sinks;

typedef struct sq_run_progress {
    int frame;          /* frames completed */
    int frames;         /* frames in the run */
    double fraction;    /* of the whole run, in [0, 1] (within a reference frame too) */
    double elapsed_s;   /* wall clock since sq_run_create */
    double frames_per_s;
    double eta_s;       /* estimate of the wall time left */
    const char *stage;  /* "warm-up", "frame", "reference", "done" */
} sq_run_progress;

typedef struct sq_run_desc {
    sq_scene *scene;          /* borrowed: must outlive the run, which steps it */
    sq_run_render render;
    int reference_samples;    /* SQ_RUN_REFERENCE: samples per pixel (> 0) */
    bool write_outputs;       /* write the scene's output section (see above) */
    bool overwrite;           /* replace existing outputs (never done otherwise) */
    bool snapshot;            /* advance copies the drawables: draw may run on another thread */
    sq_run_sinks sinks;
    /* interruption: non-zero *cancel_flag (e.g. set by a signal handler) or cancel returning
     * true stops the run at the next poll */
    const volatile int *cancel_flag;
    bool (*cancel)(void *user);
    /* progress after every frame (and during reference frames) */
    void (*progress)(void *user, const sq_run_progress *p);
    void *user;               /* for cancel and progress */
    /* Checkpoints (squall/io.h): after the first frame at or past every multiple of
     * checkpoint_every_s simulated seconds (the last frame included, so that a finished run can
     * be extended with more frames), the complete state goes to checkpoint_path,
     * atomically, replacing the run's previous checkpoint; checkpoint_cfg is the configuration
     * the scene was built from (overrides included), stored with it. 0 = none. */
    double checkpoint_every_s;
    const char *checkpoint_path;
    const struct sq_cfg *checkpoint_cfg;
    bool checkpoint_replaces; /* the file at checkpoint_path may be replaced (the one resumed) */
    /* Resume: the scene was restored from a checkpoint made before frame resume_frame
     * (sq_checkpoint_info.frame); the run continues from there, bit-identically to a run that
     * was never stopped, and writes the frames, metrics rows and fields from it on. */
    int resume_frame;
} sq_run_desc;

/* Checks every output (before any work), opens the temporaries of the video and metrics files.
 * No GL is touched. Errors: SQ_ERR_INVALID_ARG (bad desc, odd MP4 size, nothing to write for a
 * rendering run with write_outputs and no frame sink), SQ_ERR_EXISTS (output exists without
 * overwrite), SQ_ERR_IO (missing directory, not writable), SQ_ERR_UNSUPPORTED (a renderer or
 * format not compiled in). */
SQ_API sq_result sq_run_create(sq_context *ctx, const sq_run_desc *desc, sq_run **out);
/* Aborts what was not finished (temporaries removed), destroys the renderer (see Threads). */
SQ_API void sq_run_destroy(sq_run *run);

/* Advances to the next frame: warm-up before frame 0, else steps_per_frame scene steps; then the
 * camera (path or override, given to the layers' observe hooks), the drawables (copied when
 * snapshot), the metrics row and, when due (output.fields_every, last frame), the fields, to the
 * sinks and output files. SQ_ERR_INVALID_ARG once every frame is done (sq_run_done). */
SQ_API sq_result sq_run_advance(sq_run *run);
/* Draws the latest advanced frame with the run's renderer (created on first use), reads it back
 * and hands it to the frame sink and the video / PNG outputs. SQ_ERR_INVALID_ARG before the
 * first advance or for SQ_RUN_SIMULATE. */
SQ_API sq_result sq_run_draw(sq_run *run);
/* SQ_RUN_GL_CURRENT_CONTEXT only: draws the latest advanced frame into the caller's framebuffer
 * (sq_renderer_draw_to; target->content SQ_TARGET_FRAME for a viewer, DRAWABLES_OVER to put the
 * phenomena over the caller's own geometry). No read-back, no frame outputs. With a camera
 * override (sq_run_set_camera) it draws from the override as it is now, so that a viewer's camera
 * moves at the display rate even while the simulation is paused or slow. */
SQ_API sq_result sq_run_draw_to(sq_run *run, const sq_render_target *target);
/* Every remaining frame: advance, and draw unless SQ_RUN_SIMULATE. */
SQ_API sq_result sq_run_execute(sq_run *run);
/* Closes the video and renames every temporary to its final name. Call once, after the last
 * frame (or earlier to keep a shorter run). */
SQ_API sq_result sq_run_finish(sq_run *run);

/* A live change (squall/scene.h, sq_scene_apply_live) on the advance thread, between two
 * advances: checked and applied as sq_scene_apply_live does; when something was applied, the
 * latest frame is published again (same index and simulated time, the new drawables, camera
 * and rendering settings), so that the next draw shows the change without waiting for a step.
 * Every later frame carries it. res->rebuild: nothing applied; rebuild the scene and the run. */
SQ_API sq_result sq_run_apply_live(sq_run *run, const sq_scene_desc *desc, sq_live_result *res);

/* Camera override for the following advances (thread-safe); NULL returns to the scene's path. */
SQ_API void sq_run_set_camera(sq_run *run, const sq_camera *camera);
SQ_API bool sq_run_done(const sq_run *run);
/* Frames advanced so far (the latest is frame_index - 1), and the frames in the run. */
SQ_API int sq_run_frame_index(const sq_run *run);
SQ_API int sq_run_frame_count(const sq_run *run);
/* Simulated time of the latest advanced frame (s). */
SQ_API double sq_run_time(const sq_run *run);
/* Wall-clock seconds since sq_run_create. */
SQ_API double sq_run_elapsed_s(const sq_run *run);
/* The camera of the latest advanced frame. */
SQ_API sq_camera sq_run_camera(const sq_run *run);

/* Statistics of each metric over the frames advanced so far (NaN values skipped). */
typedef struct sq_run_metric_stats {
    const char *name;   /* "<layer>.<metric>", valid as long as the run */
    const char *unit;
    int count;          /* finite values */
    double min, median, max, mean, last;
} sq_run_metric_stats;
/* The metrics of the run (every layer's, in the scene's order), and the statistics of metric
 * i in [0, count): SQ_ERR_NOT_FOUND outside. */
SQ_API int sq_run_metric_count(const sq_run *run);
SQ_API sq_result sq_run_metric_stats_get(const sq_run *run, int i, sq_run_metric_stats *out);

#ifdef __cplusplus
}
#endif
#endif
