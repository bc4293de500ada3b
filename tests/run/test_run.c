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

SQ_LABEL(unit)

#include "run_fixture.h"

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

