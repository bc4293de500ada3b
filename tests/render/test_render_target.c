/* test_render_target.c — the renderer in the caller's OpenGL context (use_current_context) and
 * sq_renderer_draw_to: a sandstorm (urban mode: a homogeneous dust layer over the world, so
 * every path length is known) drawn over a depth buffer the test filled, as an application
 * would after drawing its own geometry. Judged by Beer-Lambert: with two background colours the
 * transmittance of each pixel is measured exactly (result = in-scatter + T * background), and
 * must be 1 where the "user's" wall stands in front of the dust, exp(-beta L) with L the path
 * through the dust up to the wall where the wall stands inside it, and up to the far side where
 * there is no wall. Also: the caller's GL state is the same after every call (and a hostile
 * state does not change the picture), display-referred 8-bit targets keep the pixels no
 * drawable covers, the whole frame into a target equals the renderer's own frame, and bad
 * targets are refused with nothing written. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"
#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"
#include "squall/plugin.h"
#include "squall/render.h"
#include "squall/sandstorm.h"
#include "squall/world.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

#define W 192
#define H 108
#define WALL_NEAR_M 100.0f /* left third: a wall in front of the dust (which starts at 200 m) */
#define WALL_MID_M 600.0f  /* middle third: a wall inside the dust */

typedef struct fixture {
    sq_context *ctx;
    sq__gl_context *gl; /* stands for the application's own context */
    sq_world *world;
    sq_renderer *r;
    const sq_phen_plugin *plugin;
    void *storm;
    sq_drawable dust;
    sq_camera cam;
    GLuint fbo, color, depth; /* the application's framebuffer: RGBA16F + DEPTH24_STENCIL8 */
} fixture;

static bool setup(fixture *f)
{
    memset(f, 0, sizeof *f);
    sq_context_desc cd = {0};
    cd.threads = 2;
    cd.log_level = SQ_LOG_NONE;
    SQ_CHECK_OK(sq_context_create(&cd, &f->ctx));
    if (!f->ctx) return false;
    SQ_CHECK_OK(sq__gl_context_create(f->ctx, NULL, &f->gl));
    if (!f->gl) return false;
    /* a 1 km square world north of the camera: the urban dust box covers it (z up to 400 m) */
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 1000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 17;
    wd.terrain.origin_m[0] = -500.0f;
    wd.terrain.origin_m[1] = 200.0f;
    wd.terrain.origin_set = true;
    wd.sky.turbidity = 1.0f;
    wd.sun.direction = sq_v3(-0.4f, -0.5f, 0.75f);
    SQ_CHECK_OK(sq_world_create(f->ctx, &wd, &f->world));
    if (!f->world) return false;

    f->plugin = sq_plugin_find("sandstorm");
    if (!f->plugin) return false;
    sq_sandstorm_desc sd;
    memset(&sd, 0, sizeof sd);
    sd.mode = SQ_SANDSTORM_URBAN;
    sd.urban_conc_kg_m3[0] = 5e-5f; /* 50 mg/m3: beta ~ 1.8e-3 /m */
    sd.urban_conc_count = 1;
    SQ_CHECK_OK(f->plugin->desc_resolve(&sd));
    SQ_CHECK_OK(f->plugin->create(f->ctx, &sd, f->world, &f->storm));
    if (!f->storm) return false;
    SQ_CHECK_OK(f->plugin->step(f->storm, 0.1));
    SQ_CHECK(f->plugin->drawables(f->storm, &f->dust, 1) == 1);
    SQ_CHECK(f->dust.kind == SQ_DRAWABLE_VOLUME);

    sq_render_desc rd = {0};
    rd.use_current_context = true;
    rd.seed = 3;
    SQ_CHECK_OK(sq_renderer_create(f->ctx, &rd, &f->r));
    if (!f->r) return false;

    f->cam.position_m = sq_v3(0.0f, 0.0f, 20.0f);
    f->cam.target_m = sq_v3(0.0f, 100.0f, 20.0f);
    f->cam.fov_y_deg = 50.0f;
    f->cam.near_m = 1.0f;
    f->cam.far_m = 5000.0f;

    glCreateTextures(GL_TEXTURE_2D, 1, &f->color);
    glTextureStorage2D(f->color, 1, GL_RGBA16F, W, H);
    glCreateRenderbuffers(1, &f->depth);
    glNamedRenderbufferStorage(f->depth, GL_DEPTH24_STENCIL8, W, H);
    glCreateFramebuffers(1, &f->fbo);
    glNamedFramebufferTexture(f->fbo, GL_COLOR_ATTACHMENT0, f->color, 0);
    glNamedFramebufferRenderbuffer(f->fbo, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, f->depth);
    SQ_CHECK(glCheckNamedFramebufferStatus(f->fbo, GL_FRAMEBUFFER) == GL_FRAMEBUFFER_COMPLETE);
    return true;
}

