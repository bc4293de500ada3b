/* render_clouds.c — the cloud pass (SPEC 8.4–8.5; S4 §3; Harris & Lastra 2001, Harris 2001
 * dynamic impostors):
 *   prepare (before the opaque passes): the multiple-forward-scattering light of every particle
 *     on the CPU (clouds_light.c: sun sweep in order of distance from the sun, diffuse and sky
 *     terms), cached while the particles and the sun stay the same; its final light buffer is
 *     uploaded as the sun shadow the terrain shader reads (unless a volume already casts one);
 *   draw (after volumes and soft particles): per cloud group, the distance D of its centre picks
 *     particles (D <= dist_3d), an impostor (D >= dist_impostor) or both cross-faded with the
 *     smoothstep weight w (particles' opacity x (1 - w), impostor x w); impostors are drawn first
 *     (they are the distant clouds), then the particles back to front as camera-facing billboards
 *     (clouds_billboard.*), premultiplied "over" into the HDR target, softly depth-tested against
 *     the opaque scene.
 * Impostors: the group's particles rendered from the current eye into an RGBA16F texture whose
 * frustum just holds the group's bounding sphere, re-rendered when the direction from the eye to
 * the cloud turns by more than impostor_angle_deg, the distance changes by more than 10 %, the
 * cloud's size changes by more than 10 %, or after IMP_MAX_AGE frames (the field evolves; at
 * most IMP_AGED_PER_FRAME of those per frame, the others wait a frame or a few). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render/clouds_light.h"
#include "render/render_internal.h"
#include "world/world_struct.h"

#define PACK 12            /* floats per instance: pos r | tau fade g I | amb.rgb 0 */
#define BATCH 8192
#define IMP_SLOTS 64
#define IMP_MIN_PX 32
#define IMP_MAX_PX 512
#define IMP_MAX_AGE 48     /* frames */
#define IMP_AGED_PER_FRAME 4 /* impostors re-rendered for their age alone, per frame (so that
                                clouds made together are not all re-rendered in one frame) */
#define IMP_DIST_TOL 0.10f
#define IMP_SIZE_TOL 0.10f

typedef struct impostor {
    GLuint tex, fbo;
    int px;
    bool valid;
    sq_vec3 center, dir;   /* when made: cloud centre and unit direction eye -> centre */
    float radius, dist;
    uint64_t made_frame, used_frame;
} impostor;

struct sq__clouds_pass {
    GLuint prog, prog_imp;
    GLuint vao, vbo;
    size_t vbo_bytes;
    GLuint shadow_tex;
    int shadow_w, shadow_h;
    GLuint far_depth; /* 1x1 depth 1.0: "no scene" for impostor renders */
    /* light cache */
    sq__cloud_light light;
    uint64_t light_version;
    const float *light_positions;
    sq_vec3 light_sun;
    bool light_ms;
    bool light_valid;
    /* staging */
    size_t cap;
    float *packed, *ambient;
    uint32_t *key, *idx, *key2, *idx2;
    float *group_w;
    int group_cap;
    impostor imp[IMP_SLOTS];
    uint64_t frame;
    sq__clouds_pass_stats stats;
};

