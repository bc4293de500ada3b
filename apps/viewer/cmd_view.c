/* cmd_view.c — `squall view [SCENE|PRESET]`: a GTK 4 window whose GtkGLArea (OpenGL 4.5 core)
 * shows the scene drawn by the library's renderer straight into the widget's framebuffer
 * (sq_run in pumped mode: SQ_RUN_GL_CURRENT_CONTEXT + sq_run_draw_to), while the simulation
 * advances on its own thread (view_sim.c) at the scene's time scale and the drawing shows the
 * latest frame. `--frames N --screenshot FILE.png` runs N frames in the window, writes the last
 * one and exits (for scripts and tests). Here: options, the scene and run, the window and the
 * GL area's callbacks. */
#include <epoxy/gl.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../cli/cli.h"
#include "../cli/commands.h"
#include "squall/wrf.h"
#include "view.h"

#define VIEW_INTERACTIVE_FRAMES 1000000 /* output.frames' upper limit: 11.5 h at 24 fps */

static void view_usage(void)
{
    printf("usage: squall view [SCENE.yaml|PRESET] [options]\n\n"
           "Opens a window that runs the scene: the simulation steps on its own thread at the\n"
           "scene's time scale (output.time_scale simulated seconds per second) and the window\n"
           "draws the latest state with the OpenGL renderer. Without SCENE: %s.\n\n"
           "options:\n"
           "  --size WxH           drawing area in pixels (default: output.width x height)\n"
           "  --set KEY=VALUE      override any scene key, as for squall render\n"
           "  --paused             start paused (after the warm-up frame)\n"
           "  --frames N           run N frames (frame 0 = after the warm-up), then exit\n"
           "  --screenshot FILE    with --frames: write the last frame as PNG (safe output)\n"
           "  --script FILE        timed actions: wait N, set KEY VALUE, send KEY VALUE, screenshot F,\n"
           "                       save F, panel-keys SECTION F, orbit N, pause, run, step, quit\n"
           "                       (docs/viewer.md)\n"
           "  --no-panel           hide the parameter panel (P toggles it)\n"
           "  --full-res           always draw at full size (default: while the camera moves or\n"
           "                       a live change is made, draw smaller and scale up; still: full)\n"
           "  --overwrite          replace existing screenshots and saved files\n"
           "  --threads N          simulation worker threads (default: OMP_NUM_THREADS, else all cores)\n"
           "  --json               at exit, one JSON line: draw and simulation rates of the run\n"
           "  --quiet              only errors\n\n"
           "keys: Space pause/run, N single step, R reset, +/- speed, Tab orbit/fly camera,\n"
           "      C back to the scene's camera path, F frame the phenomenon, W A S D Q E move,\n"
           "      mouse drag look/turn, wheel zoom (orbit) or speed (fly), H HUD, P panel,\n"
           "      V record MP4 (view-record.mp4), Ctrl+S save the scene (view-saved.yaml), Esc quit.\n"
           "See docs/viewer.md. Exit codes: 0 success, 1 runtime failure (no display, GL),\n"
           "2 usage or input error.\n",
           sq_preset_default());
}

static bool takes_value(const char *a)
{
    const char *v[] = {"--size", "--set", "--frames", "--screenshot", "--threads", "--script",
                       NULL};
    for (int i = 0; v[i]; i++)
        if (strcmp(a, v[i]) == 0) return true;
    return false;
}

static bool known_option(const char *a)
{
    const char *v[] = {"--size", "--set", "--frames", "--screenshot", "--threads", "--overwrite",
                       "--quiet", "--verbose", "--paused", "--script", "--no-panel", "--json", "--full-res",
                       NULL};
    for (int i = 0; v[i]; i++)
        if (strcmp(a, v[i]) == 0 || (strncmp(a, v[i], strlen(v[i])) == 0 && a[strlen(v[i])] == '='))
            return true;
    return false;
}

static int fail(sq_result r)
{
    const char *e = sq_last_error();
    sq_cli_error("%s", e && *e ? e : sq_result_name(r));
    return sq_cli_exit_code(r);
}

/* ---- scene and run ------------------------------------------------------------------------- */

