/* view_script.c — `squall view --script FILE`: timed actions for tests and demos, one per line
 * (# starts a comment), run in order by the window's frame callback:
 *   wait N                  until N more frames have been advanced and drawn (0: until the
 *                           next draw, e.g. of a frame a live change republished)
 *   wait-end                until the run's last frame is drawn (with --frames N)
 *   set KEY VALUE           as the panel does (no confirmation): KEY = section.key, e.g.
 *                           layers.dust.urban.concentration_kg_m3 or output.exposure
 *   send KEY VALUE          as set, without waiting: the next set (or the end) waits for it;
 *                           several changes sent in one display frame all apply, in order;
 *                           prints "change KEY = VALUE: applied to frame N (C changed)" (or
 *                           refused, scene restarted) when the simulation thread has taken it
 *   screenshot FILE.png     the next drawn frame (the GL area's pixels)
 *   save FILE.yaml          the scene as edited, as YAML that `squall render` reads
 *   panel-keys SECTION FILE the keys the panel lists for SECTION (e.g. layers.storm), one a line
 *                           with "live" or "rebuild" after it
 *   record FILE.mp4         start recording every new frame shown (H.264, output.fps)
 *   record-stop             finish the video (also done at the end)
 *   keyframe                the current view as a key of camera.path at the frame's video
 *                           time (as key K); prints "keyframe N at t = T s"
 *   orbit N [FILE.png]      turns the camera (orbit) before each of the next N draws, as a
 *                           mouse drag would: the view moves (reduced draws, view_dynres.c);
 *                           FILE: the last of them as shown (reduced and scaled up)
 *   print-time              prints "time: frame N, simulated T s" (the latest frame advanced)
 *   pause | run | step      the simulation thread
 *   quit                    exit 0 (also at the end of the script)
 * Outputs follow the safe-output rules: checked before the window opens (absent unless
 * --overwrite, never the scene file), written to a temporary name and renamed. A refused value
 * or a failed output stops the viewer with exit code 2 or 1 and "FILE:LINE: message". */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "../cli/cli.h"
#include "view.h"

typedef enum act_kind {
    A_WAIT, A_WAIT_END, A_SET, A_SHOT, A_SAVE, A_KEYS, A_PAUSE, A_RUN, A_STEP, A_QUIT, A_REC,
    A_REC_STOP, A_TIME, A_KEYFRAME, A_SEND, A_ORBIT
} act_kind;

typedef struct action {
    act_kind kind;
    int line;
    int n;
    char a[VIEW_PATH_MAX], b[VIEW_PATH_MAX];
} action;

struct view_script {
    char path[VIEW_PATH_MAX];
    action *acts;
    int count, next;
    bool waiting;   /* the current action has started and waits for frames or a draw */
    int target;     /* A_WAIT: drawn frame index to reach */
    int draws0;     /* A_WAIT 0, A_ORBIT: draws when it started */
    int turned;     /* A_ORBIT: draw_count at the latest turn */
    /* the live changes sent (set, send), to name the line of one refused later */
    struct {
        int line;
        char assignment[2 * VIEW_PATH_MAX + 2];
    } sent[64];
    int sent_count;
    int refusals_seen; /* viewer.live_refusals already reported */
};

static void script_fail(viewer *v, const view_script *s, int line, int code, const char *msg)
{
    sq_cli_error("%s:%d: %s", s->path, line, msg);
    v->exit_code = code;
    v->quit = true;
}

static void note_sent(view_script *s, const action *a)
{
    const int k = s->sent_count++ % 64;
    s->sent[k].line = a->line;
    snprintf(s->sent[k].assignment, sizeof s->sent[k].assignment, "%s=%s", a->a, a->b);
}

/* A change sent earlier was refused: the script stops with its line and the CLI's message. */
static bool refused_since(viewer *v, view_script *s, int line)
{
    if (v->live_refusals == s->refusals_seen) return false;
    s->refusals_seen = v->live_refusals;
    for (int i = 0; i < s->sent_count && i < 64; i++) {
        const int k = (s->sent_count - 1 - i) % 64;
        if (strcmp(s->sent[k].assignment, v->live_refused) == 0) {
            line = s->sent[k].line;
            break;
        }
    }
    script_fail(v, s, line, SQ_EXIT_USAGE, v->live_refusal);
    return true;
}

/* An output a script names: not the scene or its inputs (view_shot_check), not the script
 * itself (also through a link), an existing file only with --overwrite. */
