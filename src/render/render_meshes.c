/* render_meshes.c — world mesh instances (squall/mesh.h) in the GL renderer: every mesh's LODs in
 * one vertex buffer (position, normal, uv: 32 B per vertex) and one index buffer, the instance
 * table in a texture buffer (64 B per instance), materials (colour, tint slot, sRGB base-colour
 * texture with mipmaps). Each view (the camera, a shadow cascade, the snow occlusion map) culls
 * the instances on the CPU against its frustum, drops those smaller than half a pixel, picks
 * per instance the coarsest LOD whose geometric error projects below lod_pixels, and draws the
 * survivors instanced: one draw per (mesh, LOD, material part) for colour, one per (mesh, LOD)
 * for depth. The visible instance indices of a view are a per-instance vertex attribute read
 * from a ring buffer through the draw's base instance. */
#include <math.h>
#include <string.h>

#include "render/render_internal.h"
#include "render/snow_map.h"
#include "world/world_struct.h"

#define RING_VIEWS 8 /* views per frame before the ring wraps (camera + cascades + snow) */
#define SLOTS (2 * SQ_MESH_MAX_LODS) /* per mesh: its levels with the snow shell, then without */

typedef struct gpu_lod {
    GLint base_vertex;
    GLuint first_index; /* in the shared index buffer */
    GLsizei index_count;
    GLuint top_first;   /* its faces seen from straight above (top_faces), after all levels' */
    GLsizei top_count;
    float error_m;
} gpu_lod;

typedef struct gpu_mesh {
    gpu_lod lod[SQ_MESH_MAX_LODS];
    int lod_count;
    int material0; /* first entry in the pass's material table */
    bool closed;
} gpu_mesh;

typedef struct gpu_material {
    sq_vec3 color;
    int tint;
    GLuint texture; /* 0 = none */
} gpu_material;

struct sq__mesh_pass {
    /* cache key */
    const sq_world *world;
    uint64_t generation;
    int mesh_count, instance_count;
    GLuint vao, vbo, ibo, inst_buf, inst_tex, ring;
    GLuint sbo; /* per vertex: the snow shell's welded normal, w: top of a wall; 2_10_10_10 */
    gpu_mesh *mesh;
    gpu_material *mat;
    int mat_count;
    float *sphere;     /* 4 per instance: world centre, radius */
    float *err_scale;  /* per instance: largest scale factor */
    uint32_t *visible; /* per view: instance indices grouped by (mesh, lod) */
    int *bucket;       /* (mesh * SLOTS + slot) counts, then offsets */
    uint8_t *lod_of;   /* per instance: chosen slot, LOD + SQ_MESH_MAX_LODS without the shell (255 = culled) */
    size_t ring_cap, ring_pos; /* in instances */
    GLuint prog_color, prog_cutout, prog_depth; /* colour: opaque / textured (alpha cut-out) */
    GLuint prog_depth_sunk; /* depth, each level sunk by its error (SQ_SINK; on first use) */
    GLuint prog_color_snow, prog_cutout_snow;   /* the same with snow cover (on first use) */
    GLuint prog_color_far, prog_cutout_far;     /* snow cover without the shell (SQ_NO_SHELL) */
    sq_vec3 bounds_min, bounds_max; /* of all instances */
    sq__mesh_stats stats;
};

/* ---- lifecycle ------------------------------------------------------------------------------ */
sq_result sq__mesh_pass_create(sq_renderer *r)
{
    r->meshes = sq_alloc_zero(r->ctx, sizeof *r->meshes);
    if (!r->meshes) return SQ_ERR_OUT_OF_MEMORY;
    sq_result res = sq__gl_program_defs(r->ctx, "meshes.vert", NULL, "meshes.frag",
                                        "#define SQ_NO_SNOW 1", &r->meshes->prog_color);
    if (res == SQ_OK)
        res = sq__gl_program_defs(r->ctx, "meshes.vert", NULL, "meshes_cutout.frag",
                                  "#define SQ_NO_SNOW 1", &r->meshes->prog_cutout);
    if (res == SQ_OK)
        res = sq__gl_program(r->ctx, "depth_meshes.vert", NULL, "depth.frag", &r->meshes->prog_depth);
    return res;
}

