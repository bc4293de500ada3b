/* test_run_gl.c — the frame loop pumped with the simulation on another thread than the
 * drawing (squall/run.h, snapshot mode): frames arrive in order, and the last frame drawn
 * concurrently is byte for byte the last frame of a plain sequential run of the same scene (the
 * drawing side only ever sees consistent copies). */
#include <stdio.h>
#include <threads.h>

#include "run_fixture.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

typedef struct sim_thread {
    sq_run *run;
    sq_result result;
} sim_thread;

static int simulate_all(void *arg)
{
    sim_thread *t = (sim_thread *)arg;
    t->result = SQ_OK;
    while (t->result == SQ_OK && !sq_run_done(t->run)) t->result = sq_run_advance(t->run);
    return 0;
}

SQ_TEST(pumped_on_two_threads)
{
    sq_context *ctx = mkctx();
    sq_scene *s1 = mkscene(ctx, NULL), *s2 = mkscene(ctx, NULL);
    sink_log seq = {.last_frame = -1}, par = {.last_frame = -1};
    sq_run *r1 = NULL, *r2 = NULL;
    sq_run_desc rd = {0};
    rd.scene = s1;
    rd.render = SQ_RUN_GL;
    rd.sinks = (sq_run_sinks){on_frame, NULL, NULL, &seq};
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &r1));
    if (!r1) goto done;
    SQ_CHECK_OK(sq_run_execute(r1));
    SQ_CHECK(seq.frames_seen == FRAMES && seq.last_frame == FRAMES - 1);

    rd.scene = s2;
    rd.snapshot = true;
    rd.sinks = (sq_run_sinks){on_frame, NULL, NULL, &par};
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &r2));
    if (!r2) goto done;
    SQ_CHECK(sq_run_draw(r2) == SQ_ERR_INVALID_ARG); /* nothing advanced yet */
    sim_thread st = {r2, SQ_OK};
    thrd_t th;
    SQ_CHECK(thrd_create(&th, simulate_all, &st) == thrd_success);
    int drawn = 0;
    for (;;) { /* draw whatever frame is newest, until the last one is drawn */
        const bool done = sq_run_done(r2);
        if (sq_run_frame_index(r2) > 0 && par.last_frame < sq_run_frame_index(r2) - 1) {
            SQ_CHECK_OK(sq_run_draw(r2));
            drawn++;
        } else if (done) {
            break;
        } else {
            thrd_yield();
        }
    }
    thrd_join(th, NULL);
    SQ_CHECK_OK(st.result);
    printf("concurrent: %d of %d frames drawn, last %d\n", drawn, FRAMES, par.last_frame);
    SQ_CHECK(par.last_frame == FRAMES - 1 && drawn >= 1);
    SQ_CHECK(seq.last_rgba && par.last_rgba &&
             memcmp(seq.last_rgba, par.last_rgba, 64 * 36 * 4) == 0);
    if (SQ_HAVE_SANDSTORM) { /* the dust is in the picture: not a blank frame */
        long sum = 0;
        for (int i = 0; seq.last_rgba && i < 64 * 36 * 4; i++) sum += seq.last_rgba[i];
        SQ_CHECK(sum > 0);
    }
done:
    free(seq.last_rgba);
    free(par.last_rgba);
    sq_run_destroy(r1);
    sq_run_destroy(r2);
    sq_scene_destroy(s1);
    sq_scene_destroy(s2);
    sq_context_destroy(ctx);
}

/* Ctrl-C that reaches the renderer inside a frame (it polls between its passes and parts) ends
 * the run as one between frames does: SQ_ERR_CANCELLED with the run's message naming the frame,
 * and the frame is not delivered. */
typedef struct armed_poll {
    bool armed;
    int calls, stop_at;
} armed_poll;

static bool poll_when_armed(void *user)
{
    armed_poll *a = (armed_poll *)user;
    if (!a->armed) return false;
    return ++a->calls >= a->stop_at;
}

/* Which callback asks to stop: the context's interrupt (Ctrl-C in the CLI) or the run's own
 * cancel (sq_run_desc.cancel, an embedding application's stop button). */
typedef enum stop_source { STOP_BY_CONTEXT, STOP_BY_RUN } stop_source;

static void check_stop_inside_a_frame(stop_source by)
{
    armed_poll ap = {false, 0, 4};
    sq_context_desc cd = {0};
    cd.threads = 1;
    cd.log_level = SQ_LOG_NONE;
    if (by == STOP_BY_CONTEXT) {
        cd.interrupt = poll_when_armed;
        cd.interrupt_user = &ap;
    }
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_scene *s = mkscene(ctx, NULL);
    sink_log log = {.last_frame = -1};
    sq_run_desc rd = {0};
    rd.scene = s;
    rd.render = SQ_RUN_GL;
    rd.sinks = (sq_run_sinks){on_frame, NULL, NULL, &log};
    if (by == STOP_BY_RUN) {
        rd.user = &ap;
        rd.cancel = poll_when_armed;
    }
    sq_run *run = NULL;
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &run));
    if (!run) goto done;
    SQ_CHECK_OK(sq_run_advance(run));
    SQ_CHECK_OK(sq_run_draw(run));
    SQ_CHECK_OK(sq_run_advance(run));
    ap.armed = true; /* the run's own check before drawing is poll 1: poll 4 is inside the frame */
    SQ_CHECK_ERR(sq_run_draw(run), SQ_ERR_CANCELLED, "interrupted at frame 2 of");
    SQ_CHECK_MSG(ap.calls == ap.stop_at, "polled %d times after arming; stop asked at %d",
                 ap.calls, ap.stop_at);
    SQ_CHECK_MSG(log.frames_seen == 1, "%d frames delivered; the interrupted one must not be",
                 log.frames_seen);
done:
    free(log.last_rgba);
    sq_run_destroy(run);
    sq_scene_destroy(s);
    sq_context_destroy(ctx);
}

SQ_TEST(interrupt_inside_a_frame_ends_the_run_as_between_frames)
{
    check_stop_inside_a_frame(STOP_BY_CONTEXT);
}

/* The run's own cancel callback reaches the renderer inside a frame as the context's interrupt
 * does. */
SQ_TEST(run_cancel_reaches_inside_a_frame)
{
    check_stop_inside_a_frame(STOP_BY_RUN);
}
