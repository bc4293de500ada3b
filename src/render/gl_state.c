/* gl_state.c — the caller's OpenGL state around a renderer that draws in the caller's context
 * (sq_render_desc.use_current_context). Every piece of state any renderer pass may change is
 * saved before the renderer works and put back afterwards, and a neutral state is set in
 * between so that a caller's unusual settings (a bound pixel-unpack buffer, polygon mode
 * GL_LINE, sampler objects, reversed-Z clip control, ...) cannot break the renderer's draws.
 * The list is the one documented in include/squall/render.h ("GL state"). */
#include <string.h>

#include "render/render_internal.h"

static const GLenum tex_targets[SQ_GL_STATE_TEX_TARGETS] = {
    GL_TEXTURE_2D, GL_TEXTURE_3D, GL_TEXTURE_2D_ARRAY, GL_TEXTURE_CUBE_MAP, GL_TEXTURE_BUFFER};
static const GLenum tex_bindings[SQ_GL_STATE_TEX_TARGETS] = {
    GL_TEXTURE_BINDING_2D, GL_TEXTURE_BINDING_3D, GL_TEXTURE_BINDING_2D_ARRAY,
    GL_TEXTURE_BINDING_CUBE_MAP, GL_TEXTURE_BINDING_BUFFER};

/* Capabilities saved, set to the neutral value below during the renderer's work, restored. */
static const GLenum caps[] = {GL_BLEND,           GL_DEPTH_TEST,
                              GL_CULL_FACE,       GL_SCISSOR_TEST,
                              GL_STENCIL_TEST,    GL_POLYGON_OFFSET_FILL,
                              GL_FRAMEBUFFER_SRGB, GL_RASTERIZER_DISCARD,
                              GL_COLOR_LOGIC_OP,  GL_SAMPLE_ALPHA_TO_COVERAGE,
                              GL_PRIMITIVE_RESTART, GL_PRIMITIVE_RESTART_FIXED_INDEX,
                              GL_DEPTH_CLAMP,     GL_PROGRAM_POINT_SIZE,
                              GL_CLIP_DISTANCE0,  GL_CLIP_DISTANCE1,
                              GL_CLIP_DISTANCE2,  GL_CLIP_DISTANCE3,
                              GL_CLIP_DISTANCE4,  GL_CLIP_DISTANCE5,
                              GL_CLIP_DISTANCE6,  GL_CLIP_DISTANCE7};
#define N_CAPS ((int)(sizeof caps / sizeof caps[0]))

/* Pixel store parameters reset to their defaults (pack and unpack). */
static const GLenum pixel_params[] = {
    GL_PACK_ALIGNMENT,     GL_PACK_ROW_LENGTH,     GL_PACK_SKIP_ROWS,     GL_PACK_SKIP_PIXELS,
    GL_PACK_IMAGE_HEIGHT,  GL_PACK_SKIP_IMAGES,    GL_PACK_SWAP_BYTES,    GL_PACK_LSB_FIRST,
    GL_UNPACK_ALIGNMENT,   GL_UNPACK_ROW_LENGTH,   GL_UNPACK_SKIP_ROWS,   GL_UNPACK_SKIP_PIXELS,
    GL_UNPACK_IMAGE_HEIGHT, GL_UNPACK_SKIP_IMAGES, GL_UNPACK_SWAP_BYTES,  GL_UNPACK_LSB_FIRST};
#define N_PIXEL ((int)(sizeof pixel_params / sizeof pixel_params[0]))

_Static_assert(N_CAPS <= SQ_GL_STATE_CAPS, "sq__gl_state.caps too small");
_Static_assert(N_PIXEL <= SQ_GL_STATE_PIXEL, "sq__gl_state.pixel too small");