static void teardown(fixture *f)
{
    if (f->gl) {
        glDeleteFramebuffers(1, &f->fbo);
        glDeleteTextures(1, &f->color);
        glDeleteRenderbuffers(1, &f->depth);
    }
    sq_renderer_destroy(f->r);
    if (f->storm) f->plugin->destroy(f->storm);
    sq_world_destroy(f->ctx, f->world);
    sq__gl_context_destroy(f->gl);
    sq_context_destroy(f->ctx);
}

/* Window depth of a plane at view distance d_m for the fixture's camera. */
static float window_depth(const fixture *f, float d_m, float aspect)
{
    const sq_mat4 p = sq_camera_proj(&f->cam, aspect);
    const sq_vec4 c = sq_m4_mul_v4(p, (sq_vec4){0.0f, 0.0f, -d_m, 1.0f});
    return 0.5f * c.z / c.w + 0.5f;
}

/* The "application" draws: colour cleared to bg, depth = walls in the left and middle thirds. */
static void app_draw(const fixture *f, GLuint fbo, const float bg[3], int w, int h)
{
    const float c[4] = {bg[0], bg[1], bg[2], 1.0f};
    const float aspect = (float)w / (float)h;
    glClearNamedFramebufferfv(fbo, GL_COLOR, 0, c);
    glClearNamedFramebufferfi(fbo, GL_DEPTH_STENCIL, 0, 1.0f, 0);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, w / 3, h);
    glClearNamedFramebufferfi(fbo, GL_DEPTH_STENCIL, 0, window_depth(f, WALL_NEAR_M, aspect), 0);
    glScissor(w / 3, 0, 2 * w / 3 - w / 3, h);
    glClearNamedFramebufferfi(fbo, GL_DEPTH_STENCIL, 0, window_depth(f, WALL_MID_M, aspect), 0);
    glDisable(GL_SCISSOR_TEST);
}

static void read_rgb(GLuint fbo, int w, int h, float *rgb)
{
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, w, h, GL_RGB, GL_FLOAT, rgb);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
}

/* SQ_TARGET_DUMP=<dir>: the frame as PNG (tone-mapped, rows flipped to top first). */
static void dump(const char *name, const float *rgb)
{
    const char *dir = getenv("SQ_TARGET_DUMP");
    if (!dir) return;
    float *flip = malloc(sizeof(float) * 3 * W * H);
    uint8_t *rgba = malloc((size_t)4 * W * H);
    if (flip && rgba) {
        for (int j = 0; j < H; j++)
            memcpy(flip + (size_t)3 * W * j, rgb + (size_t)3 * W * (H - 1 - j), sizeof(float) * 3 * W);
        sq_tonemap_rgba8(flip, W, H, 1.0f, rgba);
        char path[512];
        snprintf(path, sizeof path, "%s/%s.png", dir, name);
        sq_png_write_rgba8(path, W, H, rgba, true);
    }
    free(flip);
    free(rgba);
}

static sq_render_target target_of(GLuint fbo, sq_target_colour colour)
{
    sq_render_target t = {0};
    t.framebuffer = fbo;
    t.width = W;
    t.height = H;
    t.content = SQ_TARGET_DRAWABLES_OVER;
    t.colour = colour;
    return t;
}