static sq_result check_output(viewer *v, const char *path, const char *script)
{
    struct stat a, b;
    if (stat(path, &a) == 0 && stat(script, &b) == 0 && a.st_dev == b.st_dev &&
        a.st_ino == b.st_ino)
        return sq_set_error(SQ_ERR_INVALID_ARG, "'%s' is the script being run ('%s'); inputs "
                            "are never written", path, script);
    sq_result r = view_shot_check(v, path);
    if (r == SQ_OK) r = sq_output_check(path, v->overwrite);
    return r;
}

sq_result view_script_load(viewer *v, const char *path, view_script **out)
{
    *out = NULL;
    FILE *f = fopen(path, "r");
    if (!f) return sq_set_error(SQ_ERR_IO, "--script %s: cannot open", path);
    view_script *s = (view_script *)calloc(1, sizeof *s);
    snprintf(s->path, sizeof s->path, "%s", path);
    char line[2 * VIEW_PATH_MAX];
    int no = 0, cap = 0;
    sq_result r = SQ_OK;
    while (r == SQ_OK && fgets(line, sizeof line, f)) {
        no++;
        char *hash = strchr(line, '#');
        if (hash) *hash = 0;
        char cmd[32] = "";
        action a;
        memset(&a, 0, sizeof a);
        a.line = no;
        int used = 0;
        if (sscanf(line, "%31s %n", cmd, &used) < 1) continue;
        const char *rest = line + used;
        char extra[8] = "";
        if (strcmp(cmd, "wait") == 0) {
            a.kind = A_WAIT;
            if (sscanf(rest, "%d %7s", &a.n, extra) != 1 || a.n < 0 || a.n > 1000000)
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: wait N: N must be a frame count in "
                                 "0..1000000", path, no);
        } else if (strcmp(cmd, "orbit") == 0) {
            a.kind = A_ORBIT;
            const int got = sscanf(rest, "%d %1023s %7s", &a.n, a.a, extra);
            if (got < 1 || got > 2 || a.n < 1 || a.n > 100000)
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: orbit N [FILE.png]: N must be a draw "
                                 "count in 1..100000", path, no);
            else if (got == 2 && (r = check_output(v, a.a, path)) != SQ_OK) {
                char m[700];
                snprintf(m, sizeof m, "%s", sq_last_error());
                r = sq_set_error(r, "%s:%d: %s", path, no, m);
            }
        } else if (strcmp(cmd, "set") == 0 || strcmp(cmd, "send") == 0) {
            a.kind = cmd[1] == 'e' && cmd[2] == 't' ? A_SET : A_SEND;
            int k = 0;
            if (sscanf(rest, "%1023s %n", a.a, &k) < 1 || !rest[k])
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: set KEY VALUE: missing %s", path, no,
                                 a.a[0] ? "VALUE" : "KEY");
            else {
                snprintf(a.b, sizeof a.b, "%s", rest + k);
                a.b[strcspn(a.b, "\r\n")] = 0;
                for (size_t e = strlen(a.b); e > 0 && a.b[e - 1] == ' '; e--) a.b[e - 1] = 0;
                if (!view_param_known(v, a.a))
                    r = sq_set_error(SQ_ERR_NOT_FOUND, "%s:%d: set %s: no such key in the scene's "
                                     "parameter tables (see squall params)", path, no, a.a);
            }
        } else if (strcmp(cmd, "screenshot") == 0 || strcmp(cmd, "save") == 0 ||
                   strcmp(cmd, "record") == 0) {
            a.kind = cmd[1] == 'c' ? A_SHOT : cmd[0] == 's' ? A_SAVE : A_REC;
            if (sscanf(rest, "%1023s %7s", a.a, extra) != 1)
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: %s FILE: one file name", path, no, cmd);
            else if ((r = check_output(v, a.a, path)) != SQ_OK) {
                char m[700];
                snprintf(m, sizeof m, "%s", sq_last_error());
                r = sq_set_error(r, "%s:%d: %s", path, no, m);
            }
        } else if (strcmp(cmd, "panel-keys") == 0) {
            a.kind = A_KEYS;
            if (sscanf(rest, "%1023s %1023s %7s", a.b, a.a, extra) != 2)
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: panel-keys SECTION FILE", path, no);
            else if ((r = check_output(v, a.a, path)) != SQ_OK) {
                char m[700];
                snprintf(m, sizeof m, "%s", sq_last_error());
                r = sq_set_error(r, "%s:%d: %s", path, no, m);
            }
        } else if (strcmp(cmd, "record-stop") == 0) a.kind = A_REC_STOP;
        else if (strcmp(cmd, "wait-end") == 0) {
            a.kind = A_WAIT_END;
            if (v->frames == 0)
                r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: wait-end needs --frames N (the run's "
                                 "end)", path, no);
        }
        else if (strcmp(cmd, "print-time") == 0) a.kind = A_TIME;
        else if (strcmp(cmd, "keyframe") == 0) a.kind = A_KEYFRAME;
        else if (strcmp(cmd, "pause") == 0) a.kind = A_PAUSE;
        else if (strcmp(cmd, "run") == 0) a.kind = A_RUN;
        else if (strcmp(cmd, "step") == 0) a.kind = A_STEP;
        else if (strcmp(cmd, "quit") == 0) a.kind = A_QUIT;
        else
            r = sq_set_error(SQ_ERR_INVALID_ARG, "%s:%d: unknown action '%s' (wait, wait-end, set, send, orbit, "
                             "screenshot, save, panel-keys, record, record-stop, keyframe, print-time, pause, run, step, quit)", path, no, cmd);
        if (r != SQ_OK) break;
        if (s->count == cap) {
            cap = cap ? 2 * cap : 16;
            s->acts = (action *)realloc(s->acts, (size_t)cap * sizeof *s->acts);
        }
        s->acts[s->count++] = a;
    }
    fclose(f);
    if (r != SQ_OK) {
        view_script_free(s);
        return r;
    }
    *out = s;
    return SQ_OK;
}