/* The run's scene: a copy of the user's cfg with the frame count of the viewer (the user's cfg
 * stays as the user wrote it, for saving). */
sq_cfg *view_run_cfg(viewer *v, const char *assignment, sq_result *res)
{
    *res = SQ_OK;
    char *yaml = sq_cfg_to_yaml(v->cfg);
    if (!yaml) {
        *res = sq_set_error(SQ_ERR_OUT_OF_MEMORY, "view: cannot copy the scene");
        return NULL;
    }
    sq_cfg *copy = NULL;
    sq_result r = sq_cfg_parse(v->ctx, yaml, strlen(yaml), v->cfg->source, &copy);
    free(yaml);
    if (r == SQ_OK) {
        snprintf(copy->base_dir, sizeof copy->base_dir, "%s", v->cfg->base_dir);
        char set[64];
        snprintf(set, sizeof set, "output.frames=%d",
                 v->frames > 0 ? v->frames : VIEW_INTERACTIVE_FRAMES);
        r = sq_cfg_set(copy, set);
    }
    if (r == SQ_OK && assignment) r = sq_cfg_set(copy, assignment);
    if (r != SQ_OK) {
        sq_cfg_destroy(copy);
        *res = r;
        return NULL;
    }
    return copy;
}

sq_scene_desc view_scene_desc(const sq_cfg *cfg)
{
    /* the loaders of `squall render`: heightmaps, DEMs and areas, WRF worlds, mesh files */
    sq_scene_desc sd = {.cfg = cfg, .load_heightmap = sq_scene_heightmap_loader,
                        .load_dem = sq_dem_load, .load_area = sq_area_load,
                        .load_wrf_world = sq_scene_wrf_world_loader,
                        .load_mesh = sq_scene_mesh_loader};
    return sd;
}

/* Bounds of the phenomena's fields (for "frame the phenomenon"), read before the thread starts. */
static void phenomenon_box(viewer *v)
{
    v->have_box = false;
    for (int i = 0; i < sq_scene_layer_count(v->scene); i++) {
        sq_phenomenon *p = sq_scene_layer(v->scene, i);
        sq_named_field f;
        if (!p || sq_phenomenon_field_count(p) < 1 || sq_phenomenon_field(p, 0, &f) != SQ_OK)
            continue;
        const sq_vec3 lo = sq_v3(f.origin_m.x - 0.5f * f.spacing_m.x,
                                 f.origin_m.y - 0.5f * f.spacing_m.y,
                                 f.origin_m.z - 0.5f * f.spacing_m.z);
        const sq_vec3 hi = sq_v3(lo.x + f.nx * f.spacing_m.x, lo.y + f.ny * f.spacing_m.y,
                                 lo.z + (f.nz > 1 ? f.nz : 1) * f.spacing_m.z);
        if (!v->have_box) {
            v->box_lo = lo;
            v->box_hi = hi;
        } else {
            v->box_lo = sq_v3(fminf(v->box_lo.x, lo.x), fminf(v->box_lo.y, lo.y), fminf(v->box_lo.z, lo.z));
            v->box_hi = sq_v3(fmaxf(v->box_hi.x, hi.x), fmaxf(v->box_hi.y, hi.y), fmaxf(v->box_hi.z, hi.z));
        }
        v->have_box = true;
    }
}

static sq_result start_run(viewer *v)
{
    sq_result r;
    sq_cfg *copy = view_run_cfg(v, NULL, &r); /* the run's scene: the live changes' base */
    if (!copy) return r;
    const sq_scene_desc sd = view_scene_desc(copy);
    r = sq_scene_create(v->ctx, &sd, &v->scene);
    if (r != SQ_OK) {
        sq_cfg_destroy(copy);
        return r;
    }
    phenomenon_box(v);
    const sq_scene_output *o = sq_scene_output_settings(v->scene);
    v->sim = view_sim_create(o->fps, o->steps_per_frame);
    if (!v->sim) {
        sq_cfg_destroy(copy);
        return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "view: no memory for the simulation");
    }
    view_sim_set_scene(v->sim, v->ctx, copy, &sd);
    sq_run_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.scene = v->scene;
    rd.render = SQ_RUN_GL_CURRENT_CONTEXT;
    rd.snapshot = true; /* advance (simulation thread) and draw_to (GTK thread) overlap */
    rd.sinks = view_sim_sinks(v->sim);
    r = sq_run_create(v->ctx, &rd, &v->run);
    if (r != SQ_OK) return r;
    if (v->cam.mode != VIEW_CAM_PATH) {
        const sq_camera c = view_camera_get(&v->cam);
        sq_run_set_camera(v->run, &c);
    }
    if (!view_sim_start(v->sim, v->run, v->paused_start))
        return sq_set_error(SQ_ERR_INTERNAL, "view: cannot start the simulation thread");
    v->drawn_frames = 0;
    v->redraw = true;
    return SQ_OK;
}

