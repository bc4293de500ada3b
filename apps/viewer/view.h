/* view.h — the state of `squall view` shared by its parts: the window and GL area (cmd_view.c),
 * the simulation thread (view_sim.c), the camera (view_camera.c), the HUD and keys
 * (view_input.c), screenshots (view_shot.c). */
#ifndef SQ_VIEW_H
#define SQ_VIEW_H

#include <gtk/gtk.h>
#include <stdbool.h>

#include "squall/io.h"
#include "squall/run.h"
#include "squall/scene.h"
#include "view_camera.h"
#include "view_param.h"
#include "view_sim.h"

#define VIEW_PATH_MAX 1024
#define VIEW_MAX_ROWS 1024

typedef struct view_script view_script;

typedef enum view_live_outcome {
    VIEW_LIVE_NONE = 0,
    VIEW_LIVE_APPLIED,  /* applied to the running scene (no restart) */
    VIEW_LIVE_REFUSED,  /* a rule refused it: live_message, nothing changed */
    VIEW_LIVE_REBUILT   /* it needed a rebuild: the scene restarted */
} view_live_outcome;

typedef struct viewer {
    /* options */
    const char *scene_arg;
    int frames;            /* --frames N: run N frames and exit; 0: interactive */
    const char *screenshot; /* --screenshot FILE.png (with --frames) */
    bool overwrite;
    int width, height;     /* GL area size request */
    bool paused_start;
    bool panel_on;
    const char *script_path;
    char scene_real[VIEW_PATH_MAX]; /* realpath of a scene file ("" for a preset): never written */

    sq_context *ctx;
    sq_cfg *cfg;           /* the user's scene as edited (--set, panel); what "save" writes */
    sq_scene *scene;
    sq_run *run;
    view_sim *sim;
    /* runs given up (rebuild, reset) whose simulation thread finishes the step under way: freed
     * by the tick once it has (the UI thread never waits for a step) */
    struct view_retired {
        view_sim *sim;
        sq_run *run;
        sq_scene *scene;
    } retired[8];
    int retired_count;
    bool have_box;         /* bounds of the phenomena (for "frame the phenomenon") */
    sq_vec3 box_lo, box_hi;

    /* window */
    GtkWidget *window, *area, *hud, *message;
    bool hud_on;
    int fb_width, fb_height; /* GL area framebuffer in pixels */
    bool quit;
    int exit_code;

    /* camera */
    view_camera cam;       /* used when cam.mode != VIEW_CAM_PATH (then the run's override) */
    bool keys[8];          /* W A S D Q E Shift held */
    double drag_x0, drag_y0;
    double last_tick_s;

    /* drawing */
    int drawn_frames;      /* sq_run_frame_index when the last draw started */
    bool redraw;           /* camera or size changed: draw even without a new frame */
    double draw_ms;        /* smoothed GL time of one draw (ms) */
    double fps;            /* draws per wall second */
    int fps_count;
    double fps_t0;
    double draw_ms_sum;    /* over every draw of the run, for --json */
    int draw_count;
    double t_first_draw_s;
    bool json;
    /* latency of a change (script `set`): from applying it to the first draw that shows it */
    bool lat_pending;      /* a change waits to be shown */
    bool lat_armed;        /* it is applied: the next draw shows it */
    double lat_t0_s;
    int lat_frame0;        /* sq_run_frame_index when applied (-1: the scene restarted) */
    int lat_draws0;        /* draw_count when the change was made */
    char lat_key[200];
    /* live changes sent to the simulation thread (view_param.c), and how the latest ended */
    bool live_pending;     /* some wait for their results */
    int live_outstanding;  /* sent, result not taken */
    char live_assignment[1400]; /* the latest result's change */
    view_live_outcome live_outcome;
    char live_message[800];
    view_live_result live_result; /* taken from the simulation thread */
    bool live_held;        /* live_result waits for the next tick (refusal, rebuild) */
    bool live_show;        /* the panel's status waits for the next tick */
    int live_refusals;     /* refused changes so far; the latest: */
    char live_refused[1400], live_refusal[800]; /* its assignment and message */
    int keyframes;         /* camera keyframes recorded (view_keyframe.c): save keeps the path */
    /* dynamic resolution (view_dynres.c): while the camera moves or live changes are made, the
     * scene is drawn at a reduced size and scaled up; when still, drawn again at full size */
    bool dynres;           /* on (default; --full-res turns it off) */
    double motion_t_s;     /* sq_time_now of the latest camera move or live change */
    float dyn_scale;       /* linear scale of the next reduced draw, in [VIEW_DYN_MIN, 1) */
    float last_scale;      /* scale of the latest draw (1: full size) */
    bool dyn_refine;       /* the latest draw was reduced: draw again at full size when still */
    unsigned dyn_fbo, dyn_color, dyn_depth;
    int dyn_w, dyn_h;
    int draw_count_reduced;
    double draw_ms_sum_reduced, dyn_scale_sum;
    double draw_ms_full;   /* smoothed time of a full-size draw (ms); 0: none yet */
    char gl_error[512];    /* non-empty: drawing failed (shown; --frames exits with 1) */

    /* screenshot: written by the next draw showing frame >= shot_frame */
    bool shot_pending;
    int shot_frame;
    char shot_path[VIEW_PATH_MAX];
    bool shot_done;
    float shot_scale;      /* scale of the draw the screenshot was read from (1: full size) */
    bool shot_as_shown;    /* the screenshot is the picture as shown (a reduced draw allowed) */

    /* parameter panel (view_panel.c) and script (view_script.c) */
    GtkWidget *panel, *panel_status;
    bool panel_updating;   /* widgets being set from the scene: no change signals */
    void *panel_rows[VIEW_MAX_ROWS];
    int panel_row_count;
    view_script *script;

    /* recording (view_record.c) */
    sq_video_writer *rec;
    int rec_width, rec_height, rec_last_frame, rec_frames;
    uint8_t *rec_px;
    char rec_path[VIEW_PATH_MAX];
    char rec_error[VIEW_PATH_MAX + 512];
} viewer;

