/* cmd_render.c — `squall render` and `squall simulate`: load a scene (file or preset), apply
 * the command-line overrides, and hand the scene to the library's frame loop (squall/run.h),
 * which checks every output before any work, steps, draws and writes frame by frame, writes to
 * temporary names renamed only when complete, and on a failure or an interrupt removes the
 * temporaries. Here: options, the progress line and the summary. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "squall/par.h"
#include "commands.h"
#include "rasters.h"
#include "squall/image.h"
#include "squall/io.h"
#include "squall/plugin.h"
#include "squall/render.h"
#include "squall/run.h"
#include "squall/scene.h"
#include "squall/wrf.h"

/* "/" to print after a directory name that does not end with one already. */
static const char *dir_slash(const char *dir)
{
    const size_t n = strlen(dir);
    return n > 0 && dir[n - 1] == '/' ? "" : "/";
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
               "                       (default: output.video, out/squall.mp4; out/ is made if\n"
               "                       missing)\n"
               "  --size WxH           frame size in pixels (even for MP4), e.g. 1280x720\n"
               "  --reference          render with the CPU reference path tracer (PNG frames)\n"
               "  --samples N          reference path tracer samples per pixel (> 0)\n");
    printf("  --frames N           number of frames (simulation steps of 1/fps each)\n"
           "  --duration S         length in video seconds (frames = S * fps)\n"
           "  --fps N              frames per second\n"
           "  --metrics PATH       per-frame metrics CSV\n"
           "  --fields PREFIX      field files PREFIX_NNNNN.nc (see output.fields_every)\n"
           "  --rasters DIR        at the end: every 2D map (avalanche hazard maps) as a GeoTIFF\n"
           "                       in the world's CRS, and DIR/summary.json (metrics)\n"
           "  --raster-format F    tif (default) or asc (ESRI ASCII grid + .prj)\n"
           "  --set KEY=VALUE      override any scene key, e.g. --set output.fps=30\n"
           "                       --set layers.sandstorm.wind.speed_mps=20 (see squall params)\n"
           "  --overwrite          replace existing outputs (never done otherwise; inputs never)\n"
           "  --checkpoint-every T write the complete state every T simulated seconds\n"
           "  --checkpoint PATH    where (default squall.ckpt); replaced by each new one\n"
           "  --resume CHECKPOINT  continue a run from its checkpoint, bit-identically (the scene\n"
           "                       comes from the checkpoint; only output settings may change)\n"
           "  --threads N          worker threads (default: OMP_NUM_THREADS, else all cores)\n"
           "  --quiet              no progress, only errors\n"
           "  --json               print a machine-readable summary on stdout\n\n"
           "Progress goes to stderr (a live line on a terminal, one summary line otherwise).\n"
           "Ctrl-C stops within a second and leaves nothing but the metrics rows so far\n"
           "(NAME.partial.csv); see docs/reliability.md.\n"
           "Under mpirun (mpirun -np 4 squall %s ...) the snowdrift's wind lattice\n"
           "(bit-identical results) and the sandstorm's grid (within the pressure solver's\n"
           "tolerance) are split over the ranks; rank 0 writes%s; other layers are\n"
           "computed whole on every rank; no checkpoints (docs/mpi.md).\n"
           "Exit codes: 0 success, 1 runtime failure (GL, numerical blow-up), 2 usage/input error.\n",
           simulate ? "simulate" : "render", simulate ? "" : " and renders");
}

/* Options that take a value (so their value is not mistaken for the scene name). */
static bool takes_value(const char *a)
{
    const char *v[] = {"-o", "--size", "--frames", "--duration", "--fps", "--set", "--threads",
                       "--metrics", "--fields", "--samples", "--rasters", "--raster-format",
                       "--checkpoint-every", "--checkpoint", "--resume", NULL};
    for (int i = 0; v[i]; i++)
        if (strcmp(a, v[i]) == 0) return true;
    return false;
}