/* Ray of pixel (i, j) (j from the bottom row, as GL reads) and the ray/box interval. */
static void pixel_ray(const sq_camera *c, int i, int j, sq_vec3 *d)
{
    const sq_mat4 vp = sq_m4_mul(sq_camera_proj(c, (float)W / (float)H), sq_camera_view(c));
    const sq_mat4 inv = sq_m4_inverse(vp);
    const float x = ((float)i + 0.5f) / (float)W * 2.0f - 1.0f;
    const float y = ((float)j + 0.5f) / (float)H * 2.0f - 1.0f;
    const sq_vec4 a = sq_m4_mul_v4(inv, (sq_vec4){x, y, -1.0f, 1.0f});
    const sq_vec4 b = sq_m4_mul_v4(inv, (sq_vec4){x, y, 1.0f, 1.0f});
    *d = sq_v3_norm(sq_v3_sub(sq_v3(b.x / b.w, b.y / b.w, b.z / b.w),
                              sq_v3(a.x / a.w, a.y / a.w, a.z / a.w)));
}

static bool ray_box(sq_vec3 o, sq_vec3 d, sq_vec3 lo, sq_vec3 hi, float *t0, float *t1)
{
    const float ov[3] = {o.x, o.y, o.z}, dv[3] = {d.x, d.y, d.z};
    const float lv[3] = {lo.x, lo.y, lo.z}, hv[3] = {hi.x, hi.y, hi.z};
    float a = 0.0f, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (fabsf(dv[k]) < 1e-12f) {
            if (ov[k] < lv[k] || ov[k] > hv[k]) return false;
            continue;
        }
        float u = (lv[k] - ov[k]) / dv[k], v = (hv[k] - ov[k]) / dv[k];
        if (u > v) {
            const float s = u;
            u = v;
            v = s;
        }
        a = fmaxf(a, u);
        b = fminf(b, v);
    }
    *t0 = a;
    *t1 = b;
    return b > a;
}

