/* bench_clouds.c — `squall bench clouds`: the clouds phenomenon (SPEC §8, S4) on an analytic
 * cumulus field over flat ground, rendered by the GL renderer at --width x --height (640 x 360).
 * Three measurements (--only frame|table|impostor):
 *   frame     --particles (15 000) lit and drawn, plain and structured: per frame the model step
 *             (field, clouds, particles, clustering: ms_model), the light (MFS sweeps, shadow map:
 *             ms_light = a frame after a step minus the same frame again, whose light is cached),
 *             the draw with read-back (ms_draw, the cached frame) and their sum ms_per_frame;
 *             ms_base is the same frame without clouds (sky, terrain, tone mapping, read-back),
 *             drawn right after each cloud frame; ms_clouds = model + light + draw - base, the
 *             clouds' share of a frame (median of the pairs), cpu_ms_clouds the same in process
 *             CPU time (all threads, llvmpipe's included: less sensitive to a shared machine);
 *   table     S4 Table 1: plain vs structured particle system at 2 600, 4 100, 7 800, 10 500 and
 *             13 000 particles, whole frames (model + light + draw), fps and the speed-up per row
 *             next to S4's published fps;
 *   impostor  a distant field (20 cumuli 150 km away, beyond dist_impostor): the cloud pass's
 *             cost (frame minus the base frame drawn right after it; medians of the pairs, the
 *             impostors' mean too, which includes their refreshes) with impostors and with
 *             particles only, the camera turning 0.02 degree per frame (impostors re-rendered
 *             as they go stale; impostor_renders counts those re-renders in the timed frames,
 *             so that a mean above the median can be told from the machine's noise).
 * Medians over --reps frames after --warmup frames. JSON lines. */
#include <math.h>
#include <stdio.h>
#include <sys/resource.h>
#include <stdlib.h>
#include <string.h>

#include "cases.h"
#include "squall/clouds.h"
#include "squall/render.h"
#include "squall/world.h"

typedef struct bench {
    sq_context *ctx;
    sq_world *w;
    sq_renderer *r;
    sq_render_info info;
    uint8_t *rgba;
    sq_camera cam;
    int width, height;
    const sq_bench_args *a;
} bench;

