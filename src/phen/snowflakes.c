/* snowflakes.c — falling snowflakes as a particles drawable (phen/snowflakes.h). */
#include "phen/snowflakes.h"

#include <string.h>

void sq__snowflakes_drawable(sq_drawable *dr, int count, const float *position,
                             const float *rotation_rad, const float *radius_m, const float *fade,
                             float radius_default_m, float softness_m, uint64_t version)
{
    memset(dr, 0, sizeof *dr);
    dr->kind = SQ_DRAWABLE_PARTICLES;
    dr->name = "snowfall";
    sq_particles_view *p = &dr->u.particles;
    p->count = count;
    p->position = position;
    p->rotation_rad = rotation_rad;
    p->radius_m = radius_m;
    p->fade = fade;
    p->radius_default_m = radius_default_m;
    p->tau_default = 2.0f; /* opaque flakes */
    for (int c = 0; c < 3; c++) {
        p->sigma_rel[c] = 1.0f;
        p->albedo[c] = 0.95f;
    }
    p->g = 0.5f;
    p->sprite = SQ_SPRITE_FLAKE6;
    p->softness_m = softness_m;
    p->version = version;
}
