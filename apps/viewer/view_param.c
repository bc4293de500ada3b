/* view_param.c — the parameter tables seen from the viewer (see view_param.h). */
#include "view_param.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view.h"

int view_param_groups(const viewer *v, view_group *out, int max)
{
    int n = 0;
    const char *sections[] = {"world", "camera", "output"};
    for (int i = 0; i < 3 && n < max; i++) {
        size_t count = 0;
        const sq_param *t = sq_scene_section_params(sections[i], &count);
        if (!t) continue;
        view_group *g = &out[n++];
        snprintf(g->section, sizeof g->section, "%s", sections[i]);
        snprintf(g->title, sizeof g->title, "%s", sections[i]);
        g->params = t;
        g->count = count;
        g->plugin = NULL;
    }
    const sq_cfg_node *layers = sq_cfg_get(v->cfg->root, "layers");
    int index = 0;
    for (const sq_cfg_node *l = layers ? layers->child : NULL; l && n < max; l = l->next, index++) {
        const sq_cfg_node *type = sq_cfg_get(l, "type"), *name = sq_cfg_get(l, "name");
        const sq_phen_plugin *pl = type && type->value ? sq_plugin_find(type->value) : NULL;
        if (!pl) continue;
        view_group *g = &out[n++];
        const char *nm = name && name->value ? name->value : pl->name;
        /* --set addresses a layer by name, else by type (the first of that type), else index */
        if (name && name->value)
            snprintf(g->section, sizeof g->section, "layers.%s", nm);
        else
            snprintf(g->section, sizeof g->section, "layers.%d", index);
        snprintf(g->title, sizeof g->title, "layer %s (%s)", nm, pl->name);
        g->params = pl->params;
        g->count = pl->param_count;
        g->plugin = pl;
    }
    return n;
}

/* The node of a dotted key under a map (keys may be nested maps or written with dots). */
static const sq_cfg_node *find_node(const sq_cfg_node *map, const char *key)
{
    if (!map || map->kind != SQ_CFG_MAP) return NULL;
    for (const sq_cfg_node *c = map->child; c; c = c->next) {
        if (!c->key) continue;
        const size_t k = strlen(c->key);
        if (strcmp(c->key, key) == 0) return c;
        if (strncmp(c->key, key, k) == 0 && key[k] == '.') {
            const sq_cfg_node *r = find_node(c, key + k + 1);
            if (r) return r;
        }
    }
    return NULL;
}

static const sq_cfg_node *section_node(const viewer *v, const char *section)
{
    if (strncmp(section, "layers.", 7) != 0) return find_node(v->cfg->root, section);
    const sq_cfg_node *layers = sq_cfg_get(v->cfg->root, "layers");
    const char *part = section + 7;
    char *end = NULL;
    const long idx = strtol(part, &end, 10);
    int i = 0;
    for (const sq_cfg_node *l = layers ? layers->child : NULL; l; l = l->next, i++) {
        const sq_cfg_node *name = sq_cfg_get(l, "name");
        if ((*part && !*end && i == idx) || (name && name->value && strcmp(name->value, part) == 0))
            return l;
    }
    return NULL;
}

void view_param_current(const viewer *v, const char *section, const char *key, char *buf,
                        size_t size)
{
    buf[0] = 0;
    const sq_cfg_node *n = find_node(section_node(v, section), key);
    if (!n) return;
    if (n->kind == SQ_CFG_SCALAR) {
        snprintf(buf, size, "%s", n->value ? n->value : "");
        return;
    }
    size_t len = 0;
    for (const sq_cfg_node *c = n->child; c && len + 2 < size; c = c->next)
        len += (size_t)snprintf(buf + len, size - len, "%s%s", len ? " " : "",
                                c->value ? c->value : "");
}