/* CPU time of the process (all threads: llvmpipe's rasteriser threads included), ms. */
static double cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * ((double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec) +
           1e-3 * ((double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_usec);
}

/* draw + read back (the read waits for the frame); wall ms, or -1 on error; *cpu (if set) the
 * process CPU ms of the frame */
static double timed_frame_cpu(bench *b, const sq_drawable *d, int n, double *cpu)
{
    const double c0 = cpu_ms(), t0 = sq_time_now();
    if (sq_renderer_draw(b->r, b->w, &b->cam, d, n, 0.0) != SQ_OK) return -1.0;
    if (sq_renderer_read_rgba8(b->r, b->rgba) != SQ_OK) return -1.0;
    const double t = (sq_time_now() - t0) * 1e3;
    if (cpu) *cpu = cpu_ms() - c0;
    return t;
}

static double timed_frame(bench *b, const sq_drawable *d, int n)
{
    return timed_frame_cpu(b, d, n, NULL);
}

static sq_result make_clouds(bench *b, int particles, bool plain, int clouds, double size_m,
                             bool impostors, sq_clouds **out)
{
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_CUMULUS;
    d.particles = particles;
    d.plain = plain;
    d.synthetic_clouds = clouds;
    d.synthetic_size_m[0] = d.synthetic_size_m[1] = size_m;
    d.synthetic_cells[0] = d.synthetic_cells[1] = (int)(size_m / 250.0);
    d.no_impostors = !impostors;
    d.seed = 2013;
    return sq_clouds_create(b->ctx, &d, b->w, out);
}

typedef struct frame_times {
    double model, light, draw, base, total, clouds, cpu_clouds;
    int clusters, particles;
} frame_times;

/* reps frames of: step, frame (relight), frame again (cached light), the frame without clouds
 * (base). The base frame is drawn next to each cloud frame, so that the clouds' share of a
 * frame (model + light + draw - base) is a difference of frames a moment apart: the load of a
 * shared machine drifts between them far less than over a whole run. */
static sq_result run_frames(bench *b, sq_clouds *c, int warmup, int reps, frame_times *out)
{
    double *m = malloc(sizeof(double) * (size_t)reps * 7);
    if (!m) return SQ_ERR_OUT_OF_MEMORY;
    double *ml = m + reps, *md = m + 2 * reps, *mt = m + 3 * reps, *mb = m + 4 * reps;
    double *mc = m + 5 * reps, *mcpu = m + 6 * reps;
    sq_result res = SQ_OK;
    for (int k = -warmup; k < reps && res == SQ_OK; k++) {
        const double cpu0 = cpu_ms();
        if ((res = sq_clouds_step(c, 60.0)) != SQ_OK) break;
        const double cpu_model = cpu_ms() - cpu0;
        sq_clouds_stats st;
        sq_clouds_stats_get(c, &st);
        sq_drawable d;
        if ((res = sq_clouds_drawable(c, &d)) != SQ_OK) break;
        double c1 = 0.0, cb = 0.0;
        const double t1 = timed_frame_cpu(b, &d, 1, &c1), t2 = timed_frame(b, &d, 1);
        const double tb = timed_frame_cpu(b, NULL, 0, &cb);
        if (t1 < 0.0 || t2 < 0.0 || tb < 0.0) {
            res = SQ_ERR_GL;
            break;
        }
        if (k < 0) continue;
        m[k] = st.ms_model;
        ml[k] = t1 - t2 > 0.0 ? t1 - t2 : 0.0;
        md[k] = t2;
        mb[k] = tb;
        mt[k] = st.ms_model + t1;
        mc[k] = st.ms_model + t1 - tb;
        mcpu[k] = cpu_model + c1 - cb;
        out->clusters = st.clusters;
        out->particles = st.particles;
    }
    if (res == SQ_OK) {
        out->model = sq_bench_median(m, reps);
        out->light = sq_bench_median(ml, reps);
        out->draw = sq_bench_median(md, reps);
        out->base = sq_bench_median(mb, reps);
        out->total = sq_bench_median(mt, reps);
        out->clouds = sq_bench_median(mc, reps);
        out->cpu_clouds = sq_bench_median(mcpu, reps);
    }
    free(m);
    return res;
}

static void json_head(sq_json *j, const bench *b, const char *what)
{
    sq_json_begin(j);
    sq_json_str(j, "case", "clouds");
    sq_json_str(j, "measure", what);
    sq_json_int(j, "threads", b->a->threads);
    sq_json_int(j, "width", b->width);
    sq_json_int(j, "height", b->height);
}

static int bench_frame(bench *b, int particles)
{
    for (int plain = 1; plain >= 0; plain--) {
        sq_clouds *c = NULL;
        frame_times ft;
        memset(&ft, 0, sizeof ft);
        sq_result res = make_clouds(b, particles, plain, 12, 16000.0, false, &c);
        if (res == SQ_OK) res = run_frames(b, c, b->a->warmup, b->a->reps, &ft);
        sq_clouds_destroy(c);
        if (res != SQ_OK) {
            sq_cli_error("bench clouds: %s", sq_last_error());
            return sq_cli_exit_code(res);
        }
        sq_json j;
        json_head(&j, b, "frame");
        sq_json_str(&j, "system", plain ? "plain" : "structured");
        sq_json_int(&j, "particles", ft.particles);
        sq_json_int(&j, "clusters", ft.clusters);
        sq_json_num(&j, "ms_model", ft.model);
        sq_json_num(&j, "ms_light", ft.light);
        sq_json_num(&j, "ms_draw", ft.draw);
        sq_json_num(&j, "ms_base", ft.base);
        sq_json_num(&j, "ms_per_frame", ft.total);
        sq_json_num(&j, "ms_clouds", ft.clouds);
        sq_json_num(&j, "cpu_ms_clouds", ft.cpu_clouds);
        sq_json_str(&j, "gl_renderer", b->info.gl_renderer);
        sq_json_end(&j, stdout);
    }
    return SQ_EXIT_OK;
}

static int bench_table(bench *b)
{
    static const int counts[5] = {2600, 4100, 7800, 10500, 13000};
    static const double s4_plain[5] = {25.4, 18.5, 8.7, 6.5, 5.2};
    static const double s4_structured[5] = {26.3, 19.8, 10.6, 8.3, 6.9};
    for (int row = 0; row < 5; row++) {
        double ms[2];
        int clusters = 0;
        for (int plain = 1; plain >= 0; plain--) {
            sq_clouds *c = NULL;
            frame_times ft;
            memset(&ft, 0, sizeof ft);
            sq_result res = make_clouds(b, counts[row], plain, 12, 16000.0, false, &c);
            if (res == SQ_OK) res = run_frames(b, c, b->a->warmup, b->a->reps, &ft);
            sq_clouds_destroy(c);
            if (res != SQ_OK) {
                sq_cli_error("bench clouds: %s", sq_last_error());
                return sq_cli_exit_code(res);
            }
            ms[plain] = ft.total;
            if (!plain) clusters = ft.clusters;
        }
        const double fps_p = 1000.0 / ms[1], fps_s = 1000.0 / ms[0];
        sq_json j;
        json_head(&j, b, "table1");
        sq_json_int(&j, "particles", counts[row]);
        sq_json_int(&j, "clusters", clusters);
        sq_json_num(&j, "ms_plain", ms[1]);
        sq_json_num(&j, "ms_structured", ms[0]);
        sq_json_num(&j, "fps_plain", fps_p);
        sq_json_num(&j, "fps_structured", fps_s);
        sq_json_num(&j, "speedup_percent", 100.0 * (fps_s / fps_p - 1.0));
        sq_json_num(&j, "s4_fps_plain", s4_plain[row]);
        sq_json_num(&j, "s4_fps_structured", s4_structured[row]);
        sq_json_num(&j, "s4_speedup_percent", 100.0 * (s4_structured[row] / s4_plain[row] - 1.0));
        sq_json_end(&j, stdout);
    }
    return SQ_EXIT_OK;
}

static int bench_impostor(bench *b, int particles)
{
    /* 20 cumuli over 40 km, 150 km away: every cloud beyond dist_impostor (90 km) */
    const sq_camera cam0 = b->cam;
    b->cam.position_m = sq_v3(-150000.0f, 0.0f, 3000.0f);
    b->cam.target_m = sq_v3(0.0f, 0.0f, 1500.0f);
    b->cam.fov_y_deg = 12.0f;
    b->cam.far_m = 400000.0f;
    b->cam.near_m = 50.0f;
    double ms[2] = {0, 0}, base[2] = {0, 0}, pass[2] = {0, 0}, cpu[2] = {0, 0}, mean[2] = {0, 0};
    double cpu_mean[2] = {0, 0};
    int drawn = 0, renders = 0;
    for (int imp = 0; imp < 2; imp++) {
        sq_clouds *c = NULL;
        sq_result res = make_clouds(b, particles, false, 20, 40000.0, imp == 1, &c);
        sq_drawable d;
        if (res == SQ_OK) res = sq_clouds_drawable(c, &d);
        const int reps = b->a->reps;
        double *t = malloc(sizeof(double) * (size_t)reps * 4);
        if (!t) res = SQ_ERR_OUT_OF_MEMORY;
        double *tb = t + reps, *tp = t + 2 * reps, *tc = t + 3 * reps;
        double sum = 0.0, cpu_sum = 0.0;
        int rendered = 0;
        for (int k = -b->a->warmup; res == SQ_OK && k < reps; k++) {
            const float ang = 0.0003491f * (float)(k + b->a->warmup); /* 0.02 deg per frame */
            b->cam.position_m = sq_v3(-150000.0f * cosf(ang), -150000.0f * sinf(ang), 3000.0f);
            double cf = 0.0, cb = 0.0;
            const double f = timed_frame_cpu(b, &d, 1, &cf);
            sq_render_stats rs;
            memset(&rs, 0, sizeof rs);
            sq_renderer_stats(b->r, &rs);
            const double fb = timed_frame_cpu(b, NULL, 0, &cb);
            if (f < 0.0 || fb < 0.0) res = SQ_ERR_GL;
            else if (k >= 0) {
                t[k] = f;
                tb[k] = fb;
                tp[k] = f - fb;
                tc[k] = cf - cb;
                sum += f - fb;
                cpu_sum += cf - cb;
                rendered += rs.cloud_impostors_rendered;
            }
        }
        if (res == SQ_OK) {
            ms[imp] = sq_bench_median(t, reps);
            base[imp] = sq_bench_median(tb, reps);
            pass[imp] = sq_bench_median(tp, reps);
            cpu[imp] = sq_bench_median(tc, reps);
            mean[imp] = sum / reps;
            cpu_mean[imp] = cpu_sum / reps;
            if (imp == 1) renders = rendered;
            drawn = d.u.clouds.count;
        }
        free(t);
        sq_clouds_destroy(c);
        if (res != SQ_OK) {
            sq_cli_error("bench clouds: %s", sq_last_error());
            return sq_cli_exit_code(res);
        }
    }
    sq_json j;
    json_head(&j, b, "impostor");
    sq_json_int(&j, "particles", drawn);
    sq_json_num(&j, "ms_base", 0.5 * (base[0] + base[1]));
    sq_json_num(&j, "ms_frame_particles", ms[0]);
    sq_json_num(&j, "ms_frame_impostors", ms[1]);
    sq_json_num(&j, "ms_clouds_particles", pass[0]);
    sq_json_num(&j, "ms_clouds_impostors", pass[1]);
    sq_json_num(&j, "ms_clouds_impostors_mean", mean[1]);
    sq_json_num(&j, "cpu_ms_clouds_particles", cpu[0]);
    sq_json_num(&j, "cpu_ms_clouds_impostors", cpu[1]);
    sq_json_num(&j, "cpu_ms_clouds_particles_mean", cpu_mean[0]);
    sq_json_num(&j, "cpu_ms_clouds_impostors_mean", cpu_mean[1]);
    sq_json_int(&j, "impostor_renders", renders);
    sq_json_num(&j, "speedup_clouds", pass[0] / fmax(pass[1], 1e-3));
    sq_json_num(&j, "speedup_frame", ms[0] / ms[1]);
    sq_json_end(&j, stdout);
    b->cam = cam0;
    return SQ_EXIT_OK;
}

int sq_bench_clouds(const sq_bench_args *a)
{
    bench b;
    memset(&b, 0, sizeof b);
    b.a = a;
    b.ctx = a->ctx;
    int particles;
    if (!sq_cli_int(a->argc, a->argv, "--width", 640, 16, 16384, &b.width) ||
        !sq_cli_int(a->argc, a->argv, "--height", 360, 16, 16384, &b.height) ||
        !sq_cli_int(a->argc, a->argv, "--particles", 15000, 1, 10000000, &particles))
        return SQ_EXIT_USAGE;
    const char *only = sq_cli_value(a->argc, a->argv, "--only");
    if (only && strcmp(only, "frame") != 0 && strcmp(only, "table") != 0 &&
        strcmp(only, "impostor") != 0) {
        sq_cli_error("bench clouds: --only %s; must be frame, table or impostor", only);
        return SQ_EXIT_USAGE;
    }
    int rc = SQ_EXIT_OK;
    b.rgba = malloc((size_t)b.width * (size_t)b.height * 4);
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 400000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 65;
    wd.sun.direction = sq_v3(0.5f, -0.6f, 0.6f);
    sq_result res = b.rgba ? sq_world_create(b.ctx, &wd, &b.w) : SQ_ERR_OUT_OF_MEMORY;
    sq_render_desc rd = {0};
    rd.width = b.width;
    rd.height = b.height;
    if (res == SQ_OK) res = sq_renderer_create(b.ctx, &rd, &b.r);
    if (res == SQ_OK) res = sq_renderer_info(b.r, &b.info);
    if (res != SQ_OK) {
        sq_cli_error("bench clouds: %s", sq_last_error());
        rc = sq_cli_exit_code(res);
        goto done;
    }
    b.cam.position_m = sq_v3(-14000.0f, -12000.0f, 2200.0f);
    b.cam.target_m = sq_v3(0.0f, 0.0f, 1500.0f);
    b.cam.fov_y_deg = 50.0f;
    b.cam.near_m = 5.0f;
    b.cam.far_m = 100000.0f;
    if (!only || strcmp(only, "frame") == 0) rc = bench_frame(&b, particles);
    if (rc == SQ_EXIT_OK && (!only || strcmp(only, "table") == 0)) rc = bench_table(&b);
    if (rc == SQ_EXIT_OK && (!only || strcmp(only, "impostor") == 0))
        rc = bench_impostor(&b, particles);
done:
    sq_renderer_destroy(b.r);
    sq_world_destroy(b.ctx, b.w);
    free(b.rgba);
    return rc;
}
