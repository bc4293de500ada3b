/* view_input.c — the viewer's keys, mouse and wheel, and the HUD text (draw rate, simulation
 * steps per second, simulated time, the phenomena's metrics, the state and errors). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "view.h"

enum { K_W, K_A, K_S, K_D, K_Q, K_E, K_SHIFT };

/* The first camera interaction takes over from the scene's path at its current camera. */
static void take_camera(viewer *v, view_cam_mode mode)
{
    if (!v->run) return;
    sq_camera cur = v->cam.mode != VIEW_CAM_PATH ? view_camera_get(&v->cam) : sq_run_camera(v->run);
    view_camera_take(&v->cam, &cur, mode);
}

/* Keeps the eye above the ground (the renderer refuses a camera inside the terrain). */
static void apply_camera(viewer *v)
{
    if (!v->run || v->cam.mode == VIEW_CAM_PATH) return;
    const sq_world *w = sq_scene_world(v->scene);
    const float ground = sq_world_surface_at(w, v->cam.position.x, v->cam.position.y) + 1.5f;
    if (v->cam.position.z < ground) {
        if (v->cam.mode == VIEW_CAM_ORBIT) {
            v->cam.target.z += ground - v->cam.position.z;
        }
        v->cam.position.z = ground;
    }
    const sq_camera c = view_camera_get(&v->cam);
    sq_run_set_camera(v->run, &c);
    v->redraw = true;
    view_dynres_motion(v); /* moving: reduced draws until still */
}

void view_input_turn(viewer *v, double dx_px, double dy_px)
{
    if (v->cam.mode == VIEW_CAM_PATH) take_camera(v, VIEW_CAM_ORBIT);
    view_camera_drag(&v->cam, dx_px, dy_px);
    apply_camera(v);
}

/* Ctrl+S: view-saved.yaml in the working directory (then -1, -2 ... if it exists). */
static void save_interactive(viewer *v)
{
    char path[64] = "view-saved.yaml";
    for (int i = 1; i < 1000 && sq_output_check(path, false) != SQ_OK; i++)
        snprintf(path, sizeof path, "view-saved-%d.yaml", i);
    const sq_result r = view_save_scene(v, path);
    char msg[700];
    if (r == SQ_OK)
        snprintf(msg, sizeof msg, "scene saved to %s", path);
    else
        snprintf(msg, sizeof msg, "%s", sq_last_error());
    if (v->panel_status) gtk_label_set_text(GTK_LABEL(v->panel_status), msg);
}

/* V: starts recording to view-record.mp4 (then -1, -2 ...), or stops and keeps the file. */
static void toggle_record(viewer *v)
{
    char msg[VIEW_PATH_MAX + 700];
    sq_result r;
    if (v->rec) {
        char path[VIEW_PATH_MAX];
        snprintf(path, sizeof path, "%s", v->rec_path);
        const int n = v->rec_frames;
        r = view_record_stop(v);
        if (r == SQ_OK) snprintf(msg, sizeof msg, "recorded %d frames to %s", n, path);
    } else {
        char path[64] = "view-record.mp4";
        for (int i = 1; i < 1000 && sq_output_check(path, false) != SQ_OK; i++)
            snprintf(path, sizeof path, "view-record-%d.mp4", i);
        r = view_record_start(v, path);
        if (r == SQ_OK) snprintf(msg, sizeof msg, "recording to %s (V stops)", path);
    }
    if (r != SQ_OK) snprintf(msg, sizeof msg, "%s", sq_last_error());
    if (v->panel_status) gtk_label_set_text(GTK_LABEL(v->panel_status), msg);
}

static int key_slot(guint k)
{
    switch (gdk_keyval_to_lower(k)) {
    case GDK_KEY_w: return K_W;
    case GDK_KEY_a: return K_A;
    case GDK_KEY_s: return K_S;
    case GDK_KEY_d: return K_D;
    case GDK_KEY_q: return K_Q;
    case GDK_KEY_e: return K_E;
    case GDK_KEY_Shift_L:
    case GDK_KEY_Shift_R: return K_SHIFT;
    default: return -1;
    }
}