void view_param_default(const sq_param *p, char *buf, size_t size)
{
    switch (p->type) {
    case SQ_PARAM_BOOL: snprintf(buf, size, "%s", p->def != 0.0 ? "true" : "false"); break;
    case SQ_PARAM_ENUM: {
        const char *c = p->choices ? p->choices : "";
        for (int i = 0; i < (int)p->def && strchr(c, '|'); i++) c = strchr(c, '|') + 1;
        const char *bar = strchr(c, '|');
        const int len = bar ? (int)(bar - c) : (int)strlen(c);
        snprintf(buf, size, "%.*s", len, c);
        break;
    }
    case SQ_PARAM_VEC3:
    case SQ_PARAM_STRING:
    case SQ_PARAM_FLOATS: snprintf(buf, size, "%s", p->def_text ? p->def_text : ""); break;
    case SQ_PARAM_U64:
    case SQ_PARAM_INT: snprintf(buf, size, "%.0f", p->def); break;
    default: snprintf(buf, size, "%.9g", p->def); break;
    }
}

const sq_param *view_param_find(const viewer *v, const char *full_key, view_group *group)
{
    view_group g[VIEW_MAX_GROUPS];
    const int n = view_param_groups(v, g, VIEW_MAX_GROUPS);
    for (int i = 0; i < n; i++) {
        const size_t s = strlen(g[i].section);
        if (strncmp(full_key, g[i].section, s) != 0 || full_key[s] != '.') continue;
        const sq_param *p = sq_params_find(g[i].params, g[i].count, full_key + s + 1);
        if (p) {
            if (group) *group = g[i];
            return p;
        }
    }
    return NULL;
}

bool view_param_known(const viewer *v, const char *full_key)
{
    return view_param_find(v, full_key, NULL) != NULL;
}

/* A copy of the user's scene with the assignment, checked by the scene loader (validate only). */
static sq_result check_assignment(viewer *v, const char *assignment)
{
    char *yaml = sq_cfg_to_yaml(v->cfg);
    if (!yaml) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "view: cannot copy the scene");
    sq_cfg *copy = NULL;
    sq_result r = sq_cfg_parse(v->ctx, yaml, strlen(yaml), v->cfg->source, &copy);
    free(yaml);
    if (r != SQ_OK) return r;
    snprintf(copy->base_dir, sizeof copy->base_dir, "%s", v->cfg->base_dir);
    r = sq_cfg_set(copy, assignment);
    if (r == SQ_OK) {
        sq_scene_desc sd = view_scene_desc(copy);
        sd.validate_only = true;
        sq_scene *s = NULL;
        r = sq_scene_create(v->ctx, &sd, &s);
        sq_scene_destroy(s);
    }
    sq_cfg_destroy(copy);
    return r;
}

static bool parse_vec3(const char *s, float out[3])
{
    char buf[256];
    snprintf(buf, sizeof buf, "%s", s);
    for (char *c = buf; *c; c++)
        if (*c == '[' || *c == ']' || *c == ',') *c = ' ';
    char tail[2];
    return sscanf(buf, "%f %f %f %1s", &out[0], &out[1], &out[2], tail) == 3;
}

/* camera.* applies to the viewer's camera at once (the next draw shows it). */
static void apply_camera_key(viewer *v, const char *key, const char *value)
{
    sq_camera c = v->cam.mode != VIEW_CAM_PATH ? view_camera_get(&v->cam) : sq_run_camera(v->run);
    float x[3];
    const double d = atof(value);
    if (strcmp(key, "fov_deg") == 0) c.fov_y_deg = (float)d;
    else if (strcmp(key, "near_m") == 0) c.near_m = (float)d;
    else if (strcmp(key, "far_m") == 0) c.far_m = (float)d;
    else if (strcmp(key, "position") == 0 && parse_vec3(value, x)) c.position_m = sq_v3(x[0], x[1], x[2]);
    else if (strcmp(key, "target") == 0 && parse_vec3(value, x)) c.target_m = sq_v3(x[0], x[1], x[2]);
    else if (strcmp(key, "up") == 0 && parse_vec3(value, x)) c.up = sq_v3(x[0], x[1], x[2]);
    const view_cam_mode mode = v->cam.mode != VIEW_CAM_PATH ? v->cam.mode : VIEW_CAM_ORBIT;
    view_camera_take(&v->cam, &c, mode);
    const sq_camera now = view_camera_get(&v->cam);
    sq_run_set_camera(v->run, &now);
    v->redraw = true;
    view_dynres_motion(v);
}