/* Destroys a run whose thread has stopped: the run (its renderer in the GL area's context), then
 * its scene. */
static void free_run(viewer *v, view_sim *sim, sq_run *run, sq_scene *scene)
{
    view_sim_destroy(sim);
    if (run) {
        if (v->area && gtk_widget_get_realized(v->area))
            gtk_gl_area_make_current(GTK_GL_AREA(v->area));
        sq_run_destroy(run);
    }
    sq_scene_destroy(scene);
}

/* Frees the given-up runs whose threads have finished their step (all: waits for them). */
static void reap_retired(viewer *v, bool all)
{
    int kept = 0;
    for (int i = 0; i < v->retired_count; i++) {
        struct view_retired *r = &v->retired[i];
        if (all || view_sim_stopped(r->sim)) free_run(v, r->sim, r->run, r->scene);
        else v->retired[kept++] = *r;
    }
    v->retired_count = kept;
}

/* Gives up the run: its thread is asked to stop after the step under way and the run is freed by
 * a later tick (wait: now, waiting for the step; at exit, or when 8 wait already). */
static void stop_run(viewer *v, bool wait)
{
    if (v->area && gtk_widget_get_realized(v->area)) {
        gtk_gl_area_make_current(GTK_GL_AREA(v->area));
        view_dynres_free(v);
    }
    if (!wait && v->sim && v->retired_count < (int)(sizeof v->retired / sizeof v->retired[0])) {
        view_sim_stop(v->sim);
        v->retired[v->retired_count++] = (struct view_retired){v->sim, v->run, v->scene};
    } else {
        free_run(v, v->sim, v->run, v->scene);
    }
    v->sim = NULL;
    v->run = NULL;
    v->scene = NULL;
}

sq_result view_rebuild(viewer *v)
{
    stop_run(v, false); /* the old thread finishes its step on its own: no wait here */
    v->live_pending = false; /* a live change not yet applied went with the old run */
    v->live_held = false;
    v->live_outstanding = 0;
    const sq_result r = start_run(v);
    if (r != SQ_OK) {
        const char *e = sq_last_error();
        snprintf(v->gl_error, sizeof v->gl_error, "%s", e && *e ? e : sq_result_name(r));
    }
    return r;
}

/* ---- the GL area ----------------------------------------------------------------------------- */

static void on_realize(GtkGLArea *area, gpointer user)
{
    viewer *v = (viewer *)user;
    gtk_gl_area_make_current(area);
    GError *e = gtk_gl_area_get_error(area);
    if (e) {
        snprintf(v->gl_error, sizeof v->gl_error, "no OpenGL 4.5 core context for the window: %s",
                 e->message);
        return;
    }
    GdkGLContext *c = gtk_gl_area_get_context(area);
    int maj = 0, min = 0;
    gdk_gl_context_get_version(c, &maj, &min);
    if (maj * 10 + min < 45 || gdk_gl_context_get_use_es(c))
        snprintf(v->gl_error, sizeof v->gl_error,
                 "the window's OpenGL context is %s %d.%d; the renderer needs OpenGL 4.5 core",
                 gdk_gl_context_get_use_es(c) ? "OpenGL ES" : "OpenGL", maj, min);
}

static void on_resize(GtkGLArea *area, int width, int height, gpointer user)
{
    (void)area;
    viewer *v = (viewer *)user;
    v->fb_width = width;
    v->fb_height = height;
    v->redraw = true;
}

