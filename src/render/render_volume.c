/* render_volume.c — the volume pass: half-angle slicing with multiple forward scattering
 * (SPEC 3.2-3.4; S0 §3.4; Kniss et al. 2003; Ikits et al., GPU Gems ch. 39; Harris & Lastra
 * 2001 for the light recursion 3.21 with the Δx factor of 3.19 that S0 omits).
 *
 * Per frame, for the camera and the sun:
 *   1. slice axis s: the half-angle vector between the view direction ω_v and the light
 *      propagation direction ω_l (both propagation directions): s = normalize(ω_v + ω_l) with
 *      front-to-back eye compositing when ω_v·ω_l >= 0 (light behind the viewer), else
 *      s = normalize(ω_l - ω_v) with back-to-front. In both cases s·ω_l > 0, so visiting the
 *      planes s·x = d in increasing d is the light-propagation order.
 *   2. K = desc.volume_slices planes across the box (spacing = extent of the box along s / K,
 *      jittered per frame from desc.seed and the time), clipped to the box (grown by two
 *      spacings so that the slabs of boundary planes are not lost) on the CPU.
 *   3. For each plane in light order: the eye pass (volume_eye.frag) composites the plane's
 *      slab into the eye buffers using the light buffer, then the light pass
 *      (volume_light.frag, rendered from the sun with an orthographic projection fitted to
 *      the box) carries the light buffer across the slab (ping-pong).
 *   4. The eye buffers (colour + per-channel transmittance) are composited over the HDR scene.
 * Every fragment clips its slab to the box, to the camera and to the opaque depth (a per-pixel
 * ray interval computed once per frame by volume_bounds.frag), and the first slice in front of
 * the near plane also stands for the ray down to the camera, so a homogeneous medium gets
 * exactly exp(-β_ext d) over any path, camera inside or outside (checked by the Koschmieder
 * tests in tests/volume). sq__volume_pass_prepare_shadow runs the light passes alone before
 * the opaque passes and leaves the final light buffer (sun transmittance ratio) in
 * r->sun_shadow_tex with r->sun_shadow_matrix (world -> its texture coordinates). */
#include <math.h>
#include <string.h>

#include "render/render_internal.h"
#include "squall/rng.h"

#define VOL_MAX_SLICES 4096
#define VOL_MIN_LIGHT_SIZE 8
#define VOL_MAX_LIGHT_SIZE 4096
#define VOL_MARGIN_SPACINGS 2.0f   /* box growth for the slice polygons, in slice spacings */
#define VOL_HARRIS_GAMMA_SR 0.09   /* forward solid angle kept in the beam (Harris 2001) */
#define VOL_NOISE_N 32             /* tileable value-noise texture for coordinate noise */
#define VOL_NOISE_AMP_VOXELS 1.0f  /* perturbation amplitude (S0 Fig 3.12) */
#define VOL_NOISE_FREQ 0.25f       /* noise cells per voxel */
#define VOL_RNG_STREAM 0x766f6c756d65ull /* "volume" */

typedef struct vol_plan {
    sq_vec3 lo, size, hi;
    sq_vec3 wl, s, sun_dir;
    bool front_to_back;
    float spacing, dlambda;
    float smin, smax;   /* extent of the true box along s */
    float d_first;      /* plane k: s·x = d_first + k spacing */
    int n;              /* number of planes */
    sq_vec3 e1, e2;     /* light frame */
    float u0, v0, u1, v1, l0, l1;
    sq_mat4 light_matrix;
    float blur_uv[2];
    float forward[3];
    float noise_offset[3];
} vol_plan;

struct sq__volume_pass {
    GLuint prog_eye, prog_light, prog_comp, prog_bounds;
    GLuint vao_slices, vbo_slices, vao_empty;
    size_t vbo_bytes;
    GLuint density_tex, noise_tex;
    int dnx, dny, dnz;
    uint64_t version;
    const float *data;
    bool have_data;
    GLuint light_tex[2], light_fbo[2], shadow_tex;
    int light_size;
    GLuint eye_c, eye_t, eye_fbo, bounds_tex, bounds_fbo;
    int eye_w, eye_h;
    GLuint comp_fbo, comp_color;
    int max_3d;
    /* slice polygons of the current plan */
    float *verts;      /* 3 floats per vertex, up to 6 vertices per plane */
    int *first, *count;
    int plane_cap;
    GLint loc_plane;
};

/* ---- GL state the pass changes, restored on exit ------------------------------------------ */
typedef struct gl_saved {
    GLint fbo, viewport[4], program, vao;
    GLint blend_src_rgb, blend_dst_rgb, blend_src_a, blend_dst_a, blend_eq_rgb, blend_eq_a;
    GLboolean blend, depth, cull, scissor, depth_mask;
} gl_saved;

static void state_save(gl_saved *s)
{
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s->fbo);
    glGetIntegerv(GL_VIEWPORT, s->viewport);
    glGetIntegerv(GL_CURRENT_PROGRAM, &s->program);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &s->vao);
    s->blend = glIsEnabled(GL_BLEND);
    s->depth = glIsEnabled(GL_DEPTH_TEST);
    s->cull = glIsEnabled(GL_CULL_FACE);
    s->scissor = glIsEnabled(GL_SCISSOR_TEST);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &s->depth_mask);
    glGetIntegerv(GL_BLEND_SRC_RGB, &s->blend_src_rgb);
    glGetIntegerv(GL_BLEND_DST_RGB, &s->blend_dst_rgb);
    glGetIntegerv(GL_BLEND_SRC_ALPHA, &s->blend_src_a);
    glGetIntegerv(GL_BLEND_DST_ALPHA, &s->blend_dst_a);
    glGetIntegerv(GL_BLEND_EQUATION_RGB, &s->blend_eq_rgb);
    glGetIntegerv(GL_BLEND_EQUATION_ALPHA, &s->blend_eq_a);
}

