/* test_run.c — the frame loop module (squall/run.h): the clock (warm-up, frame times), sinks,
 * metric statistics, output safety (existing files, temporaries removed on interruption), and
 * the pumped mode with the simulation on another thread than the drawing: every frame the
 * drawing side sees is a consistent copy, so the last frame drawn concurrently is byte for byte
 * the last frame of a plain sequential run. */
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <threads.h>
#include <unistd.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/run.h"
#include "squall/scene.h"

SQ_LABEL(unit)

#define FRAMES 6

static sq_context *mkctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 1; /* bit-reproducible */
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* A small desert sandstorm with dust flowing in (or no layer when no sandstorm is built). */
static sq_scene *mkscene(sq_context *ctx, const char *extra_output)
{
    char text[2048];
    snprintf(text, sizeof text,
             "name: run-test\n"
             "world:\n"
             "  terrain: {kind: flat, size_m: [2000, 2000], resolution: [33, 33]}\n"
             "camera: {position: [0, -900, 60], target: [0, 0, 60]}\n"
             "%s"
             "output: {width: 64, height: 36, fps: 4, frames: %d, warmup_s: 1.5%s%s}\n",
             SQ_HAVE_SANDSTORM ? "layers:\n"
                                 "  - type: sandstorm\n"
                                 "    domain: {nx: 12, ny: 12, nz: 6, cell_size_m: 100}\n"
                                 "    dust: {bins: 1, inflow_kg_m3: 0.002}\n"
                               : "",
             FRAMES, extra_output ? ", " : "", extra_output ? extra_output : "");
    sq_cfg *cfg = NULL;
    SQ_CHECK_OK(sq_cfg_parse(ctx, text, strlen(text), "run.yaml", &cfg));
    if (!cfg) return NULL;
    sq_scene_desc sd = {.cfg = cfg};
    sq_scene *s = NULL;
    SQ_CHECK_OK(sq_scene_create(ctx, &sd, &s));
    sq_cfg_destroy(cfg);
    return s;
}

typedef struct sink_log {
    int metric_rows, field_sets, frames_seen;
    double times[FRAMES + 4];
    int last_frame;
    uint8_t *last_rgba;
    int stop_after; /* cancel once this many metric rows arrived (0 = never) */
} sink_log;

static sq_result on_metrics(void *user, int frame, double t, const sq_metric *m, int n)
{
    sink_log *l = (sink_log *)user;
    if (frame < FRAMES + 4) l->times[frame] = t;
    l->metric_rows++;
    (void)m;
    (void)n;
    return SQ_OK;
}

static sq_result on_fields(void *user, int frame, double t, const sq_named_field *f, int n)
{
    sink_log *l = (sink_log *)user;
    l->field_sets++;
    (void)frame;
    (void)t;
    for (int i = 0; i < n; i++)
        if (!f[i].name || !f[i].units || !f[i].data) return sq_set_error(SQ_ERR_INTERNAL, "bad field");
    return SQ_OK;
}

static sq_result on_frame(void *user, const sq_run_frame *f)
{
    sink_log *l = (sink_log *)user;
    if (f->index < l->last_frame) return sq_set_error(SQ_ERR_INTERNAL, "frames out of order");
    l->last_frame = f->index;
    l->frames_seen++;
    free(l->last_rgba);
    l->last_rgba = malloc((size_t)f->width * f->height * 4);
    if (l->last_rgba) memcpy(l->last_rgba, f->rgba, (size_t)f->width * f->height * 4);
    return SQ_OK;
}

static bool cancel_when(void *user)
{
    const sink_log *l = (const sink_log *)user;
    return l->stop_after > 0 && l->metric_rows >= l->stop_after;
}

/* Simulate: frame k is at warm-up + k frame steps; sinks see every frame; statistics agree. */
SQ_TEST(simulate_clock_and_sinks)
{
    sq_context *ctx = mkctx();
    sq_scene *s = mkscene(ctx, NULL);
    sink_log log = {0};
    sq_run_desc rd = {0};
    rd.scene = s;
    rd.render = SQ_RUN_SIMULATE;
    rd.sinks = (sq_run_sinks){NULL, on_metrics, on_fields, &log};
    sq_run *run = NULL;
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &run));
    if (!run) goto done;
    SQ_CHECK(sq_run_frame_count(run) == FRAMES && !sq_run_done(run));
    SQ_CHECK(sq_run_draw(run) == SQ_ERR_INVALID_ARG); /* no frames in a simulation */
    SQ_CHECK_OK(sq_run_execute(run));
    SQ_CHECK(sq_run_done(run) && sq_run_frame_index(run) == FRAMES);
    SQ_CHECK(sq_run_advance(run) == SQ_ERR_INVALID_ARG); /* past the end */
    SQ_CHECK_OK(sq_run_finish(run));
    SQ_CHECK(log.metric_rows == FRAMES && log.field_sets == FRAMES);
    const double frame_dt = sq_scene_frame_dt(s); /* time_scale 1 / fps 4 */
    SQ_CHECK_NEAR(frame_dt, 0.25, 1e-12);
    for (int k = 0; k < FRAMES; k++) SQ_CHECK_NEAR(log.times[k], 1.5 + k * frame_dt, 1e-9);
    SQ_CHECK_NEAR(sq_scene_time(s), 1.5 + (FRAMES - 1) * frame_dt, 1e-9);
    if (SQ_HAVE_SANDSTORM) {
        SQ_CHECK(sq_run_metric_count(run) > 0);
        for (int i = 0; i < sq_run_metric_count(run); i++) {
            sq_run_metric_stats st;
            SQ_CHECK_OK(sq_run_metric_stats_get(run, i, &st));
            if (st.count > 0) SQ_CHECK(st.min <= st.median && st.median <= st.max &&
                                       st.min <= st.mean && st.mean <= st.max);
        }
    }