static gboolean on_render(GtkGLArea *area, GdkGLContext *context, gpointer user)
{
    (void)context;
    viewer *v = (viewer *)user;
    view_param_poll(v, true); /* a live change applied since the last tick is drawn now */
    const int frames = v->run ? sq_run_frame_index(v->run) : 0;
    if (v->gl_error[0] || !v->run || frames == 0 || v->fb_width < 1 || v->fb_height < 1) {
        glClearColor(0.18f, 0.18f, 0.2f, 1.0f); /* before the warm-up frame, or after an error */
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        return TRUE;
    }
    GLint fbo = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &fbo);
    const double t0 = sq_time_now();
    /* moving: a reduced draw scaled up (view_dynres.c); still, a screenshot or recording: full */
    const float scale = view_dynres_scale(v, t0);
    unsigned dfbo = 0;
    int dw = 0, dh = 0;
    const bool reduced = scale < 1.0f && view_dynres_target(v, scale, &dfbo, &dw, &dh);
    sq_render_target t = {reduced ? dfbo : (unsigned)fbo, reduced ? dw : v->fb_width,
                          reduced ? dh : v->fb_height, SQ_TARGET_FRAME, SQ_TARGET_DISPLAY};
    /* the renderer writes colour, never alpha: GTK composites the area's texture with its
     * alpha, so it must be opaque */
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    if (reduced) {
        const float black[4] = {0.0f, 0.0f, 0.0f, 1.0f};
        glClearNamedFramebufferfv(dfbo, GL_COLOR, 0, black);
        glClearNamedFramebufferfi(dfbo, GL_DEPTH_STENCIL, 0, 1.0f, 0);
    }
    const sq_result r = sq_run_draw_to(v->run, &t);
    if (r == SQ_OK && reduced) {
        view_dynres_finish(v, (unsigned)fbo);
        glBindFramebuffer(GL_FRAMEBUFFER, (GLuint)fbo);
    }
    if (r != SQ_OK) {
        const char *e = sq_last_error();
        snprintf(v->gl_error, sizeof v->gl_error, "drawing frame %d: %s", frames - 1,
                 e && *e ? e : sq_result_name(r));
        return TRUE;
    }
    view_record_frame(v, frames - 1);
    if (v->shot_pending && frames >= v->shot_frame) {
        const sq_result s = view_shot_write(v, v->shot_path, v->fb_width, v->fb_height);
        v->shot_pending = false;
        if (s != SQ_OK) {
            const char *e = sq_last_error();
            snprintf(v->gl_error, sizeof v->gl_error, "%s", e && *e ? e : sq_result_name(s));
            v->exit_code = sq_cli_exit_code(s);
        } else {
            v->shot_done = true;
            v->shot_scale = reduced ? scale : 1.0f;
            v->shot_as_shown = false;
        }
    }
    glFinish(); /* the draw time below is the GL work, not only its submission */
    const double t1 = sq_time_now(), ms = (t1 - t0) * 1e3;
    if (v->draw_count++ == 0) v->t_first_draw_s = t1;
    v->draw_ms_sum += ms;
    if (v->lat_pending && v->lat_armed) {
        v->lat_pending = false;
        printf("shown %s after %.1f ms: draw %d after the change (%d simulation frames advanced "
               "in between)\n",
               v->lat_key, (t1 - v->lat_t0_s) * 1e3, v->draw_count - v->lat_draws0,
               v->lat_frame0 < 0 ? frames : frames - v->lat_frame0);
        fflush(stdout);
    }
    v->draw_ms = v->draw_ms > 0 ? 0.8 * v->draw_ms + 0.2 * ms : ms;
    v->last_scale = reduced ? scale : 1.0f;
    v->dyn_refine = reduced;
    if (reduced) {
        v->draw_count_reduced++;
        v->draw_ms_sum_reduced += ms;
        v->dyn_scale_sum += (double)scale;
        view_dynres_adapt(v, ms);
    } else {
        v->draw_ms_full = v->draw_ms_full > 0 ? 0.8 * v->draw_ms_full + 0.2 * ms : ms;
    }
    v->drawn_frames = frames;
    v->fps_count++;
    (void)area;
    return TRUE;
}

