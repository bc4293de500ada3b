/* scene_couple.c — what one layer of a scene reads from another, one rule each:
 *   - snowcover <- snowdrift (before the snow cover steps): the snowdrift's deposited depth
 *     replaces the snow cover's model depth where its lattice lies, and the flakes fall in the
 *     lattice's wind there (issue 11, SPEC §6 with §5);
 *   - what is drawn when a scene has both: one snow surface and one snowfall. The snow cover
 *     draws the drift's depth on every surface (terrain, roofs, obstacles, meshes) through its
 *     occlusion map, so the snowdrift's own drift heightfield is left out (drawn as well, it is a
 *     second surface over the cover's shell, and where it meets a house it climbs the walls);
 *     the cover's flakes fall around the camera in the lattice wind, so the snowdrift's drawn
 *     flakes are left out when the cover draws flakes. */
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

/* Layer l drew out[first[l] .. first[l + 1] - 1]; out is compacted in place. */
int sq__scene_couple_drawables(sq_scene *s, sq_drawable *out, const int *first)
{
    const int layers = sq_scene_layer_count(s);
    bool cover_surface = false, cover_flakes = false;
    for (int l = 0; l < layers; l++) {
        if (strcmp(sq_scene_layer_type(s, l), "snowcover") != 0) continue;
        for (int i = first[l]; i < first[l + 1]; i++) {
            cover_surface |= out[i].kind == SQ_DRAWABLE_SNOW_COVER;
            cover_flakes |= out[i].kind == SQ_DRAWABLE_PARTICLES;
        }
    }
    int m = 0;
    for (int l = 0; l < layers; l++) {
        const bool drift = strcmp(sq_scene_layer_type(s, l), "snowdrift") == 0;
        for (int i = first[l]; i < first[l + 1]; i++) {
            if (drift && ((cover_surface && out[i].kind == SQ_DRAWABLE_SURFACE) ||
                          (cover_flakes && out[i].kind == SQ_DRAWABLE_PARTICLES)))
                continue;
            out[m++] = out[i];
        }
    }
    return m;
}
