/* render_shadow.c — sun shadows of opaque geometry: cascaded shadow maps fitted to the view
 * (Engel 2006; Zhang et al. 2006 "parallel-split shadow maps"), and the one routine that draws
 * all opaque world geometry (terrain, obstacles, mesh instances) into a depth target for any
 * view, which the shadow cascades and the snow occlusion map share.
 *
 * Per frame: the view depth range [near, shadow distance] is split with the practical scheme
 * (a 0.75 blend of logarithmic and uniform splits); each slice gets the bounding sphere of its
 * frustum corners (its radius depends only on the slice and the field of view, so it never
 * changes while the camera moves), an orthographic sun view around it whose origin is snapped to
 * whole texels (no shimmer), and a depth render with depth clamping (casters between the slice
 * and the sun outside the box still occlude) and a slope-scaled polygon offset. The frame's
 * surface drawables (the avalanche's snow, deposits: heightfields over the terrain) are drawn into
 * the cascades they reach, so a flow casts its shadow on the snow beside it. Surfaces look the
 * cascade up with a normal offset and 3 x 3 percentage-closer filtering (frame_common.glsl).
 *
 * Kept between frames: each cascade's map reaches a margin of M = MARGIN x R beyond the slice's
 * sphere (extra texels of the same size), and its origin (x, y across the sun, z toward it) is
 * the sphere's centre rounded to a grid of 2M, so the sphere stays inside while its centre stays
 * in one grid cell. The map is then a function of (cell, texel, sun direction, world generation,
 * the surface drawables that reach it) only: it is drawn again when one of them changes, and a kept map is the map a fresh renderer
 * draws for the same view (`render_meshes.kept_cascades_equal_fresh_ones`). */
#include <math.h>
#include <string.h>

#include "render/render_internal.h"
#include "world/world_struct.h"

#define MAX_CASCADES 4
#define MARGIN 0.25f /* of the slice's sphere radius */

/* std140 mirror of the Shadow block in shaders/frame_common.glsl. */
typedef struct shadow_block {
    float matrix[MAX_CASCADES][16];
    float split[4], texel[4], params[4];
} shadow_block;

/* What a cascade's map was drawn for: the same key gives the same map. */
typedef struct cascade_key {
    const sq_world *world;
    uint64_t generation;
    sq_vec3 sun;
    float half, cx, cy, zlo, zhi; /* light-frame box */
    uint64_t surfaces;            /* the surface drawables over the map (surfaces_signature) */
    bool valid;
} cascade_key;

#define MAX_SHADOW_SURFACES 32

/* A surface drawable's box in the sun's frame (its covered cells), for which cascades it
 * reaches. */
typedef struct surface_extent {
    float x0, x1, y0, y1, ztop; /* light frame x, y; highest world z */
    bool any;
} surface_extent;

struct sq__shadow_pass {
    GLuint tex, dummy, ubo, prog_world;
    GLuint fbo[MAX_CASCADES];
    int size, cascades;
    int margin;   /* texels beyond the slice's sphere on each side (0: no keeping) */
    int tex_size; /* size + 2 margin */
    float distance_m;
    bool enabled;
    cascade_key key[MAX_CASCADES];
    int drawn_last;
    double ms_last;
};