/* Every display frame: camera keys, then a draw when there is a new frame or a change. */
static gboolean on_tick(GtkWidget *w, GdkFrameClock *clock, gpointer user)
{
    (void)w;
    (void)clock;
    viewer *v = (viewer *)user;
    const double now = sq_time_now();
    view_param_poll(v, false); /* a live change's outcome: panel, refusal, rebuild */
    if (v->retired_count) reap_retired(v, false);
    view_input_tick(v, now);
    /* still again after reduced draws: once more at full size */
    const bool refine = v->dyn_refine && view_dynres_scale(v, now) >= 1.0f;
    if (v->run && (v->redraw || refine || sq_run_frame_index(v->run) != v->drawn_frames)) {
        v->dyn_refine = false;
        v->redraw = false;
        gtk_gl_area_queue_render(GTK_GL_AREA(v->area));
    }
    if (now - v->fps_t0 >= 1.0) {
        v->fps = v->fps_count / (now - v->fps_t0);
        v->fps_count = 0;
        v->fps_t0 = now;
    }
    if (v->script && !v->quit && v->fb_width > 0) view_script_tick(v, v->script);
    /* --frames N: done when the last frame is drawn (and written) */
    if (v->frames > 0 && !v->quit && !v->script) {
        view_sim_stats st;
        view_sim_stats_get(v->sim, &st);
        if (st.error[0]) {
            sq_cli_error("%s", st.error);
            v->exit_code = SQ_EXIT_RUNTIME;
            v->quit = true;
        } else if (v->gl_error[0]) {
            sq_cli_error("%s", v->gl_error);
            if (v->exit_code == SQ_EXIT_OK) v->exit_code = SQ_EXIT_RUNTIME;
            v->quit = true;
        } else if (st.done && v->drawn_frames >= v->frames && !v->shot_pending) {
            v->quit = true;
        }
    }
    return G_SOURCE_CONTINUE;
}

static gboolean on_hud_timer(gpointer user)
{
    view_hud_update((viewer *)user);
    return G_SOURCE_CONTINUE;
}

static gboolean on_close(GtkWindow *w, gpointer user)
{
    (void)w;
    ((viewer *)user)->quit = true;
    return TRUE; /* the main loop below tears down in order */
}

