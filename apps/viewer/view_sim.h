/* view_sim.h — the viewer's simulation thread: pumps sq_run_advance of a run (snapshot mode) at
 * the scene's time scale (one frame every 1 / (output.fps * speed) wall seconds when it keeps up),
 * with pause, single step and speed, and keeps what the HUD shows (frames, scene steps per wall
 * second, simulated time, the latest metrics) and the first error (which pauses it). The drawing
 * thread only reads these under the lock; it never waits for a step. */
#ifndef SQ_VIEW_SIM_H
#define SQ_VIEW_SIM_H

#include <stdbool.h>
#include <threads.h>

#include "squall/run.h"

#define VIEW_SIM_MAX_METRICS 32

typedef struct view_metric {
    char name[96];
    char unit[24];
    double value;
} view_metric;

typedef struct view_sim_stats {
    int frames;             /* frames advanced (the latest shown is frames - 1) */
    int frame_count;        /* frames in the run */
    double sim_time_s;      /* simulated time of the latest frame */
    double steps_per_s;     /* scene steps per wall second over the last second or so */
    double speed;           /* wall-time multiplier of the scene's time scale */
    bool paused, done, busy; /* busy: a step is running now */
    /* wall clock (sq_time_now) when frame 0 (after the warm-up) and the latest frame were done,
     * and the wall seconds spent in advances since frame 0: steps/s over the run */
    double t_frame0_s, t_last_s, busy_s;
    int steps_per_frame;
    int metric_count;
    view_metric metrics[VIEW_SIM_MAX_METRICS];
    char error[512];        /* non-empty: the run stopped with this message (paused) */
} view_sim_stats;

typedef struct view_sim view_sim;

/* A simulation side for a run that does not exist yet: create it, put view_sim_sinks(s) in the
 * sq_run_desc (snapshot = true), create the run, then view_sim_start. */
view_sim *view_sim_create(int fps, int steps_per_frame);
sq_run_sinks view_sim_sinks(view_sim *s);
/* Starts the thread on run (borrowed until view_sim_destroy). paused: start paused (the first
 * frame, after the warm-up, is still advanced so that there is something to draw). */
bool view_sim_start(view_sim *s, sq_run *run, bool paused);
/* Stops the thread (after the step that is running) and frees everything. */
void view_sim_destroy(view_sim *s);
/* Asks the thread to stop after the step that is running, without waiting for it; true from
 * view_sim_stopped once it has returned (then view_sim_destroy does not wait). */
void view_sim_stop(view_sim *s);
bool view_sim_stopped(view_sim *s);

void view_sim_set_paused(view_sim *s, bool paused);
void view_sim_toggle_pause(view_sim *s);
void view_sim_single_step(view_sim *s);   /* pauses and advances one frame */
void view_sim_set_speed(view_sim *s, double speed); /* clamped to [1/64, 64] */
double view_sim_speed(view_sim *s);
void view_sim_stats_get(view_sim *s, view_sim_stats *out);

/* Live changes: a queue of changes the thread applies in order with sq_run_apply_live, between
 * two advances (at once when it waits: paused, or between frames), never during a step; the
 * drawing thread is not held. Each change is an assignment "section.key=value" made to the scene
 * as the changes before it left it (the run's configuration, kept by the thread), so that
 * several changes made within one display frame all apply; or a whole scene (whole != NULL:
 * keyframes edit the camera path in place), which then becomes the run's configuration. Every
 * change gets one result, in order. When a change needs a rebuild, the changes queued after it
 * in the same batch are not tried (dropped: the front end folds them into the rebuilt scene). */
typedef struct view_live_result {
    sq_result r;              /* SQ_OK, or the refusal (message in error) */
    sq_live_result res;       /* applied (res.changed) or needs a rebuild (res.rebuild) */
    char error[800];
    char assignment[1400];    /* the change as requested ("section.key=value", or a label) */
    bool whole;               /* the change was a whole scene */
    bool dropped;             /* not tried: a change before it needs a rebuild */
    int frame;                /* sq_run_frame_index when applied */
    double t_request_s, t_applied_s; /* wall clock (sq_time_now) */
} view_live_result;
#define VIEW_LIVE_QUEUE 32    /* changes waiting for their result, at most */
/* The scene the run was built from (owned from now on) and the desc that builds it (its loaders;
 * cfg is replaced): the base of the assignments; ctx copies it. Before view_sim_start. */
void view_sim_set_scene(view_sim *s, sq_context *ctx, sq_cfg *run_cfg, const sq_scene_desc *base);
/* Queues a change (whole: owned by the queue, or NULL for the assignment alone); false (whole
 * destroyed) when VIEW_LIVE_QUEUE changes already wait for their results. */
bool view_sim_request_live(view_sim *s, const char *assignment, sq_cfg *whole);
/* true with the oldest result not yet read, in the order of the requests. */
bool view_sim_live_result(view_sim *s, view_live_result *out);
#endif