static void enable_if(GLenum cap, GLboolean on)
{
    if (on) glEnable(cap);
    else glDisable(cap);
}

static void state_restore(const gl_saved *s)
{
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)s->fbo);
    glViewport(s->viewport[0], s->viewport[1], s->viewport[2], s->viewport[3]);
    glUseProgram((GLuint)s->program);
    glBindVertexArray((GLuint)s->vao);
    enable_if(GL_BLEND, s->blend);
    enable_if(GL_DEPTH_TEST, s->depth);
    enable_if(GL_CULL_FACE, s->cull);
    enable_if(GL_SCISSOR_TEST, s->scissor);
    glDepthMask(s->depth_mask);
    glBlendFuncSeparate((GLenum)s->blend_src_rgb, (GLenum)s->blend_dst_rgb,
                        (GLenum)s->blend_src_a, (GLenum)s->blend_dst_a);
    glBlendEquationSeparate((GLenum)s->blend_eq_rgb, (GLenum)s->blend_eq_a);
}

static void state_set_plain(void)
{
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDisable(GL_SCISSOR_TEST);
    glDepthMask(GL_FALSE);
}

/* ---- pure geometry -------------------------------------------------------------------------- */

/* Polygon where the plane n·x = d cuts the box [lo, hi]: up to 6 vertices in order around n.
 * Returns the vertex count (0 when the plane misses the box or touches it only). */