static void build_window(viewer *v)
{
    v->window = gtk_window_new();
    gtk_window_set_title(GTK_WINDOW(v->window), "squall view");
    gtk_window_set_default_size(GTK_WINDOW(v->window), v->width + (v->panel_on ? 400 : 0),
                                v->height);
    g_signal_connect(v->window, "close-request", G_CALLBACK(on_close), v);

    GtkWidget *overlay = gtk_overlay_new();
    v->area = gtk_gl_area_new();
    gtk_gl_area_set_required_version(GTK_GL_AREA(v->area), 4, 5);
    gtk_gl_area_set_has_depth_buffer(GTK_GL_AREA(v->area), TRUE);
    gtk_gl_area_set_auto_render(GTK_GL_AREA(v->area), FALSE);
    gtk_widget_set_size_request(v->area, v->width, v->height);
    gtk_widget_set_hexpand(v->area, TRUE);
    gtk_widget_set_vexpand(v->area, TRUE);
    gtk_widget_set_focusable(v->area, TRUE);
    g_signal_connect(v->area, "realize", G_CALLBACK(on_realize), v);
    g_signal_connect(v->area, "resize", G_CALLBACK(on_resize), v);
    g_signal_connect(v->area, "render", G_CALLBACK(on_render), v);
    gtk_overlay_set_child(GTK_OVERLAY(overlay), v->area);

    v->hud = gtk_label_new("");
    gtk_widget_add_css_class(v->hud, "squall-hud");
    gtk_widget_set_halign(v->hud, GTK_ALIGN_START);
    gtk_widget_set_valign(v->hud, GTK_ALIGN_START);
    gtk_widget_set_can_target(v->hud, FALSE);
    gtk_overlay_add_overlay(GTK_OVERLAY(overlay), v->hud);
    v->message = gtk_label_new("");
    gtk_widget_add_css_class(v->message, "squall-message");
    gtk_label_set_wrap(GTK_LABEL(v->message), TRUE);
    gtk_widget_set_halign(v->message, GTK_ALIGN_CENTER);
    gtk_widget_set_valign(v->message, GTK_ALIGN_END);
    gtk_widget_set_can_target(v->message, FALSE);
    gtk_widget_set_visible(v->message, FALSE);
    gtk_overlay_add_overlay(GTK_OVERLAY(overlay), v->message);

    GtkCssProvider *css = gtk_css_provider_new();
    gtk_css_provider_load_from_data(
        css,
        ".squall-hud { font-family: monospace; font-size: 10pt; color: #f0f0f0;"
        " background-color: rgba(0,0,0,0.55); padding: 6px; margin: 6px; border-radius: 4px; }"
        ".squall-message { color: #fff; background-color: rgba(160,20,20,0.85); padding: 8px;"
        " margin: 12px; border-radius: 4px; }"
        ".squall-error { color: #c01c28; }",
        -1);
    gtk_style_context_add_provider_for_display(gdk_display_get_default(),
                                               GTK_STYLE_PROVIDER(css),
                                               GTK_STYLE_PROVIDER_PRIORITY_APPLICATION);
    g_object_unref(css);

    GtkWidget *paned = gtk_paned_new(GTK_ORIENTATION_HORIZONTAL);
    gtk_paned_set_start_child(GTK_PANED(paned), overlay);
    gtk_paned_set_resize_start_child(GTK_PANED(paned), TRUE);
    gtk_paned_set_shrink_start_child(GTK_PANED(paned), FALSE);
    v->panel = view_panel_build(v);
    gtk_paned_set_end_child(GTK_PANED(paned), v->panel);
    gtk_paned_set_resize_end_child(GTK_PANED(paned), FALSE);
    gtk_paned_set_shrink_end_child(GTK_PANED(paned), FALSE);
    gtk_widget_set_visible(v->panel, v->panel_on);
    gtk_window_set_child(GTK_WINDOW(v->window), paned);
    view_input_attach(v);
    gtk_widget_add_tick_callback(v->area, on_tick, v, NULL);
    g_timeout_add(250, on_hud_timer, v);
}

/* ---- the command ------------------------------------------------------------------------------ */

/* --json: the rates of this run (frame 0, the warm-up, is not in the simulation rate). */
static void print_json(viewer *v)
{
    view_sim_stats st;
    view_sim_stats_get(v->sim, &st);
    const double now = sq_time_now();
    const double draw_wall = now - v->t_first_draw_s;
    const double sim_frames = st.frames > 1 ? st.frames - 1 : 0;
    const char *gl = v->area && gtk_widget_get_realized(v->area) ? "" : "none";
    char renderer[160] = "";
    if (!*gl) {
        gtk_gl_area_make_current(GTK_GL_AREA(v->area));
        snprintf(renderer, sizeof renderer, "%s", (const char *)glGetString(GL_RENDERER));
    }
    sq_json j;
    sq_json_begin(&j);
    sq_json_str(&j, "command", "view");
    sq_json_str(&j, "scene", v->scene ? sq_scene_name(v->scene) : "");
    sq_json_int(&j, "width", v->fb_width);
    sq_json_int(&j, "height", v->fb_height);
    sq_json_str(&j, "gl_renderer", renderer);
    sq_json_int(&j, "frames", st.frames);
    sq_json_int(&j, "steps_per_frame", st.steps_per_frame);
    sq_json_num(&j, "simulated_s", st.sim_time_s);
    sq_json_int(&j, "draws", v->draw_count);
    sq_json_num(&j, "draw_ms_mean", v->draw_count ? v->draw_ms_sum / v->draw_count : (double)NAN);
    sq_json_num(&j, "draws_per_s", v->draw_count > 1 && draw_wall > 0 ? (v->draw_count - 1) / draw_wall : (double)NAN);
    sq_json_num(&j, "draw_fps_max", v->draw_count ? 1e3 * v->draw_count / v->draw_ms_sum : (double)NAN);
    sq_json_num(&j, "sim_steps_per_s", st.t_last_s > st.t_frame0_s ? sim_frames * st.steps_per_frame / (st.t_last_s - st.t_frame0_s) : (double)NAN);
    sq_json_num(&j, "sim_steps_per_busy_s", st.busy_s > 0 ? sim_frames * st.steps_per_frame / st.busy_s : (double)NAN);
    sq_json_num(&j, "sim_frames_per_s", st.t_last_s > st.t_frame0_s ? sim_frames / (st.t_last_s - st.t_frame0_s) : (double)NAN);
    sq_json_num(&j, "scene_fps", (double)sq_scene_output_settings(v->scene)->fps);
    const int full = v->draw_count - v->draw_count_reduced;
    sq_json_int(&j, "draws_full", full);
    sq_json_num(&j, "draw_ms_full_mean",
                full > 0 ? (v->draw_ms_sum - v->draw_ms_sum_reduced) / full : (double)NAN);
    sq_json_int(&j, "draws_reduced", v->draw_count_reduced);
    sq_json_num(&j, "draw_ms_reduced_mean",
                v->draw_count_reduced ? v->draw_ms_sum_reduced / v->draw_count_reduced : (double)NAN);
    sq_json_num(&j, "reduced_scale_mean",
                v->draw_count_reduced ? v->dyn_scale_sum / v->draw_count_reduced : (double)NAN);
    sq_json_num(&j, "shot_scale", v->shot_done ? (double)v->shot_scale : (double)NAN);
    sq_json_end(&j, stdout);
}