sq_result sq__mesh_pass_snow_programs(sq_renderer *r)
{
    sq__mesh_pass *m = r->meshes;
    sq_result res = SQ_OK;
    if (!m->prog_color_snow)
        res = sq__gl_program(r->ctx, "meshes.vert", NULL, "meshes.frag", &m->prog_color_snow);
    if (res == SQ_OK && !m->prog_cutout_snow)
        res = sq__gl_program(r->ctx, "meshes.vert", NULL, "meshes_cutout.frag",
                             &m->prog_cutout_snow);
    if (res == SQ_OK && !m->prog_color_far)
        res = sq__gl_program_defs(r->ctx, "meshes.vert", NULL, "meshes.frag",
                                  "#define SQ_NO_SHELL 1", &m->prog_color_far);
    if (res == SQ_OK && !m->prog_cutout_far)
        res = sq__gl_program_defs(r->ctx, "meshes.vert", NULL, "meshes_cutout.frag",
                                  "#define SQ_NO_SHELL 1", &m->prog_cutout_far);
    if (res == SQ_OK && !m->prog_depth_sunk)
        res = sq__gl_program_defs(r->ctx, "depth_meshes.vert", NULL, "depth.frag",
                                  "#define SQ_SINK 1", &m->prog_depth_sunk);
    return res;
}

static void release(sq_renderer *r)
{
    sq__mesh_pass *m = r->meshes;
    for (int i = 0; i < m->mat_count; i++)
        if (m->mat[i].texture) glDeleteTextures(1, &m->mat[i].texture);
    const GLuint bufs[5] = {m->vbo, m->ibo, m->inst_buf, m->ring, m->sbo};
    glDeleteBuffers(5, bufs);
    glDeleteTextures(1, &m->inst_tex);
    glDeleteVertexArrays(1, &m->vao);
    m->vbo = m->ibo = m->inst_buf = m->ring = m->inst_tex = m->vao = m->sbo = 0;
    sq_free(r->ctx, m->mesh);
    sq_free(r->ctx, m->mat);
    sq_free(r->ctx, m->sphere);
    sq_free(r->ctx, m->err_scale);
    sq_free(r->ctx, m->visible);
    sq_free(r->ctx, m->bucket);
    sq_free(r->ctx, m->lod_of);
    m->mesh = NULL;
    m->mat = NULL;
    m->sphere = m->err_scale = NULL;
    m->visible = NULL;
    m->bucket = NULL;
    m->lod_of = NULL;
    m->mat_count = m->mesh_count = m->instance_count = 0;
    m->world = NULL;
}

void sq__mesh_pass_destroy(sq_renderer *r)
{
    if (!r->meshes) return;
    release(r);
    glDeleteProgram(r->meshes->prog_color);
    glDeleteProgram(r->meshes->prog_cutout);
    glDeleteProgram(r->meshes->prog_color_snow);
    glDeleteProgram(r->meshes->prog_cutout_snow);
    glDeleteProgram(r->meshes->prog_color_far);
    glDeleteProgram(r->meshes->prog_cutout_far);
    glDeleteProgram(r->meshes->prog_depth);
    glDeleteProgram(r->meshes->prog_depth_sunk);
    sq_free(r->ctx, r->meshes);
    r->meshes = NULL;
}

/* ---- upload --------------------------------------------------------------------------------- */
/* The faces of a level that a view straight down can see (the occlusion map): those whose
 * projection on the ground has an area, facing up on a closed mesh (the others are culled as back
 * faces), either way on an open one. An instance's scale (> 0) and yaw keep the sign of a face's
 * normal z, so the choice holds for every instance; a vertical face (a wall, a window's reveal)
 * projects to a line and covers no texel centre. Appends their indices to out; returns the count. */
static GLsizei top_faces(const sq_mesh_lod *L, bool closed, uint32_t *out)
{
    GLsizei n = 0;
    for (int t = 0; t + 2 < L->index_count; t += 3) {
        const float *a = &L->positions[3 * (size_t)L->indices[t]];
        const float *b = &L->positions[3 * (size_t)L->indices[t + 1]];
        const float *c = &L->positions[3 * (size_t)L->indices[t + 2]];
        const sq_vec3 e = sq_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
        const sq_vec3 f = sq_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
        const sq_vec3 x = sq_v3_cross(e, f);
        const float lim = 1e-6f * sq_v3_len(x);
        if (closed ? x.z > lim : fabsf(x.z) > lim) {
            memcpy(&out[n], &L->indices[t], 3 * sizeof(uint32_t));
            n += 3;
        }
    }
    return n;
}