static gboolean on_key(GtkEventControllerKey *c, guint keyval, guint code, GdkModifierType mods,
                       gpointer user)
{
    (void)c;
    (void)code;
    viewer *v = (viewer *)user;
    if ((mods & GDK_CONTROL_MASK) && gdk_keyval_to_lower(keyval) == GDK_KEY_s) {
        save_interactive(v);
        return TRUE;
    }
    if (mods & (GDK_CONTROL_MASK | GDK_ALT_MASK)) return FALSE;
    const int slot = key_slot(keyval);
    if (slot >= 0) {
        if (slot != K_SHIFT && v->cam.mode == VIEW_CAM_PATH) take_camera(v, VIEW_CAM_FLY);
        v->keys[slot] = true;
        return TRUE;
    }
    if (!v->sim) return FALSE;
    switch (keyval) {
    case GDK_KEY_space: view_sim_toggle_pause(v->sim); break;
    case GDK_KEY_n:
    case GDK_KEY_period: view_sim_single_step(v->sim); break;
    case GDK_KEY_r: view_rebuild(v); break;
    case GDK_KEY_plus:
    case GDK_KEY_equal:
    case GDK_KEY_KP_Add: view_sim_set_speed(v->sim, view_sim_speed(v->sim) * 2.0); break;
    case GDK_KEY_minus:
    case GDK_KEY_KP_Subtract: view_sim_set_speed(v->sim, view_sim_speed(v->sim) * 0.5); break;
    case GDK_KEY_Tab:
        take_camera(v, v->cam.mode == VIEW_CAM_ORBIT ? VIEW_CAM_FLY : VIEW_CAM_ORBIT);
        apply_camera(v);
        break;
    case GDK_KEY_c:
        v->cam.mode = VIEW_CAM_PATH;
        sq_run_set_camera(v->run, NULL);
        v->redraw = true;
        break;
    case GDK_KEY_f:
        if (v->have_box) {
            take_camera(v, VIEW_CAM_ORBIT);
            view_camera_frame_box(&v->cam, v->box_lo, v->box_hi);
            apply_camera(v);
        }
        break;
    case GDK_KEY_v: toggle_record(v); break;
    case GDK_KEY_k: {
        int index = 0;
        double t = 0.0;
        char msg[700];
        const sq_result r = view_keyframe_add(v, &index, &t);
        if (r == SQ_OK)
            snprintf(msg, sizeof msg, "camera.path[%d]: keyframe at t = %.3f s (video time)",
                     index, t);
        else
            snprintf(msg, sizeof msg, "%s", sq_last_error());
        view_panel_status(v, msg, r != SQ_OK);
        break;
    }
    case GDK_KEY_p:
        v->panel_on = !v->panel_on;
        gtk_widget_set_visible(v->panel, v->panel_on);
        break;
    case GDK_KEY_h:
        v->hud_on = !v->hud_on;
        gtk_widget_set_visible(v->hud, v->hud_on);
        break;
    case GDK_KEY_Escape: v->quit = true; break;
    default: return FALSE;
    }
    view_hud_update(v);
    return TRUE;
}

static void on_key_up(GtkEventControllerKey *c, guint keyval, guint code, GdkModifierType mods,
                      gpointer user)
{
    (void)c;
    (void)code;
    (void)mods;
    viewer *v = (viewer *)user;
    const int slot = key_slot(keyval);
    if (slot >= 0) v->keys[slot] = false;
}

static void on_drag_begin(GtkGestureDrag *g, double x, double y, gpointer user)
{
    (void)g;
    (void)x;
    (void)y;
    viewer *v = (viewer *)user;
    if (v->cam.mode == VIEW_CAM_PATH) take_camera(v, VIEW_CAM_ORBIT);
    v->drag_x0 = v->drag_y0 = 0.0;
    gtk_widget_grab_focus(v->area);
}

static void on_drag_update(GtkGestureDrag *g, double dx, double dy, gpointer user)
{
    (void)g;
    viewer *v = (viewer *)user;
    view_camera_drag(&v->cam, dx - v->drag_x0, dy - v->drag_y0);
    v->drag_x0 = dx;
    v->drag_y0 = dy;
    apply_camera(v);
}