#if SQ_HAVE_SANDSTORM
/* Beer-Lambert behind and in front of the application's walls, measured per pixel. */
SQ_TEST(dust_occluded_by_caller_depth)
{
    fixture f;
    float *r1 = malloc(sizeof(float) * 3 * W * H), *r2 = malloc(sizeof(float) * 3 * W * H);
    if (!setup(&f) || !r1 || !r2) goto done;
    const float bg1[3] = {0.20f, 0.30f, 0.40f}, bg2[3] = {1.10f, 0.90f, 0.70f};
    const sq_render_target t = target_of(f.fbo, SQ_TARGET_LINEAR);
    app_draw(&f, f.fbo, bg1, W, H);
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &f.cam, &f.dust, 1, 0.0));
    read_rgb(f.fbo, W, H, r1);
    dump("target_over_walls", r1);
    app_draw(&f, f.fbo, bg2, W, H);
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &f.cam, &f.dust, 1, 0.0));
    read_rgb(f.fbo, W, H, r2);

    const sq_volume_view *v = &f.dust.u.volume;
    const sq_vec3 lo = v->origin_m, hi = sq_v3_add(v->origin_m, v->size_m);
    const float beta550 = v->density[0]; /* uniform: beta_ext at 550 nm (1/m) */
    printf("dust: beta_ext(550 nm) = %.3g /m, sigma_rel = %.3f %.3f %.3f, box y %.0f..%.0f m\n",
           (double)beta550, (double)v->sigma_ext[0], (double)v->sigma_ext[1],
           (double)v->sigma_ext[2], (double)lo.y, (double)hi.y);
    SQ_CHECK(beta550 > 5e-4f && beta550 < 5e-3f); /* optical depths 0.2..5 over the scene */

    double near_dev = 0.0, mid_err = 0.0, far_err = 0.0, a_mid = 0.0, a_far = 0.0;
    int n_near = 0, n_mid = 0, n_far = 0;
    for (int j = H / 2 - 12; j < H / 2 + 12; j++) /* rows near the horizon: inside the layer */
        for (int i = 0; i < W; i++) {
            const int band = i < W / 3 - 1 ? 0 : (i > W / 3 && i < 2 * W / 3 - 1) ? 1
                                                : i > 2 * W / 3 ? 2 : -1;
            if (band < 0) continue; /* one pixel column at each band edge */
            sq_vec3 d;
            pixel_ray(&f.cam, i, j, &d);
            float t0 = 0.0f, t1 = 0.0f;
            SQ_CHECK(ray_box(f.cam.position_m, d, lo, hi, &t0, &t1));
            const float fwd = d.y; /* the camera looks along +y: view depth = t * d.y */
            const float t_wall = band == 0 ? WALL_NEAR_M / fwd : band == 1 ? WALL_MID_M / fwd
                                                                            : INFINITY;
            const float L = fmaxf(fminf(t1, t_wall) - t0, 0.0f);
            for (int c = 0; c < 3; c++) {
                const size_t q = (size_t)3 * ((size_t)j * W + (size_t)i) + (size_t)c;
                const double T = (r1[q] - r2[q]) / (double)(bg1[c] - bg2[c]);
                const double A = r1[q] - T * bg1[c];
                const double expect = exp(-(double)(beta550 * v->sigma_ext[c]) * L);
                if (band == 0) {
                    near_dev = fmax(near_dev, fmax(fabs(r1[q] - bg1[c]), fabs(r2[q] - bg2[c])));
                    n_near++;
                } else if (band == 1) {
                    mid_err = fmax(mid_err, fabs(T - expect) / expect);
                    a_mid += A;
                    n_mid++;
                } else {
                    far_err = fmax(far_err, fabs(T - expect) / expect);
                    a_far += A;
                    n_far++;
                }
            }
        }
    a_mid /= n_mid > 0 ? n_mid : 1;
    a_far /= n_far > 0 ? n_far : 1;
    printf("wall in front: %d samples, max |change| %.3g; wall inside: %d samples, max rel error "
           "of T %.4f, mean in-scatter %.4f; no wall: %d samples, max rel error of T %.4f, mean "
           "in-scatter %.4f\n",
           n_near, near_dev, n_mid, mid_err, a_mid, n_far, far_err, a_far);
    SQ_CHECK(n_near > 100 && n_mid > 100 && n_far > 100);
    /* in front of the dust: the application's pixels untouched (RGBA16F round trip only) */
    SQ_CHECK(near_dev <= 1e-3);
    /* behind some dust: Beer-Lambert up to the wall or through the layer (5 %, as the
     * Koschmieder tests of the volume pass) */
    SQ_CHECK(mid_err <= 0.05);
    SQ_CHECK(far_err <= 0.05);
    /* dust appears where nothing hides it: more light scattered in along the longer paths */
    SQ_CHECK(a_mid > 0.002);
    SQ_CHECK(a_far > a_mid);
done:
    free(r1);
    free(r2);
    teardown(&f);
}

/* A few pieces of the state list, set to unusual values, and compared after the call. */
typedef struct probe {
    GLint draw_fbo, read_fbo, viewport[4], scissor[4], vao, active, tex0, tex2, sampler0, ubo0;
    GLint unpack_buf, unpack_align, unpack_row, blend_src, blend_dst, depth_func, poly[2];
    GLint clip_depth, program;
    GLboolean blend, scissor_on, cull, depth_mask, color_mask[4];
} probe;

