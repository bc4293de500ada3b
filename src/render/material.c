/* material.c — the colours both renderers give the ground and the surface drawables (the GL
 * renderer's opaque passes and the reference path tracer): terrain albedo by cover and slope,
 * surface albedo by material. No GL. */
#include "core/core_internal.h"
#include "squall/drawable.h"
#include "squall/world.h"
#include "world/world_struct.h"

/* Declared in render_internal.h and reference/reference_internal.h. */
void sq__terrain_albedo(const sq_world *w, sq_vec3 *flat, sq_vec3 *steep);
sq_vec3 sq__material_albedo(sq_material m);

void sq__terrain_albedo(const sq_world *w, sq_vec3 *flat, sq_vec3 *steep)
{
    *steep = sq_v3(0.30f, 0.28f, 0.26f); /* weathered rock */
    switch (w->terrain_material) {
    case SQ_GROUND_SAND: *flat = *steep = sq_v3(0.58f, 0.45f, 0.30f); return;
    case SQ_GROUND_SNOW: /* snow on the flats, bare rock on the faces too steep to hold it */
        *flat = sq_v3(0.88f, 0.90f, 0.94f);
        *steep = sq_v3(0.34f, 0.32f, 0.30f);
        return;
    case SQ_GROUND_ROCK: *flat = sq_v3(0.32f, 0.30f, 0.28f); return;
    case SQ_GROUND_GRASS: *flat = sq_v3(0.21f, 0.23f, 0.11f); return;
    case SQ_GROUND_ASPHALT: *flat = *steep = sq_v3(0.12f, 0.12f, 0.12f); return;
    default: break;
    }
    switch (w->terrain_kind) {
    case SQ_TERRAIN_DUNES: /* desert sand on every slope */
        *flat = sq_v3(0.58f, 0.45f, 0.30f);
        *steep = sq_v3(0.52f, 0.40f, 0.27f);
        break;
    case SQ_TERRAIN_MOUNTAIN: /* alpine meadow / scree */
        *flat = sq_v3(0.20f, 0.22f, 0.13f);
        break;
    default: /* dry grass and soil */
        *flat = sq_v3(0.21f, 0.23f, 0.11f);
        break;
    }
}

sq_vec3 sq__material_albedo(sq_material m)
{
    switch (m) {
    case SQ_MATERIAL_SAND: return sq_v3(0.58f, 0.45f, 0.30f);
    case SQ_MATERIAL_SNOW: return sq_v3(0.90f, 0.92f, 0.95f);
    case SQ_MATERIAL_ROCK: return sq_v3(0.30f, 0.28f, 0.26f);
    default: return sq_v3(0.30f, 0.25f, 0.19f); /* soil */
    }
}
