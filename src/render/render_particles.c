/* render_particles.c — the soft-particle pass (SPEC 4.2-4.5, document S3, with its ⚠ fixes):
 * instanced camera-facing quads (one instance per particle, rotated by the corrected corner
 * formula of SPEC 4.5), depth fade against the opaque scene in LINEAR view depth over
 * softness_m, no depth writes, per-channel premultiplied alpha with dual-source blending
 * (hdr = C + (1 - alpha) hdr). Particles are sorted back to front on the CPU (stable LSD radix
 * sort on view depth) so that "over" compositing is correct for any mix of colours, which also
 * removes S3's bright spots where particles overlap. Opacity alpha_c = 1 - exp(-tau sigma_rel_c
 * shape); lighting by the sun (HG phase g, shadowed through the volume pass's light buffer when
 * there is one) and the sky/ground ambient of the base renderer. SQ_SPRITE_SPHERE draws a lit
 * opaque sphere impostor instead. The per-particle fade multiplier comes from the phenomenon. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render/depth_sort.h"
#include "render/render_internal.h"
#include "world/world_struct.h"

#define PART_FLOATS 12 /* per instance: pos.xyz radius | rot tau fade seed | albedo.rgb 0 */

#define PART_KINDS 6 /* sq_sprite_kind values; DEFAULT draws as PUFF */
#define PART_BATCH 8192 /* instances per draw call */
#define PART_MIN_VISIBLE 1e-6f /* see pack() */

struct sq__particle_pass {
    GLuint prog[PART_KINDS][2]; /* by sprite kind and sun shadow (0/1), compiled on first use */
    GLuint vao, vbo, comp_fbo, comp_color;
    size_t vbo_bytes;
    size_t cap;         /* particles the staging arrays hold */
    float *packed;      /* PART_FLOATS * cap */
    uint32_t *key, *idx, *key2, *idx2;
};

sq_result sq__particle_pass_create(sq_renderer *r)
{
    sq__particle_pass *pp = sq_alloc_zero(r->ctx, sizeof *pp);
    if (!pp) return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "particle pass: no memory");
    r->particles = pp;
    glCreateVertexArrays(1, &pp->vao);
    glCreateBuffers(1, &pp->vbo);
    glVertexArrayVertexBuffer(pp->vao, 0, pp->vbo, 0, PART_FLOATS * sizeof(float));
    glVertexArrayBindingDivisor(pp->vao, 0, 1);
    for (GLuint a = 0; a < 3; a++) {
        glEnableVertexArrayAttrib(pp->vao, a);
        glVertexArrayAttribFormat(pp->vao, a, 4, GL_FLOAT, GL_FALSE, a * 4 * sizeof(float));
        glVertexArrayAttribBinding(pp->vao, a, 0);
    }
    return sq__gl_check(r->ctx, "particle pass create");
}

static void free_staging(sq_renderer *r, sq__particle_pass *pp)
{
    sq_free(r->ctx, pp->packed);
    sq_free(r->ctx, pp->key);
    sq_free(r->ctx, pp->idx);
    sq_free(r->ctx, pp->key2);
    sq_free(r->ctx, pp->idx2);
    pp->packed = NULL;
    pp->key = pp->idx = pp->key2 = pp->idx2 = NULL;
    pp->cap = 0;
}

void sq__particle_pass_destroy(sq_renderer *r)
{
    if (!r || !r->particles) return;
    sq__particle_pass *pp = r->particles;
    for (int k = 0; k < PART_KINDS; k++)
        for (int s = 0; s < 2; s++) glDeleteProgram(pp->prog[k][s]);
    glDeleteVertexArrays(1, &pp->vao);
    glDeleteBuffers(1, &pp->vbo);
    glDeleteFramebuffers(1, &pp->comp_fbo);
    free_staging(r, pp);
    sq_free(r->ctx, pp);
    r->particles = NULL;
}