/* ---- lifecycle ------------------------------------------------------------------------------- */
sq_result sq__clouds_pass_create(sq_renderer *r)
{
    sq__clouds_pass *cp = sq_alloc_zero(r->ctx, sizeof *cp);
    if (!cp) return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "cloud pass: no memory");
    r->clouds = cp;
    sq_result res = sq__gl_program(r->ctx, "clouds_billboard.vert", NULL, "clouds_billboard.frag",
                                   &cp->prog);
    if (res == SQ_OK)
        res = sq__gl_program(r->ctx, "clouds_impostor.vert", NULL, "clouds_impostor.frag",
                             &cp->prog_imp);
    if (res != SQ_OK) return res;
    glCreateVertexArrays(1, &cp->vao);
    glCreateBuffers(1, &cp->vbo);
    glVertexArrayVertexBuffer(cp->vao, 0, cp->vbo, 0, PACK * sizeof(float));
    glVertexArrayBindingDivisor(cp->vao, 0, 1);
    for (GLuint a = 0; a < 3; a++) {
        glEnableVertexArrayAttrib(cp->vao, a);
        glVertexArrayAttribFormat(cp->vao, a, 4, GL_FLOAT, GL_FALSE, a * 4 * sizeof(float));
        glVertexArrayAttribBinding(cp->vao, a, 0);
    }
    glCreateTextures(GL_TEXTURE_2D, 1, &cp->far_depth);
    glTextureStorage2D(cp->far_depth, 1, GL_R32F, 1, 1);
    const float one = 1.0f;
    glTextureSubImage2D(cp->far_depth, 0, 0, 0, 1, 1, GL_RED, GL_FLOAT, &one);
    return sq__gl_check(r->ctx, "cloud pass create");
}

static void free_staging(sq_context *ctx, sq__clouds_pass *cp)
{
    sq_free(ctx, cp->packed);
    sq_free(ctx, cp->ambient);
    sq_free(ctx, cp->key);
    sq_free(ctx, cp->idx);
    sq_free(ctx, cp->key2);
    sq_free(ctx, cp->idx2);
    cp->packed = cp->ambient = NULL;
    cp->key = cp->idx = cp->key2 = cp->idx2 = NULL;
    cp->cap = 0;
}

void sq__clouds_pass_destroy(sq_renderer *r)
{
    if (!r || !r->clouds) return;
    sq__clouds_pass *cp = r->clouds;
    glDeleteProgram(cp->prog);
    glDeleteProgram(cp->prog_imp);
    glDeleteVertexArrays(1, &cp->vao);
    glDeleteBuffers(1, &cp->vbo);
    glDeleteTextures(1, &cp->shadow_tex);
    glDeleteTextures(1, &cp->far_depth);
    for (int i = 0; i < IMP_SLOTS; i++) {
        glDeleteTextures(1, &cp->imp[i].tex);
        glDeleteFramebuffers(1, &cp->imp[i].fbo);
    }
    sq__cloud_light_free(r->ctx, &cp->light);
    free_staging(r->ctx, cp);
    sq_free(r->ctx, cp->group_w);
    sq_free(r->ctx, cp);
    r->clouds = NULL;
}

static sq_result reserve(sq_renderer *r, sq__clouds_pass *cp, size_t n, int groups)
{
    if (n > cp->cap) {
        free_staging(r->ctx, cp);
        const size_t cap = n + n / 4 + 1024;
        cp->packed = sq_alloc(r->ctx, cap * PACK * sizeof(float));
        cp->ambient = sq_alloc(r->ctx, cap * 3 * sizeof(float));
        cp->key = sq_alloc(r->ctx, cap * sizeof(uint32_t));
        cp->idx = sq_alloc(r->ctx, cap * sizeof(uint32_t));
        cp->key2 = sq_alloc(r->ctx, cap * sizeof(uint32_t));
        cp->idx2 = sq_alloc(r->ctx, cap * sizeof(uint32_t));
        if (!cp->packed || !cp->ambient || !cp->key || !cp->idx || !cp->key2 || !cp->idx2) {
            free_staging(r->ctx, cp);
            return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                            "cloud pass: no memory for %zu particles", n);
        }
        cp->cap = cap;
    }
    if (groups > cp->group_cap) {
        sq_free(r->ctx, cp->group_w);
        cp->group_w = sq_alloc(r->ctx, (size_t)groups * sizeof(float));
        if (!cp->group_w) {
            cp->group_cap = 0;
            return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "cloud pass: no memory");
        }
        cp->group_cap = groups;
    }
    return SQ_OK;
}

