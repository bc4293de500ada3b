/* view_keyframe.c — camera keyframes recorded from the current view (key K, script `keyframe`):
 * the view (position, target, field of view) becomes a key of the scene's camera.path at the
 * video time of the frame shown, t = (simulated time - output.warmup_s) / output.time_scale, the
 * time at which `squall render` puts that frame. A key at the time of the last key replaces it
 * (the same frame, while paused); a key before it is refused (keys must increase in time). The
 * path is part of the scene as edited: the running scene takes it live, and "save" writes it. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view.h"

/* The map or sequence under key in map, created when missing. */
static sq_cfg_node *child_of(sq_cfg_node *map, const char *key, sq_cfg_kind kind)
{
    sq_cfg_node *n = sq_cfg_get(map, key);
    if (n) return n->kind == kind ? n : NULL;
    n = sq_cfg_node_new(kind, key, NULL, 0, 0);
    if (n) sq_cfg_node_append(map, n);
    return n;
}

static void add_scalar(sq_cfg_node *parent, const char *key, double value)
{
    char text[64];
    snprintf(text, sizeof text, "%.9g", value);
    sq_cfg_node_append(parent, sq_cfg_node_new(SQ_CFG_SCALAR, key, text, 0, 0));
}

static void add_vec3(sq_cfg_node *parent, const char *key, sq_vec3 p)
{
    sq_cfg_node *s = sq_cfg_node_new(SQ_CFG_SEQ, key, NULL, 0, 0);
    if (!s) return;
    const double x[3] = {p.x, p.y, p.z};
    for (int i = 0; i < 3; i++) add_scalar(s, NULL, x[i]);
    sq_cfg_node_append(parent, s);
}

static double key_time(const sq_cfg_node *key)
{
    const sq_cfg_node *t = sq_cfg_get(key, "t");
    return t && t->value ? atof(t->value) : 0.0;
}

sq_result view_keyframe_add(viewer *v, int *index, double *t_out)
{
    if (!v->run || !v->sim || sq_run_frame_index(v->run) < 1)
        return sq_set_error(SQ_ERR_INVALID_ARG, "keyframe: no frame shown yet");
    if (v->live_pending)
        return sq_set_error(SQ_ERR_INVALID_ARG, "keyframe: a change is being applied; try again");
    view_sim_stats st;
    view_sim_stats_get(v->sim, &st);
    const sq_scene_output *o = sq_scene_output_settings(v->scene); /* warm-up, time scale: fixed */
    const double t = o->time_scale > 0.0 ? (st.sim_time_s - o->warmup_s) / o->time_scale
                                          : st.sim_time_s;
    const sq_camera c = v->cam.mode != VIEW_CAM_PATH ? view_camera_get(&v->cam)
                                                      : sq_run_camera(v->run);
    const float ground = sq_world_height_at(sq_scene_world(v->scene), c.position_m.x,
                                            c.position_m.y);
    if (!(c.position_m.z >= ground + 0.1f))
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "keyframe: the camera at [%g, %g, %g] m is below the terrain "
                            "surface there (%.2f m) or within 0.1 m of it",
                            (double)c.position_m.x, (double)c.position_m.y,
                            (double)c.position_m.z, (double)ground);
    sq_cfg_node *cam = child_of(v->cfg->root, "camera", SQ_CFG_MAP);
    sq_cfg_node *path = cam ? child_of(cam, "path", SQ_CFG_SEQ) : NULL;
    if (!path) return sq_set_error(SQ_ERR_INVALID_ARG, "keyframe: camera.path is not a list");
    sq_cfg_node *last = NULL, **link = &path->child;
    int n = 0;
    for (sq_cfg_node *k = path->child; k; k = k->next, n++) last = k;
    if (last && t < key_time(last) - 1e-9)
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "keyframe at t = %g s: camera.path[%d] is at t = %g s; keys must "
                            "increase in time (the scene restarted since: press C and record "
                            "from the start, or save and edit the path)",
                            t, n - 1, key_time(last));
    if (last && t <= key_time(last) + 1e-9) { /* the same frame: replace the last key */
        while (*link != last) link = &(*link)->next;
        *link = NULL;
        sq_cfg_node_free(last);
        n--;
    }
    sq_cfg_node *key = sq_cfg_node_new(SQ_CFG_MAP, NULL, NULL, 0, 0);
    if (!key) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "keyframe: no memory");
    add_scalar(key, "t", t);
    add_vec3(key, "position", c.position_m);
    add_vec3(key, "target", c.target_m);
    add_scalar(key, "fov_deg", c.fov_y_deg);
    sq_cfg_node_append(path, key);
    v->keyframes++;
    *index = n;
    *t_out = t;
    /* the running scene takes the path live (its camera when the view follows the path) */
    sq_result r;
    sq_cfg *copy = view_run_cfg(v, NULL, &r);
    if (!copy) return r;
    char label[64];
    snprintf(label, sizeof label, "camera.path[%d]=keyframe", n);
    if (!view_sim_request_live(v->sim, label, copy))
        return sq_set_error(SQ_ERR_INVALID_ARG, "keyframe: %d changes wait to be applied; try "
                            "again", VIEW_LIVE_QUEUE);
    v->live_outstanding++;
    v->live_pending = true;
    v->live_outcome = VIEW_LIVE_NONE;
    return SQ_OK;
}