void sq__gl_state_save(sq__gl_state *s)
{
    memset(s, 0, sizeof *s);
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s->draw_fbo);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &s->read_fbo);
    glGetIntegerv(GL_RENDERBUFFER_BINDING, &s->renderbuffer);
    glGetIntegerv(GL_VIEWPORT, s->viewport);
    glGetIntegerv(GL_SCISSOR_BOX, s->scissor_box);
    glGetIntegerv(GL_CURRENT_PROGRAM, &s->program);
    glGetIntegerv(GL_PROGRAM_PIPELINE_BINDING, &s->pipeline);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &s->vao);
    glGetIntegerv(GL_ARRAY_BUFFER_BINDING, &s->array_buffer);
    glGetIntegerv(GL_PIXEL_PACK_BUFFER_BINDING, &s->pack_buffer);
    glGetIntegerv(GL_PIXEL_UNPACK_BUFFER_BINDING, &s->unpack_buffer);
    glGetIntegerv(GL_UNIFORM_BUFFER_BINDING, &s->uniform_buffer);
    glGetIntegerv(GL_SHADER_STORAGE_BUFFER_BINDING, &s->storage_buffer);
    for (GLuint i = 0; i < SQ_GL_STATE_BUFFERS; i++) {
        glGetIntegeri_v(GL_UNIFORM_BUFFER_BINDING, i, &s->ubo[i].name);
        glGetInteger64i_v(GL_UNIFORM_BUFFER_START, i, &s->ubo[i].start);
        glGetInteger64i_v(GL_UNIFORM_BUFFER_SIZE, i, &s->ubo[i].size);
        glGetIntegeri_v(GL_SHADER_STORAGE_BUFFER_BINDING, i, &s->ssbo[i].name);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_START, i, &s->ssbo[i].start);
        glGetInteger64i_v(GL_SHADER_STORAGE_BUFFER_SIZE, i, &s->ssbo[i].size);
    }
    glGetIntegerv(GL_ACTIVE_TEXTURE, &s->active_texture);
    for (GLuint u = 0; u < SQ_GL_STATE_UNITS; u++) {
        glActiveTexture(GL_TEXTURE0 + u);
        for (int t = 0; t < SQ_GL_STATE_TEX_TARGETS; t++)
            glGetIntegerv(tex_bindings[t], &s->textures[u][t]);
        glGetIntegeri_v(GL_SAMPLER_BINDING, u, &s->samplers[u]);
    }
    glActiveTexture((GLenum)s->active_texture);
    for (GLuint i = 0; i < SQ_GL_STATE_IMAGES; i++) {
        glGetIntegeri_v(GL_IMAGE_BINDING_NAME, i, &s->images[i].name);
        glGetIntegeri_v(GL_IMAGE_BINDING_LEVEL, i, &s->images[i].level);
        glGetIntegeri_v(GL_IMAGE_BINDING_LAYERED, i, &s->images[i].layered);
        glGetIntegeri_v(GL_IMAGE_BINDING_LAYER, i, &s->images[i].layer);
        glGetIntegeri_v(GL_IMAGE_BINDING_ACCESS, i, &s->images[i].access);
        glGetIntegeri_v(GL_IMAGE_BINDING_FORMAT, i, &s->images[i].format);
    }
    for (int i = 0; i < N_CAPS; i++) s->caps[i] = glIsEnabled(caps[i]);
    glGetIntegerv(GL_BLEND_SRC_RGB, &s->blend[0]);
    glGetIntegerv(GL_BLEND_DST_RGB, &s->blend[1]);
    glGetIntegerv(GL_BLEND_SRC_ALPHA, &s->blend[2]);
    glGetIntegerv(GL_BLEND_DST_ALPHA, &s->blend[3]);
    glGetIntegerv(GL_BLEND_EQUATION_RGB, &s->blend[4]);
    glGetIntegerv(GL_BLEND_EQUATION_ALPHA, &s->blend[5]);
    glGetFloatv(GL_BLEND_COLOR, s->blend_color);
    glGetIntegerv(GL_DEPTH_FUNC, &s->depth_func);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &s->depth_mask);
    glGetDoublev(GL_DEPTH_RANGE, s->depth_range);
    glGetIntegerv(GL_CLIP_ORIGIN, &s->clip_origin);
    glGetIntegerv(GL_CLIP_DEPTH_MODE, &s->clip_depth);
    glGetBooleanv(GL_COLOR_WRITEMASK, s->color_mask);
    glGetIntegerv(GL_STENCIL_WRITEMASK, &s->stencil_mask);
    glGetIntegerv(GL_STENCIL_BACK_WRITEMASK, &s->stencil_back_mask);
    glGetIntegerv(GL_POLYGON_MODE, s->polygon_mode);
    glGetFloatv(GL_POLYGON_OFFSET_FACTOR, &s->offset_factor);
    glGetFloatv(GL_POLYGON_OFFSET_UNITS, &s->offset_units);
    glGetIntegerv(GL_CULL_FACE_MODE, &s->cull_mode);
    glGetIntegerv(GL_FRONT_FACE, &s->front_face);
    for (int i = 0; i < N_PIXEL; i++) glGetIntegerv(pixel_params[i], &s->pixel[i]);
}

void sq__gl_state_neutral(void)
{
    for (int i = 0; i < N_CAPS; i++) glDisable(caps[i]);
    glBindProgramPipeline(0);
    glUseProgram(0);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    for (GLuint u = 0; u < SQ_GL_STATE_UNITS; u++) glBindSampler(u, 0);
    glBlendColor(0.0f, 0.0f, 0.0f, 0.0f);
    glDepthRange(0.0, 1.0);
    glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glStencilMask(0xFFFFFFFFu);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    for (int i = 0; i < N_PIXEL; i++) {
        const GLenum p = pixel_params[i];
        glPixelStorei(p, (p == GL_PACK_ALIGNMENT || p == GL_UNPACK_ALIGNMENT) ? 4 : 0);
    }
}