sq_result view_param_apply(viewer *v, const char *full_key, const char *value, view_change *how)
{
    *how = VIEW_CHANGE_LIVE;
    char assignment[1400];
    snprintf(assignment, sizeof assignment, "%s=%s", full_key, value);
    view_group g;
    const sq_param *p = view_param_find(v, full_key, &g);
    const bool live = p && sq_param_live(p, g.plugin) && v->run && v->sim &&
                      sq_run_frame_index(v->run) > 0;
    sq_result r;
    if (live && strcmp(g.section, "camera") != 0) {
        /* to the simulation thread: made there to the scene as the changes before it left it,
         * checked as the scene loader checks it (the CLI's message), applied between two steps;
         * view_param_poll takes the outcome */
        if (!view_sim_request_live(v->sim, assignment, NULL))
            return sq_set_error(SQ_ERR_INVALID_ARG, "%s: %d changes wait to be applied; try "
                                "again when the simulation has taken them", assignment,
                                VIEW_LIVE_QUEUE);
        v->live_outstanding++;
        v->live_pending = true;
        v->live_outcome = VIEW_LIVE_NONE;
        view_dynres_motion(v); /* being changed: reduced draws until still */
        *how = VIEW_CHANGE_PENDING;
        return SQ_OK;
    }
    r = check_assignment(v, assignment);
    if (r != SQ_OK) return r;
    if (!live && v->live_outstanding > 0 && v->sim) {
        /* live changes wait for the simulation thread: this one goes after them (it comes back
         * as a rebuild, made with them), not before (the rebuild would drop them) */
        if (view_sim_request_live(v->sim, assignment, NULL)) {
            v->live_outstanding++;
            v->live_pending = true;
            v->live_outcome = VIEW_LIVE_NONE;
            *how = VIEW_CHANGE_PENDING;
            return SQ_OK;
        }
    }
    r = sq_cfg_set(v->cfg, assignment);
    if (r != SQ_OK) return r;
    if (live) { /* camera.*: the viewer's camera at once */
        apply_camera_key(v, p->key, value);
        return SQ_OK;
    }
    *how = VIEW_CHANGE_REBUILT;
    return view_rebuild(v);
}

/* The widgets' side of an outcome (never during a draw: GTK is snapshotting then). */
static void show_outcome(viewer *v)
{
    char msg[1000];
    const char *eq = strchr(v->live_assignment, '=');
    const int klen = (int)(eq ? eq - v->live_assignment : 0);
    if (v->live_outcome == VIEW_LIVE_REFUSED)
        snprintf(msg, sizeof msg, "%s", v->live_message);
    else if (v->live_outcome == VIEW_LIVE_REBUILT)
        snprintf(msg, sizeof msg, "%.*s = %s (scene restarted: %s)", klen, v->live_assignment,
                 eq ? eq + 1 : "", v->live_message);
    else
        snprintf(msg, sizeof msg, "%.*s = %s (live)", klen, v->live_assignment, eq ? eq + 1 : "");
    view_panel_status(v, v->gl_error[0] && v->live_outcome == VIEW_LIVE_REBUILT ? v->gl_error : msg,
                      v->live_outcome == VIEW_LIVE_REFUSED || v->gl_error[0]);
    view_panel_refresh(v); /* a refused value: the widget shows the scene's value again */
}

/* For scripts: one line per result, "change KEY = VALUE: applied to frame N (C changed)" or
 * ": refused: MESSAGE", ": scene restarted", ": folded into the restarted scene". */