static void probe_read(probe *p)
{
    memset(p, 0, sizeof *p);
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &p->draw_fbo);
    glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &p->read_fbo);
    glGetIntegerv(GL_VIEWPORT, p->viewport);
    glGetIntegerv(GL_SCISSOR_BOX, p->scissor);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &p->vao);
    glGetIntegerv(GL_ACTIVE_TEXTURE, &p->active);
    glGetIntegerv(GL_CURRENT_PROGRAM, &p->program);
    glActiveTexture(GL_TEXTURE0);
    glGetIntegerv(GL_TEXTURE_BINDING_2D, &p->tex0);
    glActiveTexture(GL_TEXTURE2);
    glGetIntegerv(GL_TEXTURE_BINDING_2D, &p->tex2);
    glActiveTexture((GLenum)p->active);
    glGetIntegeri_v(GL_SAMPLER_BINDING, 0, &p->sampler0);
    glGetIntegeri_v(GL_UNIFORM_BUFFER_BINDING, 0, &p->ubo0);
    glGetIntegerv(GL_PIXEL_UNPACK_BUFFER_BINDING, &p->unpack_buf);
    glGetIntegerv(GL_UNPACK_ALIGNMENT, &p->unpack_align);
    glGetIntegerv(GL_UNPACK_ROW_LENGTH, &p->unpack_row);
    glGetIntegerv(GL_BLEND_SRC_RGB, &p->blend_src);
    glGetIntegerv(GL_BLEND_DST_RGB, &p->blend_dst);
    glGetIntegerv(GL_DEPTH_FUNC, &p->depth_func);
    glGetIntegerv(GL_POLYGON_MODE, p->poly);
    glGetIntegerv(GL_CLIP_DEPTH_MODE, &p->clip_depth);
    p->blend = glIsEnabled(GL_BLEND);
    p->scissor_on = glIsEnabled(GL_SCISSOR_TEST);
    p->cull = glIsEnabled(GL_CULL_FACE);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &p->depth_mask);
    glGetBooleanv(GL_COLOR_WRITEMASK, p->color_mask);
}

/* The caller's state comes back; a hostile state (pixel-unpack buffer bound, row length set,
 * wireframe, sampler objects, reversed-Z clip control, masks) changes no pixel of the result. */
SQ_TEST(caller_state_restored)
{
    fixture f;
    float *clean = malloc(sizeof(float) * 3 * W * H), *hostile = malloc(sizeof(float) * 3 * W * H);
    GLuint other_fbo = 0, tex_a = 0, tex_b = 0, sampler = 0, ubo = 0, pbo = 0, vao = 0;
    if (!setup(&f) || !clean || !hostile) goto done;
    const float bg[3] = {0.3f, 0.3f, 0.3f};
    const sq_render_target t = target_of(f.fbo, SQ_TARGET_LINEAR);
    app_draw(&f, f.fbo, bg, W, H);
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &f.cam, &f.dust, 1, 0.0));
    read_rgb(f.fbo, W, H, clean);

    glCreateFramebuffers(1, &other_fbo);
    glCreateTextures(GL_TEXTURE_2D, 1, &tex_a);
    glCreateTextures(GL_TEXTURE_2D, 1, &tex_b);
    glTextureStorage2D(tex_a, 1, GL_RGBA8, 4, 4);
    glTextureStorage2D(tex_b, 1, GL_RGBA8, 4, 4);
    glCreateSamplers(1, &sampler);
    glSamplerParameteri(sampler, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glCreateBuffers(1, &ubo);
    glNamedBufferStorage(ubo, 256, NULL, GL_DYNAMIC_STORAGE_BIT);
    glCreateBuffers(1, &pbo);
    glNamedBufferStorage(pbo, 1 << 16, NULL, GL_DYNAMIC_STORAGE_BIT);
    glCreateVertexArrays(1, &vao);
    app_draw(&f, f.fbo, bg, W, H);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, other_fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, f.fbo);
    glViewport(3, 5, 7, 11);
    glScissor(1, 2, 3, 4);
    glEnable(GL_SCISSOR_TEST);
    glEnable(GL_CULL_FACE);
    glEnable(GL_BLEND);
    glBlendFunc(GL_DST_COLOR, GL_SRC_ALPHA);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_FALSE);
    glColorMask(GL_TRUE, GL_FALSE, GL_TRUE, GL_FALSE);
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glBindVertexArray(vao);
    glBindTextureUnit(0, tex_a);
    glBindTextureUnit(2, tex_b);
    glBindSampler(0, sampler);
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, ubo);
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, pbo);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 2);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 7);
    glActiveTexture(GL_TEXTURE5);
    probe before, after;
    probe_read(&before);
    /* a new volume version forces a density upload under the hostile unpack state */
    sq_drawable d = f.dust;
    d.u.volume.version += 1000;
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &f.cam, &d, 1, 0.0));
    probe_read(&after);
    SQ_CHECK(glGetError() == GL_NO_ERROR);
    SQ_CHECK_MSG(memcmp(&before, &after, sizeof before) == 0, "GL state changed by the call");
    SQ_CHECK(after.draw_fbo == (GLint)other_fbo && after.vao == (GLint)vao &&
             after.tex0 == (GLint)tex_a && after.unpack_buf == (GLint)pbo &&
             after.poly[0] == GL_LINE && after.active == GL_TEXTURE5);
    /* put the harmless state back for the read-back */
    glBindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    read_rgb(f.fbo, W, H, hostile);
    double dev = 0.0;
    for (size_t k = 0; k < (size_t)3 * W * H; k++) dev = fmax(dev, fabs(clean[k] - hostile[k]));
    printf("hostile caller state: max pixel difference %.3g\n", dev);
    SQ_CHECK(dev == 0.0);