static void enable_if(GLenum cap, GLboolean on)
{
    if (on) glEnable(cap);
    else glDisable(cap);
}

void sq__gl_state_restore(const sq__gl_state *s)
{
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)s->draw_fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, (GLuint)s->read_fbo);
    glBindRenderbuffer(GL_RENDERBUFFER, (GLuint)s->renderbuffer);
    glViewport(s->viewport[0], s->viewport[1], s->viewport[2], s->viewport[3]);
    glScissor(s->scissor_box[0], s->scissor_box[1], s->scissor_box[2], s->scissor_box[3]);
    glUseProgram((GLuint)s->program);
    glBindProgramPipeline((GLuint)s->pipeline);
    glBindVertexArray((GLuint)s->vao);
    glBindBuffer(GL_ARRAY_BUFFER, (GLuint)s->array_buffer);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, (GLuint)s->pack_buffer);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, (GLuint)s->unpack_buffer);
    for (GLuint i = 0; i < SQ_GL_STATE_BUFFERS; i++) {
        const sq__gl_buffer_binding *u = &s->ubo[i], *b = &s->ssbo[i];
        if (u->name && u->size > 0)
            glBindBufferRange(GL_UNIFORM_BUFFER, i, (GLuint)u->name, (GLintptr)u->start,
                              (GLsizeiptr)u->size);
        else glBindBufferBase(GL_UNIFORM_BUFFER, i, (GLuint)u->name);
        if (b->name && b->size > 0)
            glBindBufferRange(GL_SHADER_STORAGE_BUFFER, i, (GLuint)b->name, (GLintptr)b->start,
                              (GLsizeiptr)b->size);
        else glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, (GLuint)b->name);
    }
    /* the generic binding points last: glBindBufferBase/Range also set them */
    glBindBuffer(GL_UNIFORM_BUFFER, (GLuint)s->uniform_buffer);
    glBindBuffer(GL_SHADER_STORAGE_BUFFER, (GLuint)s->storage_buffer);
    for (GLuint u = 0; u < SQ_GL_STATE_UNITS; u++) {
        glActiveTexture(GL_TEXTURE0 + u);
        for (int t = 0; t < SQ_GL_STATE_TEX_TARGETS; t++)
            glBindTexture(tex_targets[t], (GLuint)s->textures[u][t]);
        glBindSampler(u, (GLuint)s->samplers[u]);
    }
    glActiveTexture((GLenum)s->active_texture);
    for (GLuint i = 0; i < SQ_GL_STATE_IMAGES; i++) {
        const sq__gl_image_binding *m = &s->images[i];
        glBindImageTexture(i, (GLuint)m->name, m->level, m->layered ? GL_TRUE : GL_FALSE,
                           m->layer, (GLenum)m->access,
                           (GLenum)(m->format ? m->format : GL_R8));
    }
    for (int i = 0; i < N_CAPS; i++) enable_if(caps[i], s->caps[i]);
    glBlendFuncSeparate((GLenum)s->blend[0], (GLenum)s->blend[1], (GLenum)s->blend[2],
                        (GLenum)s->blend[3]);
    glBlendEquationSeparate((GLenum)s->blend[4], (GLenum)s->blend[5]);
    glBlendColor(s->blend_color[0], s->blend_color[1], s->blend_color[2], s->blend_color[3]);
    glDepthFunc((GLenum)s->depth_func);
    glDepthMask(s->depth_mask);
    glDepthRange(s->depth_range[0], s->depth_range[1]);
    glClipControl((GLenum)s->clip_origin, (GLenum)s->clip_depth);
    glColorMask(s->color_mask[0], s->color_mask[1], s->color_mask[2], s->color_mask[3]);
    glStencilMaskSeparate(GL_FRONT, (GLuint)s->stencil_mask);
    glStencilMaskSeparate(GL_BACK, (GLuint)s->stencil_back_mask);
    /* core profile: one mode for both faces (GL_POLYGON_MODE returns it twice) */
    glPolygonMode(GL_FRONT_AND_BACK, (GLenum)s->polygon_mode[0]);
    glPolygonOffset(s->offset_factor, s->offset_units);
    glCullFace((GLenum)s->cull_mode);
    glFrontFace((GLenum)s->front_face);
    for (int i = 0; i < N_PIXEL; i++) glPixelStorei(pixel_params[i], s->pixel[i]);
}
