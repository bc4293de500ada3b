/* cmd_render.c — `squall render` and `squall simulate`: load a scene (file or preset), apply
 * overrides, check every output before any work, then step / draw / write frame by frame.
 * Outputs go to temporary names and are renamed only when complete; on any failure or an
 * interrupt the temporaries are removed and no final name is created or changed. */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "commands.h"
#include "squall/image.h"
#include "squall/io.h"
#include "squall/plugin.h"
#include "squall/render.h"
#include "squall/scene.h"

#define MAX_DRAWABLES 32
#define MAX_METRICS 128
#define MAX_FIELDS 32

static volatile sig_atomic_t interrupted;
static sq_context *signal_ctx; /* cancelled by the handler: long library stages stop too */
static void on_signal(int sig)
{
    (void)sig;
    interrupted = 1;
    if (signal_ctx) sq_context_cancel(signal_ctx);
}

static void render_usage(bool simulate)
{
    printf("usage: squall %s [SCENE.yaml|PRESET] [options]\n\n", simulate ? "simulate" : "render");
    printf("%s\n\n", simulate ? "Steps the scene and writes metrics and fields, without rendering."
                              : "Simulates the scene and renders it (headless OpenGL) to H.264 MP4 "
                                "and/or PNG frames.");
    printf("Without SCENE the default demo (%s) is used. `squall scenes` lists presets.\n\n"
           "options:\n",
           sq_preset_default());
    if (!simulate)
        printf("  -o PATH              output: a .mp4 file, or a directory for PNG frames\n"
               "  --size WxH           frame size in pixels (even for MP4), e.g. 1280x720\n"
               "  --reference          render with the CPU reference path tracer (PNG frames)\n"
               "  --samples N          reference path tracer samples per pixel (> 0)\n");
    printf("  --frames N           number of frames (simulation steps of 1/fps each)\n"
           "  --duration S         length in video seconds (frames = S * fps)\n"
           "  --fps N              frames per second\n"
           "  --metrics PATH       per-frame metrics CSV\n"
           "  --fields PREFIX      field files PREFIX_NNNNN.nc (see output.fields_every)\n"
           "  --set KEY=VALUE      override any scene key, e.g. --set output.fps=30\n"
           "                       --set layers.sandstorm.wind.speed_mps=20 (see squall params)\n"
           "  --overwrite          replace existing outputs (never done otherwise)\n"
           "  --threads N          worker threads (default: all cores)\n"
           "  --quiet              no progress, only errors\n"
           "  --json               print a machine-readable summary on stdout\n\n"
           "Progress goes to stderr (a live line on a terminal, one summary line otherwise).\n"
           "Exit codes: 0 success, 1 runtime failure (GL, numerical blow-up), 2 usage/input error.\n");
}

/* An option's value is checked against the output table here, so a bad value is blamed on the
 * option (--size 10x10), not on the scene's --set overrides. Returns false after printing. */
static bool option_value_ok(const char *opt, const char *optval, const char *key, const char *value)
{
    size_t n = 0;
    const sq_param *t = sq_scene_section_params("output", &n);
    sq_scene_output scratch;
    sq_params_defaults(t, n, &scratch);
    if (sq_params_set(t, n, &scratch, "output", key, value, NULL) == SQ_OK) return true;
    sq_cli_error("%s %s: %s", opt, optval, sq_last_error());
    return false;
}

/* -o PATH: a .mp4 file (any case) is video; a name without an extension, or ending in '/', is a
 * directory of PNG frames; anything else (out.avi, frame.png) is refused rather than silently
 * becoming a directory. */
static bool output_is_video(const char *v, bool *ok)
{
    const size_t n = strlen(v);
    const char *base = strrchr(v, '/');
    base = base ? base + 1 : v;
    const char *dot = strrchr(base, '.');
    *ok = true;
    if (n >= 4 && strcasecmp(v + n - 4, ".mp4") == 0) return true;
    if (*base && dot && dot != base && dot[1]) {
        sq_cli_error("-o %s: squall writes video as .mp4 (H.264) and frames as PNG into a "
                     "directory; '%s' is neither (end the name with .mp4, or give a directory "
                     "name without an extension, or end it with '/')",
                     v, dot);
        *ok = false;
    }
    return false;
}