static GLuint upload_texture(const sq_mesh_material *mt)
{
    GLuint t = 0;
    int levels = 1;
    for (int s = mt->texture_w > mt->texture_h ? mt->texture_w : mt->texture_h; s > 1; s >>= 1) levels++;
    glCreateTextures(GL_TEXTURE_2D, 1, &t);
    glTextureStorage2D(t, levels, GL_SRGB8_ALPHA8, mt->texture_w, mt->texture_h);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(t, 0, 0, 0, mt->texture_w, mt->texture_h, GL_RGBA, GL_UNSIGNED_BYTE,
                        mt->texture_rgba);
    glGenerateTextureMipmap(t);
    glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(t, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(t, GL_TEXTURE_WRAP_T, GL_REPEAT);
    return t;
}

/* Signed normalised 10-bit component. */
static uint32_t snorm10(float v)
{
    const int q = (int)lrintf(sq_clampf(v, -1.0f, 1.0f) * 511.0f);
    return (uint32_t)q & 0x3ffu;
}

/* The LOD's welded normals (sq__snow_welded_normals) packed as GL_INT_2_10_10_10_REV, the flag
 * "top of a wall" in the 2-bit w (1 or 0): the snow shell moves coincident vertices of
 * split-normal creases together. */
static bool welded_normals(sq_context *ctx, const sq_mesh_lod *L, uint32_t *out)
{
    const size_t n = (size_t)L->vertex_count;
    float *sm = sq_alloc(ctx, (n > 0 ? n : 1) * 4 * sizeof(float));
    if (!sm || !sq__snow_welded_normals(ctx, L->positions, L->normals, L->vertex_count, L->indices,
                                          L->index_count, sm)) {
        sq_free(ctx, sm);
        return false;
    }
    for (size_t v = 0; v < n; v++)
        out[v] = snorm10(sm[4 * v]) | snorm10(sm[4 * v + 1]) << 10 | snorm10(sm[4 * v + 2]) << 20 |
                 (sm[4 * v + 3] > 0.5f ? 1u : 0u) << 30;
    sq_free(ctx, sm);
    return true;
}

static sq_result upload(sq_renderer *r, const sq_world *w)
{
    sq_context *ctx = r->ctx;
    sq__mesh_pass *m = r->meshes;
    release(r);
    m->world = w;
    m->generation = w->generation;
    if (w->mesh_count == 0 || w->mesh_instance_count == 0) return SQ_OK;
    const int nm = w->mesh_count, ni = w->mesh_instance_count;
    /* sizes */
    size_t nv = 0, nidx = 0;
    int nmat = 0;
    for (int i = 0; i < nm; i++) {
        const sq_mesh *s = w->meshes[i];
        for (int l = 0; l < s->lod_count; l++) {
            nv += (size_t)s->lods[l].vertex_count;
            nidx += (size_t)s->lods[l].index_count;
        }
        nmat += s->material_count;
    }
    m->mesh = sq_alloc_zero(ctx, (size_t)nm * sizeof *m->mesh);
    m->mat = sq_alloc_zero(ctx, (size_t)nmat * sizeof *m->mat);
    m->sphere = sq_alloc(ctx, (size_t)ni * 4 * sizeof(float));
    m->err_scale = sq_alloc(ctx, (size_t)ni * sizeof(float));
    m->visible = sq_alloc(ctx, (size_t)ni * sizeof(uint32_t));
    m->lod_of = sq_alloc(ctx, (size_t)ni);
    m->bucket = sq_alloc(ctx, ((size_t)nm * SLOTS + 1) * sizeof(int));
    float *vb = sq_alloc(ctx, (nv > 0 ? nv : 1) * 8 * sizeof(float));
    /* every level's indices, then their top faces (at most as many) */
    uint32_t *ib = sq_alloc(ctx, (nidx > 0 ? 2 * nidx : 1) * sizeof(uint32_t));
    float *inst = sq_alloc(ctx, (size_t)ni * 16 * sizeof(float));
    uint32_t *sb = sq_alloc(ctx, (nv > 0 ? nv : 1) * sizeof(uint32_t));
    if (!m->mesh || !m->mat || !m->sphere || !m->err_scale || !m->visible || !m->lod_of ||
        !m->bucket || !vb || !ib || !inst || !sb) {
        sq_free(ctx, sb);
        sq_free(ctx, vb);
        sq_free(ctx, ib);
        sq_free(ctx, inst);
        release(r);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                        "out of memory uploading %d meshes and %d instances", nm, ni);
    }
    m->mesh_count = nm;
    m->instance_count = ni;
    size_t v0 = 0, i0 = 0, t0 = nidx;
    for (int i = 0; i < nm; i++) {
        const sq_mesh *s = w->meshes[i];
        gpu_mesh *g = &m->mesh[i];
        g->lod_count = s->lod_count;
        g->closed = s->solid;
        g->material0 = m->mat_count;
        for (int k = 0; k < s->material_count; k++) {
            const sq_mesh_material *mt = &s->materials[k];
            gpu_material *o = &m->mat[m->mat_count++];
            o->color = mt->base_color;
            o->tint = (int)mt->tint;
            o->texture = mt->texture_rgba ? upload_texture(mt) : 0;
        }
        for (int l = 0; l < s->lod_count; l++) {
            const sq_mesh_lod *L = &s->lods[l];
            g->lod[l].base_vertex = (GLint)v0;
            g->lod[l].first_index = (GLuint)i0;
            g->lod[l].index_count = L->index_count;
            g->lod[l].error_m = L->error_m;
            for (int v = 0; v < L->vertex_count; v++) {
                float *o = &vb[8 * (v0 + (size_t)v)];
                memcpy(o, &L->positions[3 * v], 3 * sizeof(float));
                memcpy(o + 3, &L->normals[3 * v], 3 * sizeof(float));
                o[6] = L->uvs ? L->uvs[2 * v] : 0.0f;
                o[7] = L->uvs ? 1.0f - L->uvs[2 * v + 1] : 0.0f; /* rows top first in memory */
            }
            memcpy(&ib[i0], L->indices, (size_t)L->index_count * sizeof(uint32_t));
            g->lod[l].top_first = (GLuint)t0;
            g->lod[l].top_count = top_faces(L, g->closed, &ib[t0]);
            t0 += (size_t)g->lod[l].top_count;
            if (!welded_normals(ctx, L, &sb[v0])) {
                sq_free(ctx, sb);
                sq_free(ctx, vb);
                sq_free(ctx, ib);
                sq_free(ctx, inst);
                release(r);
                return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                                "out of memory welding the normals of mesh %d", i);
            }
            v0 += (size_t)L->vertex_count;
            i0 += (size_t)L->index_count;
        }
    }
    m->bounds_min = sq_v3(1e30f, 1e30f, 1e30f);
    m->bounds_max = sq_v3(-1e30f, -1e30f, -1e30f);
    for (int i = 0; i < ni; i++) {
        const sq_mesh_instance *in = &w->mesh_instances[i];
        const sq_mesh *s = w->meshes[in->mesh];
        float *o = &inst[16 * i];
        o[0] = in->position_m.x;
        o[1] = in->position_m.y;
        o[2] = in->position_m.z;
        o[3] = in->yaw_deg * SQ_PI_F / 180.0f;
        o[4] = in->scale.x;
        o[5] = in->scale.y;
        o[6] = in->scale.z;
        o[7] = 0.0f;
        o[8] = in->tint[0].x;
        o[9] = in->tint[0].y;
        o[10] = in->tint[0].z;
        o[11] = 0.0f;
        o[12] = in->tint[1].x;
        o[13] = in->tint[1].y;
        o[14] = in->tint[1].z;
        o[15] = 0.0f;
        const float kmax = fmaxf(in->scale.x, fmaxf(in->scale.y, in->scale.z));
        const sq_vec3 c = sq_v3_scale(sq_v3_add(s->bounds_min, s->bounds_max), 0.5f);
        const sq_mat4 M = sq_mesh_instance_matrix(in);
        const sq_vec4 wc = sq_m4_mul_v4(M, (sq_vec4){c.x, c.y, c.z, 1.0f});
        const float rad = 0.5f * sq_v3_len(sq_v3_sub(s->bounds_max, s->bounds_min)) * kmax;
        m->sphere[4 * i] = wc.x;
        m->sphere[4 * i + 1] = wc.y;
        m->sphere[4 * i + 2] = wc.z;
        m->sphere[4 * i + 3] = rad;
        m->err_scale[i] = kmax;
        m->bounds_min = sq_v3(fminf(m->bounds_min.x, wc.x - rad), fminf(m->bounds_min.y, wc.y - rad),
                              fminf(m->bounds_min.z, wc.z - rad));
        m->bounds_max = sq_v3(fmaxf(m->bounds_max.x, wc.x + rad), fmaxf(m->bounds_max.y, wc.y + rad),
                              fmaxf(m->bounds_max.z, wc.z + rad));
    }
    glCreateBuffers(1, &m->vbo);
    glNamedBufferStorage(m->vbo, (GLsizeiptr)((nv > 0 ? nv : 1) * 8 * sizeof(float)), vb, 0);
    glCreateBuffers(1, &m->ibo);
    glNamedBufferStorage(m->ibo, (GLsizeiptr)((t0 > 0 ? t0 : 1) * sizeof(uint32_t)), ib, 0);
    glCreateBuffers(1, &m->inst_buf);
    glNamedBufferStorage(m->inst_buf, (GLsizeiptr)((size_t)ni * 16 * sizeof(float)), inst, 0);
    glCreateTextures(GL_TEXTURE_BUFFER, 1, &m->inst_tex);
    glTextureBuffer(m->inst_tex, GL_RGBA32F, m->inst_buf);
    m->ring_cap = (size_t)ni * RING_VIEWS;
    m->ring_pos = 0;
    glCreateBuffers(1, &m->ring);
    glNamedBufferStorage(m->ring, (GLsizeiptr)(m->ring_cap * sizeof(uint32_t)), NULL,
                         GL_DYNAMIC_STORAGE_BIT);
    glCreateBuffers(1, &m->sbo);
    glNamedBufferStorage(m->sbo, (GLsizeiptr)((nv > 0 ? nv : 1) * sizeof(uint32_t)), sb, 0);
    sq_free(ctx, sb);
    sq_free(ctx, vb);
    sq_free(ctx, ib);
    sq_free(ctx, inst);
    glCreateVertexArrays(1, &m->vao);
    glVertexArrayVertexBuffer(m->vao, 0, m->vbo, 0, 8 * sizeof(float));
    glVertexArrayElementBuffer(m->vao, m->ibo);
    const GLint size[3] = {3, 3, 2};
    const GLuint off[3] = {0, 3 * sizeof(float), 6 * sizeof(float)};
    for (GLuint a = 0; a < 3; a++) {
        glEnableVertexArrayAttrib(m->vao, a);
        glVertexArrayAttribFormat(m->vao, a, size[a], GL_FLOAT, GL_FALSE, off[a]);
        glVertexArrayAttribBinding(m->vao, a, 0);
    }
    glEnableVertexArrayAttrib(m->vao, 3);
    glVertexArrayAttribIFormat(m->vao, 3, 1, GL_UNSIGNED_INT, 0);
    glVertexArrayAttribBinding(m->vao, 3, 1);
    glVertexArrayVertexBuffer(m->vao, 1, m->ring, 0, sizeof(uint32_t));
    glVertexArrayBindingDivisor(m->vao, 1, 1);
    glVertexArrayVertexBuffer(m->vao, 2, m->sbo, 0, sizeof(uint32_t));
    glEnableVertexArrayAttrib(m->vao, 4);
    glVertexArrayAttribFormat(m->vao, 4, 4, GL_INT_2_10_10_10_REV, GL_TRUE, 0);
    glVertexArrayAttribBinding(m->vao, 4, 2);
    sq_log(ctx, SQ_LOG_DEBUG, "render", "meshes: %d meshes (%zu vertices, %zu indices), %d instances",
           nm, nv, nidx, ni);
    return sq__gl_check(ctx, "mesh upload");
}