/* Host staging: 64 bytes per particle (48 packed + 16 for the sort). */
static sq_result reserve(sq_renderer *r, sq__particle_pass *pp, size_t n)
{
    if (n <= pp->cap) return SQ_OK;
    free_staging(r, pp);
    size_t cap = n + n / 4 + 1024;
    char what[64];
    snprintf(what, sizeof what, "particle staging for %zu particles", cap);
    sq_result res = sq_context_check_memory(r->ctx, (uint64_t)cap * 64u, what);
    if (res != SQ_OK) return res;
    pp->packed = sq_alloc(r->ctx, cap * PART_FLOATS * sizeof(float));
    pp->key = sq_alloc(r->ctx, cap * sizeof(uint32_t));
    pp->idx = sq_alloc(r->ctx, cap * sizeof(uint32_t));
    pp->key2 = sq_alloc(r->ctx, cap * sizeof(uint32_t));
    pp->idx2 = sq_alloc(r->ctx, cap * sizeof(uint32_t));
    if (!pp->packed || !pp->key || !pp->idx || !pp->key2 || !pp->idx2) {
        free_staging(r, pp);
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                        "particle pass: no memory for %zu particles", cap);
    }
    pp->cap = cap;
    return SQ_OK;
}

/* The program for a sprite kind with or without the sun shadow: particles_sprite.frag compiled
 * with PART_SPRITE and PART_SHADOW defined after its #version line (on first use). */
static sq_result sprite_program(sq_renderer *r, int kind, bool shadow, GLuint *out)
{
    sq__particle_pass *pp = r->particles;
    GLuint *prog = &pp->prog[kind][shadow ? 1 : 0];
    *out = *prog;
    if (*prog) return SQ_OK;
    const char *vs = sq__shader_source("particles_sprite.vert");
    const char *fs = sq__shader_source("particles_sprite.frag");
    const char *eol = fs ? strchr(fs, '\n') : NULL;
    if (!vs || !eol)
        return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render",
                        "no embedded particle shaders with a #version line");
    const size_t head = (size_t)(eol - fs) + 1;
    char *text = sq_alloc(r->ctx, strlen(fs) + 96);
    if (!text)
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "no memory for a particle shader");
    memcpy(text, fs, head);
    snprintf(text + head, 96, "#define PART_SPRITE %d\n#define PART_SHADOW %d\n#line 2\n", kind,
             shadow ? 1 : 0);
    strcat(text + head, fs + head);
    GLuint sh[2] = {0, 0};
    sq_result res = sq__gl_shader_compile(r->ctx, GL_VERTEX_SHADER, "particles_sprite.vert", vs,
                                          &sh[0]);
    if (res == SQ_OK)
        res = sq__gl_shader_compile(r->ctx, GL_FRAGMENT_SHADER, "particles_sprite.frag", text,
                                    &sh[1]);
    if (res == SQ_OK) res = sq__gl_program_link(r->ctx, "particles_sprite", sh, 2, prog);
    glDeleteShader(sh[0]);
    glDeleteShader(sh[1]);
    sq_free(r->ctx, text);
    *out = *prog;
    return res;
}