static sq_result validate(sq_renderer *r, const sq_clouds_view *v)
{
    sq_context *ctx = r->ctx;
    if (v->count < 0 || (v->count > 0 && (!v->position || !v->radius_m)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "clouds drawable: count = %d, position %s, radius_m %s; need count >= 0 "
                        "and both arrays",
                        v->count, v->position ? "set" : "NULL", v->radius_m ? "set" : "NULL");
    if (!v->splat_opacity && v->count > 0 && !v->tau)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "clouds drawable: tau is NULL with physical opacity");
    if (!(v->albedo >= 0.0f && v->albedo <= 1.0f) || !(v->g_default > -1.0f && v->g_default < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "clouds drawable: albedo = %g (must be in [0, 1]), g = %g (in (-1, 1))",
                        (double)v->albedo, (double)v->g_default);
    if (v->group_count < 0 || (v->group_count > 0 && !v->groups))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "clouds drawable: %d groups, groups %s",
                        v->group_count, v->groups ? "set" : "NULL");
    for (int q = 0; q < v->group_count; q++) {
        const sq_cloud_group *g = &v->groups[q];
        if (g->first < 0 || g->count < 0 || g->first + g->count > v->count)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "clouds drawable: group %d covers particles [%d, %d) of %d", q,
                            g->first, g->first + g->count, v->count);
    }
    for (int i = 0; i < v->count; i++) {
        const float *p = v->position + 3 * i;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]) || !(v->radius_m[i] > 0.0f) ||
            !isfinite(v->radius_m[i]) || (v->tau && !(v->tau[i] >= 0.0f && isfinite(v->tau[i]))))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "clouds drawable: particle %d at (%g, %g, %g) m, radius %g m, tau %g; "
                            "position must be finite, radius > 0 and tau >= 0",
                            i, (double)p[0], (double)p[1], (double)p[2], (double)v->radius_m[i],
                            v->tau ? (double)v->tau[i] : 0.0);
    }
    return SQ_OK;
}

