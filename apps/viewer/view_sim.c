/* view_sim.c — the simulation thread of `squall view` (see view_sim.h). */
#include "view_sim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "squall/io.h"

struct view_sim {
    sq_run *run;
    thrd_t thread;
    bool started;
    bool exited;         /* the thread has returned (under lock) */
    mtx_t lock;
    cnd_t wake;
    bool quit;
    int steps_requested; /* single steps asked for while paused */
    double frame_wall_s; /* 1 / fps: wall seconds per frame at speed 1 */
    int steps_per_frame;
    view_sim_stats st;   /* under lock */
    /* steps/s over a sliding window: frames and wall time at the window's start */
    double window_t0;
    int window_f0;
    /* live changes: the requests waiting for the thread, the results for the UI (rings), the
     * changes requested whose result was not read yet, and what the thread applies them to */
    struct live_req {
        char assignment[1400];
        sq_cfg *whole;     /* owned; NULL: the assignment on run_cfg */
        double t_request;
    } req[VIEW_LIVE_QUEUE], batch[VIEW_LIVE_QUEUE];
    int req_head, req_count;
    view_live_result res[VIEW_LIVE_QUEUE], batch_res[VIEW_LIVE_QUEUE];
    int res_head, res_count;
    int outstanding;
    sq_context *ctx;
    sq_cfg *run_cfg;           /* the scene as the run has it now (the thread's) */
    sq_scene_desc base;        /* loaders; cfg replaced */
};

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

static sq_result on_metrics(void *user, int frame, double time_s, const sq_metric *m, int count)
{
    (void)frame;
    view_sim *s = (view_sim *)user;
    mtx_lock(&s->lock);
    const int n = count < VIEW_SIM_MAX_METRICS ? count : VIEW_SIM_MAX_METRICS;
    for (int i = 0; i < n; i++) {
        snprintf(s->st.metrics[i].name, sizeof s->st.metrics[i].name, "%s", m[i].name);
        snprintf(s->st.metrics[i].unit, sizeof s->st.metrics[i].unit, "%s",
                 m[i].unit ? m[i].unit : "");
        s->st.metrics[i].value = m[i].value;
    }
    s->st.metric_count = n;
    s->st.sim_time_s = time_s;
    mtx_unlock(&s->lock);
    return SQ_OK;
}

view_sim *view_sim_create(int fps, int steps_per_frame)
{
    view_sim *s = (view_sim *)calloc(1, sizeof *s);
    if (!s) return NULL;
    if (mtx_init(&s->lock, mtx_plain) != thrd_success) {
        free(s);
        return NULL;
    }
    if (cnd_init(&s->wake) != thrd_success) {
        mtx_destroy(&s->lock);
        free(s);
        return NULL;
    }
    s->frame_wall_s = 1.0 / (fps > 0 ? fps : 24);
    s->steps_per_frame = steps_per_frame > 0 ? steps_per_frame : 1;
    s->st.speed = 1.0;
    s->st.steps_per_frame = s->steps_per_frame;
    return s;
}

sq_run_sinks view_sim_sinks(view_sim *s)
{
    sq_run_sinks k;
    memset(&k, 0, sizeof k);
    k.metrics = on_metrics;
    k.user = s;
    return k;
}

/* Sleeps on the condition until t (sq_time_now seconds) or a wake-up; lock held. */
static void wait_until(view_sim *s, double t)
{
    const double now = sq_time_now();
    if (t <= now) return;
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    const double dt = t - now;
    ts.tv_sec += (time_t)dt;
    ts.tv_nsec += (long)((dt - floor(dt)) * 1e9);
    if (ts.tv_nsec >= 1000000000L) {
        ts.tv_sec++;
        ts.tv_nsec -= 1000000000L;
    }
    cnd_timedwait(&s->wake, &s->lock, &ts);
}

/* run_cfg with one more assignment, as a new configuration (NULL with the message in *out). */
static sq_cfg *edited_cfg(view_sim *s, const char *assignment, view_live_result *out)
{
    char *yaml = sq_cfg_to_yaml(s->run_cfg);
    sq_cfg *copy = NULL;
    sq_result r = yaml ? sq_cfg_parse(s->ctx, yaml, strlen(yaml), s->run_cfg->source, &copy)
                       : sq_set_error(SQ_ERR_OUT_OF_MEMORY, "view: cannot copy the scene");
    free(yaml);
    if (r == SQ_OK) {
        snprintf(copy->base_dir, sizeof copy->base_dir, "%s", s->run_cfg->base_dir);
        r = sq_cfg_set(copy, assignment);
    }
    if (r != SQ_OK) {
        const char *e = sq_last_error(); /* thread-local: read it on this thread */
        out->r = r;
        snprintf(out->error, sizeof out->error, "%s", e && *e ? e : sq_result_name(r));
        sq_cfg_destroy(copy);
        return NULL;
    }
    return copy;
}