/* Options that take a value (so their value is not mistaken for the scene name). */
static bool takes_value(const char *a)
{
    const char *v[] = {"-o", "--size", "--frames", "--duration", "--fps", "--set", "--threads",
                       "--metrics", "--fields", "--samples", NULL};
    for (int i = 0; v[i]; i++)
        if (strcmp(a, v[i]) == 0) return true;
    return false;
}

static bool known_option(const char *a)
{
    const char *v[] = {"-o", "--size", "--frames", "--duration", "--fps", "--set", "--threads",
                       "--metrics", "--fields", "--samples", "--overwrite", "--quiet", "--json",
                       "--reference", "--verbose", NULL};
    for (int i = 0; v[i]; i++)
        if (strcmp(a, v[i]) == 0 || (strncmp(a, v[i], strlen(v[i])) == 0 && a[strlen(v[i])] == '='))
            return true;
    return false;
}

static int fail(sq_result r, const char *what)
{
    const char *e = sq_last_error();
    if (what && *what)
        sq_cli_error("%s: %s", what, e && *e ? e : sq_result_name(r));
    else
        sq_cli_error("%s", e && *e ? e : sq_result_name(r));
    return sq_cli_exit_code(r);
}

static void format_eta(double s, char *buf, size_t n)
{
    if (!isfinite(s) || s < 0) s = 0;
    int m = (int)(s / 60.0);
    if (m)
        snprintf(buf, n, "%dm%02ds", m, (int)fmod(s, 60.0));
    else
        snprintf(buf, n, "%.0fs", s);
}

/* Checks a frames directory: parent must exist; the directory is created if missing; the first
 * frame must not exist unless overwrite. */
static sq_result check_frames_dir(const char *dir, bool overwrite, bool *created)
{
    struct stat st;
    *created = false;
    if (stat(dir, &st) == 0) {
        if (!S_ISDIR(st.st_mode))
            return sq__cli_set_error(SQ_ERR_IO, "frames directory '%s' is not a directory", dir);
    } else {
        char parent[1024];
        snprintf(parent, sizeof parent, "%s", dir);
        char *slash = strrchr(parent, '/');
        if (slash && slash != parent) {
            *slash = 0;
            if (stat(parent, &st) != 0 || !S_ISDIR(st.st_mode))
                return sq__cli_set_error(SQ_ERR_IO,
                                         "cannot write frames to '%s': directory '%s' does not exist",
                                         dir, parent);
        }
        if (mkdir(dir, 0777) != 0)
            return sq__cli_set_error(SQ_ERR_IO, "cannot create frames directory '%s': %s", dir,
                                     strerror(errno));
        *created = true;
    }
    char first[1100];
    snprintf(first, sizeof first, "%s/frame_00000.png", dir);
    return sq_output_check(first, overwrite);
}

typedef struct metrics_log {
    FILE *f;
    char tmp[1100];
    const char *path;
    int count;
    char names[MAX_METRICS][96];
    char units[MAX_METRICS][24];
    double *values; /* frames x count */
    int frames, cap;
} metrics_log;

