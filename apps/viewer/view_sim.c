/* view_sim.c — the simulation thread of `squall view` (see view_sim.h). */
#include "view_sim.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct view_sim {
    sq_run *run;
    thrd_t thread;
    bool started;
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
    /* live change: the request waiting for the thread, and the result for the UI */
    bool live_req;
    sq_scene_desc live_desc;   /* cfg owned */
    double live_t_request;
    bool live_done;
    view_live_result live;
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

/* Applies the waiting live request (lock held on entry and exit, released while applying). */
static void apply_live(view_sim *s)
{
    sq_scene_desc d = s->live_desc;
    const double t_req = s->live_t_request;
    s->live_req = false;
    memset(&s->live_desc, 0, sizeof s->live_desc);
    mtx_unlock(&s->lock);
    view_live_result out;
    memset(&out, 0, sizeof out);
    out.r = sq_run_apply_live(s->run, &d, &out.res);
    if (out.r != SQ_OK) {
        const char *e = sq_last_error(); /* thread-local: read it on this thread */
        snprintf(out.error, sizeof out.error, "%s", e && *e ? e : sq_result_name(out.r));
    }
    out.frame = sq_run_frame_index(s->run);
    out.t_request_s = t_req;
    out.t_applied_s = sq_time_now();
    sq_cfg_destroy((sq_cfg *)d.cfg);
    mtx_lock(&s->lock);
    s->live = out;
    s->live_done = true;
}

static int sim_main(void *arg)
{
    view_sim *s = (view_sim *)arg;
    double next_due = sq_time_now();
    mtx_lock(&s->lock);
    for (;;) {
        if (s->quit) break;
        if (s->live_req && s->st.frames > 0) {
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
    mtx_unlock(&s->lock);
    return 0;
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
    sq_cfg_destroy((sq_cfg *)s->live_desc.cfg);
    cnd_destroy(&s->wake);
    mtx_destroy(&s->lock);
    free(s);
}

void view_sim_request_live(view_sim *s, const sq_scene_desc *desc)
{
    mtx_lock(&s->lock);
    sq_cfg_destroy((sq_cfg *)s->live_desc.cfg); /* a request not yet taken is replaced */
    s->live_desc = *desc;
    s->live_req = true;
    s->live_done = false;
    s->live_t_request = sq_time_now();
    cnd_broadcast(&s->wake);
    mtx_unlock(&s->lock);
}

bool view_sim_live_result(view_sim *s, view_live_result *out)
{
    mtx_lock(&s->lock);
    const bool done = s->live_done;
    if (done) {
        *out = s->live;
        s->live_done = false;
    }
    mtx_unlock(&s->lock);
    return done;
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