/* Applies the waiting live changes in order (lock held on entry and exit, released while
 * applying); their results are published together, so that the UI sees a whole batch. */
static void apply_live(view_sim *s)
{
    const int n = s->req_count;
    for (int k = 0; k < n; k++) s->batch[k] = s->req[(s->req_head + k) % VIEW_LIVE_QUEUE];
    s->req_head = (s->req_head + n) % VIEW_LIVE_QUEUE;
    s->req_count = 0;
    mtx_unlock(&s->lock);
    bool rebuild = false;
    for (int k = 0; k < n; k++) {
        struct live_req *q = &s->batch[k];
        view_live_result *out = &s->batch_res[k];
        memset(out, 0, sizeof *out);
        snprintf(out->assignment, sizeof out->assignment, "%s", q->assignment);
        out->whole = q->whole != NULL;
        out->t_request_s = q->t_request;
        if (rebuild) {
            out->dropped = true;
            sq_cfg_destroy(q->whole);
            continue;
        }
        sq_cfg *c = q->whole ? q->whole : edited_cfg(s, q->assignment, out);
        if (c) {
            sq_scene_desc d = s->base;
            d.cfg = c;
            out->r = sq_run_apply_live(s->run, &d, &out->res);
            if (out->r != SQ_OK) {
                const char *e = sq_last_error(); /* thread-local: read it on this thread */
                snprintf(out->error, sizeof out->error, "%s", e && *e ? e : sq_result_name(out->r));
            }
            if (out->r == SQ_OK && !out->res.rebuild) { /* the scene as the run has it now */
                sq_cfg_destroy(s->run_cfg);
                s->run_cfg = c;
            } else {
                sq_cfg_destroy(c);
            }
            rebuild = out->r == SQ_OK && out->res.rebuild;
        }
        out->frame = sq_run_frame_index(s->run);
        out->t_applied_s = sq_time_now();
    }
    mtx_lock(&s->lock);
    for (int k = 0; k < n; k++) {
        s->res[(s->res_head + s->res_count) % VIEW_LIVE_QUEUE] = s->batch_res[k];
        s->res_count++;
    }
}

static int sim_main(void *arg)
{
    view_sim *s = (view_sim *)arg;
    double next_due = sq_time_now();
    mtx_lock(&s->lock);
    for (;;) {
        if (s->quit) break;
        if (s->req_count > 0 && s->st.frames > 0) {
            apply_live(s); /* between two advances, before the next is due */
            continue;
        }
        const bool can = !s->st.done && !s->st.error[0];
        const bool first = s->st.frames == 0;
        const bool go = can && (first || !s->st.paused || s->steps_requested > 0);
        if (!go) {
            cnd_wait(&s->wake, &s->lock);
            next_due = sq_time_now();
            continue;
        }
        if (!first && !s->st.paused && sq_time_now() < next_due) {
            wait_until(s, next_due); /* at the scene's time scale, or woken by a change */
            continue;
        }
        const bool single = s->st.paused && s->steps_requested > 0;
        if (single) s->steps_requested--;
        s->st.busy = true;
        mtx_unlock(&s->lock);
        const double t_start = sq_time_now();

        const sq_result r = sq_run_advance(s->run); /* the step: no lock held */
        char err[512] = "";
        if (r != SQ_OK) {
            const char *e = sq_last_error(); /* thread-local: read it on this thread */
            snprintf(err, sizeof err, "%s", e && *e ? e : sq_result_name(r));
        }
        const double now = sq_time_now();

        mtx_lock(&s->lock);
        s->st.busy = false;
        if (r != SQ_OK) {
            snprintf(s->st.error, sizeof s->st.error, "%s", err);
            s->st.paused = true;
        } else {
            s->st.frames = sq_run_frame_index(s->run);
            s->st.done = sq_run_done(s->run);
            if (s->st.frames == 1) s->st.t_frame0_s = now;
            else s->st.busy_s += now - t_start;
            s->st.t_last_s = now;
        }
        if (s->st.frames == 1 || s->window_t0 == 0.0) {
            /* the warm-up frame is not counted in the rate */
            s->window_t0 = now;
            s->window_f0 = s->st.frames;
        } else if (now - s->window_t0 >= 1.0) {
            s->st.steps_per_s =
                (double)(s->st.frames - s->window_f0) * s->steps_per_frame / (now - s->window_t0);
            s->window_t0 = now;
            s->window_f0 = s->st.frames;
        }
        /* the next frame is due one frame of wall time (at this speed) after this one was; a
         * simulation slower than that runs as fast as it can without catching up bursts */
        next_due += s->frame_wall_s / s->st.speed;
        if (next_due < now) next_due = now;
    }
    s->exited = true;
    mtx_unlock(&s->lock);
    return 0;
}