/* ---- prepare: light and shadow ------------------------------------------------------------ */
static sq_result ensure_light(sq_renderer *r, sq__clouds_pass *cp, const sq_clouds_view *v)
{
    const sq_vec3 sun = sq_v3_norm(r->world->sun_dir);
    if (cp->light_valid && cp->light_version == v->version && cp->light_positions == v->position &&
        cp->light.n == v->count && cp->light_ms == v->multiple_scattering && cp->light_sun.x == sun.x &&
        cp->light_sun.y == sun.y && cp->light_sun.z == sun.z)
        return SQ_OK;
    const double t0 = sq_time_now();
    sq_result res = sq__cloud_light_compute(r->ctx, &cp->light, v, sun);
    if (res != SQ_OK) return res;
    cp->stats.ms_light = (sq_time_now() - t0) * 1e3;
    cp->stats.relights++;
    cp->light_valid = true;
    cp->light_version = v->version;
    cp->light_positions = v->position;
    cp->light_ms = v->multiple_scattering;
    cp->light_sun = sun;
    /* the shadow map: light below the clouds (R32F read as rgb through a swizzle) */
    const sq__cloud_light *L = &cp->light;
    if (!cp->shadow_tex || cp->shadow_w != L->nx || cp->shadow_h != L->ny) {
        glDeleteTextures(1, &cp->shadow_tex);
        glCreateTextures(GL_TEXTURE_2D, 1, &cp->shadow_tex);
        glTextureStorage2D(cp->shadow_tex, 1, GL_R32F, L->nx, L->ny);
        glTextureParameteri(cp->shadow_tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(cp->shadow_tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(cp->shadow_tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
        glTextureParameteri(cp->shadow_tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
        const float border[4] = {1.0f, 1.0f, 1.0f, 1.0f};
        glTextureParameterfv(cp->shadow_tex, GL_TEXTURE_BORDER_COLOR, border);
        const GLint swz[4] = {GL_RED, GL_RED, GL_RED, GL_ONE};
        glTextureParameteriv(cp->shadow_tex, GL_TEXTURE_SWIZZLE_RGBA, swz);
        cp->shadow_w = L->nx;
        cp->shadow_h = L->ny;
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTextureSubImage2D(cp->shadow_tex, 0, 0, 0, L->nx, L->ny, GL_RED, GL_FLOAT, L->shadow);
    return sq__gl_check(r->ctx, "cloud light");
}

sq_result sq__clouds_pass_prepare(sq_renderer *r, const sq_clouds_view *v)
{
    if (!r->clouds) return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render", "no cloud pass");
    sq_result res = validate(r, v);
    if (res != SQ_OK || v->count == 0) return res;
    if ((res = ensure_light(r, r->clouds, v)) != SQ_OK) return res;
    if (v->shadows && r->sun_shadow_tex == 0) {
        r->sun_shadow_tex = r->clouds->shadow_tex;
        r->sun_shadow_matrix = r->clouds->light.shadow_matrix;
    }
    return SQ_OK;
}

/* ---- draw ---------------------------------------------------------------------------------- */
/* Per-particle light toward the eye except the view-dependent phase: the ambient part (diffuse
 * sun + sky), in the base renderer's radiance units. */
static void ambient_of(const sq_renderer *r, const sq__cloud_light *L, int i, float out[3])
{
    const sq_world *w = r->world;
    const sq_vec3 sky = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const float mu = w->sun_dir.z > 0.0f ? w->sun_dir.z : 0.0f;
    const sq_vec3 ground =
        sq_v3_mul(w->ground_albedo, sq_v3_add(sq_v3_scale(w->sun_radiance, mu), sky));
    const sq_vec3 amb = sq_v3_scale(sq_v3_add(sky, ground), 0.5f * L->sky[i]);
    const sq_vec3 dif = sq_v3_scale(w->sun_radiance, L->diffuse[i]);
    out[0] = amb.x + dif.x;
    out[1] = amb.y + dif.y;
    out[2] = amb.z + dif.z;
}

static void set_common_uniforms(sq_renderer *r, const sq_clouds_view *v, GLuint prog)
{
    const sq_world *w = r->world;
    const sq_vec3 sun = sq_v3_norm(w->sun_dir);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sun"), sun.x, sun.y, sun.z);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sun_E"), w->sun_radiance.x,
                       w->sun_radiance.y, w->sun_radiance.z);
    glProgramUniform1f(prog, glGetUniformLocation(prog, "u_albedo"), v->albedo);
    glProgramUniform1i(prog, glGetUniformLocation(prog, "u_splat_opacity"), v->splat_opacity);
    glProgramUniform1f(prog, glGetUniformLocation(prog, "u_splat_peak"),
                       -expm1f(-v->tau_splat) * v->eta1);
    glProgramUniform1i(prog, glGetUniformLocation(prog, "u_rayleigh"), v->rayleigh);
    glProgramUniform1f(prog, glGetUniformLocation(prog, "u_noise"), v->splat_noise);
}

static void set_camera_uniforms(GLuint prog, const sq_mat4 *view_proj, sq_vec3 cam, sq_vec3 right,
                                sq_vec3 up, sq_vec3 fwd, const sq_mat4 *proj, bool use_depth)
{
    glProgramUniformMatrix4fv(prog, glGetUniformLocation(prog, "u_bb_view_proj"), 1, GL_FALSE,
                              view_proj->m);
    const sq_vec3 v3[4] = {cam, right, up, fwd};
    const char *n3[4] = {"u_cam", "u_right", "u_up", "u_forward"};
    for (int i = 0; i < 4; i++)
        glProgramUniform3f(prog, glGetUniformLocation(prog, n3[i]), v3[i].x, v3[i].y, v3[i].z);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_proj_z"), proj->m[10], proj->m[14]);
    glProgramUniform1i(prog, glGetUniformLocation(prog, "u_use_depth"), use_depth ? 1 : 0);
}

/* Packs particles [first, first + count) whose fade > 0, sorted back to front for a camera at
 * cam looking along fwd, from offset `at` of the staging; returns how many. */
static size_t pack_sorted(sq__clouds_pass *cp, const sq_clouds_view *v, const int *firsts,
                          const int *counts, const float *fades, int nranges, sq_vec3 cam,
                          sq_vec3 fwd)
{
    size_t m = 0;
    for (int q = 0; q < nranges; q++) {
        if (!(fades[q] > 0.0f)) continue;
        for (int i = firsts[q]; i < firsts[q] + counts[q]; i++) {
            const float *x = v->position + 3 * i;
            const float depth = (x[0] - cam.x) * fwd.x + (x[1] - cam.y) * fwd.y + (x[2] - cam.z) * fwd.z;
            if (depth < -v->radius_m[i]) continue;
            if (v->tau && !(v->tau[i] > 0.0f) && !v->splat_opacity) continue;
            cp->key[m] = ~sq__float_sort_key(depth);
            cp->idx[m] = (uint32_t)i | ((uint32_t)q << 24); /* group slot in the top bits */
            m++;
        }
    }
    sq__radix_sort_u32(cp->key, cp->idx, cp->key2, cp->idx2, m);
    const sq__cloud_light *L = &cp->light;
    for (size_t j = 0; j < m; j++) {
        const uint32_t tag = cp->idx[j];
        const int i = (int)(tag & 0xffffffu), q = (int)(tag >> 24);
        float *o = cp->packed + PACK * j;
        const float *x = v->position + 3 * i;
        o[0] = x[0];
        o[1] = x[1];
        o[2] = x[2];
        o[3] = v->radius_m[i];
        o[4] = v->tau ? v->tau[i] : 0.0f;
        o[5] = fades[q];
        o[6] = v->g ? v->g[i] : v->g_default;
        o[7] = L->sun[i];
        o[8] = cp->ambient[3 * i + 0];
        o[9] = cp->ambient[3 * i + 1];
        o[10] = cp->ambient[3 * i + 2];
        o[11] = 0.0f;
    }
    return m;
}

static void upload_and_draw(sq__clouds_pass *cp, size_t m)
{
    const size_t bytes = m * PACK * sizeof(float);
    if (bytes > cp->vbo_bytes) {
        cp->vbo_bytes = bytes + bytes / 4;
        glNamedBufferData(cp->vbo, (GLsizeiptr)cp->vbo_bytes, NULL, GL_STREAM_DRAW);
    } else {
        glInvalidateBufferData(cp->vbo);
    }
    glNamedBufferSubData(cp->vbo, 0, (GLsizeiptr)bytes, cp->packed);
    glBindVertexArray(cp->vao);
    for (size_t first = 0; first < m; first += BATCH) {
        const size_t n = m - first < BATCH ? m - first : BATCH;
        glDrawArraysInstancedBaseInstance(GL_TRIANGLE_STRIP, 0, 4, (GLsizei)n, (GLuint)first);
    }
}

/* The slot of the impostor for a group: the one made for (nearly) the same cloud, else a free
 * or the least recently used one. */
static impostor *impostor_slot(sq__clouds_pass *cp, const sq_cloud_group *g)
{
    impostor *best = NULL, *lru = &cp->imp[0];
    float best_d = INFINITY;
    for (int i = 0; i < IMP_SLOTS; i++) {
        impostor *im = &cp->imp[i];
        if (im->used_frame < lru->used_frame || (!im->valid && lru->valid)) lru = im;
        if (!im->valid || im->used_frame == cp->frame) continue;
        const float d = sq_v3_len(sq_v3_sub(im->center, g->center_m));
        if (d < 0.5f * g->radius_m && d < best_d) {
            best_d = d;
            best = im;
        }
    }
    if (best) return best;
    lru->valid = false;
    return lru;
}

static sq_result render_impostor(sq_renderer *r, sq__clouds_pass *cp, const sq_clouds_view *v,
                                 int group, impostor *im, float dist, sq_vec3 dir)
{
    const sq_cloud_group *g = &v->groups[group];
    /* size: the sphere's projected diameter in pixels, rounded up to a power of two */
    const float px_per_rad = (float)r->height / (2.0f * atanf(1.0f / r->proj.m[5]));
    const float ang = 2.0f * asinf(fminf(g->radius_m / dist, 0.999f));
    int px = IMP_MIN_PX;
    while (px < IMP_MAX_PX && (float)px < ang * px_per_rad) px *= 2;
    if (!im->tex || im->px != px) {
        glDeleteTextures(1, &im->tex);
        if (!im->fbo) glCreateFramebuffers(1, &im->fbo);
        im->tex = sq__gl_texture_2d(GL_RGBA16F, px, px, GL_LINEAR);
        glNamedFramebufferTexture(im->fbo, GL_COLOR_ATTACHMENT0, im->tex, 0);
        sq_result res = sq__gl_check_framebuffer(r->ctx, im->fbo, "cloud impostor");
        if (res != SQ_OK) return res;
        im->px = px;
    }
    /* the impostor camera: from the eye toward the cloud, frustum around its sphere */
    sq_camera c;
    memset(&c, 0, sizeof c);
    c.position_m = r->cam_pos;
    c.target_m = g->center_m;
    c.up = fabsf(dir.z) > 0.99f ? sq_v3(0.0f, 1.0f, 0.0f) : sq_v3(0.0f, 0.0f, 1.0f);
    c.fov_y_deg = ang * 57.2957795f;
    c.near_m = fmaxf(dist - g->radius_m, 1.0f);
    c.far_m = dist + g->radius_m;
    const sq_mat4 view = sq_camera_view(&c), proj = sq_camera_proj(&c, 1.0f);
    const sq_mat4 vp = sq_m4_mul(proj, view);
    const sq_vec3 right = sq_v3_norm(sq_v3_cross(dir, c.up));
    const sq_vec3 up = sq_v3_cross(right, dir);
    const int first = g->first, count = g->count;
    const float fade = 1.0f;
    const size_t m = pack_sorted(cp, v, &first, &count, &fade, 1, r->cam_pos, dir);
    const float clear[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    glClearNamedFramebufferfv(im->fbo, GL_COLOR, 0, clear);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, im->fbo);
    glViewport(0, 0, px, px);
    set_camera_uniforms(cp->prog, &vp, r->cam_pos, right, up, dir, &proj, false);
    glBindTextureUnit(2, cp->far_depth);
    glUseProgram(cp->prog);
    glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    upload_and_draw(cp, m);
    im->valid = true;
    im->center = g->center_m;
    im->radius = g->radius_m;
    im->dir = dir;
    im->dist = dist;
    im->made_frame = cp->frame;
    cp->stats.impostor_renders++;
    return sq__gl_check(r->ctx, "cloud impostor render");
}

sq_result sq__clouds_pass_draw(sq_renderer *r, const sq_clouds_view *v)
{
    sq__clouds_pass *cp = r->clouds;
    if (!cp) return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render", "no cloud pass");
    sq_result res = validate(r, v);
    if (res != SQ_OK || v->count == 0) return res;
    if ((res = ensure_light(r, cp, v)) != SQ_OK) return res;
    const double t0 = sq_time_now();
    const sq_cloud_group whole = {sq_v3(0, 0, 0), 0.0f, 0, v->count};
    const sq_cloud_group *groups = v->groups && v->group_count > 0 ? v->groups : &whole;
    const int ng = v->groups && v->group_count > 0 ? v->group_count : 1;
    if ((res = reserve(r, cp, (size_t)v->count, ng)) != SQ_OK) return res;
    cp->frame++;
    for (int i = 0; i < v->count; i++) ambient_of(r, &cp->light, i, cp->ambient + 3 * i);

    /* impostor weights per group */
    const bool imp_on = v->impostors && v->groups && v->group_count > 0;
    for (int q = 0; q < ng; q++) {
        const float d = sq_v3_len(sq_v3_sub(groups[q].center_m, r->cam_pos));
        cp->group_w[q] = imp_on && d > groups[q].radius_m * 1.05f
                             ? sq__cloud_impostor_weight(d, v->dist_3d_m, v->dist_impostor_m)
                             : 0.0f;
    }

    GLint saved_fbo, saved_vp[4], saved_prog, saved_vao;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &saved_fbo);
    glGetIntegerv(GL_VIEWPORT, saved_vp);
    glGetIntegerv(GL_CURRENT_PROGRAM, &saved_prog);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &saved_vao);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDepthMask(GL_FALSE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    set_common_uniforms(r, v, cp->prog);

    /* 1. impostors: refresh where needed, then draw back to front */
    int nimp = 0;
    if (imp_on) {
        /* order the impostor groups far to near */
        uint32_t *ik = cp->key, *ii = cp->idx;
        for (int q = 0; q < ng; q++) {
            if (!(cp->group_w[q] > 0.0f)) continue;
            const float d = sq_v3_len(sq_v3_sub(groups[q].center_m, r->cam_pos));
            ik[nimp] = ~sq__float_sort_key(d);
            ii[nimp] = (uint32_t)q;
            nimp++;
        }
        sq__radix_sort_u32(ik, ii, cp->key2, cp->idx2, (size_t)nimp);
        int order[IMP_SLOTS];
        impostor *slot[IMP_SLOTS];
        float dist[IMP_SLOTS];
        if (nimp > IMP_SLOTS) nimp = IMP_SLOTS; /* the farthest beyond the slots are dropped */
        for (int k = 0; k < nimp; k++) order[k] = (int)ii[k];
        int aged = 0;
        for (int k = 0; k < nimp; k++) {
            const sq_cloud_group *g = &groups[order[k]];
            const sq_vec3 to = sq_v3_sub(g->center_m, r->cam_pos);
            const float d = sq_v3_len(to);
            const sq_vec3 dir = sq_v3_scale(to, 1.0f / d);
            impostor *im = impostor_slot(cp, g);
            const float cosang = im->valid ? sq_v3_dot(dir, im->dir) : -2.0f;
            const bool moved =
                !im->valid || cosang < cosf(v->impostor_angle_deg * 0.0174532925f) ||
                fabsf(d - im->dist) > IMP_DIST_TOL * im->dist ||
                fabsf(g->radius_m - im->radius) > IMP_SIZE_TOL * im->radius;
            const bool old = cp->frame - im->made_frame > IMP_MAX_AGE;
            const bool stale = moved || (old && aged < IMP_AGED_PER_FRAME);
            if (stale && !moved) aged++;
            im->used_frame = cp->frame;
            if (stale && (res = render_impostor(r, cp, v, order[k], im, d, dir)) != SQ_OK)
                return res;
            slot[k] = im;
            dist[k] = d;
        }
        /* draw them */
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)saved_fbo);
        glViewport(saved_vp[0], saved_vp[1], saved_vp[2], saved_vp[3]);
        glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
        GLuint pi = cp->prog_imp;
        glProgramUniformMatrix4fv(pi, glGetUniformLocation(pi, "u_view_proj"), 1, GL_FALSE,
                                  r->view_proj.m);
        glProgramUniform3f(pi, glGetUniformLocation(pi, "u_cam"), r->cam_pos.x, r->cam_pos.y,
                           r->cam_pos.z);
        glProgramUniform3f(pi, glGetUniformLocation(pi, "u_forward"), r->cam_forward.x,
                           r->cam_forward.y, r->cam_forward.z);
        glProgramUniform2f(pi, glGetUniformLocation(pi, "u_proj_z"), r->proj.m[10], r->proj.m[14]);
        glUseProgram(pi);
        glBindTextureUnit(2, r->depth_tex);
        glBindVertexArray(r->empty_vao);
        for (int k = 0; k < nimp; k++) {
            const impostor *im = slot[k];
            const sq_cloud_group *g = &groups[order[k]];
            const sq_vec3 to = sq_v3_sub(g->center_m, r->cam_pos);
            const sq_vec3 dir = sq_v3_scale(to, 1.0f / dist[k]);
            const sq_vec3 upref = fabsf(dir.z) > 0.99f ? sq_v3(0.0f, 1.0f, 0.0f) : sq_v3(0.0f, 0.0f, 1.0f);
            const sq_vec3 right = sq_v3_norm(sq_v3_cross(dir, upref));
            const sq_vec3 up = sq_v3_cross(right, dir);
            const float rr = im->radius, dd = fmaxf(dist[k], rr * 1.001f);
            const float half = rr * dd / sqrtf(dd * dd - rr * rr);
            glProgramUniform3f(pi, glGetUniformLocation(pi, "u_center"), g->center_m.x,
                               g->center_m.y, g->center_m.z);
            glProgramUniform3f(pi, glGetUniformLocation(pi, "u_right"), right.x, right.y, right.z);
            glProgramUniform3f(pi, glGetUniformLocation(pi, "u_up"), up.x, up.y, up.z);
            glProgramUniform1f(pi, glGetUniformLocation(pi, "u_half"), half);
            glProgramUniform1f(pi, glGetUniformLocation(pi, "u_weight"), cp->group_w[order[k]]);
            glProgramUniform1f(pi, glGetUniformLocation(pi, "u_soft"), 0.5f * rr);
            glBindTextureUnit(0, im->tex);
            glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
        }
    }

    /* 2. particles of the groups not wholly impostors, back to front */
    int *rf = sq_alloc(r->ctx, (size_t)ng * 2 * sizeof(int));
    float *rfade = sq_alloc(r->ctx, (size_t)ng * sizeof(float));
    if (!rf || !rfade) {
        sq_free(r->ctx, rf);
        sq_free(r->ctx, rfade);
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "cloud pass: no memory");
    }
    for (int q = 0; q < ng; q++) {
        rf[q] = groups[q].first;
        rf[ng + q] = groups[q].count;
        rfade[q] = 1.0f - cp->group_w[q];
    }
    const size_t m = pack_sorted(cp, v, rf, rf + ng, rfade, ng, r->cam_pos, r->cam_forward);
    sq_free(r->ctx, rf);
    sq_free(r->ctx, rfade);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)saved_fbo);
    glViewport(saved_vp[0], saved_vp[1], saved_vp[2], saved_vp[3]);
    glBlendFuncSeparate(GL_ONE, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
    set_camera_uniforms(cp->prog, &r->view_proj, r->cam_pos, r->cam_right, r->cam_up,
                        r->cam_forward, &r->proj, true);
    glBindTextureUnit(2, r->depth_tex);
    glUseProgram(cp->prog);
    upload_and_draw(cp, m);

    cp->stats.particles_drawn = (int)m;
    cp->stats.impostors_drawn = nimp;
    cp->stats.ms_draw_cpu = (sq_time_now() - t0) * 1e3;
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)saved_fbo);
    glViewport(saved_vp[0], saved_vp[1], saved_vp[2], saved_vp[3]);
    glUseProgram((GLuint)saved_prog);
    glBindVertexArray((GLuint)saved_vao);
    glDisable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ZERO);
    return sq__gl_check(r->ctx, "cloud pass");
}

void sq__clouds_pass_get_stats(const sq_renderer *r, sq__clouds_pass_stats *out)
{
    if (r && r->clouds) *out = r->clouds->stats;
    else memset(out, 0, sizeof *out);
}