sq_result sq__mesh_pass_update(sq_renderer *r, const sq_world *w)
{
    sq__mesh_pass *m = r->meshes;
    if (m->world == w && m->generation == w->generation && m->instance_count == w->mesh_instance_count)
        return SQ_OK;
    return upload(r, w);
}

void sq__mesh_pass_bounds(const sq_renderer *r, sq_vec3 *mn, sq_vec3 *mx, bool *any)
{
    const sq__mesh_pass *m = r->meshes;
    *any = m->instance_count > 0;
    *mn = m->bounds_min;
    *mx = m->bounds_max;
}

/* ---- culling and LOD ------------------------------------------------------------------------ */
void sq__frustum_planes(const sq_mat4 *vp, float pl[6][4])
{
    const float *m = vp->m;
    for (int k = 0; k < 6; k++) {
        const int row = k / 2;
        const float s = (k & 1) ? -1.0f : 1.0f;
        float len = 0.0f;
        for (int c = 0; c < 4; c++) pl[k][c] = m[c * 4 + 3] + s * m[c * 4 + row];
        len = sqrtf(pl[k][0] * pl[k][0] + pl[k][1] * pl[k][1] + pl[k][2] * pl[k][2]);
        if (len > 0.0f)
            for (int c = 0; c < 4; c++) pl[k][c] /= len;
    }
}