static int parse_args(viewer *v, int argc, char **argv)
{
    for (int i = 1; i < argc; i++) {
        if (argv[i][0] == '-') {
            if (!known_option(argv[i])) {
                sq_cli_error("unknown option '%s' (see squall view --help)", argv[i]);
                return SQ_EXIT_USAGE;
            }
            if (takes_value(argv[i])) {
                if (i + 1 >= argc) {
                    sq_cli_error("%s needs a value (see squall view --help)", argv[i]);
                    return SQ_EXIT_USAGE;
                }
                i++;
            }
            continue;
        }
        if (v->scene_arg) {
            sq_cli_error("more than one scene given ('%s' and '%s')", v->scene_arg, argv[i]);
            return SQ_EXIT_USAGE;
        }
        v->scene_arg = argv[i];
    }
    if (!v->scene_arg) v->scene_arg = sq_preset_default();
    v->overwrite = sq_cli_flag(argc, argv, "--overwrite");
    v->paused_start = sq_cli_flag(argc, argv, "--paused");
    v->screenshot = sq_cli_value(argc, argv, "--screenshot");
    v->script_path = sq_cli_value(argc, argv, "--script");
    v->panel_on = !sq_cli_flag(argc, argv, "--no-panel");
    v->json = sq_cli_flag(argc, argv, "--json");
    v->dynres = !sq_cli_flag(argc, argv, "--full-res");
    if (!sq_cli_int(argc, argv, "--frames", 0, 1, VIEW_INTERACTIVE_FRAMES, &v->frames))
        return SQ_EXIT_USAGE;
    if (v->screenshot && v->frames == 0) {
        sq_cli_error("--screenshot %s needs --frames N (the frame to write)", v->screenshot);
        return SQ_EXIT_USAGE;
    }
    const char *size = sq_cli_value(argc, argv, "--size");
    if (size) {
        char tail = 0;
        if (sscanf(size, "%dx%d%c", &v->width, &v->height, &tail) != 2 || v->width < 16 ||
            v->height < 16 || v->width > 8192 || v->height > 8192) {
            sq_cli_error("--size %s: expected WIDTHxHEIGHT, each in 16..8192, e.g. 1280x720", size);
            return SQ_EXIT_USAGE;
        }
    }
    return SQ_EXIT_OK;
}

/* The scene as the CLI loads it: file or preset, --set overrides, every rule checked (with the
 * CLI's messages) before a window opens. */