done:
    sq_run_destroy(run);
    sq_scene_destroy(s);
    sq_context_destroy(ctx);
}

/* Counts the files in dir whose name contains part. */
static int count_files(const char *dir, const char *part)
{
    DIR *d = opendir(dir);
    if (!d) return -1;
    int n = 0;
    for (struct dirent *e; (e = readdir(d));) n += strstr(e->d_name, part) != NULL;
    closedir(d);
    return n;
}

/* An existing output is refused before any work and left as it was; an interrupted run leaves
 * neither the final file nor a temporary. */
SQ_TEST(output_safety_and_interruption)
{
    sq_context *ctx = mkctx();
    char dir[] = "/tmp/sq_run_test_XXXXXX";
    SQ_CHECK(mkdtemp(dir) != NULL);
    char metrics[256], opt[400];
    snprintf(metrics, sizeof metrics, "%s/m.csv", dir);
    FILE *f = fopen(metrics, "w");
    fputs("precious\n", f);
    fclose(f);
    snprintf(opt, sizeof opt, "metrics: %s", metrics);
    sq_scene *s = mkscene(ctx, opt);
    sink_log log = {0};
    sq_run_desc rd = {0};
    rd.scene = s;
    rd.render = SQ_RUN_SIMULATE;
    rd.write_outputs = true;
    rd.sinks = (sq_run_sinks){NULL, on_metrics, NULL, &log};
    rd.cancel = cancel_when;
    rd.user = &log;
    sq_run *run = NULL;
    SQ_CHECK(sq_run_create(ctx, &rd, &run) == SQ_ERR_EXISTS && run == NULL);
    char buf[32] = {0};
    f = fopen(metrics, "r");
    SQ_CHECK(f && fgets(buf, sizeof buf, f) && strcmp(buf, "precious\n") == 0);
    if (f) fclose(f);
    SQ_CHECK(log.metric_rows == 0); /* refused before any work */
    remove(metrics);

    log.stop_after = 2;
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &run));
    const sq_result r = run ? sq_run_execute(run) : SQ_OK;
    SQ_CHECK(r == SQ_ERR_CANCELLED);
    SQ_CHECK(strstr(sq_last_error(), "interrupted at frame 2 of 6") != NULL);
    /* issue 17: the rows so far are kept as a complete, clearly named partial file (and the
     * message says where); nothing else, no temporary, no final name */
    char partial[300];
    snprintf(partial, sizeof partial, "%s/m.partial.csv", dir);
    SQ_CHECK(strstr(sq_last_error(), "m.partial.csv") != NULL);
    SQ_CHECK(count_files(dir, ".tmp") == 0);
    sq_run_destroy(run);
    SQ_CHECK(count_files(dir, ".tmp") == 0);
    SQ_CHECK(access(metrics, F_OK) != 0);
    int partial_lines = 0;
    f = fopen(partial, "r");
    for (int c; f && (c = fgetc(f)) != EOF;) partial_lines += c == '\n';
    if (f) fclose(f);
    SQ_CHECK_MSG(partial_lines == 3, "%s has %d lines; a header and 2 rows expected", partial,
                 partial_lines);
    remove(partial);

    /* finished: the file appears under its final name with a header and one row per frame */
    log.stop_after = 0;
    run = NULL;
    SQ_CHECK_OK(sq_run_create(ctx, &rd, &run));
    if (run) {
        SQ_CHECK_OK(sq_run_execute(run));
        SQ_CHECK_OK(sq_run_finish(run));
        sq_run_destroy(run);
    }
    int lines = 0;
    f = fopen(metrics, "r");
    for (int c; f && (c = fgetc(f)) != EOF;) lines += c == '\n';
    if (f) fclose(f);
    SQ_CHECK(lines == FRAMES + 1);
    remove(metrics);
    rmdir(dir);
    sq_scene_destroy(s);
    sq_context_destroy(ctx);
}

#if SQ_HAVE_GL
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

/* The renderer pumped by the main thread while another thread advances the simulation
 * (snapshot mode): frames arrive in order, and the last one is byte-identical to the last
 * frame of a sequential run of the same scene. */
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
#endif