done:
    glDeleteFramebuffers(1, &other_fbo);
    glDeleteTextures(1, &tex_a);
    glDeleteTextures(1, &tex_b);
    glDeleteSamplers(1, &sampler);
    glDeleteBuffers(1, &ubo);
    glDeleteBuffers(1, &pbo);
    glDeleteVertexArrays(1, &vao);
    free(clean);
    free(hostile);
    teardown(&f);
}

/* An 8-bit display-referred target (RGBA8 + DEPTH32F texture): pixels behind the near wall keep
 * their bytes (within 1 of 255: the inverse tone curve, a half-float frame, the curve again),
 * the dust changes the others. */
SQ_TEST(display_target_keeps_covered_pixels)
{
    fixture f;
    GLuint fbo = 0, color = 0, depth = 0;
    uint8_t *before = malloc((size_t)4 * W * H), *after = malloc((size_t)4 * W * H);
    if (!setup(&f) || !before || !after) goto done;
    glCreateTextures(GL_TEXTURE_2D, 1, &color);
    glTextureStorage2D(color, 1, GL_RGBA8, W, H);
    glCreateTextures(GL_TEXTURE_2D, 1, &depth);
    glTextureStorage2D(depth, 1, GL_DEPTH_COMPONENT32F, W, H);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color, 0);
    glNamedFramebufferTexture(fbo, GL_DEPTH_ATTACHMENT, depth, 0);
    /* a gradient of display colours, so that the whole curve is exercised */
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            uint8_t *p = before + 4 * ((size_t)j * W + (size_t)i);
            p[0] = (uint8_t)(i * 255 / (W - 1));
            p[1] = (uint8_t)(j * 255 / (H - 1));
            p[2] = (uint8_t)((i + j) % 256);
            p[3] = 77; /* alpha is never written */
        }
    glTextureSubImage2D(color, 0, 0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, before);
    const float aspect = (float)W / (float)H;
    const float far_depth = 1.0f, near_depth = window_depth(&f, WALL_NEAR_M, aspect);
    glClearNamedFramebufferfv(fbo, GL_DEPTH, 0, &far_depth);
    glEnable(GL_SCISSOR_TEST);
    glScissor(0, 0, W / 2, H);
    glClearNamedFramebufferfv(fbo, GL_DEPTH, 0, &near_depth);
    glDisable(GL_SCISSOR_TEST);
    const sq_render_target t = target_of(fbo, SQ_TARGET_DISPLAY);
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &f.cam, &f.dust, 1, 0.0));
    glGetTextureImage(color, 0, GL_RGBA, GL_UNSIGNED_BYTE, 4 * W * H, after);
    int kept_dev = 0, changed = 0, n_right = 0, alpha_bad = 0;
    for (int j = H / 2 - 10; j < H / 2 + 10; j++)
        for (int i = 0; i < W; i++) {
            const uint8_t *a = before + 4 * ((size_t)j * W + (size_t)i);
            const uint8_t *b = after + 4 * ((size_t)j * W + (size_t)i);
            alpha_bad += b[3] != 77;
            if (i < W / 2 - 1) {
                for (int c = 0; c < 3; c++) kept_dev = abs(a[c] - b[c]) > kept_dev ? abs(a[c] - b[c]) : kept_dev;
            } else if (i > W / 2) {
                n_right++;
                changed += abs(a[0] - b[0]) + abs(a[1] - b[1]) + abs(a[2] - b[2]) > 12;
            }
        }
    printf("display target: covered pixels max byte change %d; uncovered changed by dust %d of "
           "%d\n", kept_dev, changed, n_right);
    SQ_CHECK(kept_dev <= 1);
    SQ_CHECK(changed > 0.9 * n_right);
    SQ_CHECK(alpha_bad == 0);