static void print_result(const viewer *v, const view_live_result *lr, const char *how)
{
    if (!v->script) return;
    const char *eq = strchr(lr->assignment, '=');
    printf("change %.*s = %s: %s\n", (int)(eq ? eq - lr->assignment : 0), lr->assignment,
           eq ? eq + 1 : "", how);
    fflush(stdout);
}

/* A change not tried because one before it rebuilds the scene: checked as a rebuild key is and
 * made to the user's scene, which the rebuild then builds. */
static void fold_dropped(viewer *v, const view_live_result *lr)
{
    const sq_result r = check_assignment(v, lr->assignment);
    if (r == SQ_OK && sq_cfg_set(v->cfg, lr->assignment) == SQ_OK) {
        print_result(v, lr, "folded into the restarted scene");
        return;
    }
    v->live_refusals++;
    snprintf(v->live_refused, sizeof v->live_refused, "%s", lr->assignment);
    snprintf(v->live_refusal, sizeof v->live_refusal, "%s", sq_last_error());
    char how[900];
    snprintf(how, sizeof how, "refused: %s", v->live_refusal);
    print_result(v, lr, how);
}

/* Takes the results of the live changes, in order. An applied change is in the frame drawn now
 * (in_draw: for the latency) and becomes part of the user's scene; a refusal or a rebuild is
 * handled by the next tick (never during a draw: GTK is snapshotting then); the changes dropped
 * after a rebuild are folded into the rebuilt scene. */
void view_param_poll(viewer *v, bool in_draw)
{
    bool rebuild = false, shown = false;
    for (;;) {
        if (!v->live_held) {
            if (!v->sim || v->live_outstanding <= 0 || !view_sim_live_result(v->sim, &v->live_result))
                break;
            v->live_outstanding--;
            v->live_held = true;
        }
        const view_live_result *lr = &v->live_result;
        const bool applied = lr->r == SQ_OK && !lr->res.rebuild && !lr->dropped;
        if (!applied && in_draw) break; /* the next tick */
        v->live_held = false;
        if (lr->dropped) {
            fold_dropped(v, lr);
            continue;
        }
        snprintf(v->live_assignment, sizeof v->live_assignment, "%s", lr->assignment);
        char how[1000];
        if (applied) {
            v->live_outcome = VIEW_LIVE_APPLIED;
            if (!lr->whole) sq_cfg_set(v->cfg, lr->assignment); /* the user's scene now */
            snprintf(v->live_message, sizeof v->live_message,
                     "applied to frame %d, %.1f ms after the change", lr->frame - 1,
                     (lr->t_applied_s - lr->t_request_s) * 1e3);
            snprintf(how, sizeof how, "applied to frame %d (%d changed)", lr->frame - 1,
                     lr->res.changed);
            v->lat_armed = true;
            v->redraw = true;
        } else if (lr->r != SQ_OK) {
            v->live_outcome = VIEW_LIVE_REFUSED;
            snprintf(v->live_message, sizeof v->live_message, "%s", lr->error);
            v->live_refusals++;
            snprintf(v->live_refused, sizeof v->live_refused, "%s", lr->assignment);
            snprintf(v->live_refusal, sizeof v->live_refusal, "%s", lr->error);
            snprintf(how, sizeof how, "refused: %s", lr->error);
            v->lat_pending = false;
        } else {
            v->live_outcome = VIEW_LIVE_REBUILT;
            snprintf(v->live_message, sizeof v->live_message, "%s", lr->res.reason);
            if (!lr->whole) sq_cfg_set(v->cfg, lr->assignment);
            snprintf(how, sizeof how, "scene restarted");
            rebuild = true;
        }
        print_result(v, lr, how);
        shown = true;
    }
    v->live_pending = v->live_outstanding > 0 || v->live_held;
    if (rebuild) {
        view_rebuild(v); /* the changes queued after it went with the old run: folded above */
        v->lat_frame0 = -1;
        v->lat_armed = true;
        v->live_pending = false;
    }
    if (shown && in_draw) v->live_show = true;
    else if (shown || (!in_draw && v->live_show)) {
        v->live_show = false;
        show_outcome(v);
    }
}