void view_sim_stop(view_sim *s)
{
    if (!s) return;
    mtx_lock(&s->lock);
    s->quit = true;
    cnd_broadcast(&s->wake);
    mtx_unlock(&s->lock);
}

bool view_sim_stopped(view_sim *s)
{
    if (!s || !s->started) return true;
    mtx_lock(&s->lock);
    const bool e = s->exited;
    mtx_unlock(&s->lock);
    return e;
}

bool view_sim_start(view_sim *s, sq_run *run, bool paused)
{
    s->run = run;
    s->st.paused = paused;
    s->st.frame_count = sq_run_frame_count(run);
    if (thrd_create(&s->thread, sim_main, s) != thrd_success) return false;
    s->started = true;
    return true;
}

void view_sim_destroy(view_sim *s)
{
    if (!s) return;
    if (s->started) {
        mtx_lock(&s->lock);
        s->quit = true;
        cnd_broadcast(&s->wake);
        mtx_unlock(&s->lock);
        thrd_join(s->thread, NULL);
    }
    for (int k = 0; k < s->req_count; k++)
        sq_cfg_destroy(s->req[(s->req_head + k) % VIEW_LIVE_QUEUE].whole);
    sq_cfg_destroy(s->run_cfg);
    cnd_destroy(&s->wake);
    mtx_destroy(&s->lock);
    free(s);
}

void view_sim_set_scene(view_sim *s, sq_context *ctx, sq_cfg *run_cfg, const sq_scene_desc *base)
{
    s->ctx = ctx;
    sq_cfg_destroy(s->run_cfg);
    s->run_cfg = run_cfg;
    s->base = *base;
    s->base.cfg = NULL;
}

bool view_sim_request_live(view_sim *s, const char *assignment, sq_cfg *whole)
{
    mtx_lock(&s->lock);
    const bool room = s->outstanding < VIEW_LIVE_QUEUE && (whole || s->run_cfg);
    if (room) {
        struct live_req *q = &s->req[(s->req_head + s->req_count) % VIEW_LIVE_QUEUE];
        snprintf(q->assignment, sizeof q->assignment, "%s", assignment);
        q->whole = whole;
        q->t_request = sq_time_now();
        s->req_count++;
        s->outstanding++;
        cnd_broadcast(&s->wake);
    }
    mtx_unlock(&s->lock);
    if (!room) sq_cfg_destroy(whole);
    return room;
}

bool view_sim_live_result(view_sim *s, view_live_result *out)
{
    mtx_lock(&s->lock);
    const bool any = s->res_count > 0;
    if (any) {
        *out = s->res[s->res_head];
        s->res_head = (s->res_head + 1) % VIEW_LIVE_QUEUE;
        s->res_count--;
        s->outstanding--;
    }
    mtx_unlock(&s->lock);
    return any;
}

void view_sim_set_paused(view_sim *s, bool paused)
{
    mtx_lock(&s->lock);
    s->st.paused = paused;
    if (!paused) s->steps_requested = 0;
    cnd_broadcast(&s->wake);
    mtx_unlock(&s->lock);
}

void view_sim_toggle_pause(view_sim *s)
{
    mtx_lock(&s->lock);
    const bool p = !s->st.paused;
    mtx_unlock(&s->lock);
    view_sim_set_paused(s, p);
}

void view_sim_single_step(view_sim *s)
{
    mtx_lock(&s->lock);
    s->st.paused = true;
    s->steps_requested++;
    cnd_broadcast(&s->wake);
    mtx_unlock(&s->lock);
}

void view_sim_set_speed(view_sim *s, double speed)
{
    mtx_lock(&s->lock);
    s->st.speed = clampd(speed, 1.0 / 64.0, 64.0);
    cnd_broadcast(&s->wake);
    mtx_unlock(&s->lock);
}

double view_sim_speed(view_sim *s)
{
    mtx_lock(&s->lock);
    const double v = s->st.speed;
    mtx_unlock(&s->lock);
    return v;
}

void view_sim_stats_get(view_sim *s, view_sim_stats *out)
{
    mtx_lock(&s->lock);
    *out = s->st;
    mtx_unlock(&s->lock);
}