static bool known_option(const char *a)
{
    const char *v[] = {"-o", "--size", "--frames", "--duration", "--fps", "--set", "--threads",
                       "--metrics", "--fields", "--samples", "--overwrite", "--quiet", "--json",
                       "--reference", "--verbose", "--rasters", "--raster-format",
                       "--checkpoint-every", "--checkpoint", "--resume", NULL};
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

static void format_eta(double s, char *buf, size_t n)
{
    if (!isfinite(s) || s < 0) s = 0;
    int m = (int)(s / 60.0);
    if (m)
        snprintf(buf, n, "%dm%02ds", m, (int)fmod(s, 60.0));
    else
        snprintf(buf, n, "%.0fs", s);
}

/* The live progress line on a terminal. */
static void on_progress(void *user, const sq_run_progress *p)
{
    if (!*(const bool *)user) return;
    char eta[32];
    format_eta(p->eta_s, eta, sizeof eta);
    if (strcmp(p->stage, "reference") == 0)
        fprintf(stderr, "\rsquall: reference frame %d/%d  %3.0f%%  ETA %s   ", p->frame + 1,
                p->frames, 100.0 * (p->fraction * p->frames - p->frame), eta);
    else
        fprintf(stderr, "\rsquall: frame %d/%d  %.2f frames/s  ETA %s   ", p->frame, p->frames,
                p->frames_per_s, eta);
    fflush(stderr);
}

/* Per-metric statistics over the run as one JSON object. */
static void metrics_summary_json(const sq_run *run, sq_json *j)
{
    char buf[6144];
    size_t len = (size_t)snprintf(buf, sizeof buf, "{");
    for (int i = 0; i < sq_run_metric_count(run) && len < sizeof buf - 200; i++) {
        sq_run_metric_stats st;
        if (sq_run_metric_stats_get(run, i, &st) != SQ_OK || st.count == 0) continue;
        len += (size_t)snprintf(buf + len, sizeof buf - len,
                                "%s\"%s\": {\"min\": %.6g, \"median\": %.6g, \"max\": %.6g, "
                                "\"mean\": %.6g, \"last\": %.6g, \"unit\": \"%s\"}",
                                len > 1 ? ", " : "", st.name, st.min, st.median, st.max, st.mean,
                                isfinite(st.last) ? st.last : 0.0, st.unit);
    }
    if (len < sizeof buf) snprintf(buf + len, sizeof buf - len, "}");
    sq_json_raw(j, "metrics", buf);
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
    const char *resume = sq_cli_value(argc, argv, "--resume");
    if (resume && scene_arg) {
        sq_cli_error("--resume %s: the scene comes from the checkpoint; do not name one ('%s')",
                     resume, scene_arg);
        return SQ_EXIT_USAGE;
    }
    if (!scene_arg) scene_arg = sq_preset_default();
    double ck_every = 0.0;
    if (!sq_cli_double(argc, argv, "--checkpoint-every", 0.0, 0.0, 1e12, &ck_every))
        return SQ_EXIT_USAGE;
    if (sq_cli_value(argc, argv, "--checkpoint-every") && !(ck_every > 0.0)) {
        sq_cli_error("--checkpoint-every %s: must be > 0 simulated seconds",
                     sq_cli_value(argc, argv, "--checkpoint-every"));
        return SQ_EXIT_USAGE;
    }
    if (sq_par_size() > 1 && (resume || ck_every > 0.0)) {
        sq_cli_error("%s: checkpoints of a run split over %d ranks are not supported; run "
                     "with one rank (without mpirun) to write or resume checkpoints",
                     resume ? "--resume" : "--checkpoint-every", sq_par_size());
        return SQ_EXIT_USAGE;
    }
    const char *ck_path = sq_cli_value(argc, argv, "--checkpoint");
    if (!ck_path) ck_path = "squall.ckpt";
    const bool overwrite = sq_cli_flag(argc, argv, "--overwrite");
    const bool quiet = sq_cli_flag(argc, argv, "--quiet");
    const bool json = sq_cli_flag(argc, argv, "--json");
    const bool reference = !simulate && sq_cli_flag(argc, argv, "--reference");
    int samples = 0;
    if (!sq_cli_int(argc, argv, "--samples", 64, -1000000, 1000000, &samples)) return SQ_EXIT_USAGE;
    const char *rasters = sq_cli_value(argc, argv, "--rasters");
    const char *rfmt = sq_cli_value(argc, argv, "--raster-format");
    if (rfmt && strcmp(rfmt, "tif") != 0 && strcmp(rfmt, "asc") != 0) {
        sq_cli_error("--raster-format %s: must be tif (GeoTIFF) or asc (ESRI ASCII grid)", rfmt);
        return SQ_EXIT_USAGE;
    }
    const int raster_format = rfmt && strcmp(rfmt, "asc") == 0 ? SQ_RASTER_ASCII : SQ_RASTER_GEOTIFF;
    bool rasters_created = false;
    double raster_s = 0.0;
    if (reference && samples <= 0) {
        sq_cli_error("--samples %d: the reference path tracer needs at least 1 sample per pixel",
                     samples);
        return SQ_EXIT_USAGE;
    }

    sq_context *ctx = NULL;
    if (sq_cli_context(argc, argv, &ctx) != SQ_OK) return SQ_EXIT_USAGE;
    /* Ctrl-C is answered from here on: loading, terrain generation, layer creation and
     * stepping poll the context's interrupt callback, the run its cancel_flag */
    sq_cli_catch_interrupts();
    sq_cfg *cfg = NULL;
    sq_checkpoint_info ck_info;
    memset(&ck_info, 0, sizeof ck_info);
    sq_result r = resume ? sq_checkpoint_read_header(ctx, resume, &ck_info, &cfg)
                         : sq_cfg_load(ctx, scene_arg, &cfg);
    if (r != SQ_OK) {
        sq_context_destroy(ctx);
        return fail(r, NULL);
    }
    /* command-line overrides become cfg assignments, so they are checked by the same tables */
    char set[1200];
    int rc = SQ_EXIT_OK;
    for (int i = 1; i < argc && r == SQ_OK; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        set[0] = 0;
        /* a resumed run continues the same simulation: only outputs may change, not the
         * physics, nor the frame clock (fps, steps per frame, time scale, warm-up) */
        if (resume && (strcmp(a, "--fps") == 0 ||
                       (strcmp(a, "--set") == 0 &&
                        (strncmp(v, "output.", 7) != 0 || strncmp(v, "output.fps", 10) == 0 ||
                         strncmp(v, "output.steps_per_frame", 22) == 0 ||
                         strncmp(v, "output.time_scale", 17) == 0 ||
                         strncmp(v, "output.warmup_s", 15) == 0)))) {
            sq_cli_error("%s %s: cannot change this when resuming from '%s': the run would not "
                         "continue the same simulation (only output settings may change)",
                         a, v, resume);
            rc = SQ_EXIT_USAGE;
            break;
        }
        /* a path option's value becomes a --set: its text is blamed on the option */
        if ((strcmp(a, "-o") == 0 && !simulate) || strcmp(a, "--metrics") == 0 ||
            strcmp(a, "--fields") == 0)
            r = sq_cfg_check_text(a, v);
        if (r != SQ_OK) break;
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
        sq_context_destroy(ctx);
        return rc != SQ_EXIT_OK ? rc : fail(r, NULL);
    }

    sq_scene_desc sd = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                        .load_dem = sq_dem_load, .load_area = sq_area_load,
                        .load_wrf_world = sq_scene_wrf_world_loader,
                        .load_mesh = sq_scene_mesh_loader};
    sq_scene *scene = NULL;
    r = sq_scene_create(ctx, &sd, &scene);
    if (r == SQ_OK && resume) r = sq_checkpoint_restore(ctx, resume, scene, &ck_info);
    /* a checkpoint being written when its run was killed left a temporary next to it */
    if (r == SQ_OK && resume) sq_output_remove_stale(ctx, resume, false);
    r = sq_par_agree(r); /* a distributed run: every rank stops with the first failure */
    if (r == SQ_OK && resume && ck_info.frame >= sq_scene_frame_count(scene))
        r = sq_set_error(SQ_ERR_INVALID_ARG,
                         "--resume %s: the checkpoint is at frame %d; the scene has %d frames "
                         "(more with --frames)",
                         resume, ck_info.frame, sq_scene_frame_count(scene));
    if (r != SQ_OK) {
        sq_scene_destroy(scene);
        sq_cfg_destroy(cfg);
        sq_context_destroy(ctx);
        return fail(r, NULL);
    }
    const sq_scene_output *out = sq_scene_output_settings(scene);
    const int W = out->width, H = out->height, N = sq_scene_frame_count(scene);
    const char *video = !simulate && out->video[0] ? out->video : NULL;
    const char *frames_dir = !simulate && out->frames_dir[0] ? out->frames_dir : NULL;
    const char *metrics_path = out->metrics[0] ? out->metrics : NULL;
    sq_run *run = NULL;
    /* a distributed run (mpirun): the snowdrift's wind lattice and the sandstorm's grid are
     * split over the ranks; rank 0 renders and writes from the gathered fields, the others only
     * step (docs/mpi.md) */
    const bool root = sq_par_rank() == 0;
    if (sq_par_size() > 1 && root && !quiet) {
        for (int i = 0; i < sq_scene_layer_count(scene); i++)
            if (strcmp(sq_scene_layer_type(scene, i), "snowdrift") != 0 &&
                strcmp(sq_scene_layer_type(scene, i), "sandstorm") != 0)
                fprintf(stderr, "squall: warning: layer '%s' (%s) is not split over the %d "
                        "ranks: every rank computes it whole (the same answer, no speed-up)\n",
                        sq_scene_layer_name(scene, i), sq_scene_layer_type(scene, i),
                        sq_par_size());
        fprintf(stderr, "squall: %d ranks; rank 0 %s the outputs\n", sq_par_size(),
                simulate ? "writes" : "renders and writes");
    }
    if (rasters && !root) rasters = NULL; /* rank 0 writes them */
    if (rasters) {
        const char *const others[][2] = {
            {"the metrics (output.metrics)", metrics_path},
            {"the video (output.video)", video},
            {"the checkpoint (--checkpoint)", ck_every > 0.0 ? ck_path : NULL},
            {NULL, NULL}};
        r = sq_cli_rasters_check(ctx, scene, rasters, raster_format, overwrite, others,
                                 &rasters_created);
        if (r != SQ_OK) {
            rc = fail(r, NULL);
            goto done;
        }
    }

    /* the frame loop, its outputs and their safety rules are the library's (squall/run.h) */
    bool tty = isatty(2) && !quiet && root;
    sq_run_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.scene = scene;
    rd.render = simulate || !root ? SQ_RUN_SIMULATE : reference ? SQ_RUN_REFERENCE : SQ_RUN_GL;
    rd.reference_samples = samples;
    rd.write_outputs = root;
    rd.overwrite = overwrite;
    rd.cancel_flag = &sq_cli_interrupted_flag;
    rd.checkpoint_every_s = ck_every;
    rd.checkpoint_path = ck_path;
    rd.checkpoint_cfg = cfg;
    rd.resume_frame = resume ? ck_info.frame : 0;
    {
        struct stat a, b;
        rd.checkpoint_replaces = resume && stat(resume, &a) == 0 && stat(ck_path, &b) == 0 &&
                                 a.st_dev == b.st_dev && a.st_ino == b.st_ino;
    }
    /* a first run in a fresh directory: the default video's directory (out/) is made */
    if (video && !simulate && root) {
        size_t nt = 0;
        const sq_param *vp = sq_params_find(sq_scene_section_params("output", &nt), nt, "video");
        const char *slash = strrchr(video, '/');
        if (vp && vp->def_text && strcmp(video, vp->def_text) == 0 && slash) {
            char dir[256];
            snprintf(dir, sizeof dir, "%.*s", (int)(slash - video), video);
            if (mkdir(dir, 0777) == 0 && !quiet)
                fprintf(stderr, "squall: made '%s/' for the default output\n", dir);
        }
    }
    rd.progress = on_progress;
    rd.user = &tty;
    r = sq_par_agree(sq_run_create(ctx, &rd, &run));
    if (r == SQ_OK) r = sq_run_execute(run);
    if (tty && r != SQ_OK) fprintf(stderr, "\n");
    if (r == SQ_OK) r = sq_run_finish(run);
    r = sq_par_agree(r);
    if (r == SQ_OK && rasters) {
        sq_metric mv[128];
        const int nm = sq_scene_metrics(scene, mv, 128);
        r = sq_cli_rasters_write(ctx, scene, rasters, raster_format, overwrite, mv, nm, &raster_s);
    }
    r = sq_par_agree(r);
    if (r != SQ_OK) {
        rc = fail(r, NULL);
        goto done;
    }
    if (tty) fprintf(stderr, "\n");
    if (root) {
        const double el = sq_run_elapsed_s(run);
        if (!quiet) {
            fprintf(stderr, "squall: %s %d frame%s of '%s' in %.1f s (%.2f frames/s)",
                    simulate ? "simulated" : "rendered", N, N == 1 ? "" : "s", sq_scene_name(scene),
                    el, N / (el > 0 ? el : 1e-9));
            if (video) fprintf(stderr, " -> %s", video);
            if (frames_dir) fprintf(stderr, " -> %s%s", frames_dir, dir_slash(frames_dir));
            if (metrics_path) fprintf(stderr, " (metrics %s)", metrics_path);
            if (rasters)
                fprintf(stderr, " (rasters %s%s, written in %.2f s)", rasters, dir_slash(rasters),
                        raster_s);
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
            sq_json_str(&j, "rasters_dir", rasters ? rasters : "");
            sq_json_num(&j, "rasters_seconds", raster_s);
            metrics_summary_json(run, &j);
            sq_json_end(&j, stdout);
        } else if (!quiet && video) {
            printf("%s\n", video);
        }
    }
done:
    if (rc != SQ_EXIT_OK && rasters_created) sq_cli_rasters_discard(rasters, scene, raster_format);
    sq_run_destroy(run);
    sq_scene_destroy(scene);
    sq_cfg_destroy(cfg);
    sq_context_destroy(ctx);
    return rc;
}