static int plane_box_polygon(sq_vec3 lo, sq_vec3 hi, sq_vec3 n, float d, sq_vec3 out[6])
{
    sq_vec3 c[8];
    for (int i = 0; i < 8; i++)
        c[i] = sq_v3((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
    static const int edges[12][2] = {{0, 1}, {2, 3}, {4, 5}, {6, 7}, {0, 2}, {1, 3},
                                     {4, 6}, {5, 7}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    sq_vec3 pts[12];
    int m = 0;
    const float eps = 1e-6f * (sq_v3_len(sq_v3_sub(hi, lo)) + 1.0f);
    for (int e = 0; e < 12; e++) {
        const sq_vec3 a = c[edges[e][0]], b = c[edges[e][1]];
        const float da = sq_v3_dot(n, a) - d, db = sq_v3_dot(n, b) - d;
        if ((da < 0.0f) == (db < 0.0f)) continue;
        const float t = da / (da - db);
        const sq_vec3 p = sq_v3_lerp(a, b, t);
        bool dup = false;
        for (int k = 0; k < m && !dup; k++) dup = sq_v3_len(sq_v3_sub(p, pts[k])) < eps;
        if (!dup) pts[m++] = p;
    }
    if (m < 3) return 0;
    if (m > 6) m = 6; /* cannot happen for a plane and a box; guards the output size */
    sq_vec3 centre = sq_v3(0.0f, 0.0f, 0.0f);
    for (int k = 0; k < m; k++) centre = sq_v3_add(centre, pts[k]);
    centre = sq_v3_scale(centre, 1.0f / (float)m);
    const sq_vec3 ref = fabsf(n.z) < 0.9f ? sq_v3(0.0f, 0.0f, 1.0f) : sq_v3(1.0f, 0.0f, 0.0f);
    const sq_vec3 u = sq_v3_norm(sq_v3_cross(ref, n));
    const sq_vec3 v = sq_v3_cross(n, u);
    float ang[6];
    for (int k = 0; k < m; k++) {
        const sq_vec3 q = sq_v3_sub(pts[k], centre);
        ang[k] = atan2f(sq_v3_dot(q, v), sq_v3_dot(q, u));
    }
    for (int i = 1; i < m; i++) { /* insertion sort by angle */
        const float a = ang[i];
        const sq_vec3 p = pts[i];
        int j = i - 1;
        while (j >= 0 && ang[j] > a) {
            ang[j + 1] = ang[j];
            pts[j + 1] = pts[j];
            j--;
        }
        ang[j + 1] = a;
        pts[j + 1] = p;
    }
    for (int k = 0; k < m; k++) out[k] = pts[k];
    return m;
}

/* Fraction of Henyey–Greenstein scattering (asymmetry g) into the cone cos θ >= mu:
 * ∫_mu^1 2π p(μ') dμ' = (1 - g^2)/(2g) [1/(1 - g) - (1 + g^2 - 2 g mu)^(-1/2)]; (1 - mu)/2 at g = 0. */
static double hg_cone_fraction(double g, double mu)
{
    if (fabs(g) < 1e-5) return 0.5 * (1.0 - mu);
    return (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 - g) - 1.0 / sqrt(1.0 + g * g - 2.0 * g * mu));
}

static float project_extent(sq_vec3 axis, sq_vec3 size)
{
    return fabsf(axis.x) * size.x + fabsf(axis.y) * size.y + fabsf(axis.z) * size.z;
}

/* Slicing plan for one frame (SPEC 3.4 steps 1-2) and the light frame. */
static void make_plan(const sq_renderer *r, const sq_volume_view *v, vol_plan *p)
{
    memset(p, 0, sizeof *p);
    p->lo = v->origin_m;
    p->size = v->size_m;
    p->hi = sq_v3_add(v->origin_m, v->size_m);
    p->sun_dir = sq_v3_norm(r->world->sun_dir);
    if (sq_v3_len(p->sun_dir) == 0.0f) p->sun_dir = sq_v3(0.0f, 0.0f, 1.0f);
    p->wl = sq_v3_scale(p->sun_dir, -1.0f);
    const sq_vec3 wv = sq_v3_norm(r->cam_forward);
    if (sq_v3_dot(wv, p->wl) >= 0.0f) {
        p->s = sq_v3_norm(sq_v3_add(wv, p->wl));
        p->front_to_back = true;
    } else {
        p->s = sq_v3_norm(sq_v3_sub(p->wl, wv));
        p->front_to_back = false;
    }
    const int K = r->desc.volume_slices;
    const sq_vec3 centre = sq_v3_add(p->lo, sq_v3_scale(p->size, 0.5f));
    const float ext = project_extent(p->s, p->size);
    const float sc = sq_v3_dot(p->s, centre);
    p->smin = sc - 0.5f * ext;
    p->smax = sc + 0.5f * ext;
    p->spacing = ext / (float)K;
    p->dlambda = p->spacing / sq_v3_dot(p->s, p->wl);

    /* per-frame jitter of the plane positions from the seed and the time */
    uint64_t tbits;
    memcpy(&tbits, &r->time_s, sizeof tbits);
    const float jitter = sq_rng_uniform(r->desc.seed, VOL_RNG_STREAM, tbits);
    const float margin = VOL_MARGIN_SPACINGS * p->spacing * project_extent(p->s, sq_v3(1, 1, 1));
    p->d_first = p->smin - margin + jitter * p->spacing;
    p->n = (int)ceilf((p->smax + margin - p->d_first) / p->spacing) + 1;

    /* light frame: orthographic view along wl fitted to the box */
    const sq_vec3 ref = fabsf(p->wl.z) < 0.9f ? sq_v3(0.0f, 0.0f, 1.0f) : sq_v3(1.0f, 0.0f, 0.0f);
    p->e1 = sq_v3_norm(sq_v3_cross(ref, p->wl));
    p->e2 = sq_v3_cross(p->wl, p->e1);
    p->u0 = p->v0 = p->l0 = INFINITY;
    p->u1 = p->v1 = p->l1 = -INFINITY;
    for (int i = 0; i < 8; i++) {
        const sq_vec3 c = sq_v3((i & 1) ? p->hi.x : p->lo.x, (i & 2) ? p->hi.y : p->lo.y,
                                (i & 4) ? p->hi.z : p->lo.z);
        const float u = sq_v3_dot(p->e1, c), w = sq_v3_dot(p->e2, c), l = sq_v3_dot(p->wl, c);
        p->u0 = fminf(p->u0, u);
        p->u1 = fmaxf(p->u1, u);
        p->v0 = fminf(p->v0, w);
        p->v1 = fmaxf(p->v1, w);
        p->l0 = fminf(p->l0, l);
        p->l1 = fmaxf(p->l1, l);
    }
    /* two texels of margin for the forward blur */
    const float mu_ = 2.0f * (p->u1 - p->u0) / (float)r->desc.light_buffer_size;
    const float mv_ = 2.0f * (p->v1 - p->v0) / (float)r->desc.light_buffer_size;
    p->u0 -= mu_;
    p->u1 += mu_;
    p->v0 -= mv_;
    p->v1 += mv_;
    const float du = p->u1 - p->u0, dv = p->v1 - p->v0, dl = fmaxf(p->l1 - p->l0, 1e-6f);
    sq_mat4 m = sq_m4_identity();
    m.m[0] = p->e1.x / du;
    m.m[4] = p->e1.y / du;
    m.m[8] = p->e1.z / du;
    m.m[12] = -p->u0 / du;
    m.m[1] = p->e2.x / dv;
    m.m[5] = p->e2.y / dv;
    m.m[9] = p->e2.z / dv;
    m.m[13] = -p->v0 / dv;
    m.m[2] = p->wl.x / dl;
    m.m[6] = p->wl.y / dl;
    m.m[10] = p->wl.z / dl;
    m.m[14] = -p->l0 / dl;
    p->light_matrix = m;

    /* forward cone of Harris's solid angle: cos θc = 1 - γ / 2π */
    const double mu_c = 1.0 - VOL_HARRIS_GAMMA_SR / (2.0 * SQ_PI);
    const double tan_c = sqrt(1.0 - mu_c * mu_c) / mu_c;
    const double blur_m = (double)p->dlambda * tan_c;
    p->blur_uv[0] = (float)(blur_m / (double)du);
    p->blur_uv[1] = (float)(blur_m / (double)dv);
    const bool iso = r->desc.isotropic_phase;
    const double g2 = iso ? 0.0 : (double)v->g2, w2 = (double)v->w2;
    for (int c = 0; c < 3; c++) {
        const double g1 = iso ? 0.0 : (double)v->g[c];
        p->forward[c] = (float)((1.0 - w2) * hg_cone_fraction(g1, mu_c) +
                                w2 * hg_cone_fraction(g2, mu_c));
    }
    const float t = (float)fmod(r->time_s, 1.0e4);
    p->noise_offset[0] = 0.05f * t;
    p->noise_offset[1] = 0.031f * t;
    p->noise_offset[2] = 0.017f * t;
}

/* ---- resources -------------------------------------------------------------------------- */

static void set_linear_clamp(GLuint tex)
{
    glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_R, GL_CLAMP_TO_EDGE);
}

static sq_result make_noise_texture(sq_renderer *r, sq__volume_pass *vp)
{
    const int n = VOL_NOISE_N;
    const size_t count = (size_t)n * n * n * 4;
    uint8_t *data = sq_alloc(r->ctx, count);
    if (!data)
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                        "volume pass: no memory for the %d^3 noise texture", n);
    for (size_t i = 0; i < count; i++) {
        const float u = sq_rng_uniform(r->desc.seed, VOL_RNG_STREAM + 1, (uint64_t)i);
        data[i] = (uint8_t)(u * 255.0f + 0.5f);
    }
    glCreateTextures(GL_TEXTURE_3D, 1, &vp->noise_tex);
    glTextureStorage3D(vp->noise_tex, 1, GL_RGBA8, n, n, n);
    glTextureSubImage3D(vp->noise_tex, 0, 0, 0, 0, n, n, n, GL_RGBA, GL_UNSIGNED_BYTE, data);
    glTextureParameteri(vp->noise_tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(vp->noise_tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(vp->noise_tex, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(vp->noise_tex, GL_TEXTURE_WRAP_T, GL_REPEAT);
    glTextureParameteri(vp->noise_tex, GL_TEXTURE_WRAP_R, GL_REPEAT);
    sq_free(r->ctx, data);
    return SQ_OK;
}

static sq_result make_light_buffers(sq_renderer *r, sq__volume_pass *vp)
{
    const int n = r->desc.light_buffer_size;
    glCreateTextures(GL_TEXTURE_2D, 2, vp->light_tex);
    glCreateFramebuffers(2, vp->light_fbo);
    for (int i = 0; i < 2; i++) {
        glTextureStorage2D(vp->light_tex[i], 1, GL_RGBA16F, n, n);
        set_linear_clamp(vp->light_tex[i]);
        glNamedFramebufferTexture(vp->light_fbo[i], GL_COLOR_ATTACHMENT0, vp->light_tex[i], 0);
        sq_result res = sq__gl_check_framebuffer(r->ctx, vp->light_fbo[i], "volume light buffer");
        if (res != SQ_OK) return res;
    }
    /* the shadow copy: outside the box's footprint the sun is unobstructed (border 1) */
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->shadow_tex);
    glTextureStorage2D(vp->shadow_tex, 1, GL_RGBA16F, n, n);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
    const float one[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    glTextureParameterfv(vp->shadow_tex, GL_TEXTURE_BORDER_COLOR, one);
    vp->light_size = n;
    return SQ_OK;
}

static sq_result ensure_eye_buffers(sq_renderer *r, sq__volume_pass *vp)
{
    if (vp->eye_fbo && vp->eye_w == r->width && vp->eye_h == r->height) return SQ_OK;
    if (vp->eye_fbo) glDeleteFramebuffers(1, &vp->eye_fbo);
    if (vp->bounds_fbo) glDeleteFramebuffers(1, &vp->bounds_fbo);
    if (vp->eye_c) glDeleteTextures(1, &vp->eye_c);
    if (vp->eye_t) glDeleteTextures(1, &vp->eye_t);
    if (vp->bounds_tex) glDeleteTextures(1, &vp->bounds_tex);
    vp->eye_fbo = vp->eye_c = vp->eye_t = vp->bounds_tex = vp->bounds_fbo = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->bounds_tex);
    glTextureStorage2D(vp->bounds_tex, 1, GL_RG32F, r->width, r->height);
    glCreateFramebuffers(1, &vp->bounds_fbo);
    glNamedFramebufferTexture(vp->bounds_fbo, GL_COLOR_ATTACHMENT0, vp->bounds_tex, 0);
    glNamedFramebufferDrawBuffer(vp->bounds_fbo, GL_COLOR_ATTACHMENT0);
    sq_result res = sq__gl_check_framebuffer(r->ctx, vp->bounds_fbo, "volume ray bounds");
    if (res != SQ_OK) return res;
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->eye_c);
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->eye_t);
    /* 32-bit floats: hundreds of slices accumulate here (half floats would lose ~0.1 %) */
    glTextureStorage2D(vp->eye_c, 1, GL_RGBA32F, r->width, r->height);
    glTextureStorage2D(vp->eye_t, 1, GL_RGBA32F, r->width, r->height);
    glCreateFramebuffers(1, &vp->eye_fbo);
    glNamedFramebufferTexture(vp->eye_fbo, GL_COLOR_ATTACHMENT0, vp->eye_c, 0);
    glNamedFramebufferTexture(vp->eye_fbo, GL_COLOR_ATTACHMENT1, vp->eye_t, 0);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(vp->eye_fbo, 2, bufs);
    vp->eye_w = r->width;
    vp->eye_h = r->height;
    return sq__gl_check_framebuffer(r->ctx, vp->eye_fbo, "volume eye buffer");
}