void view_script_free(view_script *s)
{
    if (!s) return;
    free(s->acts);
    free(s);
}

/* One step of the script per display frame; returns when an action waits. */
void view_script_tick(viewer *v, view_script *s)
{
    while (!v->quit && s->next < s->count) {
        action *a = &s->acts[s->next];
        view_sim_stats st;
        view_sim_stats_get(v->sim, &st);
        if (st.error[0]) {
            script_fail(v, s, a->line, SQ_EXIT_RUNTIME, st.error);
            return;
        }
        if (v->gl_error[0]) {
            script_fail(v, s, a->line, v->exit_code ? v->exit_code : SQ_EXIT_RUNTIME, v->gl_error);
            return;
        }
        if (refused_since(v, s, a->line)) return;
        switch (a->kind) {
        case A_WAIT:
            if (!s->waiting) {
                s->waiting = true;
                s->target = v->drawn_frames + a->n;
                s->draws0 = v->draw_count;
                v->redraw = true;
            }
            if (a->n == 0) {
                if (v->draw_count == s->draws0) return;
                break;
            }
            if (v->drawn_frames < s->target) {
                if (st.done && v->drawn_frames >= st.frames) script_fail(v, s, a->line, SQ_EXIT_USAGE, "wait: the run has no more frames");
                return;
            }
            break;
        case A_ORBIT:
            /* the camera turns 12 px of mouse drag before each of n draws (deterministic: by
             * draws, not by time), as a user dragging */
            if (!s->waiting) {
                s->waiting = true;
                s->draws0 = s->turned = v->draw_count;
            } else {
                if (v->draw_count == s->turned) return;
                s->turned = v->draw_count;
            }
            if (v->draw_count - s->draws0 < a->n) {
                if (a->a[0] && v->draw_count - s->draws0 == a->n - 1) {
                    /* the last draw of the turn, as it is shown (reduced while moving) */
                    snprintf(v->shot_path, sizeof v->shot_path, "%s", a->a);
                    v->shot_frame = v->run ? sq_run_frame_index(v->run) : 1;
                    if (v->shot_frame < 1) v->shot_frame = 1;
                    v->shot_pending = v->shot_as_shown = true;
                }
                view_input_turn(v, 12.0, 0.0);
                return;
            }
            if (v->shot_pending) return;
            if (v->exit_code) {
                v->quit = true;
                return;
            }
            break;
        case A_WAIT_END:
            if (!st.done || v->drawn_frames < st.frames) return;
            break;
        case A_SEND: {
            view_change how = VIEW_CHANGE_LIVE;
            const sq_result r = view_panel_set(v, a->a, a->b, &how);
            if (r != SQ_OK) {
                script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                return;
            }
            v->redraw = true;
            if (how == VIEW_CHANGE_PENDING) note_sent(s, a);
            else {
                printf("set %s = %s: %s\n", a->a, a->b,
                       how == VIEW_CHANGE_REBUILT ? "scene restarted" : "live");
                fflush(stdout);
            }
            break;
        }
        case A_SET: {
            if (!s->waiting) {
                view_change how = VIEW_CHANGE_LIVE;
                const double t0 = sq_time_now();
                const int f0 = v->run ? sq_run_frame_index(v->run) : 0;
                const int d0 = v->draw_count;
                const sq_result r = view_panel_set(v, a->a, a->b, &how);
                if (r != SQ_OK) {
                    script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                    return;
                }
                v->lat_pending = true;
                v->lat_armed = how != VIEW_CHANGE_PENDING;
                v->lat_t0_s = t0;
                v->lat_frame0 = how == VIEW_CHANGE_REBUILT ? -1 : f0;
                v->lat_draws0 = d0;
                v->redraw = true;
                snprintf(v->lat_key, sizeof v->lat_key, "%.199s", a->a);
                if (how == VIEW_CHANGE_PENDING) {
                    note_sent(s, a);
                    s->waiting = true; /* the simulation thread applies it between two steps */
                    return;
                }
                printf("set %s = %s: %s\n", a->a, a->b,
                       how == VIEW_CHANGE_REBUILT ? "scene restarted" : "live");
                fflush(stdout);
                break;
            }
            if (v->live_pending) return; /* this change and every one sent before it */
            if (refused_since(v, s, a->line)) return;
            printf("set %s = %s: %s (%s)\n", a->a, a->b,
                   v->live_outcome == VIEW_LIVE_REBUILT ? "scene restarted" : "live",
                   v->live_message);
            fflush(stdout);
            break;
        }
        case A_SHOT:
            if (!s->waiting) {
                s->waiting = true;
                snprintf(v->shot_path, sizeof v->shot_path, "%s", a->a);
                v->shot_frame = v->run ? sq_run_frame_index(v->run) : 1;
                if (v->shot_frame < 1) v->shot_frame = 1;
                v->shot_pending = true;
                v->shot_as_shown = false; /* full size, also while the view moves */
                v->redraw = true;
            }
            if (v->shot_pending) return;
            if (v->exit_code) {
                v->quit = true;
                return;
            }
            break;
        case A_SAVE: {
            const sq_result r = view_save_scene(v, a->a);
            if (r != SQ_OK) {
                script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                return;
            }
            break;
        }
        case A_KEYS: {
            static char buf[65536];
            view_panel_keys(v, a->b, buf, sizeof buf);
            const sq_result r = sq_output_write_file(a->a, buf, strlen(buf), v->overwrite);
            if (r != SQ_OK) {
                script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                return;
            }
            break;
        }
        case A_REC:
        case A_REC_STOP: {
            gtk_gl_area_make_current(GTK_GL_AREA(v->area));
            const sq_result r = a->kind == A_REC ? view_record_start(v, a->a) : view_record_stop(v);
            if (r != SQ_OK) {
                script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                return;
            }
            break;
        }
        case A_KEYFRAME: {
            if (!s->waiting) {
                int index = 0;
                double t = 0.0;
                const sq_result r = view_keyframe_add(v, &index, &t);
                if (r != SQ_OK) {
                    script_fail(v, s, a->line, sq_cli_exit_code(r), sq_last_error());
                    return;
                }
                printf("keyframe %d at t = %.6g s\n", index, t);
                fflush(stdout);
                s->waiting = true; /* until the running scene has the path */
            }
            if (v->live_pending) return;
            if (v->live_outcome == VIEW_LIVE_REFUSED) {
                script_fail(v, s, a->line, SQ_EXIT_USAGE, v->live_message);
                return;
            }
            break;
        }
        case A_TIME:
            printf("time: frame %d, simulated %.6g s\n", st.frames - 1, st.sim_time_s);
            fflush(stdout);
            break;
        case A_PAUSE: view_sim_set_paused(v->sim, true); break;
        case A_RUN: view_sim_set_paused(v->sim, false); break;
        case A_STEP: view_sim_single_step(v->sim); break;
        case A_QUIT: v->quit = true; return;
        }
        s->waiting = false;
        s->next++;
    }
    if (s->next >= s->count && !v->quit) {
        if (v->live_pending) return; /* the changes sent: their results */
        if (!refused_since(v, s, s->count ? s->acts[s->count - 1].line : 0)) v->quit = true;
    }
}