sq_result sq__shadow_pass_create(sq_renderer *r)
{
    sq_context *ctx = r->ctx;
    sq__shadow_pass *s = sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    r->shadow = s;
    s->size = r->desc.shadow_map_size;
    s->cascades = r->desc.shadow_cascades;
    s->distance_m = r->desc.shadow_distance_m;
    s->enabled = !r->desc.shadows_off && s->cascades > 0 && s->size > 0;
    sq_result res = sq__gl_program(ctx, "depth_world.vert", NULL, "depth.frag", &s->prog_world);
    if (res != SQ_OK) return res;
    glCreateBuffers(1, &s->ubo);
    shadow_block zero;
    memset(&zero, 0, sizeof zero);
    glNamedBufferStorage(s->ubo, sizeof zero, &zero, GL_DYNAMIC_STORAGE_BIT);
    /* a 1x1x1 map for frames without shadows (the sampler must have a depth texture bound) */
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &s->dummy);
    glTextureStorage3D(s->dummy, 1, GL_DEPTH_COMPONENT32F, 1, 1, 1);
    glTextureParameteri(s->dummy, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    glTextureParameteri(s->dummy, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    if (s->enabled) {
        GLint max_size = 0;
        glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
        s->margin = (int)ceilf(0.5f * MARGIN * (float)s->size);
        if (s->size + 2 * s->margin > max_size) s->margin = (max_size - s->size) / 2;
        if (s->margin < 0) s->margin = 0;
        s->tex_size = s->size + 2 * s->margin;
        glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &s->tex);
        glTextureStorage3D(s->tex, 1, GL_DEPTH_COMPONENT32F, s->tex_size, s->tex_size, s->cascades);
        glTextureParameteri(s->tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTextureParameteri(s->tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTextureParameteri(s->tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTextureParameteri(s->tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        glTextureParameteri(s->tex, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
        glTextureParameteri(s->tex, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
        for (int c = 0; c < s->cascades; c++) {
            glCreateFramebuffers(1, &s->fbo[c]);
            glNamedFramebufferTextureLayer(s->fbo[c], GL_DEPTH_ATTACHMENT, s->tex, 0, c);
            glNamedFramebufferDrawBuffer(s->fbo[c], GL_NONE);
            glNamedFramebufferReadBuffer(s->fbo[c], GL_NONE);
            res = sq__gl_check_framebuffer(ctx, s->fbo[c], "shadow cascade");
            if (res != SQ_OK) return res;
        }
    }
    return sq__gl_check(ctx, "shadow map creation");
}

void sq__shadow_pass_destroy(sq_renderer *r)
{
    sq__shadow_pass *s = r->shadow;
    if (!s) return;
    glDeleteProgram(s->prog_world);
    glDeleteBuffers(1, &s->ubo);
    glDeleteTextures(1, &s->tex);
    glDeleteTextures(1, &s->dummy);
    for (int c = 0; c < MAX_CASCADES; c++)
        if (s->fbo[c]) glDeleteFramebuffers(1, &s->fbo[c]);
    sq_free(r->ctx, s);
    r->shadow = NULL;
}

/* ---- all opaque world geometry into a depth target ---------------------------------------- */
void sq__world_depth_draw(sq_renderer *r, const sq__depth_view *v)
{
    const sq__shadow_pass *s = r->shadow;
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    if (v->ortho) glEnable(GL_DEPTH_CLAMP);
    glProgramUniformMatrix4fv(s->prog_world, 0, 1, GL_FALSE, v->view_proj.m);
    glUseProgram(s->prog_world);
    sq__terrain_draw(r, &v->view_proj, v->ortho);
    if (r->obstacle_vertex_count > 0) {
        glBindVertexArray(r->obstacle_vao);
        glDrawArrays(GL_TRIANGLES, 0, r->obstacle_vertex_count);
    }
    sq__mesh_pass_draw_depth(r, v);
    if (v->ortho) glDisable(GL_DEPTH_CLAMP);
}

/* ---- surface drawables as casters ------------------------------------------------------------ */
/* Light-frame extent of each surface drawable's covered cells (in the order of the frame's
 * surfaces); returns how many surfaces there are. */
static int surface_extents(const sq_drawable *ds, int count, sq_vec3 lx, sq_vec3 ly,
                           surface_extent *out)
{
    int n = 0;
    for (int i = 0; i < count && n < MAX_SHADOW_SURFACES; i++) {
        if (ds[i].kind != SQ_DRAWABLE_SURFACE) continue;
        const sq_surface_view *v = &ds[i].u.surface;
        surface_extent e = {INFINITY, -INFINITY, INFINITY, -INFINITY, -INFINITY, false};
        float zlo = INFINITY;
        int i0 = v->nx, i1 = -1, j0 = v->ny, j1 = -1;
        for (int j = 0; j < v->ny; j++)
            for (int k = 0; k < v->nx; k++) {
                const size_t c = (size_t)j * (size_t)v->nx + (size_t)k;
                if (v->coverage && !(v->coverage[c] > 0.0f)) continue;
                const float z = v->height_m[c];
                e.ztop = fmaxf(e.ztop, z);
                zlo = fminf(zlo, z);
                i0 = k < i0 ? k : i0;
                i1 = k > i1 ? k : i1;
                j0 = j < j0 ? j : j0;
                j1 = j > j1 ? j : j1;
            }
        if (i1 >= 0) {
            e.any = true;
            /* the covered cells' box (one cell beyond: a drawn cell needs one covered corner) */
            const float x0 = v->origin_m.x + (float)(i0 > 0 ? i0 - 1 : 0) * v->dx_m;
            const float x1 = v->origin_m.x + (float)(i1 < v->nx - 1 ? i1 + 1 : i1) * v->dx_m;
            const float y0 = v->origin_m.y + (float)(j0 > 0 ? j0 - 1 : 0) * v->dy_m;
            const float y1 = v->origin_m.y + (float)(j1 < v->ny - 1 ? j1 + 1 : j1) * v->dy_m;
            for (int k = 0; k < 8; k++) {
                const sq_vec3 p = sq_v3((k & 1) ? x1 : x0, (k & 2) ? y1 : y0, (k & 4) ? e.ztop : zlo);
                const float a = sq_v3_dot(p, lx), b = sq_v3_dot(p, ly);
                e.x0 = fminf(e.x0, a);
                e.x1 = fmaxf(e.x1, a);
                e.y0 = fminf(e.y0, b);
                e.y1 = fmaxf(e.y1, b);
            }
        }
        out[n++] = e;
    }
    return n;
}

static uint64_t fnv_mix(uint64_t h, const void *data, size_t size)
{
    const unsigned char *b = data;
    for (size_t i = 0; i < size; i++) h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

/* The surfaces a cascade's map of light-frame square (cx, cy, half) overlaps (a bit per surface)
 * and a signature of what they are (data, version, grid): a map is drawn again when it changes. */
static uint64_t surfaces_signature(const sq_drawable *ds, int count, const surface_extent *ext,
                                   int n, float cx, float cy, float half, unsigned *mask)
{
    uint64_t h = 1469598103934665603ull;
    *mask = 0;
    int slot = 0;
    for (int i = 0; i < count && slot < n; i++) {
        if (ds[i].kind != SQ_DRAWABLE_SURFACE) continue;
        const surface_extent *e = &ext[slot];
        if (e->any && e->x1 >= cx - half && e->x0 <= cx + half && e->y1 >= cy - half &&
            e->y0 <= cy + half) {
            const sq_surface_view *v = &ds[i].u.surface;
            *mask |= 1u << slot;
            h = fnv_mix(h, &slot, sizeof slot);
            h = fnv_mix(h, &v->height_m, sizeof v->height_m);
            h = fnv_mix(h, &v->coverage, sizeof v->coverage);
            h = fnv_mix(h, &v->version, sizeof v->version);
            const float grid[5] = {v->origin_m.x, v->origin_m.y, v->origin_m.z, v->dx_m, v->dy_m};
            const int size[2] = {v->nx, v->ny};
            h = fnv_mix(h, grid, sizeof grid);
            h = fnv_mix(h, size, sizeof size);
        }
        slot++;
    }
    return h;
}

/* ---- cascades ------------------------------------------------------------------------------- */
/* Light frame: lz toward the sun, lx, ly across. */
static void light_basis(sq_vec3 sun, sq_vec3 *lx, sq_vec3 *ly, sq_vec3 *lz)
{
    *lz = sq_v3_norm(sun);
    const sq_vec3 ref = fabsf(lz->z) > 0.99f ? sq_v3(0, 1, 0) : sq_v3(0, 0, 1);
    *lx = sq_v3_norm(sq_v3_cross(ref, *lz));
    *ly = sq_v3_cross(*lz, *lx);
}

/* World -> clip of an orthographic sun view: x, y in [c - R, c + R] of the light frame, depth
 * from zlo (away from the sun) to zhi (toward it) mapped to clip z 1 .. -1. */
static sq_mat4 light_matrix(sq_vec3 lx, sq_vec3 ly, sq_vec3 lz, float cx, float cy, float R,
                            float zlo, float zhi)
{
    sq_mat4 m = sq_m4_identity();
    const float dz = zhi - zlo;
    const sq_vec3 rows[3] = {sq_v3_scale(lx, 1.0f / R), sq_v3_scale(ly, 1.0f / R),
                             sq_v3_scale(lz, -2.0f / dz)};
    const float t[3] = {-cx / R, -cy / R, 1.0f + 2.0f * zlo / dz};
    for (int row = 0; row < 3; row++) {
        m.m[0 * 4 + row] = rows[row].x;
        m.m[1 * 4 + row] = rows[row].y;
        m.m[2 * 4 + row] = rows[row].z;
        m.m[3 * 4 + row] = t[row];
    }
    return m;
}

bool sq__shadow_casters_possible(const sq_renderer *r, const sq_world *w)
{
    if (r->obstacle_vertex_count > 0) return true;
    sq_vec3 mmin, mmax;
    bool any;
    sq__mesh_pass_bounds(r, &mmin, &mmax, &any);
    if (any) return true;
    /* a heightfield whose every triangle rises by less than the sunlight climbs cannot reach
     * above a sun ray from any point of it: along the ray's ground track the surface gains at
     * most max_slope x s while the ray gains tan(elevation) x s */
    const sq_vec3 sun = sq_v3_norm(w->sun_dir);
    const double sx = sun.x, sy = sun.y, sz = sun.z;
    const double horiz = sqrt(sx * sx + sy * sy);
    const double tan_elev = horiz > 0.0 ? sz / horiz : (double)INFINITY;
    return r->terrain_index_count > 0 && !(r->terrain_max_slope < tan_elev);
}

void sq__shadow_cascades(sq_vec3 cam, sq_vec3 fwd, float tx, float ty, float n, float f, int C,
                         int size, int margin, sq_vec3 sun, float reach, sq__cascade_box *out)
{
    const float k2 = tx * tx + ty * ty;
    sq_vec3 lx, ly, lz;
    light_basis(sun, &lx, &ly, &lz);
    float d0 = n;
    for (int c = 0; c < C; c++) {
        const float u = (float)(c + 1) / (float)C;
        const float d1 = 0.75f * n * powf(f / n, u) + 0.25f * (n + (f - n) * u);
        /* bounding sphere of the slice's corners: centre on the view axis */
        float zc = 0.5f * (d0 + d1) * (1.0f + k2);
        if (zc > d1) zc = d1;
        float R = sqrtf((zc - d0) * (zc - d0) + k2 * d0 * d0);
        R = fmaxf(R, sqrtf((d1 - zc) * (d1 - zc) + k2 * d1 * d1));
        R *= 1.02f;
        const sq_vec3 centre = sq_v3_add(cam, sq_v3_scale(fwd, zc));
        const float texel = 2.0f * R / (float)size;
        const float M = (float)margin * texel, half = R + M;
        float cx = sq_v3_dot(centre, lx), cy = sq_v3_dot(centre, ly), cz = sq_v3_dot(centre, lz);
        if (margin > 0) {
            /* the centre's cell of 2M (whole texels): the sphere stays inside the map */
            const float g = 2.0f * M;
            cx = roundf(cx / g) * g;
            cy = roundf(cy / g) * g;
            cz = roundf(cz / g) * g;
        } else {
            /* snap the light-space origin to whole texels */
            cx = floorf(cx / texel) * texel;
            cy = floorf(cy / texel) * texel;
        }
        out[c] = (sq__cascade_box){d1, texel, half, cx, cy, cz - half, cz + half + reach};
        d0 = d1;
    }
}

sq_result sq__shadow_pass_prepare(sq_renderer *r, const sq_world *w, bool draw,
                                  const sq_drawable *drawables, int count)
{
    sq__shadow_pass *s = r->shadow;
    shadow_block blk;
    memset(&blk, 0, sizeof blk);
    const bool sun_up = w->sun_dir.z > 0.0f;
    sq_vec3 lx, ly, lz;
    light_basis(w->sun_dir, &lx, &ly, &lz);
    surface_extent ext[MAX_SHADOW_SURFACES];
    const int nsurf = draw && s->enabled && sun_up ? surface_extents(drawables, count, lx, ly, ext) : 0;
    bool surface_casters = false;
    for (int i = 0; i < nsurf; i++) surface_casters |= ext[i].any;
    if (draw && s->enabled && sun_up && !surface_casters && !sq__shadow_casters_possible(r, w))
        draw = false;
    if (draw && s->enabled && sun_up) {
        const double t0 = sq_time_now();
        const int C = s->cascades;
        const float n = r->near_m, f = fminf(r->far_m, s->distance_m);
        /* the highest thing in the world, for how far toward the sun to look */
        sq_vec3 wmin, wmax, mmin, mmax;
        bool any;
        sq_world_bounds(w, &wmin, &wmax);
        sq__mesh_pass_bounds(r, &mmin, &mmax, &any);
        float top = wmax.z;
        if (any) top = fmaxf(top, mmax.z);
        for (int i = 0; i < w->obstacle_count; i++)
            top = fmaxf(top, w->obstacles[i].center_m.z + w->obstacles[i].size_m.z + w->obstacles[i].roof_m);
        for (int i = 0; i < nsurf; i++)
            if (ext[i].any) top = fmaxf(top, ext[i].ztop);
        /* toward the sun beyond the slice: as far as the world's height range reaches along the
         * sun's direction (a function of the world and the sun only; nearer casters beyond it
         * still occlude by depth clamping) */
        const float reach = fminf(fmaxf(0.0f, top - wmin.z) / fmaxf(lz.z, 0.05f), 20000.0f);
        sq__cascade_box box[MAX_CASCADES];
        sq__shadow_cascades(r->cam_pos, r->cam_forward, 1.0f / r->proj.m[0], 1.0f / r->proj.m[5], n, f,
                            C, s->size, s->margin, w->sun_dir, reach, box);
        int drawn = 0;
        glEnable(GL_POLYGON_OFFSET_FILL);
        glPolygonOffset(2.0f, 2.0f);
        for (int c = 0; c < C; c++) {
            const float half = box[c].half, cx = box[c].cx, cy = box[c].cy, zlo = box[c].zlo,
                        zhi = box[c].zhi, texel = box[c].texel;
            const sq_mat4 vp = light_matrix(lx, ly, lz, cx, cy, half, zlo, zhi);
            /* lookup: clip -> [0, 1] */
            sq_mat4 bias = sq_m4_identity();
            bias.m[0] = bias.m[5] = bias.m[10] = 0.5f;
            bias.m[12] = bias.m[13] = bias.m[14] = 0.5f;
            const sq_mat4 look = sq_m4_mul(bias, vp);
            memcpy(blk.matrix[c], look.m, sizeof look.m);
            blk.split[c] = box[c].split;
            blk.texel[c] = texel;
            unsigned mask = 0;
            const uint64_t surf = surfaces_signature(drawables, count, ext, nsurf, cx, cy, half, &mask);
            const cascade_key key = {w, w->generation, w->sun_dir, half, cx, cy, zlo, zhi, surf, true};
            const cascade_key *k = &s->key[c];
            if (s->margin > 0 && k->valid && k->world == key.world &&
                k->generation == key.generation && k->sun.x == key.sun.x &&
                k->sun.y == key.sun.y && k->sun.z == key.sun.z && k->half == key.half &&
                k->cx == key.cx && k->cy == key.cy && k->zlo == key.zlo && k->zhi == key.zhi &&
                k->surfaces == key.surfaces)
                continue; /* the map drawn for this key is still there */
            s->key[c] = key;
            drawn++;
            /* the map must not stay bound for sampling while it is rendered into */
            glBindTextureUnit(8, s->dummy);
            glViewport(0, 0, s->tex_size, s->tex_size);
            glBindFramebuffer(GL_FRAMEBUFFER, s->fbo[c]);
            glDepthMask(GL_TRUE); /* a clear obeys the depth mask */
            const float one = 1.0f;
            glClearNamedFramebufferfv(s->fbo[c], GL_DEPTH, 0, &one);
            sq__depth_view v;
            memset(&v, 0, sizeof v);
            v.view_proj = vp;
            v.ortho = true;
            v.px_per_m = 1.0f / texel;
            v.lod_pixels = 2.0f;
            v.min_pixels = 1.0f;
            sq__world_depth_draw(r, &v);
            if (mask) {
                /* the snow lying on the terrain (avalanche flow, deposits) casts its shadow too */
                glEnable(GL_DEPTH_CLAMP);
                sq__surfaces_draw_depth(r, &vp, drawables, count, mask);
                glDisable(GL_DEPTH_CLAMP);
            }
        }
        glDisable(GL_POLYGON_OFFSET_FILL);
        blk.params[0] = (float)C;
        blk.params[1] = (float)s->tex_size;
        blk.params[2] = 0.85f * f;
        s->drawn_last = drawn;
        s->ms_last = (sq_time_now() - t0) * 1e3;
    } else {
        s->drawn_last = 0;
        s->ms_last = 0.0;
    }
    glNamedBufferSubData(s->ubo, 0, sizeof blk, &blk);
    sq__shadow_bind(r);
    return sq__gl_check(r->ctx, "shadow maps");
}

void sq__shadow_bind(sq_renderer *r)
{
    const sq__shadow_pass *s = r->shadow;
    glBindBufferBase(GL_UNIFORM_BUFFER, 3, s->ubo);
    glBindTextureUnit(8, s->enabled ? s->tex : s->dummy);
}

double sq__shadow_pass_ms(const sq_renderer *r) { return r->shadow ? r->shadow->ms_last : 0.0; }

int sq__shadow_pass_drawn(const sq_renderer *r) { return r->shadow ? r->shadow->drawn_last : 0; }