static sq_result ensure_comp_fbo(sq_renderer *r, sq__volume_pass *vp)
{
    if (vp->comp_fbo && vp->comp_color == r->hdr_color) return SQ_OK;
    if (!vp->comp_fbo) glCreateFramebuffers(1, &vp->comp_fbo);
    glNamedFramebufferTexture(vp->comp_fbo, GL_COLOR_ATTACHMENT0, r->hdr_color, 0);
    glNamedFramebufferDrawBuffer(vp->comp_fbo, GL_COLOR_ATTACHMENT0);
    vp->comp_color = r->hdr_color;
    return sq__gl_check_framebuffer(r->ctx, vp->comp_fbo, "volume composite target");
}

sq_result sq__volume_pass_create(sq_renderer *r)
{
    const int K = r->desc.volume_slices;
    if (K < 1 || K > VOL_MAX_SLICES)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "render.volume_slices = %d; must be in [1, %d] (0 selects 128)", K,
                        VOL_MAX_SLICES);
    GLint max2d = 0, max3d = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max2d);
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &max3d);
    const int L = r->desc.light_buffer_size;
    const int lmax = max2d < VOL_MAX_LIGHT_SIZE ? max2d : VOL_MAX_LIGHT_SIZE;
    if (L < VOL_MIN_LIGHT_SIZE || L > lmax)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "render.light_buffer_size = %d; must be in [%d, %d] (0 selects 256; the "
                        "upper limit is GL_MAX_TEXTURE_SIZE = %d capped at %d)",
                        L, VOL_MIN_LIGHT_SIZE, lmax, (int)max2d, VOL_MAX_LIGHT_SIZE);

    sq__volume_pass *vp = sq_alloc_zero(r->ctx, sizeof *vp);
    if (!vp) return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "volume pass: no memory");
    r->volume = vp;
    vp->max_3d = (int)max3d;
    vp->plane_cap = K + 64;
    vp->verts = sq_alloc(r->ctx, sizeof(float) * 18 * (size_t)vp->plane_cap);
    vp->first = sq_alloc(r->ctx, sizeof(int) * (size_t)vp->plane_cap);
    vp->count = sq_alloc(r->ctx, sizeof(int) * (size_t)vp->plane_cap);
    if (!vp->verts || !vp->first || !vp->count)
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                        "volume pass: no memory for %d slice polygons", vp->plane_cap);

    sq_result res = sq__gl_program(r->ctx, "volume_slice.vert", NULL, "volume_eye.frag",
                                   &vp->prog_eye);
    if (res == SQ_OK)
        res = sq__gl_program(r->ctx, "volume_fullscreen.vert", NULL, "volume_light.frag",
                             &vp->prog_light);
    if (res == SQ_OK)
        res = sq__gl_program(r->ctx, "volume_fullscreen.vert", NULL, "volume_composite.frag",
                             &vp->prog_comp);
    if (res == SQ_OK)
        res = sq__gl_program(r->ctx, "volume_fullscreen.vert", NULL, "volume_bounds.frag",
                             &vp->prog_bounds);
    if (res != SQ_OK) return res;
    vp->loc_plane = glGetUniformLocation(vp->prog_light, "u_plane");

    glCreateVertexArrays(1, &vp->vao_empty);
    glCreateVertexArrays(1, &vp->vao_slices);
    glCreateBuffers(1, &vp->vbo_slices);
    vp->vbo_bytes = sizeof(float) * 18 * (size_t)vp->plane_cap;
    glNamedBufferData(vp->vbo_slices, (GLsizeiptr)vp->vbo_bytes, NULL, GL_STREAM_DRAW);
    glVertexArrayVertexBuffer(vp->vao_slices, 0, vp->vbo_slices, 0, 3 * sizeof(float));
    glEnableVertexArrayAttrib(vp->vao_slices, 0);
    glVertexArrayAttribFormat(vp->vao_slices, 0, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vp->vao_slices, 0, 0);

    res = make_noise_texture(r, vp);
    if (res == SQ_OK) res = make_light_buffers(r, vp);
    if (res == SQ_OK) res = sq__gl_check(r->ctx, "volume pass create");
    return res;
}