static void metrics_store(metrics_log *m, int frame, double t, const sq_metric *mv, int n)
{
    if (frame == 0) {
        m->count = n;
        for (int i = 0; i < n; i++) {
            snprintf(m->names[i], sizeof m->names[i], "%s", mv[i].name);
            snprintf(m->units[i], sizeof m->units[i], "%s", mv[i].unit ? mv[i].unit : "");
        }
        if (m->f) {
            fprintf(m->f, "frame,time_s");
            for (int i = 0; i < n; i++)
                fprintf(m->f, ",%s%s%s%s", mv[i].name, m->units[i][0] ? " [" : "", m->units[i],
                        m->units[i][0] ? "]" : "");
            fprintf(m->f, "\n");
        }
    }
    if (m->frames >= m->cap) {
        int cap = m->cap ? m->cap * 2 : 256;
        double *v = (double *)realloc(m->values, sizeof(double) * (size_t)cap * MAX_METRICS);
        if (!v) return;
        m->values = v;
        m->cap = cap;
    }
    for (int i = 0; i < m->count; i++)
        m->values[(size_t)m->frames * MAX_METRICS + (size_t)i] = i < n ? mv[i].value : (double)NAN;
    m->frames++;
    if (m->f) {
        fprintf(m->f, "%d,%.17g", frame, t); /* full precision: times must difference exactly */
        for (int i = 0; i < m->count; i++) fprintf(m->f, ",%.9g", i < n ? mv[i].value : (double)NAN);
        fprintf(m->f, "\n");
    }
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static void metrics_summary_json(const metrics_log *m, sq_json *j)
{
    char buf[6144];
    size_t len = 0;
    len += (size_t)snprintf(buf + len, sizeof buf - len, "{");
    double *col = (double *)malloc(sizeof(double) * (size_t)(m->frames > 0 ? m->frames : 1));
    for (int i = 0; col && i < m->count && len < sizeof buf - 200; i++) {
        int n = 0;
        double sum = 0;
        for (int f = 0; f < m->frames; f++) {
            double v = m->values[(size_t)f * MAX_METRICS + (size_t)i];
            if (isfinite(v)) {
                col[n++] = v;
                sum += v;
            }
        }
        if (!n) continue;
        double last = m->values[(size_t)(m->frames - 1) * MAX_METRICS + (size_t)i];
        qsort(col, (size_t)n, sizeof(double), cmp_d);
        double med = n % 2 ? col[n / 2] : 0.5 * (col[n / 2 - 1] + col[n / 2]);
        len += (size_t)snprintf(buf + len, sizeof buf - len,
                                "%s\"%s\": {\"min\": %.6g, \"median\": %.6g, \"max\": %.6g, "
                                "\"mean\": %.6g, \"last\": %.6g, \"unit\": \"%s\"}",
                                len > 1 ? ", " : "", m->names[i], col[0], med, col[n - 1], sum / n,
                                isfinite(last) ? last : 0.0, m->units[i]);
    }
    free(col);
    if (len < sizeof buf) snprintf(buf + len, sizeof buf - len, "}");
    sq_json_raw(j, "metrics", buf);
}

/* A 2D field in metres as a 16-bit grey PNG at 1 mm per unit (0..65.535 m), north up. */
static sq_result write_depth_png(const char *path, const sq_named_field *f, bool overwrite)
{
    uint16_t *g = (uint16_t *)malloc(sizeof(uint16_t) * (size_t)f->nx * (size_t)f->ny);
    if (!g) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory writing '%s'", path);
    for (int j = 0; j < f->ny; j++)
        for (int i = 0; i < f->nx; i++) {
            double v = (double)f->data[(size_t)j * f->nx + i] * 1000.0;
            v = !isfinite(v) || v < 0.0 ? 0.0 : v > 65535.0 ? 65535.0 : v;
            g[(size_t)(f->ny - 1 - j) * f->nx + i] = (uint16_t)(v + 0.5);
        }
    sq_result r = sq_png_write_gray16(path, f->nx, f->ny, g, overwrite);
    free(g);
    return r;
}

/* The ParaView time-series index PREFIX[_maps].pvd, rewritten after every .vti so that an
 * interrupted run still leaves a complete index of the files it wrote. */
typedef struct vtk_series {
    char **files;
    double *times;
    int count, cap;
} vtk_series;

static sq_result vtk_series_add(sq_context *ctx, vtk_series *s, const char *prefix,
                                const char *tag, const char *vti_path, double t, bool overwrite)
{
    if (s->count == s->cap) {
        int cap = s->cap ? 2 * s->cap : 64;
        char **f = (char **)realloc(s->files, sizeof *f * (size_t)cap);
        if (f) s->files = f;
        double *tt = f ? (double *)realloc(s->times, sizeof *tt * (size_t)cap) : NULL;
        if (!f || !tt) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory (series index)");
        s->times = tt;
        s->cap = cap;
    }
    const char *base = strrchr(vti_path, '/');
    s->files[s->count] = strdup(base ? base + 1 : vti_path);
    if (!s->files[s->count]) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory");
    s->times[s->count++] = t;
    char pvd[1100];
    snprintf(pvd, sizeof pvd, "%s%s.pvd", prefix, tag);
    /* the first write follows --overwrite; later ones replace this run's own index */
    return sq_vtk_write_series(ctx, pvd, (const char *const *)s->files, s->times, s->count,
                               overwrite || s->count > 1);
}

static void vtk_series_free(vtk_series *s)
{
    for (int i = 0; i < s->count; i++) free(s->files[i]);
    free(s->files);
    free(s->times);
}

typedef struct ref_progress {
    double t0;
    int frame, frames;
    bool tty;
} ref_progress;

/* Progress of the reference path tracer within a frame, with ETA (terminal only). */
static bool reference_progress(void *user, double fraction)
{
    const ref_progress *p = (const ref_progress *)user;
    if (p->tty && fraction > 0.0) {
        double el = sq_time_now() - p->t0;
        double total = el / ((p->frame + fraction) / p->frames);
        char eta[32];
        format_eta(total - el, eta, sizeof eta);
        fprintf(stderr, "\rsquall: reference frame %d/%d  %3.0f%%  ETA %s   ", p->frame + 1,
                p->frames, 100.0 * fraction, eta);
        fflush(stderr);
    }
    return !interrupted;
}

int sq_cmd_render(int argc, char **argv)
{
    const bool simulate = strcmp(argv[0], "simulate") == 0;
    if (sq_cli_flag(argc, argv, "--help") || sq_cli_flag(argc, argv, "-h")) {
        render_usage(simulate);
        return SQ_EXIT_OK;
    }
    /* positional scene argument and unknown options */
    const char *scene_arg = NULL;
    for (int i = 1; i < argc; i++) {
        if (argv[i][0] == '-') {
            if (!known_option(argv[i])) {
                sq_cli_error("unknown option '%s' (see squall %s --help)", argv[i], argv[0]);
                return SQ_EXIT_USAGE;
            }
            if (takes_value(argv[i])) {
                if (i + 1 >= argc) {
                    sq_cli_error("%s needs a value (see squall %s --help)", argv[i], argv[0]);
                    return SQ_EXIT_USAGE;
                }
                i++;
            }
            continue;
        }
        if (scene_arg) {
            sq_cli_error("more than one scene given ('%s' and '%s')", scene_arg, argv[i]);
            return SQ_EXIT_USAGE;
        }
        scene_arg = argv[i];
    }
    if (!scene_arg) scene_arg = sq_preset_default();
    const bool overwrite = sq_cli_flag(argc, argv, "--overwrite");
    const bool quiet = sq_cli_flag(argc, argv, "--quiet");
    const bool json = sq_cli_flag(argc, argv, "--json");
    const bool reference = !simulate && sq_cli_flag(argc, argv, "--reference");
    int samples = 0;
    if (!sq_cli_int(argc, argv, "--samples", 64, -1000000, 1000000, &samples)) return SQ_EXIT_USAGE;
    if (reference && samples <= 0) {
        sq_cli_error("--samples %d: the reference path tracer needs at least 1 sample per pixel",
                     samples);
        return SQ_EXIT_USAGE;
    }

    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) return SQ_EXIT_USAGE;
    /* Ctrl-C is answered from here on: scene building, terrain generation and stepping check
     * the context's cancel flag */
    signal_ctx = ctx;
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    sq_cfg *cfg = NULL;
    sq_result r = sq_cfg_load(ctx, scene_arg, &cfg);
    if (r != SQ_OK) {
        signal_ctx = NULL;
        sq_context_destroy(ctx);
        return fail(r, NULL);
    }
    /* command-line overrides become cfg assignments, so they are checked by the same tables */
    char set[1200];
    int rc = SQ_EXIT_OK;
    for (int i = 1; i < argc && r == SQ_OK; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        set[0] = 0;
        if (strcmp(a, "--set") == 0) {
            r = sq_cfg_set(cfg, v);
        } else if (strcmp(a, "-o") == 0 && !simulate) {
            bool ok = true;
            const bool is_video = output_is_video(v, &ok);
            if (!ok) {
                rc = SQ_EXIT_USAGE;
                break;
            }
            if (is_video) {
                snprintf(set, sizeof set, "output.video=%s", v);
                r = sq_cfg_set(cfg, set);
            } else {
                snprintf(set, sizeof set, "output.frames_dir=%s", v);
                r = sq_cfg_set(cfg, set);
                if (r == SQ_OK) r = sq_cfg_set(cfg, "output.video=");
            }
        } else if (strcmp(a, "--size") == 0 && !simulate) {
            int w = 0, h = 0;
            char tail = 0;
            if (sscanf(v, "%dx%d%c", &w, &h, &tail) != 2) {
                sq_cli_error("--size %s: expected WIDTHxHEIGHT, e.g. 1280x720", v);
                rc = SQ_EXIT_USAGE;
                break;
            }
            char ws[32], hs[32];
            snprintf(ws, sizeof ws, "%d", w);
            snprintf(hs, sizeof hs, "%d", h);
            if (!option_value_ok(a, v, "width", ws) || !option_value_ok(a, v, "height", hs)) {
                rc = SQ_EXIT_USAGE;
                break;
            }
            snprintf(set, sizeof set, "output.width=%d", w);
            r = sq_cfg_set(cfg, set);
            snprintf(set, sizeof set, "output.height=%d", h);
            if (r == SQ_OK) r = sq_cfg_set(cfg, set);
        } else if (strcmp(a, "--frames") == 0) {
            if (!option_value_ok(a, v, "frames", v)) {
                rc = SQ_EXIT_USAGE;
                break;
            }
            snprintf(set, sizeof set, "output.frames=%s", v);
            r = sq_cfg_set(cfg, set);
        } else if (strcmp(a, "--duration") == 0) {
            if (!option_value_ok(a, v, "duration_s", v)) {
                rc = SQ_EXIT_USAGE;
                break;
            }
            snprintf(set, sizeof set, "output.duration_s=%s", v);
            r = sq_cfg_set(cfg, set);
            if (r == SQ_OK) r = sq_cfg_set(cfg, "output.frames=0");
        } else if (strcmp(a, "--fps") == 0) {
            if (!option_value_ok(a, v, "fps", v)) {
                rc = SQ_EXIT_USAGE;
                break;
            }
            snprintf(set, sizeof set, "output.fps=%s", v);
            r = sq_cfg_set(cfg, set);
        } else if (strcmp(a, "--metrics") == 0) {
            snprintf(set, sizeof set, "output.metrics=%s", v);
            r = sq_cfg_set(cfg, set);
        } else if (strcmp(a, "--fields") == 0) {
            snprintf(set, sizeof set, "output.fields=%s", v);
            r = sq_cfg_set(cfg, set);
        }
    }
    if (rc != SQ_EXIT_OK || r != SQ_OK) {
        sq_cfg_destroy(cfg);
        signal_ctx = NULL;
        sq_context_destroy(ctx);
        return rc != SQ_EXIT_OK ? rc : fail(r, NULL);
    }

    sq_scene_desc sd = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                        .load_dem = sq_dem_load, .load_area = sq_area_load};
    sq_scene *scene = NULL;
    r = sq_scene_create(ctx, &sd, &scene);
    sq_cfg_destroy(cfg);
    if (r != SQ_OK) {
        signal_ctx = NULL;
        sq_context_destroy(ctx);
        return fail(r, NULL);
    }
    const sq_scene_output *out = sq_scene_output_settings(scene);
    const char *video = !simulate && out->video[0] ? out->video : NULL;
    const char *frames_dir = !simulate && out->frames_dir[0] ? out->frames_dir : NULL;
    const char *metrics_path = out->metrics[0] ? out->metrics : NULL;
    const char *fields = out->fields[0] ? out->fields : NULL;
    const int W = out->width, H = out->height, N = sq_scene_frame_count(scene);

    /* every output is checked before any work */
    bool frames_dir_created = false;
    int frame = 0;
    sq_video_writer *vw = NULL;
    sq_renderer *ren = NULL;
    metrics_log ml;
    memset(&ml, 0, sizeof ml);
    vtk_series series[2];
    memset(series, 0, sizeof series);
    uint8_t *rgba = NULL;
    float *lin = NULL;
    /* inputs are never written, not even with --overwrite; temporaries that a killed run left
     * next to these outputs are removed (io: sq_output_check_inputs, sq_output_remove_stale) */
    {
        char pfx[1100];
        const struct {
            const char *path;
            const char *suffix;
            bool prefix;
        } outs[] = {{video, "", false},          {metrics_path, "", false},
                    {frames_dir, "/frame_", true}, {fields, "_", true},
                    {fields, ".pvd", false},       {fields, "_maps.pvd", false}};
        for (size_t k = 0; r == SQ_OK && k < sizeof outs / sizeof outs[0]; k++) {
            if (!outs[k].path) continue;
            snprintf(pfx, sizeof pfx, "%s%s", outs[k].path, outs[k].suffix);
            r = sq_output_check_inputs(ctx, pfx, outs[k].prefix);
            if (r == SQ_OK) sq_output_remove_stale(ctx, pfx, outs[k].prefix);
        }
    }
    /* the camera stays above the terrain (named by key and file:line before any GL work) */
    if (r == SQ_OK && !simulate) r = sq_scene_check_camera(scene);
    if (r == SQ_OK && video) {
        if (W % 2 || H % 2)
            r = sq__cli_set_error(SQ_ERR_INVALID_ARG,
                                  "output size %dx%d: MP4 (yuv420p) needs even width and height",
                                  W, H);
        if (r == SQ_OK) r = sq_output_check(video, overwrite);
    }
    if (r == SQ_OK && frames_dir) r = check_frames_dir(frames_dir, overwrite, &frames_dir_created);
    if (r == SQ_OK && metrics_path) r = sq_output_check(metrics_path, overwrite);
    if (r == SQ_OK && fields) {
        char first[1100];
        snprintf(first, sizeof first, "%s_%05d.%s", fields, out->fields_every ? 0 : N - 1,
                 out->fields_format == SQ_FIELDS_VTK ? "vti" : "nc");
        r = sq_output_check(first, overwrite);
    }
    if (r == SQ_OK && !simulate && !video && !frames_dir)
        r = sq__cli_set_error(SQ_ERR_INVALID_ARG,
                              "nothing to write: output.video and output.frames_dir are both empty "
                              "(use -o out.mp4 or -o DIR)");
    if (r != SQ_OK) {
        rc = fail(r, NULL);
        goto done;
    }
    if (!simulate) {
        rgba = (uint8_t *)malloc((size_t)W * (size_t)H * 4);
        lin = (float *)malloc((size_t)W * (size_t)H * 3 * sizeof(float));
        if (!rgba || !lin) {
            rc = fail(SQ_ERR_OUT_OF_MEMORY, "frame buffers");
            goto done;
        }
        if (!reference) {
            sq_render_desc rd = {0};
            rd.width = W;
            rd.height = H;
            rd.exposure = out->exposure;
            rd.volume_slices = out->volume_slices;
            rd.light_buffer_size = out->light_buffer;
            rd.volume_noise = out->volume_noise;
            rd.seed = sq_scene_seed(scene);
            r = sq_renderer_create(ctx, &rd, &ren);
            if (r != SQ_OK) {
                rc = fail(r, NULL);
                goto done;
            }
        }
    }
    if (video) {
        sq_video_desc vd = {video, W, H, out->fps, 0, overwrite};
        r = sq_video_open(ctx, &vd, &vw);
        if (r != SQ_OK) {
            rc = fail(r, NULL);
            goto done;
        }
    }
    if (metrics_path) {
        ml.path = metrics_path;
        r = sq_output_temp_name(metrics_path, ml.tmp, sizeof ml.tmp);
        if (r == SQ_OK) {
            ml.f = fopen(ml.tmp, "w");
            if (!ml.f)
                r = sq__cli_set_error(SQ_ERR_IO, "cannot write metrics '%s': %s", metrics_path,
                                      strerror(errno));
        }
        if (r != SQ_OK) {
            rc = fail(r, NULL);
            goto done;
        }
    }

    const bool tty = isatty(2) && !quiet;
    const double frame_dt = sq_scene_frame_dt(scene);
    const int spf = out->steps_per_frame;
    double t0 = sq_time_now();
    /* warm-up before the first frame */
    while (r == SQ_OK && sq_scene_time(scene) + 1e-9 < out->warmup_s && !interrupted)
        r = sq_scene_step(scene, frame_dt / spf);
    for (frame = 0; r == SQ_OK && frame < N; frame++) {
        if (interrupted) {
            r = sq__cli_set_error(SQ_ERR_CANCELLED, "interrupted at frame %d of %d", frame, N);
            break;
        }
        if (frame > 0)
            for (int s = 0; s < spf && r == SQ_OK; s++) r = sq_scene_step(scene, frame_dt / spf);
        if (r != SQ_OK) break;
        sq_camera cam = sq_scene_camera(scene);
        sq_drawable dr[MAX_DRAWABLES];
        int nd = sq_scene_drawables(scene, dr, MAX_DRAWABLES);
        if (!simulate) {
            if (reference) {
                sq_reference_desc rdsc = {0};
                rdsc.width = W;
                rdsc.height = H;
                rdsc.samples = samples;
                rdsc.exposure = out->exposure;
                rdsc.seed = sq_scene_seed(scene) + (uint64_t)frame;
                ref_progress rp = {t0, frame, N, tty};
                rdsc.progress = reference_progress;
                rdsc.progress_user = &rp;
                r = sq_reference_render(ctx, &rdsc, sq_scene_world(scene), &cam, dr, nd, lin);
                if (r == SQ_OK) sq_tonemap_rgba8(lin, W, H, out->exposure, rgba);
            } else {
                r = sq_renderer_draw(ren, sq_scene_world(scene), &cam, dr, nd, sq_scene_time(scene));
                if (r == SQ_OK) r = sq_renderer_read_rgba8(ren, rgba);
            }
            if (r == SQ_OK && vw) r = sq_video_add_rgba8(vw, rgba);
            if (r == SQ_OK && frames_dir) {
                char path[1100];
                snprintf(path, sizeof path, "%s/frame_%05d.png", frames_dir, frame);
                r = sq_png_write_rgba8(path, W, H, rgba, overwrite);
            }
            if (r == SQ_OK && reference && frames_dir) {
                char path[1100];
                snprintf(path, sizeof path, "%s/frame_%05d.pfm", frames_dir, frame);
                r = sq_pfm_write(path, W, H, lin, overwrite);
            }
            if (r != SQ_OK) break;
        }
        sq_metric mv[MAX_METRICS];
        int nm = sq_scene_metrics(scene, mv, MAX_METRICS);
        metrics_store(&ml, frame, sq_scene_time(scene), mv, nm);
        bool want_fields = fields && ((out->fields_every > 0 && frame % out->fields_every == 0) ||
                                      frame == N - 1);
        if (want_fields) {
            sq_named_field fv[MAX_FIELDS];
            int nf = sq_scene_fields(scene, fv, MAX_FIELDS);
            if (nf > 0) {
                char path[1100];
                sq_field_file_desc fd;
                memset(&fd, 0, sizeof fd);
                fd.path = path;
                fd.title = sq_scene_name(scene);
                fd.source = "squall " SQ_VERSION_STRING;
                fd.time_s = sq_scene_time(scene);
                fd.overwrite = overwrite;
                fd.crs_wkt = sq_scene_world(scene)->crs_wkt;
                fd.crs_offset_m[0] = sq_scene_world(scene)->crs_offset_m[0];
                fd.crs_offset_m[1] = sq_scene_world(scene)->crs_offset_m[1];
                /* 3D fields and 2D maps go to separate files (a file holds one grid) */
                sq_named_field f3[MAX_FIELDS], f2[MAX_FIELDS];
                int n3 = 0, n2 = 0;
                for (int q = 0; q < nf; q++) {
                    if (fv[q].nz == 1)
                        f2[n2++] = fv[q];
                    else
                        f3[n3++] = fv[q];
                }
                for (int grp = 0; grp < 2 && r == SQ_OK; grp++) {
                    const sq_named_field *fs = grp ? f2 : f3;
                    int nfs = grp ? n2 : n3;
                    if (!nfs) continue;
                    const char *tag = grp ? "_maps" : "";
                    if (out->fields_format != SQ_FIELDS_VTK) {
                        snprintf(path, sizeof path, "%s%s_%05d.nc", fields, tag, frame);
                        r = sq_netcdf_write_fields(ctx, &fd, fs, nfs);
                    }
                    if (r == SQ_OK && out->fields_format != SQ_FIELDS_NETCDF) {
                        snprintf(path, sizeof path, "%s%s_%05d.vti", fields, tag, frame);
                        r = sq_vtk_write_fields(ctx, &fd, fs, nfs);
                        if (r == SQ_OK) r = vtk_series_add(ctx, &series[grp], fields, tag, path,
                                                           fd.time_s, overwrite);
                    }
                }
                /* 2D maps in metres (snow depth, deposit depth) also as 16-bit PNG, 1 mm per
                 * unit, row 0 = north edge */
                for (int q = 0; r == SQ_OK && q < nf; q++)
                    if (fv[q].nz == 1 && fv[q].units && strcmp(fv[q].units, "m") == 0 &&
                        strstr(fv[q].name, "depth")) {
                        snprintf(path, sizeof path, "%s_%s_%05d.png", fields, fv[q].name, frame);
                        r = write_depth_png(path, &fv[q], overwrite);
                    }
                if (r != SQ_OK) break;
            }
        }
        if (tty) {
            double el = sq_time_now() - t0, rate = (frame + 1) / (el > 0 ? el : 1e-9);
            char eta[32];
            format_eta((N - frame - 1) / rate, eta, sizeof eta);
            fprintf(stderr, "\rsquall: frame %d/%d  %.2f frames/s  ETA %s   ", frame + 1, N, rate,
                    eta);
            fflush(stderr);
        }
    }
    if (tty) fprintf(stderr, "\n");
    if (r != SQ_OK) {
        rc = fail(r, NULL);
        goto done;
    }
    /* commit outputs */
    if (vw) {
        r = sq_video_close(vw);
        vw = NULL;
        if (r != SQ_OK) {
            rc = fail(r, NULL);
            goto done;
        }
    }
    if (ml.f) {
        errno = 0;
        int bad = ferror(ml.f) | (fclose(ml.f) != 0);
        const int e = errno;
        ml.f = NULL;
        r = !bad ? sq_output_commit(ml.tmp, ml.path, overwrite)
            : e == ENOSPC || e == EDQUOT
                ? sq__cli_set_error(SQ_ERR_NO_SPACE,
                                    "cannot write metrics '%s': no space left on device", ml.path)
                : sq__cli_set_error(SQ_ERR_IO, "cannot write metrics '%s': %s", ml.path,
                                    strerror(e ? e : EIO));
        if (r != SQ_OK) {
            rc = fail(r, NULL);
            goto done;
        }
        ml.tmp[0] = 0;
    }
    {
        double el = sq_time_now() - t0;
        if (!quiet) {
            fprintf(stderr, "squall: %s %d frame%s of '%s'%s in %.1f s (%.2f frames/s)", 
                    simulate ? "simulated" : "rendered", N, N == 1 ? "" : "s", sq_scene_name(scene),
                    simulate ? "" : "", el, N / (el > 0 ? el : 1e-9));
            if (video) fprintf(stderr, " -> %s", video);
            if (frames_dir) fprintf(stderr, " -> %s/", frames_dir);
            if (metrics_path) fprintf(stderr, " (metrics %s)", metrics_path);
            fprintf(stderr, "\n");
        }
        if (json) {
            sq_json j;
            sq_json_begin(&j);
            sq_json_str(&j, "command", simulate ? "simulate" : "render");
            sq_json_str(&j, "scene", sq_scene_name(scene));
            sq_json_int(&j, "frames", N);
            sq_json_int(&j, "width", W);
            sq_json_int(&j, "height", H);
            sq_json_num(&j, "seconds", el);
            sq_json_num(&j, "frames_per_s", N / (el > 0 ? el : 1e-9));
            sq_json_num(&j, "simulated_s", sq_scene_time(scene));
            sq_json_str(&j, "video", video ? video : "");
            sq_json_str(&j, "frames_dir", frames_dir ? frames_dir : "");
            sq_json_str(&j, "metrics_file", metrics_path ? metrics_path : "");
            metrics_summary_json(&ml, &j);
            sq_json_end(&j, stdout);
        } else if (!quiet && video) {
            printf("%s\n", video);
        }
    }
done:
    if (vw) sq_video_abort(vw);
    if (ml.f) fclose(ml.f);
    if (ml.tmp[0]) remove(ml.tmp);
    free(ml.values);
    vtk_series_free(&series[0]);
    vtk_series_free(&series[1]);
    if (rc != SQ_EXIT_OK && frames_dir_created) {
        /* remove frames written by this failed run only if we created the directory */
        for (int f = 0; f <= frame && f < N; f++) {
            char path[1100];
            snprintf(path, sizeof path, "%s/frame_%05d.png", frames_dir, f);
            remove(path);
            snprintf(path, sizeof path, "%s/frame_%05d.pfm", frames_dir, f);
            remove(path);
        }
        rmdir(frames_dir);
    }
    sq_renderer_destroy(ren);
    free(rgba);
    free(lin);
    sq_scene_destroy(scene);
    signal_ctx = NULL;
    sq_context_destroy(ctx);
    return rc;
}