bool sq__box_may_be_seen(float pl[6][4], int last, const float lo[3], const float hi[3], float pad)
{
    for (int k = 0; k <= last; k++) {
        /* the box's corner farthest along the plane's normal */
        const float x = pl[k][0] >= 0.0f ? hi[0] + pad : lo[0] - pad;
        const float y = pl[k][1] >= 0.0f ? hi[1] + pad : lo[1] - pad;
        const float z = pl[k][2] >= 0.0f ? hi[2] + pad : lo[2] - pad;
        if (pl[k][0] * x + pl[k][1] * y + pl[k][2] * z + pl[k][3] < 0.0f) return false;
    }
    return true;
}

/* Culls and buckets the instances for view v; returns the number visible. Fills m->bucket with
 * offsets (size mesh_count * SLOTS + 1) and m->visible. With v->shell_max_m > 0 an instance whose
 * nearest point is so far that the deepest snow shell would move it by less than half a pixel
 * goes to the slots without the shell (llvmpipe runs a shader's branches for every vertex, so
 * the shell's occlusion-map taps are left out by another program, not by a branch). */
static int cull(sq__mesh_pass *m, const sq__depth_view *v)
{
    float pl[6][4];
    sq__frustum_planes(&v->view_proj, pl);
    const int nb = m->mesh_count * SLOTS;
    memset(m->bucket, 0, ((size_t)nb + 1) * sizeof(int));
    const float shell_far = 2.0f * v->shell_max_m * v->px_per_m; /* 0.5 px at this distance */
    const float min_px = v->min_pixels > 0.0f ? v->min_pixels : 0.5f;
    const float lod_px = v->lod_pixels > 0.0f ? v->lod_pixels : 1.0f;
    const int first_plane = 0, last_plane = v->ortho ? 3 : 5; /* ortho: near/far unbounded (depth clamp) */
    for (int i = 0; i < m->instance_count; i++) {
        const float *s = &m->sphere[4 * i];
        m->lod_of[i] = 255;
        bool in = true;
        for (int k = first_plane; k <= last_plane && in; k++)
            in = pl[k][0] * s[0] + pl[k][1] * s[1] + pl[k][2] * s[2] + pl[k][3] >= -s[3];
        if (!in) continue;
        /* pixels per metre at the instance */
        float ppm = v->px_per_m;
        bool far = false;
        if (!v->ortho) {
            const float dx = s[0] - v->eye.x, dy = s[1] - v->eye.y, dz = s[2] - v->eye.z;
            const float d = sqrtf(dx * dx + dy * dy + dz * dz) - s[3];
            ppm = d > 0.5f ? v->px_per_m / d : v->px_per_m / 0.5f;
            if (v->max_distance_m > 0.0f && d > v->max_distance_m) continue;
            far = v->shell_max_m > 0.0f && d > shell_far;
        }
        if (s[3] * ppm < min_px) continue;
        const int mi = m->world->mesh_instances[i].mesh;
        const gpu_mesh *g = &m->mesh[mi];
        int lod = 0;
        for (int l = g->lod_count - 1; l > 0; l--)
            if (g->lod[l].error_m * m->err_scale[i] * ppm <= lod_px) {
                lod = l;
                break;
            }
        const int slot = lod + (far ? SQ_MESH_MAX_LODS : 0);
        m->lod_of[i] = (uint8_t)slot;
        m->bucket[mi * SLOTS + slot + 1]++;
    }
    for (int b = 0; b < nb; b++) m->bucket[b + 1] += m->bucket[b];
    const int total = m->bucket[nb];
    /* fill (bucket[b] becomes the end of bucket b; its start is recomputed by the caller) */
    for (int i = 0; i < m->instance_count; i++) {
        if (m->lod_of[i] == 255) continue;
        const int b = m->world->mesh_instances[i].mesh * SLOTS + m->lod_of[i];
        m->visible[m->bucket[b]++] = (uint32_t)i;
    }
    /* shift back: bucket[b] = start of b */
    for (int b = nb; b > 0; b--) m->bucket[b] = m->bucket[b - 1];
    m->bucket[0] = 0;
    return total;
}

