/* render_particles.c — STUB (placeholder written by the base-renderer helper so the library
 * links while the real particle pass is written in parallel; the particle helper replaces this
 * file). Draws nothing. */
#include "render/render_internal.h"

sq_result sq__particle_pass_create(sq_renderer *r)
{
    (void)r;
    return SQ_OK;
}

void sq__particle_pass_destroy(sq_renderer *r) { (void)r; }

sq_result sq__particle_pass_draw(sq_renderer *r, const sq_particles_view *p)
{
    (void)r;
    (void)p;
    return SQ_OK;
}