void sq__volume_pass_destroy(sq_renderer *r)
{
    if (!r || !r->volume) return;
    sq__volume_pass *vp = r->volume;
    if (r->sun_shadow_tex == vp->shadow_tex) r->sun_shadow_tex = 0;
    glDeleteProgram(vp->prog_eye);
    glDeleteProgram(vp->prog_light);
    glDeleteProgram(vp->prog_comp);
    glDeleteProgram(vp->prog_bounds);
    glDeleteVertexArrays(1, &vp->vao_slices);
    glDeleteVertexArrays(1, &vp->vao_empty);
    glDeleteBuffers(1, &vp->vbo_slices);
    GLuint tex[8] = {vp->density_tex, vp->noise_tex, vp->light_tex[0], vp->light_tex[1],
                     vp->shadow_tex, vp->eye_c, vp->eye_t, vp->bounds_tex};
    glDeleteTextures(8, tex);
    GLuint fbo[5] = {vp->light_fbo[0], vp->light_fbo[1], vp->eye_fbo, vp->comp_fbo,
                     vp->bounds_fbo};
    glDeleteFramebuffers(5, fbo);
    sq_free(r->ctx, vp->verts);
    sq_free(r->ctx, vp->first);
    sq_free(r->ctx, vp->count);
    sq_free(r->ctx, vp);
    r->volume = NULL;
}

/* ---- validation and upload ---------------------------------------------------------------- */

