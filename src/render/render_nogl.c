/* render_nogl.c — the OpenGL renderer's calls in a library built without OpenGL
 * (-DSQ_WITH_GL=OFF, no EGL or libepoxy needed): each refuses with SQ_ERR_UNSUPPORTED and says
 * so. The CPU reference path tracer, the tone curve and the image metrics are still built. */
#include "core/core_internal.h"
#include "squall/render.h"

#define NO_GL(what)                                                                             \
    sq__fail(ctx, SQ_ERR_UNSUPPORTED, "render",                                                 \
             "%s: this libsquall was built without OpenGL (SQ_WITH_GL=OFF); the reference path " \
             "tracer (sq_reference_render) still renders",                                      \
             what)

sq_result sq_renderer_create(sq_context *ctx, const sq_render_desc *desc, sq_renderer **out)
{
    (void)desc;
    if (out) *out = NULL;
    return NO_GL("sq_renderer_create");
}

void sq_renderer_destroy(sq_renderer *r) { (void)r; }

sq_result sq_renderer_set_look(sq_renderer *r, float exposure, int volume_slices,
                               bool volume_noise)
{
    (void)r;
    (void)exposure;
    (void)volume_slices;
    (void)volume_noise;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_set_look");
}

sq_result sq_renderer_info(const sq_renderer *r, sq_render_info *out)
{
    (void)r;
    (void)out;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_info");
}

sq_result sq_gl_probe(sq_context *ctx, sq_render_info *out)
{
    (void)out;
    return NO_GL("sq_gl_probe");
}

sq_result sq_renderer_draw(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                           const sq_drawable *drawables, int count, double time_s)
{
    (void)r, (void)world, (void)camera, (void)drawables, (void)count, (void)time_s;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_draw");
}

sq_result sq_renderer_draw_to(sq_renderer *r, const sq_render_target *target,
                              const sq_world *world, const sq_camera *camera,
                              const sq_drawable *drawables, int count, double time_s)
{
    (void)r, (void)target, (void)world, (void)camera, (void)drawables, (void)count, (void)time_s;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_draw_to");
}

sq_result sq_renderer_read_rgba8(sq_renderer *r, uint8_t *rgba)
{
    (void)r, (void)rgba;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_read_rgba8");
}

sq_result sq_renderer_read_linear(sq_renderer *r, float *rgb)
{
    (void)r, (void)rgb;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_read_linear");
}

sq_result sq_renderer_stats(const sq_renderer *r, sq_render_stats *out)
{
    (void)r, (void)out;
    sq_context *ctx = NULL;
    return NO_GL("sq_renderer_stats");
}
