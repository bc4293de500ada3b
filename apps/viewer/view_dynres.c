/* view_dynres.c — dynamic resolution of `squall view`: a software GL (Mesa llvmpipe) takes
 * seconds to draw a volumetric scene at 1280x720, so a camera that moves, or a parameter that is
 * being changed, would answer at that pace. While the view moves (a camera move or a live change
 * within VIEW_DYN_HOLD_S) the scene is drawn into an offscreen framebuffer of scale x the area's
 * size and scaled up (linear filter) into the area; when the view is still it is drawn again at
 * full size. The scale adapts after every reduced draw so that one takes about
 * VIEW_DYN_TARGET_MS: the drawing work is mostly per pixel, so the time goes with the pixel
 * count, scale^2 (clamped to [VIEW_DYN_MIN, 1)). Screenshots and recordings are always drawn at
 * full size (view_dynres_scale answers 1 for them). */
#include <epoxy/gl.h>
#include <math.h>

#include "view.h"

void view_dynres_motion(viewer *v) { v->motion_t_s = sq_time_now(); }

float view_dynres_scale(const viewer *v, double now_s)
{
    if (!v->dynres || (v->shot_pending && !v->shot_as_shown) || v->rec || v->motion_t_s <= 0.0 ||
        now_s - v->motion_t_s > VIEW_DYN_HOLD_S)
        return 1.0f;
    return v->dyn_scale > 0.0f ? v->dyn_scale : 0.5f;
}

bool view_dynres_target(viewer *v, float scale, unsigned *fbo, int *w, int *h)
{
    const int tw = (int)lroundf((float)v->fb_width * scale), th = (int)lroundf((float)v->fb_height * scale);
    *w = tw > 16 ? tw : 16;
    *h = th > 16 ? th : 16;
    if (!v->dyn_fbo || v->dyn_w != *w || v->dyn_h != *h) {
        view_dynres_free(v);
        glCreateFramebuffers(1, &v->dyn_fbo);
        glCreateRenderbuffers(1, &v->dyn_color);
        glCreateRenderbuffers(1, &v->dyn_depth);
        glNamedRenderbufferStorage(v->dyn_color, GL_RGBA8, *w, *h);
        glNamedRenderbufferStorage(v->dyn_depth, GL_DEPTH24_STENCIL8, *w, *h);
        glNamedFramebufferRenderbuffer(v->dyn_fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, v->dyn_color);
        glNamedFramebufferRenderbuffer(v->dyn_fbo, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER,
                                       v->dyn_depth);
        v->dyn_w = *w;
        v->dyn_h = *h;
        if (glCheckNamedFramebufferStatus(v->dyn_fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
            view_dynres_free(v);
            return false;
        }
    }
    *fbo = v->dyn_fbo;
    return true;
}

void view_dynres_finish(viewer *v, unsigned area_fbo)
{
    glBlitNamedFramebuffer(v->dyn_fbo, area_fbo, 0, 0, v->dyn_w, v->dyn_h, 0, 0, v->fb_width,
                           v->fb_height, GL_COLOR_BUFFER_BIT, GL_LINEAR);
}

void view_dynres_adapt(viewer *v, double ms)
{
    const float s = v->dyn_scale > 0.0f ? v->dyn_scale : 0.5f;
    float next = s * (float)sqrt(VIEW_DYN_TARGET_MS / (ms > 1.0 ? ms : 1.0));
    if (next < VIEW_DYN_MIN) next = VIEW_DYN_MIN;
    if (next > 0.9f) next = 0.9f;
    v->dyn_scale = next;
}

void view_dynres_free(viewer *v)
{
    if (v->dyn_fbo) glDeleteFramebuffers(1, &v->dyn_fbo);
    if (v->dyn_color) glDeleteRenderbuffers(1, &v->dyn_color);
    if (v->dyn_depth) glDeleteRenderbuffers(1, &v->dyn_depth);
    v->dyn_fbo = v->dyn_color = v->dyn_depth = 0;
    v->dyn_w = v->dyn_h = 0;
}
