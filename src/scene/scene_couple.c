/* scene_couple.c — what one layer of a scene reads from another, one rule each, applied before
 * the reading layer steps:
 *   - snowcover <- snowdrift: the snowdrift's deposited depth replaces the snow cover's model
 *     depth where its lattice lies, and the flakes fall in the lattice's wind there (issue 11,
 *     SPEC §6 with §5). */
#include <string.h>

#include "scene/scene_internal.h"
#include "squall/phenomenon.h"
#include "sq_config.h"

#if SQ_HAVE_SNOWCOVER
#include "squall/snowcover.h"
#endif

static sq_phenomenon *first_of(sq_scene *s, const char *type)
{
    for (int i = 0; i < sq_scene_layer_count(s); i++)
        if (strcmp(sq_scene_layer_type(s, i), type) == 0) return sq_scene_layer(s, i);
    return NULL;
}

void sq__scene_couple(sq_scene *s, int layer)
{
#if SQ_HAVE_SNOWCOVER
    sq_phenomenon *ph = sq_scene_layer(s, layer);
    sq_snowcover *cover = ph ? (sq_snowcover *)sq_phenomenon_typed(ph, "snowcover") : NULL;
    if (!cover) return;
    sq_phenomenon *drift = first_of(s, "snowdrift");
    if (!drift) return;
    sq_named_field depth, u, v, w;
    const bool has_depth = sq_phenomenon_field_find(drift, "snow_depth", &depth) == SQ_OK;
    const bool has_wind = sq_phenomenon_field_find(drift, "u", &u) == SQ_OK &&
                          sq_phenomenon_field_find(drift, "v", &v) == SQ_OK &&
                          sq_phenomenon_field_find(drift, "w", &w) == SQ_OK;
    sq_snowcover_set_inputs(cover, has_depth ? &depth : NULL, has_wind ? &u : NULL,
                            has_wind ? &v : NULL, has_wind ? &w : NULL);
#else
    (void)s, (void)layer;
#endif
}