static sq_result validate(sq_renderer *r, const sq_particles_view *p)
{
    sq_context *ctx = r->ctx;
    if (!p) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "particle drawable: view is NULL");
    if (p->count < 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "particles count = %d; must be >= 0",
                        p->count);
    if (p->count > 0 && !p->position)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles: position is NULL with count = %d", p->count);
    if (!p->radius_m && !(p->radius_default_m > 0.0f && isfinite(p->radius_default_m)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles radius_default_m = %g with radius_m NULL; must be > 0",
                        (double)p->radius_default_m);
    if (!p->tau && !(p->tau_default >= 0.0f && isfinite(p->tau_default)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles tau_default = %g with tau NULL; must be finite and >= 0",
                        (double)p->tau_default);
    if (!(p->softness_m >= 0.0f) || !isfinite(p->softness_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles softness_m = %g; must be finite and >= 0 (0 = hard)",
                        (double)p->softness_m);
    if (!(p->g > -1.0f && p->g < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles g = %g; the HG asymmetry must be in (-1, 1)", (double)p->g);
    if ((int)p->sprite < (int)SQ_SPRITE_DEFAULT || (int)p->sprite > (int)SQ_SPRITE_SPHERE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "particles sprite = %d; must be a sq_sprite_kind (0..5)", (int)p->sprite);
    for (int c = 0; c < 3; c++) {
        if (!(p->sigma_rel[c] >= 0.0f) || !isfinite(p->sigma_rel[c]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "particles sigma_rel[%d] = %g; must be finite and >= 0", c,
                            (double)p->sigma_rel[c]);
        if (!p->color && !(p->albedo[c] >= 0.0f && p->albedo[c] <= 1.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                            "particles albedo[%d] = %g; must be in [0, 1]", c,
                            (double)p->albedo[c]);
    }
    return SQ_OK;
}

/* Light a particle sends toward the eye, per unit opacity, at most (in units of the sun's
 * radiance scale): pi p_HG,max for the sun (SPEC 2.6: p peaks at (1 + |g|) / (4 pi (1 - |g|)^2))
 * plus about 1 for the ambient; a lit sphere reflects at most about 2. */
static float light_bound(const sq_renderer *r, const sq_particles_view *p, int sprite)
{
    if (sprite == SQ_SPRITE_SPHERE) return 2.0f;
    const float g = r->desc.isotropic_phase ? 0.0f : fabsf(p->g);
    return (1.0f + g) / (4.0f * (1.0f - g) * (1.0f - g)) + 1.0f;
}

/* Packs visible particles back to front; returns the count in *visible. A particle whose
 * largest possible opacity (tau sigma_rel,max times the sprite's shape peak, times fade) times
 * light_bound stays below PART_MIN_VISIBLE is skipped: its light and its dimming of what lies
 * behind are both below 1e-6 of the sun's radiance scale (a simulation may hand over
 * thousands of particles with tau ~ 1e-19 in clean air, each costing full fragment work). */
static sq_result pack(sq_renderer *r, const sq_particles_view *p, size_t *visible)
{
    sq__particle_pass *pp = r->particles;
    *visible = 0;
    const size_t n = (size_t)p->count;
    sq_result res = reserve(r, pp, n);
    if (res != SQ_OK) return res;
    const sq_vec3 cam = r->cam_pos, fwd = r->cam_forward;
    const int sprite = p->sprite == SQ_SPRITE_DEFAULT ? (int)SQ_SPRITE_PUFF : (int)p->sprite;
    float srel = fmaxf(p->sigma_rel[0], fmaxf(p->sigma_rel[1], p->sigma_rel[2]));
    if (srel == 0.0f) srel = 1.0f; /* all zero: 1, 1, 1 (as the shader uniform) */
    const float tau_scale = srel * (sprite == SQ_SPRITE_PUFF ? 1.7f : 1.0f);
    const float min_alpha = PART_MIN_VISIBLE / light_bound(r, p, sprite);
    size_t m = 0;
    for (size_t i = 0; i < n; i++) {
        const float *x = p->position + 3 * i;
        const float rad = p->radius_m ? p->radius_m[i] : p->radius_default_m;
        if (!isfinite(x[0]) || !isfinite(x[1]) || !isfinite(x[2]) || !isfinite(rad))
            return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                            "particle %zu: position (%g, %g, %g) m, radius %g m; must be finite",
                            i, (double)x[0], (double)x[1], (double)x[2], (double)rad);
        const float tau = p->tau ? p->tau[i] : p->tau_default;
        const float fade = p->fade ? p->fade[i] : 1.0f;
        if (!(rad > 0.0f) || !(tau > 0.0f) || !(fade > 0.0f)) continue; /* invisible */
        const float alpha_max = fminf(fade, 1.0f) * (sprite == SQ_SPRITE_SPHERE
                                                         ? 1.0f
                                                         : -expm1f(-tau * tau_scale));
        if (alpha_max < min_alpha) continue; /* too faint to change any pixel */
        const float depth = (x[0] - cam.x) * fwd.x + (x[1] - cam.y) * fwd.y + (x[2] - cam.z) * fwd.z;
        if (depth < -rad) continue; /* wholly behind the camera */
        pp->key[m] = ~sq__float_sort_key(depth); /* descending depth: back to front */
        pp->idx[m] = (uint32_t)i;
        m++;
    }
    sq__radix_sort_u32(pp->key, pp->idx, pp->key2, pp->idx2, m);
    for (size_t j = 0; j < m; j++) {
        const size_t i = pp->idx[j];
        float *o = pp->packed + PART_FLOATS * j;
        const float *x = p->position + 3 * i;
        o[0] = x[0];
        o[1] = x[1];
        o[2] = x[2];
        o[3] = p->radius_m ? p->radius_m[i] : p->radius_default_m;
        o[4] = p->rotation_rad && isfinite(p->rotation_rad[i]) ? p->rotation_rad[i] : 0.0f;
        o[5] = p->tau ? p->tau[i] : p->tau_default;
        o[6] = p->fade ? sq_clampf(p->fade[i], 0.0f, 1.0f) : 1.0f;
        o[7] = (float)(i & 0xffffu);
        for (int c = 0; c < 3; c++)
            o[8 + c] = sq_clampf(p->color ? p->color[3 * i + (size_t)c] : p->albedo[c], 0.0f, 1.0f);
        o[11] = 0.0f;
    }
    *visible = m;
    return SQ_OK;
}

sq_result sq__particle_pass_draw(sq_renderer *r, const sq_particles_view *p)
{
    if (!r->particles)
        return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render", "particle pass was not created");
    sq_result res = validate(r, p);
    if (res != SQ_OK || p->count == 0) return res;
    sq__particle_pass *pp = r->particles;
    size_t m = 0;
    if ((res = pack(r, p, &m)) != SQ_OK) return res;
    if (m == 0) return SQ_OK;

    const size_t bytes = m * PART_FLOATS * sizeof(float);
    if (bytes > pp->vbo_bytes) {
        pp->vbo_bytes = bytes + bytes / 4;
        glNamedBufferData(pp->vbo, (GLsizeiptr)pp->vbo_bytes, NULL, GL_STREAM_DRAW);
    } else {
        glInvalidateBufferData(pp->vbo);
    }
    glNamedBufferSubData(pp->vbo, 0, (GLsizeiptr)bytes, pp->packed);

    if (!pp->comp_fbo || pp->comp_color != r->hdr_color) {
        if (!pp->comp_fbo) glCreateFramebuffers(1, &pp->comp_fbo);
        glNamedFramebufferTexture(pp->comp_fbo, GL_COLOR_ATTACHMENT0, r->hdr_color, 0);
        glNamedFramebufferDrawBuffer(pp->comp_fbo, GL_COLOR_ATTACHMENT0);
        pp->comp_color = r->hdr_color;
        if ((res = sq__gl_check_framebuffer(r->ctx, pp->comp_fbo, "particle target")) != SQ_OK)
            return res;
    }

    const int sprite = p->sprite == SQ_SPRITE_DEFAULT ? (int)SQ_SPRITE_PUFF : (int)p->sprite;
    GLuint prog = 0;
    if ((res = sprite_program(r, sprite, r->sun_shadow_tex != 0, &prog)) != SQ_OK) return res;
    const sq_world *w = r->world;
    glProgramUniformMatrix4fv(prog, glGetUniformLocation(prog, "u_view_proj"), 1, GL_FALSE,
                              r->view_proj.m);
    const sq_vec3 v3[4] = {r->cam_pos, r->cam_right, r->cam_up, r->cam_forward};
    const char *n3[4] = {"u_cam", "u_right", "u_up", "u_forward"};
    for (int i = 0; i < 4; i++)
        glProgramUniform3f(prog, glGetUniformLocation(prog, n3[i]), v3[i].x, v3[i].y, v3[i].z);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_proj_z"), r->proj.m[10], r->proj.m[14]);
    float srel[3] = {p->sigma_rel[0], p->sigma_rel[1], p->sigma_rel[2]};
    if (srel[0] == 0.0f && srel[1] == 0.0f && srel[2] == 0.0f) srel[0] = srel[1] = srel[2] = 1.0f;
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sigma_rel"), srel[0], srel[1], srel[2]);
    glProgramUniform1f(prog, glGetUniformLocation(prog, "u_g"),
                       r->desc.isotropic_phase ? 0.0f : p->g);
    glProgramUniform1f(prog, glGetUniformLocation(prog, "u_softness"), p->softness_m);
    /* radiance units of the base renderer: a white Lambertian plane facing the sun has
     * radiance sun_radiance (so the sun's irradiance is pi sun_radiance); the ambient
     * hemispheres are its sky mean and the sunlit ground below */
    const sq_vec3 sun = sq_v3_norm(w->sun_dir);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sun_radiance"), w->sun_radiance.x,
                       w->sun_radiance.y, w->sun_radiance.z);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sun_dir"), sun.x, sun.y, sun.z);
    const sq_vec3 sky = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const float mu = sun.z > 0.0f ? sun.z : 0.0f;
    const sq_vec3 ground =
        sq_v3_mul(w->ground_albedo, sq_v3_add(sq_v3_scale(w->sun_radiance, mu), sky));
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_sky"), sky.x, sky.y, sky.z);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_ground"), ground.x, ground.y,
                       ground.z);
    glProgramUniformMatrix4fv(prog, glGetUniformLocation(prog, "u_shadow_matrix"), 1, GL_FALSE,
                              r->sun_shadow_matrix.m);

    GLint saved_fbo, saved_vp[4], saved_prog, saved_vao;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &saved_fbo);
    glGetIntegerv(GL_VIEWPORT, saved_vp);
    glGetIntegerv(GL_CURRENT_PROGRAM, &saved_prog);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &saved_vao);
    const GLboolean saved_blend = glIsEnabled(GL_BLEND), saved_depth = glIsEnabled(GL_DEPTH_TEST),
                    saved_cull = glIsEnabled(GL_CULL_FACE);
    GLboolean saved_depth_mask;
    glGetBooleanv(GL_DEPTH_WRITEMASK, &saved_depth_mask);
    /* the blend function too: left at SRC1_COLOR it would make later draws into several
     * colour buffers invalid (dual-source blending allows one) */
    GLint saved_bf[6];
    glGetIntegerv(GL_BLEND_SRC_RGB, &saved_bf[0]);
    glGetIntegerv(GL_BLEND_DST_RGB, &saved_bf[1]);
    glGetIntegerv(GL_BLEND_SRC_ALPHA, &saved_bf[2]);
    glGetIntegerv(GL_BLEND_DST_ALPHA, &saved_bf[3]);
    glGetIntegerv(GL_BLEND_EQUATION_RGB, &saved_bf[4]);
    glGetIntegerv(GL_BLEND_EQUATION_ALPHA, &saved_bf[5]);

    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, pp->comp_fbo);
    glViewport(0, 0, r->width, r->height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glDepthMask(GL_FALSE);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
    glBindTextureUnit(2, r->depth_tex);
    if (r->sun_shadow_tex) glBindTextureUnit(6, r->sun_shadow_tex);
    glUseProgram(prog);
    glBindVertexArray(pp->vao);
    /* in batches: llvmpipe's vertex stage allocates its output per draw, and one draw of 10^5
     * instances (tens of MB) would be fresh, zero-filled pages every frame */
    for (size_t first = 0; first < m; first += PART_BATCH) {
        const size_t n = m - first < PART_BATCH ? m - first : PART_BATCH;
        glDrawArraysInstancedBaseInstance(GL_TRIANGLE_STRIP, 0, 4, (GLsizei)n, (GLuint)first);
        if (sq__render_part_done(r)) break; /* Ctrl-C: the frame ends (renderer.c) */
    }

    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, (GLuint)saved_fbo);
    glViewport(saved_vp[0], saved_vp[1], saved_vp[2], saved_vp[3]);
    glUseProgram((GLuint)saved_prog);
    glBindVertexArray((GLuint)saved_vao);
    glBlendFuncSeparate((GLenum)saved_bf[0], (GLenum)saved_bf[1], (GLenum)saved_bf[2],
                        (GLenum)saved_bf[3]);
    glBlendEquationSeparate((GLenum)saved_bf[4], (GLenum)saved_bf[5]);
    glDepthMask(saved_depth_mask);
    if (!saved_blend) glDisable(GL_BLEND);
    if (saved_depth) glEnable(GL_DEPTH_TEST);
    if (saved_cull) glEnable(GL_CULL_FACE);
    return sq__gl_check(r->ctx, "particle pass");
}
