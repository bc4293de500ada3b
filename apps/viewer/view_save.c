/* view_save.c — "save scene": the user's scene as edited in the viewer (--set, panel, script)
 * written as YAML that `squall render` reads and renders to the same frames. When the user has
 * taken the camera over, the saved camera is that view (position, target, field of view, near
 * and far planes) and the scene's camera path is left out, unless camera keyframes were recorded
 * (view_keyframe.c): then the path with them is saved, and the render follows it. Written through a temporary and
 * renamed (sq_output_write_file); never onto the scene file that is being viewed. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "view.h"

/* Removes key from a map node (and frees it). */
static void remove_key(sq_cfg_node *map, const char *key)
{
    if (!map) return;
    for (sq_cfg_node **p = &map->child; *p; p = &(*p)->next) {
        if ((*p)->key && strcmp((*p)->key, key) == 0) {
            sq_cfg_node *n = *p;
            *p = n->next;
            n->next = NULL;
            sq_cfg_node_free(n);
            return;
        }
    }
}

sq_result view_save_scene(viewer *v, const char *path)
{
    sq_result r = view_shot_check(v, path);
    if (r != SQ_OK) return r;
    char *yaml = sq_cfg_to_yaml(v->cfg);
    if (!yaml) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "save '%s': no memory", path);
    sq_cfg *copy = NULL;
    r = sq_cfg_parse(v->ctx, yaml, strlen(yaml), v->cfg->source, &copy);
    free(yaml);
    if (r != SQ_OK) return r;
    if (v->cam.mode != VIEW_CAM_PATH) {
        const sq_camera c = view_camera_get(&v->cam);
        char set[256];
        /* the view taken over replaces the path, unless keyframes were recorded into it */
        if (v->keyframes == 0) remove_key(sq_cfg_get(copy->root, "camera"), "path");
        snprintf(set, sizeof set, "camera.position=[%.9g, %.9g, %.9g]", (double)c.position_m.x,
                 (double)c.position_m.y, (double)c.position_m.z);
        r = sq_cfg_set(copy, set);
        snprintf(set, sizeof set, "camera.target=[%.9g, %.9g, %.9g]", (double)c.target_m.x,
                 (double)c.target_m.y, (double)c.target_m.z);
        if (r == SQ_OK) r = sq_cfg_set(copy, set);
        snprintf(set, sizeof set, "camera.fov_deg=%.9g", (double)c.fov_y_deg);
        if (r == SQ_OK) r = sq_cfg_set(copy, set);
        snprintf(set, sizeof set, "camera.near_m=%.9g", (double)c.near_m);
        if (r == SQ_OK) r = sq_cfg_set(copy, set);
        snprintf(set, sizeof set, "camera.far_m=%.9g", (double)c.far_m);
        if (r == SQ_OK) r = sq_cfg_set(copy, set);
    }
    if (r == SQ_OK) {
        char *text = sq_cfg_to_yaml(copy);
        if (!text) r = sq_set_error(SQ_ERR_OUT_OF_MEMORY, "save '%s': no memory", path);
        else r = sq_output_write_file(path, text, strlen(text), v->overwrite);
        free(text);
    }
    sq_cfg_destroy(copy);
    return r;
}