/* Uploads the visible list into the ring; returns its first slot. */
static GLuint ring_put(sq__mesh_pass *m, int count)
{
    if (m->ring_pos + (size_t)count > m->ring_cap) m->ring_pos = 0;
    const GLuint at = (GLuint)m->ring_pos;
    if (count > 0)
        glNamedBufferSubData(m->ring, (GLintptr)(m->ring_pos * sizeof(uint32_t)),
                             (GLsizeiptr)((size_t)count * sizeof(uint32_t)), m->visible);
    m->ring_pos += (size_t)count;
    return at;
}

/* A part (sq__render_part_done) is about this many faces: one draw call holds at most this many,
 * and a part ends after the draw that reaches it. A software rasteriser (llvmpipe) spends
 * seconds on 10^7 faces; Ctrl-C is answered between parts. */
#define DRAW_CHUNK_FACES (1 << 20)

static int instance_chunk(int faces_per_instance)
{
    const int f = faces_per_instance > 0 ? faces_per_instance : 1;
    return f >= DRAW_CHUNK_FACES ? 1 : DRAW_CHUNK_FACES / f;
}

/* Draws the culled instances with the bound program; materials: set the colour uniforms and
 * textures per part (the colour program's locations 0, 1, 2 and unit 10), textured parts with
 * prog_cutout (which may discard), the others with prog; the slots without the shell with
 * far[0] (far[1] textured). With materials or cull_closed, the back faces of closed meshes are
 * culled: every generated or imported solid is a union of closed, outward-oriented parts, so the
 * first surface a view's ray meets on it is where the ray enters a part, a front face — a depth
 * view (shadow cascade, occlusion map) keeps the same nearest depth and rasterises about half
 * the triangles. sink: the program's location 1 gets each level's error (sq__depth_view.sink);
 * lod_error: the colour programs' location 3 gets it (the snow exposure's allowance for a level
 * drawn below the map's finer one, meshes.vert); top: only the faces a view straight down sees
 * (top_faces; depth only). */