static gboolean on_scroll(GtkEventControllerScroll *c, double dx, double dy, gpointer user)
{
    (void)c;
    (void)dx;
    viewer *v = (viewer *)user;
    if (v->cam.mode == VIEW_CAM_PATH) take_camera(v, VIEW_CAM_ORBIT);
    view_camera_wheel(&v->cam, dy);
    apply_camera(v);
    return TRUE;
}

void view_input_attach(viewer *v)
{
    GtkEventController *k = gtk_event_controller_key_new();
    g_signal_connect(k, "key-pressed", G_CALLBACK(on_key), v);
    g_signal_connect(k, "key-released", G_CALLBACK(on_key_up), v);
    gtk_widget_add_controller(v->window, k);
    GtkGesture *d = gtk_gesture_drag_new();
    g_signal_connect(d, "drag-begin", G_CALLBACK(on_drag_begin), v);
    g_signal_connect(d, "drag-update", G_CALLBACK(on_drag_update), v);
    gtk_widget_add_controller(v->area, GTK_EVENT_CONTROLLER(d));
    GtkEventController *s = gtk_event_controller_scroll_new(GTK_EVENT_CONTROLLER_SCROLL_VERTICAL);
    g_signal_connect(s, "scroll", G_CALLBACK(on_scroll), v);
    gtk_widget_add_controller(v->area, s);
}

void view_input_tick(viewer *v, double now_s)
{
    const double dt = v->last_tick_s > 0.0 ? fmin(now_s - v->last_tick_s, 0.1) : 0.0;
    v->last_tick_s = now_s;
    if (v->cam.mode == VIEW_CAM_PATH) return;
    const float f = (float)(v->keys[K_W] - v->keys[K_S]), r = (float)(v->keys[K_D] - v->keys[K_A]),
                u = (float)(v->keys[K_E] - v->keys[K_Q]);
    if (f == 0.0f && r == 0.0f && u == 0.0f) return;
    view_camera_move(&v->cam, f, r, u, dt * (v->keys[K_SHIFT] ? 4.0 : 1.0));
    apply_camera(v);
}

void view_hud_update(viewer *v)
{
    if (!v->sim) return;
    view_sim_stats st;
    view_sim_stats_get(v->sim, &st);
    char text[4096];
    size_t n = 0;
    const char *state = st.error[0] ? "STOPPED" : st.done ? "done" : st.paused ? "paused" : "running";
    n += (size_t)snprintf(text + n, sizeof text - n,
                          "%s%s  frame %d  t = %.2f s  speed x%g\n"
                          "draw %.1f fps (%.1f ms/draw, %dx%d%s)  sim %.1f steps/s\n"
                          "camera: %s",
                          v->rec ? "REC " : "", state, st.frames > 0 ? st.frames - 1 : 0, st.sim_time_s, st.speed,
                          v->fps, v->draw_ms, v->fb_width, v->fb_height,
                          v->last_scale > 0.0f && v->last_scale < 1.0f ? " reduced" : "",
                          st.paused ? 0.0 : st.steps_per_s,
                          v->cam.mode == VIEW_CAM_PATH    ? "scene path"
                          : v->cam.mode == VIEW_CAM_ORBIT ? "orbit"
                                                          : "fly");
    if (v->cam.mode == VIEW_CAM_FLY)
        n += (size_t)snprintf(text + n, sizeof text - n, " %.1f m/s", (double)v->cam.speed_mps);
    for (int i = 0; i < st.metric_count && n < sizeof text - 200; i++) {
        const view_metric *m = &st.metrics[i];
        n += (size_t)snprintf(text + n, sizeof text - n, "\n%s = %.4g %s", m->name, m->value,
                              strcmp(m->unit, "1") == 0 ? "" : m->unit);
    }
    gtk_label_set_text(GTK_LABEL(v->hud), text);
    const char *err = st.error[0] ? st.error : v->gl_error[0] ? v->gl_error : NULL;
    if (err) {
        char msg[700];
        snprintf(msg, sizeof msg, "%s%s", err, st.error[0] ? "\n(simulation paused; R resets)" : "");
        gtk_label_set_text(GTK_LABEL(v->message), msg);
    }
    gtk_widget_set_visible(v->message, err != NULL);
}