done:
    glDeleteFramebuffers(1, &fbo);
    glDeleteTextures(1, &color);
    glDeleteTextures(1, &depth);
    free(before);
    free(after);
    teardown(&f);
}
#endif

/* SQ_TARGET_FRAME into an 8-bit target is the renderer's own frame, pixel for pixel (rows bottom
 * first in GL), with no sandstorm needed: sky and terrain. */
SQ_TEST(whole_frame_into_target)
{
    fixture f;
    memset(&f, 0, sizeof f);
    GLuint fbo = 0, color = 0, depth = 0;
    uint8_t *own = malloc((size_t)4 * W * H), *tgt = malloc((size_t)4 * W * H);
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    SQ_CHECK_OK(sq_context_create(&cd, &f.ctx));
    SQ_CHECK_OK(sq__gl_context_create(f.ctx, NULL, &f.gl));
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_HILLS;
    SQ_CHECK_OK(sq_world_create(f.ctx, &wd, &f.world));
    sq_render_desc rd = {0};
    rd.use_current_context = true;
    rd.width = W;
    rd.height = H;
    SQ_CHECK_OK(sq_renderer_create(f.ctx, &rd, &f.r));
    if (!f.r || !f.world || !own || !tgt) goto done;
    sq_camera cam = {0};
    cam.position_m = sq_v3(0.0f, -600.0f, sq_world_height_at(f.world, 0.0f, -600.0f) + 60.0f);
    cam.target_m = sq_v3(0.0f, 400.0f, 20.0f);
    SQ_CHECK_OK(sq_renderer_draw(f.r, f.world, &cam, NULL, 0, 0.0));
    SQ_CHECK_OK(sq_renderer_read_rgba8(f.r, own));
    glCreateTextures(GL_TEXTURE_2D, 1, &color);
    glTextureStorage2D(color, 1, GL_RGBA8, W, H);
    glCreateRenderbuffers(1, &depth);
    glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT24, W, H);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color, 0);
    glNamedFramebufferRenderbuffer(fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    sq_render_target t = {0};
    t.framebuffer = fbo;
    t.width = W;
    t.height = H;
    t.content = SQ_TARGET_FRAME;
    t.colour = SQ_TARGET_DISPLAY;
    SQ_CHECK_OK(sq_renderer_draw_to(f.r, &t, f.world, &cam, NULL, 0, 0.0));
    glGetTextureImage(color, 0, GL_RGBA, GL_UNSIGNED_BYTE, 4 * W * H, tgt);
    int worst = 0;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++)
            for (int c = 0; c < 3; c++) {
                const int a = own[4 * ((size_t)(H - 1 - j) * W + (size_t)i) + (size_t)c];
                const int b = tgt[4 * ((size_t)j * W + (size_t)i) + (size_t)c];
                worst = abs(a - b) > worst ? abs(a - b) : worst;
            }
    printf("whole frame into a target: max byte difference to the own frame %d\n", worst);
    SQ_CHECK(worst == 0);
    /* the depth of the terrain reached the target: the centre pixel is nearer than the far plane */
    GLuint probe_fbo = fbo;
    float z = 1.0f;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, probe_fbo);
    glReadPixels(W / 2, H / 4, 1, 1, GL_DEPTH_COMPONENT, GL_FLOAT, &z);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    SQ_CHECK(z < 0.9999f);
done:
    glDeleteFramebuffers(1, &fbo);
    glDeleteTextures(1, &color);
    glDeleteRenderbuffers(1, &depth);
    free(own);
    free(tgt);
    teardown(&f);
}