static void draw_buckets(sq_renderer *r, GLuint base, bool materials, bool cull_closed, bool sink,
                         bool lod_error, bool top, GLuint prog_near, GLuint cutout_near,
                         const GLuint far[2])
{
    GLuint bound = prog_near;
    sq__mesh_pass *m = r->meshes;
    glBindVertexArray(m->vao);
    glBindTextureUnit(9, m->inst_tex);
    bool cull_on = false;
    int64_t unpolled = 0; /* faces issued since the last part ended */
    for (int mi = 0; mi < m->mesh_count; mi++) {
        const gpu_mesh *g = &m->mesh[mi];
        const sq_mesh *s = m->world->meshes[mi];
        for (int slot = 0; slot < SLOTS; slot++) {
            const int l = slot % SQ_MESH_MAX_LODS;
            if (l >= g->lod_count) continue;
            const int b = mi * SLOTS + slot;
            const int n_all = m->bucket[b + 1] - m->bucket[b];
            if (n_all <= 0) continue;
            const bool with_shell = slot < SQ_MESH_MAX_LODS;
            const GLuint prog = with_shell ? prog_near : far[0];
            const GLuint prog_cutout = with_shell ? cutout_near : far[1];
            if (!materials && prog != bound) glUseProgram(bound = prog);
            if ((materials || cull_closed) && g->closed != cull_on) {
                cull_on = g->closed;
                if (cull_on) glEnable(GL_CULL_FACE);
                else glDisable(GL_CULL_FACE);
            }
            const gpu_lod *L = &g->lod[l];
            if (sink) glProgramUniform1f(bound, 1, L->error_m);
            if (lod_error) {
                glProgramUniform1f(prog, 3, L->error_m);
                glProgramUniform1f(prog_cutout, 3, L->error_m);
            }
            const int chunk = instance_chunk(L->index_count / 3);
            for (int i0 = 0; i0 < n_all; i0 += chunk) {
                if (unpolled >= (materials ? 1 : DRAW_CHUNK_FACES)) {
                    unpolled = 0;
                    if (sq__render_part_done(r)) goto done;
                }
                const int n = n_all - i0 < chunk ? n_all - i0 : chunk;
                const GLuint first = base + (GLuint)(m->bucket[b] + i0);
                m->stats.instances += n;
                if (!materials) {
                    const GLsizei count = top ? L->top_count : L->index_count;
                    const GLuint at = top ? L->top_first : L->first_index;
                    if (count > 0)
                        glDrawElementsInstancedBaseVertexBaseInstance(
                            GL_TRIANGLES, count, GL_UNSIGNED_INT,
                            (const void *)(uintptr_t)(at * sizeof(uint32_t)), n, L->base_vertex, first);
                    m->stats.faces += (int64_t)n * (count / 3);
                    unpolled += (int64_t)n * (count / 3);
                    continue;
                }
                const sq_mesh_lod *SL = &s->lods[l];
                for (int p = 0; p < SL->part_count; p++) {
                    const sq_mesh_part *part = &SL->parts[p];
                    const gpu_material *mt = &m->mat[g->material0 + part->material];
                    const GLuint use = mt->texture ? prog_cutout : prog;
                    if (use != bound) glUseProgram(bound = use);
                    glProgramUniform3f(use, 0, mt->color.x, mt->color.y, mt->color.z);
                    glProgramUniform1i(use, 1, mt->tint);
                    glProgramUniform1i(use, 2, mt->texture ? 1 : 0);
                    if (mt->texture) glBindTextureUnit(10, mt->texture);
                    glDrawElementsInstancedBaseVertexBaseInstance(
                        GL_TRIANGLES, (GLsizei)part->index_count, GL_UNSIGNED_INT,
                        (const void *)(uintptr_t)((L->first_index + part->first_index) * sizeof(uint32_t)),
                        n, L->base_vertex, first);
                    m->stats.faces += (int64_t)n * (part->index_count / 3);
                    unpolled += (int64_t)n * (part->index_count / 3);
                }
            }
        }
    }
done:
    if (cull_on) glDisable(GL_CULL_FACE);
}