/* view_shot.c: the GL area's framebuffer (bound now) -> PNG, rows top first, written under the
 * safe-output rules (temporary + rename, no replacement without overwrite, never the scene). */
sq_result view_shot_write(viewer *v, const char *path, int width, int height);
/* Reads the bound framebuffer's (0,0)-(width,height) as RGBA, rows top first. */
bool view_shot_read(int width, int height, uint8_t *px);
/* SQ_ERR_INVALID_ARG when path is the scene file (inputs are never written). */
sq_result view_shot_check(const viewer *v, const char *path);

/* view_input.c: keys, mouse, wheel and the HUD. */
void view_input_attach(viewer *v);
void view_input_tick(viewer *v, double now_s);
void view_hud_update(viewer *v);

/* view_panel.c: the parameter panel generated from the tables (see the file). */
GtkWidget *view_panel_build(viewer *v);
void view_panel_refresh(viewer *v);
void view_panel_free(viewer *v);
/* The keys the panel lists for section (e.g. "layers.storm"), one per line; returns the count. */
int view_panel_keys(const viewer *v, const char *section, char *buf, size_t size);
/* Sets a key as the panel's widget would, without asking (scripts). */
sq_result view_panel_set(viewer *v, const char *full_key, const char *value, view_change *how);

/* view_script.c: --script FILE (see the file for the actions), checked before the window opens. */
sq_result view_script_load(viewer *v, const char *path, view_script **out);
void view_script_tick(viewer *v, view_script *s);
void view_script_free(view_script *s);

/* view_record.c: MP4 of the frames shown (each new simulation frame once), through the library's
 * H.264 writer (temporary name, renamed by stop). The size is the GL area's, rounded down to even. */
sq_result view_record_start(viewer *v, const char *path);
void view_record_frame(viewer *v, int frame);   /* in the GL callback, after the draw */
sq_result view_record_stop(viewer *v);           /* closes and renames; no-op when not recording */
void view_record_abort(viewer *v);

/* view_dynres.c: dynamic resolution. view_dynres_motion marks a camera move or a live change;
 * view_dynres_scale says whether the coming draw is reduced (1: full size; never for a
 * screenshot or while recording); view_dynres_target gives the framebuffer to draw a reduced
 * frame into (scale x the area's size), view_dynres_finish scales it up into the area's
 * framebuffer, view_dynres_adapt sets the next scale from the time it took; view_dynres_free releases
 * the GL objects (the area's context current). */
#define VIEW_DYN_MIN 0.25f
#define VIEW_DYN_HOLD_S 0.3       /* still for this long: the next draw is at full size */
#define VIEW_DYN_TARGET_MS 100.0  /* a reduced draw aims at this time */
void view_dynres_motion(viewer *v);
float view_dynres_scale(const viewer *v, double now_s);
bool view_dynres_target(viewer *v, float scale, unsigned *fbo, int *w, int *h);
void view_dynres_finish(viewer *v, unsigned area_fbo);
void view_dynres_adapt(viewer *v, double ms); /* after a reduced draw that took ms */
void view_dynres_free(viewer *v);
/* view_input.c: turns the camera as a mouse drag of (dx, dy) pixels would (scripts). */
void view_input_turn(viewer *v, double dx_px, double dy_px);

/* view_keyframe.c: the current view as a key of camera.path at the shown frame's video time
 * (see the file); *index and *t of the key. */
sq_result view_keyframe_add(viewer *v, int *index, double *t);

/* view_save.c: the scene as edited (and the camera as it is) to YAML, safe output. */
sq_result view_save_scene(viewer *v, const char *path);

/* view_param.c */
bool view_param_known(const viewer *v, const char *full_key);

/* cmd_view.c: rebuild the scene from v->cfg (reset), keeping the camera. */
sq_result view_rebuild(viewer *v);
/* A copy of v->cfg as the run was built from it (output.frames of the viewer), with one more
 * "key=value" (NULL: none); NULL with *res on failure. */
sq_cfg *view_run_cfg(viewer *v, const char *assignment, sq_result *res);
/* A scene desc with the io loaders of the CLI for cfg. */
sq_scene_desc view_scene_desc(const sq_cfg *cfg);

/* view_param.c: the outcome of a live change, every display frame (in_draw = false: panel
 * status, refusal, rebuild) and at the start of every draw (in_draw = true: an applied change
 * is in the frame drawn, for the latency). */
void view_param_poll(viewer *v, bool in_draw);
/* view_panel.c: the panel's status line. */
void view_panel_status(viewer *v, const char *msg, bool error);

#endif
