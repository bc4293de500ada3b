/* render_volume.c — STUB (placeholder written by the base-renderer helper so the library links
 * while the real volume pass is written in parallel; the volume helper replaces this file).
 * Draws nothing and leaves sun_shadow_tex at 0. */
#include "render/render_internal.h"

sq_result sq__volume_pass_create(sq_renderer *r)
{
    (void)r;
    return SQ_OK;
}

void sq__volume_pass_destroy(sq_renderer *r) { (void)r; }

sq_result sq__volume_pass_prepare_shadow(sq_renderer *r, const sq_volume_view *v)
{
    (void)r;
    (void)v;
    return SQ_OK;
}

sq_result sq__volume_pass_draw(sq_renderer *r, const sq_volume_view *v)
{
    (void)r;
    (void)v;
    return SQ_OK;
}