/* Refusals: the own-context renderer, a missing depth buffer, a multisampled target, a bad size,
 * no current context. The target is not written. */
SQ_TEST(bad_targets_refused)
{
    fixture f;
    memset(&f, 0, sizeof f);
    GLuint fbo = 0, color = 0, ms_fbo = 0, ms_color = 0;
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    SQ_CHECK_OK(sq_context_create(&cd, &f.ctx));
    /* no context current: refused with a message, no crash */
    sq_render_desc rd = {0};
    rd.use_current_context = true;
    sq_renderer *r = NULL;
    SQ_CHECK(sq_renderer_create(f.ctx, &rd, &r) == SQ_ERR_GL && r == NULL);
    SQ_CHECK(strstr(sq_last_error(), "no OpenGL context is current") != NULL);
    SQ_CHECK_OK(sq__gl_context_create(f.ctx, NULL, &f.gl));
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    SQ_CHECK_OK(sq_world_create(f.ctx, &wd, &f.world));
    SQ_CHECK_OK(sq_renderer_create(f.ctx, &rd, &f.r));
    if (!f.r || !f.world) goto done;
    sq_camera cam = {0};
    cam.position_m = sq_v3(0.0f, 0.0f, 10.0f);
    cam.target_m = sq_v3(0.0f, 10.0f, 10.0f);
    glCreateTextures(GL_TEXTURE_2D, 1, &color);
    glTextureStorage2D(color, 1, GL_RGBA8, W, H);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color, 0);
    const float mark[4] = {0.25f, 0.5f, 0.75f, 1.0f};
    glClearNamedFramebufferfv(fbo, GL_COLOR, 0, mark);
    sq_render_target t = {0};
    t.framebuffer = fbo;
    t.width = W;
    t.height = H;
    t.content = SQ_TARGET_DRAWABLES_OVER;
    SQ_CHECK(sq_renderer_draw_to(f.r, &t, f.world, &cam, NULL, 0, 0.0) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "has no depth buffer") != NULL);
    uint8_t px[4] = {0};
    glGetTextureSubImage(color, 0, W / 2, H / 2, 0, 1, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, 4, px);
    SQ_CHECK(px[0] == 64 && px[1] == 128 && px[2] == 191);
    t.width = 0;
    SQ_CHECK(sq_renderer_draw_to(f.r, &t, f.world, &cam, NULL, 0, 0.0) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "sq_render_target.width") != NULL);
    t.width = W;
    t.framebuffer = 987654;
    SQ_CHECK(sq_renderer_draw_to(f.r, &t, f.world, &cam, NULL, 0, 0.0) == SQ_ERR_INVALID_ARG);
    glCreateRenderbuffers(1, &ms_color);
    glNamedRenderbufferStorageMultisample(ms_color, 4, GL_RGBA8, W, H);
    glCreateFramebuffers(1, &ms_fbo);
    glNamedFramebufferRenderbuffer(ms_fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, ms_color);
    t.framebuffer = ms_fbo;
    t.content = SQ_TARGET_FRAME;
    SQ_CHECK(sq_renderer_draw_to(f.r, &t, f.world, &cam, NULL, 0, 0.0) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "multisampled") != NULL);
    /* a renderer with its own context cannot draw into the caller's framebuffer */
    sq_render_desc own = {0};
    own.width = 16;
    own.height = 16;
    sq_renderer *r2 = NULL;
    SQ_CHECK_OK(sq_renderer_create(f.ctx, &own, &r2));
    SQ_CHECK(sq_renderer_draw_to(r2, &t, f.world, &cam, NULL, 0, 0.0) == SQ_ERR_INVALID_ARG);
    SQ_CHECK(strstr(sq_last_error(), "use_current_context") != NULL);
    sq_renderer_destroy(r2);
    SQ_CHECK_OK(sq__gl_context_make_current(f.gl)); /* r2 made its own context current */
done:
    glDeleteFramebuffers(1, &fbo);
    glDeleteFramebuffers(1, &ms_fbo);
    glDeleteTextures(1, &color);
    glDeleteRenderbuffers(1, &ms_color);
    teardown(&f);
}