static bool finite3(sq_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static sq_result validate_view(sq_renderer *r, const sq_volume_view *v)
{
    sq_context *ctx = r->ctx;
    if (!v) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "volume drawable: view is NULL");
    if (v->nx < 1 || v->ny < 1 || v->nz < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume resolution %dx%dx%d; every axis needs at least 1 cell", v->nx,
                        v->ny, v->nz);
    if (v->nx > r->volume->max_3d || v->ny > r->volume->max_3d || v->nz > r->volume->max_3d)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume resolution %dx%dx%d exceeds GL_MAX_3D_TEXTURE_SIZE = %d of this "
                        "OpenGL implementation (%s); resample the density to at most %d per axis",
                        v->nx, v->ny, v->nz, r->volume->max_3d, r->info.gl_renderer,
                        r->volume->max_3d);
    if (!v->density)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "volume drawable: density is NULL");
    if (!finite3(v->origin_m) || !finite3(v->size_m) || !(v->size_m.x > 0.0f) ||
        !(v->size_m.y > 0.0f) || !(v->size_m.z > 0.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume box origin (%g, %g, %g) m, size (%g, %g, %g) m; the size must be "
                        "finite and > 0 on every axis",
                        (double)v->origin_m.x, (double)v->origin_m.y, (double)v->origin_m.z,
                        (double)v->size_m.x, (double)v->size_m.y, (double)v->size_m.z);
    for (int c = 0; c < 3; c++) {
        if (!(v->sigma_ext[c] >= 0.0f) || !isfinite(v->sigma_ext[c]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "volume sigma_ext[%d] = %g; must be finite and >= 0", c,
                            (double)v->sigma_ext[c]);
        if (!(v->albedo[c] >= 0.0f && v->albedo[c] <= 1.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "volume albedo[%d] = %g; must be in [0, 1]", c, (double)v->albedo[c]);
        if (!(v->g[c] > -1.0f && v->g[c] < 1.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "volume g[%d] = %g; the HG asymmetry must be in (-1, 1)", c,
                            (double)v->g[c]);
    }
    if (!(v->w2 >= 0.0f && v->w2 < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume w2 = %g; the second-lobe weight must be in [0, 1)", (double)v->w2);
    if (v->w2 > 0.0f && !(v->g2 > -1.0f && v->g2 < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume g2 = %g; the second-lobe asymmetry must be in (-1, 1)",
                        (double)v->g2);
    return SQ_OK;
}

/* Uploads the density when its version, size or storage changed (R32F, x fastest as GL). */
static sq_result upload_density(sq_renderer *r, const sq_volume_view *v)
{
    sq__volume_pass *vp = r->volume;
    if (vp->have_data && vp->version == v->version && vp->data == v->density &&
        vp->dnx == v->nx && vp->dny == v->ny && vp->dnz == v->nz)
        return SQ_OK;
    const size_t n = (size_t)v->nx * (size_t)v->ny * (size_t)v->nz;
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(v->density[i])) {
            const size_t nxy = (size_t)v->nx * (size_t)v->ny;
            return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                            "volume density[%zu] (cell %zu,%zu,%zu) = %g; densities must be "
                            "finite (not rendered)",
                            i, i % (size_t)v->nx, (i % nxy) / (size_t)v->nx, i / nxy,
                            (double)v->density[i]);
        }
    }
    if (!vp->density_tex || vp->dnx != v->nx || vp->dny != v->ny || vp->dnz != v->nz) {
        if (vp->density_tex) glDeleteTextures(1, &vp->density_tex);
        glCreateTextures(GL_TEXTURE_3D, 1, &vp->density_tex);
        glTextureStorage3D(vp->density_tex, 1, GL_R32F, v->nx, v->ny, v->nz);
        set_linear_clamp(vp->density_tex);
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
    glTextureSubImage3D(vp->density_tex, 0, 0, 0, 0, v->nx, v->ny, v->nz, GL_RED, GL_FLOAT,
                        v->density);
    vp->have_data = true;
    vp->version = v->version;
    vp->data = v->density;
    vp->dnx = v->nx;
    vp->dny = v->ny;
    vp->dnz = v->nz;
    return sq__gl_check(r->ctx, "volume density upload (glTextureSubImage3D)");
}

/* ---- passes ----------------------------------------------------------------------------- */

static void u3(GLuint prog, const char *name, sq_vec3 v)
{
    glProgramUniform3f(prog, glGetUniformLocation(prog, name), v.x, v.y, v.z);
}
static void u3a(GLuint prog, const char *name, const float *v)
{
    glProgramUniform3f(prog, glGetUniformLocation(prog, name), v[0], v[1], v[2]);
}
static void u1f(GLuint prog, const char *name, float v)
{
    glProgramUniform1f(prog, glGetUniformLocation(prog, name), v);
}
static void u1i(GLuint prog, const char *name, int v)
{
    glProgramUniform1i(prog, glGetUniformLocation(prog, name), v);
}
static void um4(GLuint prog, const char *name, const sq_mat4 *m)
{
    glProgramUniformMatrix4fv(prog, glGetUniformLocation(prog, name), 1, GL_FALSE, m->m);
}

static void set_common_uniforms(sq_renderer *r, GLuint prog, const sq_volume_view *v,
                                const vol_plan *p)
{
    u3(prog, "u_box_lo", p->lo);
    u3(prog, "u_box_size", p->size);
    u3(prog, "u_dims", sq_v3((float)v->nx, (float)v->ny, (float)v->nz));
    u3(prog, "u_s", p->s);
    u3(prog, "u_wl", p->wl);
    u1f(prog, "u_dlambda", p->dlambda);
    u3a(prog, "u_sigma_ext", v->sigma_ext);
    u3a(prog, "u_albedo", v->albedo);
    u1i(prog, "u_use_noise", r->desc.volume_noise ? 1 : 0);
    u1f(prog, "u_noise_amp", VOL_NOISE_AMP_VOXELS);
    u1f(prog, "u_noise_freq", VOL_NOISE_FREQ / (float)VOL_NOISE_N);
    u3a(prog, "u_noise_offset", p->noise_offset);
}

static void set_light_uniforms(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    const GLuint prog = r->volume->prog_light;
    set_common_uniforms(r, prog, v, p);
    const float n = (float)r->volume->light_size;
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_size"), n, n);
    glProgramUniform4f(prog, glGetUniformLocation(prog, "u_uv_rect"), p->u0, p->v0, p->u1, p->v1);
    u3(prog, "u_e1", p->e1);
    u3(prog, "u_e2", p->e2);
    u3a(prog, "u_forward", p->forward);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_blur"), p->blur_uv[0], p->blur_uv[1]);
    const bool wide = fmaxf(p->blur_uv[0], p->blur_uv[1]) * n >= 0.5f;
    u1i(prog, "u_blur_wide", wide ? 1 : 0);
    u1i(prog, "u_multiple", r->desc.single_scatter_only ? 0 : 1);
}

/* Radiance units: the renderer's surfaces reflect albedo * (sun_radiance cos + ambient), i.e.
 * a white Lambertian plane facing the sun has radiance sun_radiance, so the sun's irradiance
 * is E = pi * sun_radiance and the in-scattered radiance of a medium is E p(theta) per unit
 * scattering depth. */
static sq_vec3 sun_irradiance(const sq_world *w) { return sq_v3_scale(w->sun_radiance, SQ_PI_F); }

/* Phase-averaged ambient radiance on the medium: the sky above (the mean of the base renderer's
 * hemisphere blend, mix(horizon, zenith, 0.35)) and the ground below (Lambertian, lit by the
 * sun and that sky), each over half the sphere (isotropic weighting of the two hemispheres). */
static sq_vec3 ambient_radiance(const sq_world *w)
{
    const sq_vec3 sky = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const sq_vec3 sun = sq_v3_norm(w->sun_dir);
    const float mu = sun.z > 0.0f ? sun.z : 0.0f;
    const sq_vec3 ground =
        sq_v3_mul(w->ground_albedo, sq_v3_add(sq_v3_scale(w->sun_radiance, mu), sky));
    return sq_v3_scale(sq_v3_add(sky, ground), 0.5f);
}

static void set_eye_uniforms(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    const GLuint prog = r->volume->prog_eye;
    set_common_uniforms(r, prog, v, p);
    um4(prog, "u_view_proj", &r->view_proj);
    u3(prog, "u_cam", r->cam_pos);
    u3(prog, "u_cam_forward", sq_v3_norm(r->cam_forward));
    u1f(prog, "u_near", r->near_m);
    const GLuint pb = r->volume->prog_bounds;
    um4(pb, "u_inv_view_proj", &r->inv_view_proj);
    glProgramUniform2f(pb, glGetUniformLocation(pb, "u_viewport"), (float)r->width,
                       (float)r->height);
    u3(pb, "u_cam", r->cam_pos);
    u3(pb, "u_box_lo", p->lo);
    u3(pb, "u_box_size", p->size);
    u1f(prog, "u_spacing", p->spacing);
    um4(prog, "u_light_matrix", &p->light_matrix);
    float g[3];
    for (int c = 0; c < 3; c++) g[c] = r->desc.isotropic_phase ? 0.0f : v->g[c];
    u3a(prog, "u_g", g);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_g2w2"),
                       r->desc.isotropic_phase ? 0.0f : v->g2, v->w2);
    u3(prog, "u_sun_radiance", sun_irradiance(r->world));
    u3(prog, "u_sun_dir", p->sun_dir);
    u3(prog, "u_ambient", ambient_radiance(r->world));
    u1i(prog, "u_front_to_back", p->front_to_back ? 1 : 0);
}

/* Fills the slice polygons of the plan into the vertex buffer. */
static sq_result build_slices(sq_renderer *r, vol_plan *p)
{
    sq__volume_pass *vp = r->volume;
    if (p->n > vp->plane_cap) p->n = vp->plane_cap; /* K + 64 planes; cannot be exceeded */
    const float grow = VOL_MARGIN_SPACINGS * p->spacing;
    const sq_vec3 glo = sq_v3_sub(p->lo, sq_v3(grow, grow, grow));
    const sq_vec3 ghi = sq_v3_add(p->hi, sq_v3(grow, grow, grow));
    int nv = 0;
    for (int k = 0; k < p->n; k++) {
        sq_vec3 poly[6];
        const int m = plane_box_polygon(glo, ghi, p->s, p->d_first + (float)k * p->spacing, poly);
        vp->first[k] = nv;
        vp->count[k] = m;
        for (int i = 0; i < m; i++) {
            vp->verts[3 * nv + 0] = poly[i].x;
            vp->verts[3 * nv + 1] = poly[i].y;
            vp->verts[3 * nv + 2] = poly[i].z;
            nv++;
        }
    }
    glNamedBufferSubData(vp->vbo_slices, 0, (GLsizeiptr)(sizeof(float) * 3 * (size_t)nv),
                         vp->verts);
    return SQ_OK;
}

/* True if slab k overlaps the box along s (otherwise the light pass would copy). */
static bool slab_in_box(const vol_plan *p, int k)
{
    const float d = p->d_first + (float)k * p->spacing;
    return d + 0.5f * p->spacing > p->smin && d - 0.5f * p->spacing < p->smax;
}

static void light_step(sq__volume_pass *vp, const vol_plan *p, int k, int *cur)
{
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->light_fbo[1 - *cur]);
    glViewport(0, 0, vp->light_size, vp->light_size);
    glUseProgram(vp->prog_light);
    glProgramUniform1f(vp->prog_light, vp->loc_plane, p->d_first + (float)k * p->spacing);
    glBindTextureUnit(1, vp->light_tex[*cur]);
    glBindVertexArray(vp->vao_empty);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    *cur = 1 - *cur;
}

static void bind_volume_textures(sq__volume_pass *vp)
{
    glBindTextureUnit(0, vp->density_tex);
    glBindTextureUnit(5, vp->noise_tex);
}

static void clear_light(sq__volume_pass *vp)
{
    const float one[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    glClearNamedFramebufferfv(vp->light_fbo[0], GL_COLOR, 0, one);
    glClearNamedFramebufferfv(vp->light_fbo[1], GL_COLOR, 0, one);
}

/* Leaves the light buffer `cur` in the shadow texture for the opaque and particle passes. */
static void publish_shadow(sq_renderer *r, const vol_plan *p, int cur)
{
    sq__volume_pass *vp = r->volume;
    const int n = vp->light_size;
    glCopyImageSubData(vp->light_tex[cur], GL_TEXTURE_2D, 0, 0, 0, 0, vp->shadow_tex,
                       GL_TEXTURE_2D, 0, 0, 0, 0, n, n, 1);
    r->sun_shadow_tex = vp->shadow_tex;
    r->sun_shadow_matrix = p->light_matrix;
}

static sq_result prepare(sq_renderer *r, const sq_volume_view *v, vol_plan *p)
{
    if (!r->volume)
        return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render", "volume pass was not created");
    if (!r->world)
        return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render", "volume pass: no world for the frame");
    sq_result res = validate_view(r, v);
    if (res == SQ_OK) res = upload_density(r, v);
    if (res != SQ_OK) return res;
    make_plan(r, v, p);
    return SQ_OK;
}

sq_result sq__volume_pass_prepare_shadow(sq_renderer *r, const sq_volume_view *v)
{
    vol_plan p;
    sq_result res = prepare(r, v, &p);
    if (res != SQ_OK) return res;
    sq__volume_pass *vp = r->volume;
    gl_saved saved;
    state_save(&saved);
    state_set_plain();
    set_light_uniforms(r, v, &p);
    bind_volume_textures(vp);
    clear_light(vp);
    int cur = 0;
    for (int k = 0; k < p.n; k++)
        if (slab_in_box(&p, k)) light_step(vp, &p, k, &cur);
    publish_shadow(r, &p, cur);
    state_restore(&saved);
    return sq__gl_check(r->ctx, "volume light passes");
}

sq_result sq__volume_pass_draw(sq_renderer *r, const sq_volume_view *v)
{
    vol_plan p;
    sq_result res = prepare(r, v, &p);
    if (res != SQ_OK) return res;
    sq__volume_pass *vp = r->volume;
    res = ensure_eye_buffers(r, vp);
    if (res == SQ_OK) res = ensure_comp_fbo(r, vp);
    if (res != SQ_OK) return res;
    build_slices(r, &p);

    gl_saved saved;
    state_save(&saved);
    state_set_plain();
    set_light_uniforms(r, v, &p);
    set_eye_uniforms(r, v, &p);
    bind_volume_textures(vp);

    /* per-pixel ray interval the volume may fill (box, camera, opaque depth) */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->bounds_fbo);
    glViewport(0, 0, r->width, r->height);
    glBindTextureUnit(2, r->depth_tex);
    glUseProgram(vp->prog_bounds);
    glBindVertexArray(vp->vao_empty);
    glDrawArrays(GL_TRIANGLES, 0, 3);

    glBindTextureUnit(2, vp->bounds_tex);
    glBindTextureUnit(3, vp->eye_c);
    glBindTextureUnit(4, vp->eye_t);
    clear_light(vp);
    const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f}, one[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    glClearNamedFramebufferfv(vp->eye_fbo, GL_COLOR, 0, zero);
    glClearNamedFramebufferfv(vp->eye_fbo, GL_COLOR, 1, one);
    glTextureBarrier();

    int cur = 0;
    for (int k = 0; k < p.n; k++) {
        if (vp->count[k] >= 3) { /* eye pass of slice k with the light arriving at it */
            glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->eye_fbo);
            glViewport(0, 0, r->width, r->height);
            glUseProgram(vp->prog_eye);
            glBindTextureUnit(1, vp->light_tex[cur]);
            glBindVertexArray(vp->vao_slices);
            glDrawArrays(GL_TRIANGLE_FAN, vp->first[k], vp->count[k]);
            glTextureBarrier(); /* the next slice reads what this one wrote */
        }
        if (slab_in_box(&p, k)) light_step(vp, &p, k, &cur);
    }
    publish_shadow(r, &p, cur);

    /* composite: hdr = C + T hdr per channel */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->comp_fbo);
    glViewport(0, 0, r->width, r->height);
    glUseProgram(vp->prog_comp);
    glBindVertexArray(vp->vao_empty);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_BLEND);
    state_restore(&saved);
    return sq__gl_check(r->ctx, "volume pass (half-angle slicing)");
}
