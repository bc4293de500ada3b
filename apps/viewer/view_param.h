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
/* Checks "full_key=value" as --set does on a copy of the scene (SQ_ERR_* with the CLI's message);
 * then applies it to the user's scene: a camera key at once to the viewer's camera; other keys
 * by restarting the scene (*rebuilt = true). */
sq_result view_param_apply(struct viewer *v, const char *full_key, const char *value,
                           bool *rebuilt);

#endif
