/* view_param.h — scene parameters as the viewer sees them: the groups of the parameter tables
 * (world, camera, output and one per layer, `layers.<name>`), the current text of a key in the
 * user's scene (or its default), and one change checked exactly as `squall render --set` checks
 * it (the same message on refusal) and applied live or by a rebuild, as the table's
 * SQ_PARAM_LIVE flag says. */
#ifndef SQ_VIEW_PARAM_H
#define SQ_VIEW_PARAM_H

#include <stdbool.h>
#include <stddef.h>

#include "squall/plugin.h"

struct viewer;

typedef struct view_group {
    char section[96];      /* "world", "camera", "output", "layers.<name>" */
    char title[128];       /* "layer storm (sandstorm)" */
    const sq_param *params;
    size_t count;
    const sq_phen_plugin *plugin; /* a layer's plug-in; NULL for a section */
} view_group;

#define VIEW_MAX_GROUPS 24

/* The groups of the user's scene: its sections and one per layer (from its type's table). */
int view_param_groups(const struct viewer *v, view_group *out, int max);
/* The value of section.key in the user's scene as text ("" when the scene does not set it). */
void view_param_current(const struct viewer *v, const char *section, const char *key, char *buf,
                        size_t size);
/* The default of an entry as text, in the form sq_params_set reads. */
void view_param_default(const sq_param *p, char *buf, size_t size);
/* The table entry of a full key "section.key" (NULL if none). */
const sq_param *view_param_find(const struct viewer *v, const char *full_key, view_group *group);
typedef enum view_change {
    VIEW_CHANGE_LIVE = 0,    /* applied now (camera keys: the viewer's camera) */
    VIEW_CHANGE_PENDING = 1, /* a live key sent to the simulation thread: view_param_poll
                                takes the outcome (viewer.live_outcome) a display frame later */
    VIEW_CHANGE_REBUILT = 2  /* the scene was rebuilt (restarted from t = 0) */
} view_change;

/* Applies "full_key=value" to the user's scene. A live key (SQ_PARAM_LIVE) goes to the
 * simulation thread, which checks it exactly as the scene loader (and so `--set`) does and
 * applies it between two steps without restarting (sq_run_apply_live), after the live changes
 * sent before it (each made to the scene as those left it); a refusal comes back with
 * the CLI's message, a change that still needs a rebuild (a phenomenon without live changes)
 * restarts the scene. A camera key goes to the viewer's camera at once. Any other key is checked
 * on a copy of the scene (SQ_ERR_* with the CLI's message) and rebuilds the scene (after the live
 * changes still waiting for the simulation thread, when there are: then VIEW_CHANGE_PENDING). */
sq_result view_param_apply(struct viewer *v, const char *full_key, const char *value,
                           view_change *how);

#endif