/* ---- entry points ------------------------------------------------------------------------- */
sq__depth_view sq__depth_view_camera(const sq_renderer *r)
{
    sq__depth_view v;
    memset(&v, 0, sizeof v);
    v.view_proj = r->view_proj;
    v.eye = r->cam_pos;
    v.px_per_m = 0.5f * (float)r->height * r->proj.m[5]; /* H / (2 tan(fov/2)) */
    v.lod_pixels = r->desc.lod_pixels;
    v.min_pixels = r->desc.cull_pixels;
    v.max_distance_m = r->desc.mesh_distance_m;
    v.shell_max_m = r->snow_on && !r->shell_everywhere ? r->shell_max_m : 0.0f;
    return v;
}

void sq__mesh_pass_draw(sq_renderer *r)
{
    sq__mesh_pass *m = r->meshes;
    if (!m || m->instance_count == 0) return;
    const sq__depth_view v = sq__depth_view_camera(r);
    const int n = cull(m, &v);
    if (n == 0) return;
    const GLuint base = ring_put(m, n);
    const GLuint color = r->snow_on ? m->prog_color_snow : m->prog_color;
    const GLuint cutout = r->snow_on ? m->prog_cutout_snow : m->prog_cutout;
    const GLuint far[2] = {r->snow_on ? m->prog_color_far : m->prog_color,
                           r->snow_on ? m->prog_cutout_far : m->prog_cutout};
    glUseProgram(color);
    draw_buckets(r, base, true, true, false, r->snow_on, false, color, cutout, far);
}

void sq__mesh_pass_draw_depth(sq_renderer *r, const sq__depth_view *v)
{
    sq__mesh_pass *m = r->meshes;
    if (!m || m->instance_count == 0) return;
    const int n = cull(m, v);
    if (n == 0) return;
    const GLuint base = ring_put(m, n);
    const GLuint prog = v->sink && m->prog_depth_sunk ? m->prog_depth_sunk : m->prog_depth;
    glUseProgram(prog);
    glProgramUniformMatrix4fv(prog, 0, 1, GL_FALSE, v->view_proj.m);
    const GLuint same[2] = {prog, prog};
    draw_buckets(r, base, false, !r->depth_cull_off, prog == m->prog_depth_sunk, false,
                 v->top_only && !r->depth_cull_off, prog, prog, same);
}

void sq__mesh_pass_draw_with(sq_renderer *r, const sq__depth_view *v, GLuint program,
                             bool materials)
{
    sq__mesh_pass *m = r->meshes;
    if (!m || m->instance_count == 0) return;
    const int n = cull(m, v);
    if (n == 0) return;
    const GLuint base = ring_put(m, n);
    glUseProgram(program);
    const GLuint same[2] = {program, program};
    draw_buckets(r, base, materials, materials, false, false, false, program, program, same);
}

sq__mesh_stats sq__mesh_pass_stats(sq_renderer *r, bool reset)
{
    sq__mesh_stats s = r->meshes ? r->meshes->stats : (sq__mesh_stats){0, 0};
    if (reset && r->meshes) memset(&r->meshes->stats, 0, sizeof r->meshes->stats);
    return s;
}