static int load_scene(viewer *v, int argc, char **argv)
{
    sq_result r = sq_cfg_load(v->ctx, v->scene_arg, &v->cfg);
    if (r != SQ_OK) return fail(r);
    if (!realpath(v->scene_arg, v->scene_real)) v->scene_real[0] = 0;
    for (int i = 1; i < argc && r == SQ_OK; i++)
        if (strcmp(argv[i], "--set") == 0 && i + 1 < argc) r = sq_cfg_set(v->cfg, argv[++i]);
    if (r != SQ_OK) return fail(r);
    sq_scene_desc sd = view_scene_desc(v->cfg);
    sd.validate_only = true;
    sq_scene *check = NULL;
    r = sq_scene_create(v->ctx, &sd, &check);
    if (r != SQ_OK) return fail(r);
    const sq_scene_output *o = sq_scene_output_settings(check);
    if (v->width == 0) {
        v->width = o->width;
        v->height = o->height;
    }
    sq_scene_destroy(check);
    if (v->screenshot) {
        r = view_shot_check(v, v->screenshot);
        if (r == SQ_OK) r = sq_output_check(v->screenshot, v->overwrite);
        if (r != SQ_OK) return fail(r);
        snprintf(v->shot_path, sizeof v->shot_path, "%s", v->screenshot);
        v->shot_pending = true;
        v->shot_frame = v->frames;
    }
    if (v->script_path) {
        const sq_result r2 = view_script_load(v, v->script_path, &v->script);
        if (r2 != SQ_OK) return fail(r2);
    }
    return SQ_EXIT_OK;
}

int sq_cmd_view(int argc, char **argv)
{
    if (sq_cli_flag(argc, argv, "--help") || sq_cli_flag(argc, argv, "-h")) {
        view_usage();
        return SQ_EXIT_OK;
    }
    viewer *v = (viewer *)calloc(1, sizeof *v);
    if (!v) return SQ_EXIT_RUNTIME;
    v->hud_on = true;
    int rc = parse_args(v, argc, argv);
    if (rc == SQ_EXIT_OK && sq_cli_context(argc, argv, &v->ctx) != SQ_OK) rc = SQ_EXIT_USAGE;
    if (rc == SQ_EXIT_OK) rc = load_scene(v, argc, argv);
    /* without a session bus (Xvfb, ssh) GTK's accessibility bridge only prints a warning */
    if (!getenv("DBUS_SESSION_BUS_ADDRESS")) setenv("GTK_A11Y", "none", 0);
    if (rc == SQ_EXIT_OK && !gtk_init_check()) {
        const char *d = getenv("DISPLAY"), *wd = getenv("WAYLAND_DISPLAY");
        sq_cli_error("cannot open a window: no display (DISPLAY=%s, WAYLAND_DISPLAY=%s); run it "
                     "under a desktop session or xvfb-run",
                     d ? d : "unset", wd ? wd : "unset");
        rc = SQ_EXIT_RUNTIME;
    }
    if (rc != SQ_EXIT_OK) goto done;

    build_window(v);
    gtk_window_present(GTK_WINDOW(v->window));
    v->fps_t0 = sq_time_now();
    const sq_result r = start_run(v);
    if (r != SQ_OK) {
        rc = fail(r);
        v->quit = true;
    }
    while (!v->quit) g_main_context_iteration(NULL, TRUE);
    if (v->frames == 0 && v->gl_error[0] && rc == SQ_EXIT_OK) rc = SQ_EXIT_OK;
    if (rc == SQ_EXIT_OK) rc = v->exit_code;
    if (rc == SQ_EXIT_OK && v->json) print_json(v);
    if (v->rec) {
        gtk_gl_area_make_current(GTK_GL_AREA(v->area));
        const sq_result rr = view_record_stop(v);
        if (rr != SQ_OK && rc == SQ_EXIT_OK) rc = fail(rr);
    }
    stop_run(v, true);
    reap_retired(v, true);
    gtk_window_destroy(GTK_WINDOW(v->window));
    view_panel_free(v);
    while (g_main_context_pending(NULL)) g_main_context_iteration(NULL, FALSE);
done:
    view_script_free(v->script);
    sq_cfg_destroy(v->cfg);
    if (v->ctx) sq_context_destroy(v->ctx);
    free(v);
    return rc;
}
