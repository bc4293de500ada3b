/* renderer.c — the base OpenGL 4.5 renderer (ARCHITECTURE "render"): frame buffers (HDR
 * RGBA16F + DEPTH32F texture, 8-bit LDR), camera matrices, input checks (camera inside the
 * terrain, non-finite volume densities), and the passes of a frame in order:
 *   volume light passes (sun shadow) -> opaque shadow cascades (render_shadow.c) -> sky ->
 *   terrain -> obstacles -> meshes (render_meshes.c) -> surfaces -> volumes -> particles ->
 *   tone mapping.
 * Static geometry (terrain mesh, obstacles) is uploaded once per world generation; surfaces
 * once per drawable version. Shading models are in shaders/<pass>.glsl (frame_common.glsl holds the
 * sky, ambient and haze). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render/render_internal.h"
#include "world/world_struct.h"

#define SQ_MAX_SURFACES 8
#define SQ_MAX_SCANNED_VOLUMES 8

typedef struct surface_slot {
    GLuint height_tex, coverage_tex;
    int nx, ny;
    bool has_coverage;
    uint64_t version;
    const float *height, *coverage;
} surface_slot;

typedef struct scanned_volume {
    const float *density;
    int nx, ny, nz;
    uint64_t version;
} scanned_volume;

struct sq__base_cache {
    surface_slot surfaces[SQ_MAX_SURFACES];
    scanned_volume scanned[SQ_MAX_SCANNED_VOLUMES];
    const sq_world *world; /* world the geometry cache was built from */
    const float *world_heights;
    int world_nx, world_ny;
    bool has_world;
    uint64_t frames;
};

/* std140 mirror of the Frame block in shaders/frame_common.glsl. */
typedef struct frame_block {
    float view_proj[16], inv_view_proj[16], view[16], sun_shadow_matrix[16];
    float cam_pos[4], sun_dir[4], sun_radiance[4], sky_zenith[4], sky_horizon[4];
    float ground_albedo[4], viewport[4], params[4];
} frame_block;

/* Vertex of the obstacle mesh: position, normal, albedo, aux (kind, along, height fraction). */
typedef struct mesh_vertex {
    float p[3], n[3], albedo[3], aux[3];
} mesh_vertex;

static sq_result check_size(sq_renderer *r, int width, int height, const char *what);
static sq_result resize_targets(sq_renderer *r, int w, int h, GLenum depth_format);

/* ---- camera ----------------------------------------------------------------------------- */
static bool finite3(sq_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static sq_result setup_camera(sq_renderer *r, const sq_camera *camera)
{
    sq_context *ctx = r->ctx;
    const sq_camera c = sq_camera_resolve(*camera);
    const sq_camera *cam = &c;
    const float fov = c.fov_y_deg, znear = c.near_m, zfar = c.far_m;
    const sq_vec3 up = c.up;
    if (!finite3(cam->position_m) || !finite3(cam->target_m) || !finite3(up))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera position (%g, %g, %g), target (%g, %g, %g) or up is not finite",
                        (double)cam->position_m.x, (double)cam->position_m.y,
                        (double)cam->position_m.z, (double)cam->target_m.x,
                        (double)cam->target_m.y, (double)cam->target_m.z);
    if (!(fov > 0.0f && fov < 180.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera fov_y_deg = %g; must be in (0, 180)", (double)fov);
    if (!(znear > 0.0f) || !(zfar > znear) || !isfinite(zfar))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera near_m = %g, far_m = %g; need 0 < near < far (finite)",
                        (double)znear, (double)zfar);
    const sq_vec3 f = sq_v3_sub(cam->target_m, cam->position_m);
    if (sq_v3_len(f) <= 0.0f)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera target equals its position (%g, %g, %g); it must look somewhere",
                        (double)cam->position_m.x, (double)cam->position_m.y,
                        (double)cam->position_m.z);
    const sq_vec3 fn = sq_v3_norm(f);
    if (sq_v3_len(sq_v3_cross(fn, sq_v3_norm(up))) < 1e-4f)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera looks along its up vector (%g, %g, %g); give an up that is not "
                        "parallel to target - position (e.g. up = (0, 1, 0) for a view "
                        "straight down)",
                        (double)up.x, (double)up.y, (double)up.z);
    const float aspect = (float)r->width / (float)r->height;
    r->view = sq_camera_view(cam);
    r->proj = sq_camera_proj(cam, aspect);
    r->view_proj = sq_m4_mul(r->proj, r->view);
    r->inv_view_proj = sq_m4_inverse(r->view_proj);
    r->cam_pos = cam->position_m;
    r->cam_forward = fn;
    r->cam_right = sq_v3_norm(sq_v3_cross(fn, up));
    r->cam_up = sq_v3_cross(r->cam_right, fn);
    r->near_m = znear;
    r->far_m = zfar;
    return SQ_OK;
}

/* ---- input checks ----------------------------------------------------------------------- */
static sq_result check_camera_above_terrain(sq_renderer *r, const sq_world *w)
{
    const sq_vec3 p = r->cam_pos;
    const float h = sq_world_height_at(w, p.x, p.y);
    if (p.z < h + 0.1f)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "camera at (%.2f, %.2f, %.2f) is below the terrain surface (%.2f m) or "
                        "within 0.1 m of it; raise the camera (position_m.z) above %.2f m",
                        (double)p.x, (double)p.y, (double)p.z, (double)h, (double)(h + 0.1f));
    return SQ_OK;
}

static const char *drawable_name(const sq_drawable *d) { return d->name ? d->name : "(unnamed)"; }

static sq_result check_volume(sq_renderer *r, const sq_drawable *d, int index)
{
    const sq_volume_view *v = &d->u.volume;
    if (!v->density || v->nx < 1 || v->ny < 1 || v->nz < 1)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume drawable \"%s\" (#%d): density %s, cells %dx%dx%d; need data and "
                        "at least 1 cell per axis",
                        drawable_name(d), index, v->density ? "set" : "NULL", v->nx, v->ny, v->nz);
    if (!finite3(v->origin_m) || !finite3(v->size_m) || !(v->size_m.x > 0.0f) ||
        !(v->size_m.y > 0.0f) || !(v->size_m.z > 0.0f))
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume drawable \"%s\": box size (%g, %g, %g) m; every side must be "
                        "finite and > 0",
                        drawable_name(d), (double)v->size_m.x, (double)v->size_m.y,
                        (double)v->size_m.z);
    /* Scanning is skipped for a volume already found clean at this version. */
    struct sq__base_cache *b = r->base;
    const int slot = index < SQ_MAX_SCANNED_VOLUMES ? index : -1;
    if (slot >= 0) {
        const scanned_volume *s = &b->scanned[slot];
        if (s->density == v->density && s->version == v->version && s->nx == v->nx &&
            s->ny == v->ny && s->nz == v->nz)
            return SQ_OK;
    }
    const size_t n = (size_t)v->nx * (size_t)v->ny * (size_t)v->nz;
    for (size_t c = 0; c < n; c++) {
        if (!isfinite(v->density[c])) {
            const size_t i = c % (size_t)v->nx;
            const size_t j = (c / (size_t)v->nx) % (size_t)v->ny;
            const size_t k = c / ((size_t)v->nx * (size_t)v->ny);
            return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                            "volume drawable \"%s\": density at cell (%zu, %zu, %zu) is %g; "
                            "refusing to render a non-finite volume (the simulation that made "
                            "it has blown up)",
                            drawable_name(d), i, j, k, (double)v->density[c]);
        }
    }
    if (slot >= 0) {
        scanned_volume *s = &b->scanned[slot];
        s->density = v->density;
        s->version = v->version;
        s->nx = v->nx;
        s->ny = v->ny;
        s->nz = v->nz;
    }
    return SQ_OK;
}

static sq_result check_drawables(sq_renderer *r, const sq_drawable *ds, int count)
{
    int volumes = 0, surfaces = 0;
    for (int i = 0; i < count; i++) {
        const sq_drawable *d = &ds[i];
        switch (d->kind) {
        case SQ_DRAWABLE_VOLUME: {
            sq_result res = check_volume(r, d, volumes++);
            if (res != SQ_OK) return res;
            break;
        }
        case SQ_DRAWABLE_SURFACE: {
            const sq_surface_view *s = &d->u.surface;
            if (!s->height_m || s->nx < 2 || s->ny < 2 || !(s->dx_m > 0.0f) || !(s->dy_m > 0.0f))
                return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                                "surface drawable \"%s\": %dx%d samples, spacing %g x %g m, "
                                "heights %s; need >= 2x2 samples, spacing > 0 and heights",
                                drawable_name(d), s->nx, s->ny, (double)s->dx_m,
                                (double)s->dy_m, s->height_m ? "set" : "NULL");
            if (++surfaces > SQ_MAX_SURFACES)
                return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                                "surface drawable \"%s\" is surface number %d; at most %d per "
                                "frame",
                                drawable_name(d), surfaces, SQ_MAX_SURFACES);
            break;
        }
        case SQ_DRAWABLE_PARTICLES: {
            const sq_particles_view *p = &d->u.particles;
            if (p->count < 0 || (p->count > 0 && !p->position))
                return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                                "particle drawable \"%s\": count = %d, positions %s; need "
                                "count >= 0 and positions when count > 0",
                                drawable_name(d), p->count, p->position ? "set" : "NULL");
            break;
        }
        case SQ_DRAWABLE_CLOUDS: break; /* checked by the cloud pass */
        case SQ_DRAWABLE_SNOW_COVER: {
            const sq_snow_cover_view *s = &d->u.snow_cover;
            const int t = s->taps;
            if (!s->depth_m || s->nx < 1 || s->ny < 1 || !(s->dx_m > 0.0f) || !(s->dy_m > 0.0f) ||
                s->map_size < 16 || s->map_size > 16384 || !(t == 1 || t == 4 || t == 5 || t == 9) ||
                !(s->detail_distance_m > 0.0f))
                return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                                "snow-cover drawable \"%s\": %dx%d cells of %g x %g m, depth %s, "
                                "map %d texels, %d taps, detail distance %g m; need cells >= 1, "
                                "spacing > 0, depths, a map of 16..16384 texels, 1, 4, 5 or 9 "
                                "taps and a distance > 0",
                                drawable_name(d), s->nx, s->ny, (double)s->dx_m, (double)s->dy_m,
                                s->depth_m ? "set" : "NULL", s->map_size, t,
                                (double)s->detail_distance_m);
            break;
        }
        case SQ_DRAWABLE_NONE: break;
        default:
            return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                            "drawable \"%s\" (#%d) has unknown kind %d", drawable_name(d), i,
                            (int)d->kind);
        }
    }
    return SQ_OK;
}

/* ---- world geometry cache --------------------------------------------------------------- */
/* Terrain mesh: at most SQ_TERRAIN_MAX_SIDE vertices per side (a larger heightfield, e.g. a big
 * heightmap, is sampled every `stride` samples, always including the last row and column). */
#define SQ_TERRAIN_MAX_SIDE 1025
#define TERRAIN_TILE 32 /* cells per side of a culling tile */

/* Sample index of mesh vertex m along an axis of n samples taken every stride. */
static int mesh_sample(int m, int stride, int n)
{
    const int i = m * stride;
    return i < n - 1 ? i : n - 1;
}

/* Steepest rise of the plane through three mesh vertices (x, y, z first): |grad z|; infinite
 * for a vertical or degenerate triangle. */
static double triangle_slope(const float *a, const float *b, const float *c)
{
    const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
    const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
    const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const double h = sqrt(nx * nx + ny * ny);
    return fabs(nz) > 0.0 ? h / fabs(nz) : (h > 0.0 ? (double)INFINITY : 0.0);
}

static sq_result build_terrain(sq_renderer *r, const sq_world *w)
{
    sq_context *ctx = r->ctx;
    r->terrain_index_count = 0;
    r->terrain_max_slope = 0.0;
    if (w->nx < 2 || w->ny < 2 || !w->heights) return SQ_OK; /* nothing to draw */
    const int big = w->nx > w->ny ? w->nx : w->ny;
    const int stride = (big - 1 + SQ_TERRAIN_MAX_SIDE - 2) / (SQ_TERRAIN_MAX_SIDE - 1);
    const int nx = (w->nx - 1 + stride - 1) / stride + 1, ny = (w->ny - 1 + stride - 1) / stride + 1;
    const size_t nv = (size_t)nx * (size_t)ny;
    const size_t ni = (size_t)(nx - 1) * (size_t)(ny - 1) * 6;
    float *v = sq_alloc(ctx, nv * 6 * sizeof(float));
    uint32_t *idx = sq_alloc(ctx, ni * sizeof(uint32_t));
    if (!v || !idx) {
        sq_free(ctx, v);
        sq_free(ctx, idx);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    const int wnx = w->nx, wny = w->ny;
    for (int mj = 0; mj < ny; mj++) {
        const int j = mesh_sample(mj, stride, wny);
        for (int mi = 0; mi < nx; mi++) {
            const int i = mesh_sample(mi, stride, wnx);
            const size_t c = (size_t)j * (size_t)wnx + (size_t)i;
            float *o = v + 6 * ((size_t)mj * (size_t)nx + (size_t)mi);
            o[0] = w->origin.x + (float)i * w->dx;
            o[1] = w->origin.y + (float)j * w->dy;
            o[2] = w->heights[c];
            if (w->normals) {
                o[3] = w->normals[3 * c + 0];
                o[4] = w->normals[3 * c + 1];
                o[5] = w->normals[3 * c + 2];
            } else { /* central differences */
                const int il = i > 0 ? i - 1 : i, ir = i < wnx - 1 ? i + 1 : i;
                const int jl = j > 0 ? j - 1 : j, jr = j < wny - 1 ? j + 1 : j;
                const float *hh = w->heights;
                const float gx = (hh[(size_t)j * wnx + ir] - hh[(size_t)j * wnx + il]) /
                                 ((float)(ir - il) * w->dx);
                const float gy = (hh[(size_t)jr * wnx + i] - hh[(size_t)jl * wnx + i]) /
                                 ((float)(jr - jl) * w->dy);
                const sq_vec3 n = sq_v3_norm(sq_v3(-gx, -gy, 1.0f));
                o[3] = n.x;
                o[4] = n.y;
                o[5] = n.z;
            }
        }
    }
    /* triangles tile by tile (TERRAIN_TILE cells a side), each tile with its bounding box */
    const int tx = (nx - 1 + TERRAIN_TILE - 1) / TERRAIN_TILE, ty = (ny - 1 + TERRAIN_TILE - 1) / TERRAIN_TILE;
    sq_free(ctx, r->terrain_tiles);
    sq_free(ctx, r->tile_counts);
    sq_free(ctx, (void *)r->tile_offsets);
    r->terrain_tile_count = 0;
    r->terrain_tiles = sq_alloc(ctx, (size_t)tx * (size_t)ty * sizeof *r->terrain_tiles);
    r->tile_counts = sq_alloc(ctx, (size_t)tx * (size_t)ty * sizeof *r->tile_counts);
    r->tile_offsets = sq_alloc(ctx, (size_t)tx * (size_t)ty * sizeof *r->tile_offsets);
    if (!r->terrain_tiles || !r->tile_counts || !r->tile_offsets) {
        sq_free(ctx, v);
        sq_free(ctx, idx);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    size_t k = 0;
    double max_slope = 0.0;
    for (int tj = 0; tj < ty; tj++)
        for (int ti = 0; ti < tx; ti++) {
            sq__terrain_tile *t = &r->terrain_tiles[r->terrain_tile_count++];
            t->first = (GLsizei)k;
            for (int a = 0; a < 3; a++) {
                t->lo[a] = 1e30f;
                t->hi[a] = -1e30f;
            }
            for (int j = tj * TERRAIN_TILE; j < (tj + 1) * TERRAIN_TILE && j < ny - 1; j++)
                for (int i = ti * TERRAIN_TILE; i < (ti + 1) * TERRAIN_TILE && i < nx - 1; i++) {
                    const uint32_t a = (uint32_t)(j * nx + i), b = a + 1;
                    const uint32_t c = a + (uint32_t)nx, d = c + 1;
                    idx[k++] = a; idx[k++] = b; idx[k++] = d;
                    idx[k++] = a; idx[k++] = d; idx[k++] = c;
                    const double sa = triangle_slope(v + 6 * a, v + 6 * b, v + 6 * d);
                    const double sb = triangle_slope(v + 6 * a, v + 6 * d, v + 6 * c);
                    max_slope = fmax(max_slope, fmax(sa, sb));
                    const uint32_t corner[4] = {a, b, c, d};
                    for (int q = 0; q < 4; q++)
                        for (int e = 0; e < 3; e++) {
                            t->lo[e] = fminf(t->lo[e], v[6 * corner[q] + e]);
                            t->hi[e] = fmaxf(t->hi[e], v[6 * corner[q] + e]);
                        }
                }
            t->count = (GLsizei)k - t->first;
        }
    r->terrain_max_slope = max_slope;
    if (!r->terrain_vao) {
        glCreateVertexArrays(1, &r->terrain_vao);
        glEnableVertexArrayAttrib(r->terrain_vao, 0);
        glEnableVertexArrayAttrib(r->terrain_vao, 1);
        glVertexArrayAttribFormat(r->terrain_vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
        glVertexArrayAttribFormat(r->terrain_vao, 1, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float));
        glVertexArrayAttribBinding(r->terrain_vao, 0, 0);
        glVertexArrayAttribBinding(r->terrain_vao, 1, 0);
    }
    glDeleteBuffers(1, &r->terrain_vbo);
    glDeleteBuffers(1, &r->terrain_ibo);
    glCreateBuffers(1, &r->terrain_vbo);
    glCreateBuffers(1, &r->terrain_ibo);
    glNamedBufferStorage(r->terrain_vbo, (GLsizeiptr)(nv * 6 * sizeof(float)), v, 0);
    glNamedBufferStorage(r->terrain_ibo, (GLsizeiptr)(ni * sizeof(uint32_t)), idx, 0);
    glVertexArrayVertexBuffer(r->terrain_vao, 0, r->terrain_vbo, 0, 6 * sizeof(float));
    glVertexArrayElementBuffer(r->terrain_vao, r->terrain_ibo);
    r->terrain_index_count = (GLsizei)ni;
    sq_free(ctx, v);
    sq_free(ctx, idx);
    return sq__gl_check(ctx, "terrain mesh upload");
}

void sq__terrain_draw(sq_renderer *r, const sq_mat4 *view_proj, bool ortho)
{
    if (r->terrain_index_count <= 0) return;
    float pl[6][4];
    sq__frustum_planes(view_proj, pl);
    int runs = 0;
    GLsizei next = -1; /* where the last run ends: tiles next to each other in the buffer join */
    for (int i = 0; i < r->terrain_tile_count; i++) {
        const sq__terrain_tile *t = &r->terrain_tiles[i];
        if (!sq__box_may_be_seen(pl, ortho ? 3 : 5, t->lo, t->hi, r->shell_max_m)) continue;
        r->terrain_faces += t->count / 3;
        if (runs > 0 && t->first == next) {
            r->tile_counts[runs - 1] += t->count;
        } else {
            r->tile_counts[runs] = t->count;
            r->tile_offsets[runs] = (const void *)((uintptr_t)t->first * sizeof(uint32_t));
            runs++;
        }
        next = t->first + t->count;
    }
    if (runs == 0) return;
    glBindVertexArray(r->terrain_vao);
    /* in SQ_RENDER_PARTS parts of about equal faces: Ctrl-C reaches the pass between them */
    int64_t total = 0;
    for (int k = 0; k < runs; k++) total += r->tile_counts[k];
    const int64_t per = total / SQ_RENDER_PARTS + 1;
    int64_t acc = 0;
    for (int a = 0, k = 0; k < runs; k++) {
        acc += r->tile_counts[k];
        if (acc < per && k + 1 < runs) continue;
        glMultiDrawElements(GL_TRIANGLES, r->tile_counts + a, GL_UNSIGNED_INT, r->tile_offsets + a,
                            k + 1 - a);
        a = k + 1;
        acc = 0;
        if (sq__render_part_done(r)) return;
    }
}

/* Obstacle mesh building: local frame centred on the footprint, base at z = 0, ridge along x;
 * rotated by yaw about z and moved to the obstacle's place. */
typedef struct mesh_builder {
    mesh_vertex *v;
    int n, cap;
    sq_vec3 centre, albedo;
    float cos_yaw, sin_yaw, height, along_sign;
    int kind;
    bool along_x; /* fences: boards run along the longer footprint axis */
} mesh_builder;

static sq_vec3 to_world(const mesh_builder *m, sq_vec3 p)
{
    return sq_v3(m->centre.x + m->cos_yaw * p.x - m->sin_yaw * p.y,
                 m->centre.y + m->sin_yaw * p.x + m->cos_yaw * p.y, m->centre.z + p.z);
}

/* Adds triangle a b c (local), oriented so that its normal points away from inside. */
static void add_tri(mesh_builder *m, sq_vec3 a, sq_vec3 b, sq_vec3 c, sq_vec3 inside)
{
    if (m->n + 3 > m->cap) return;
    sq_vec3 n = sq_v3_norm(sq_v3_cross(sq_v3_sub(b, a), sq_v3_sub(c, a)));
    const sq_vec3 centroid = sq_v3_scale(sq_v3_add(sq_v3_add(a, b), c), 1.0f / 3.0f);
    if (sq_v3_dot(n, sq_v3_sub(centroid, inside)) < 0.0f) {
        n = sq_v3_scale(n, -1.0f);
        const sq_vec3 t = b;
        b = c;
        c = t;
    }
    const sq_vec3 nw = sq_v3(m->cos_yaw * n.x - m->sin_yaw * n.y,
                             m->sin_yaw * n.x + m->cos_yaw * n.y, n.z);
    const sq_vec3 pts[3] = {a, b, c};
    for (int i = 0; i < 3; i++) {
        mesh_vertex *o = &m->v[m->n++];
        const sq_vec3 w = to_world(m, pts[i]);
        o->p[0] = w.x; o->p[1] = w.y; o->p[2] = w.z;
        o->n[0] = nw.x; o->n[1] = nw.y; o->n[2] = nw.z;
        o->albedo[0] = m->albedo.x; o->albedo[1] = m->albedo.y; o->albedo[2] = m->albedo.z;
        o->aux[0] = (float)m->kind;
        o->aux[1] = m->along_x ? pts[i].x : pts[i].y;
        o->aux[2] = m->height > 0.0f ? pts[i].z / m->height : 0.0f;
    }
}

static void add_quad(mesh_builder *m, sq_vec3 a, sq_vec3 b, sq_vec3 c, sq_vec3 d, sq_vec3 inside)
{
    add_tri(m, a, b, c, inside);
    add_tri(m, a, c, d, inside);
}

/* Four walls and a flat top (the bottom is never seen). */
static void add_box(mesh_builder *m, float hx, float hy, float h, bool top)
{
    const sq_vec3 in = sq_v3(0.0f, 0.0f, 0.5f * h);
    const sq_vec3 p000 = sq_v3(-hx, -hy, 0.0f), p100 = sq_v3(hx, -hy, 0.0f);
    const sq_vec3 p010 = sq_v3(-hx, hy, 0.0f), p110 = sq_v3(hx, hy, 0.0f);
    const sq_vec3 p001 = sq_v3(-hx, -hy, h), p101 = sq_v3(hx, -hy, h);
    const sq_vec3 p011 = sq_v3(-hx, hy, h), p111 = sq_v3(hx, hy, h);
    add_quad(m, p000, p100, p101, p001, in); /* south */
    add_quad(m, p010, p110, p111, p011, in); /* north */
    add_quad(m, p000, p010, p011, p001, in); /* west */
    add_quad(m, p100, p110, p111, p101, in); /* east */
    if (top) add_quad(m, p001, p101, p111, p011, in);
}

static float obstacle_base(const sq_world *w, const sq_obstacle *o)
{
    if (isfinite(o->center_m.z)) return o->center_m.z;
    /* on the terrain: the lowest ground under the footprint, so that nothing floats */
    const float c = cosf(o->yaw_deg * SQ_PI_F / 180.0f), s = sinf(o->yaw_deg * SQ_PI_F / 180.0f);
    float zmin = sq_world_height_at(w, o->center_m.x, o->center_m.y);
    for (int k = 0; k < 4; k++) {
        const float lx = (k & 1 ? 0.5f : -0.5f) * o->size_m.x;
        const float ly = (k & 2 ? 0.5f : -0.5f) * o->size_m.y;
        const float h = sq_world_height_at(w, o->center_m.x + c * lx - s * ly,
                                           o->center_m.y + s * lx + c * ly);
        if (h < zmin) zmin = h;
    }
    return zmin;
}

static sq_result build_obstacles(sq_renderer *r, const sq_world *w)
{
    sq_context *ctx = r->ctx;
    r->obstacle_vertex_count = 0;
    const int count = sq_clampi(w->obstacle_count, 0, SQ_MAX_OBSTACLES);
    if (count == 0) return SQ_OK;
    const int per = 48; /* house: 4 walls (24) + 2 roof slopes (12) + 2 gables (6) */
    mesh_builder m = {.cap = count * per};
    m.v = sq_alloc(ctx, (size_t)m.cap * sizeof(mesh_vertex));
    if (!m.v) return SQ_ERR_OUT_OF_MEMORY;
    for (int i = 0; i < count; i++) {
        const sq_obstacle *o = &w->obstacles[i];
        const float hx = 0.5f * o->size_m.x, hy = 0.5f * o->size_m.y, h = o->size_m.z;
        if (!(hx > 0.0f && hy > 0.0f && h > 0.0f)) continue;
        const bool given = o->albedo.x > 0.0f || o->albedo.y > 0.0f || o->albedo.z > 0.0f;
        m.centre = sq_v3(o->center_m.x, o->center_m.y, obstacle_base(w, o));
        m.cos_yaw = cosf(o->yaw_deg * SQ_PI_F / 180.0f);
        m.sin_yaw = sinf(o->yaw_deg * SQ_PI_F / 180.0f);
        m.kind = (int)o->kind;
        m.height = h;
        m.along_x = o->size_m.x >= o->size_m.y;
        switch (o->kind) {
        case SQ_OBSTACLE_HOUSE: {
            m.albedo = given ? o->albedo : sq_v3(0.70f, 0.64f, 0.54f); /* rendered walls */
            add_box(&m, hx, hy, h, o->roof_m <= 0.0f);
            if (o->roof_m > 0.0f) {
                m.albedo = given ? o->albedo : sq_v3(0.40f, 0.19f, 0.13f); /* clay tiles */
                const float t = h + o->roof_m;
                const sq_vec3 in = sq_v3(0.0f, 0.0f, h);
                const sq_vec3 es0 = sq_v3(-hx, -hy, h), es1 = sq_v3(hx, -hy, h);
                const sq_vec3 en0 = sq_v3(-hx, hy, h), en1 = sq_v3(hx, hy, h);
                const sq_vec3 r0 = sq_v3(-hx, 0.0f, t), r1 = sq_v3(hx, 0.0f, t);
                add_quad(&m, es0, es1, r1, r0, in);
                add_quad(&m, en0, en1, r1, r0, in);
                m.albedo = given ? o->albedo : sq_v3(0.70f, 0.64f, 0.54f);
                add_tri(&m, es0, en0, r0, in);
                add_tri(&m, es1, en1, r1, in);
            }
            break;
        }
        case SQ_OBSTACLE_FENCE:
            m.albedo = given ? o->albedo : sq_v3(0.42f, 0.32f, 0.20f); /* weathered wood */
            add_box(&m, hx, hy, h, true);
            break;
        default:
            m.albedo = given ? o->albedo : sq_v3(0.50f, 0.48f, 0.45f); /* concrete */
            add_box(&m, hx, hy, h, true);
            break;
        }
    }
    if (!r->obstacle_vao) {
        glCreateVertexArrays(1, &r->obstacle_vao);
        for (GLuint a = 0; a < 4; a++) {
            glEnableVertexArrayAttrib(r->obstacle_vao, a);
            glVertexArrayAttribFormat(r->obstacle_vao, a, 3, GL_FLOAT, GL_FALSE,
                                      a * 3 * (GLuint)sizeof(float));
            glVertexArrayAttribBinding(r->obstacle_vao, a, 0);
        }
    }
    glDeleteBuffers(1, &r->obstacle_vbo);
    r->obstacle_vbo = 0;
    if (m.n > 0) {
        glCreateBuffers(1, &r->obstacle_vbo);
        glNamedBufferStorage(r->obstacle_vbo, (GLsizeiptr)((size_t)m.n * sizeof(mesh_vertex)),
                             m.v, 0);
        glVertexArrayVertexBuffer(r->obstacle_vao, 0, r->obstacle_vbo, 0, sizeof(mesh_vertex));
    }
    r->obstacle_vertex_count = m.n;
    sq_free(ctx, m.v);
    return sq__gl_check(ctx, "obstacle mesh upload");
}

static sq_result update_world_cache(sq_renderer *r, const sq_world *w)
{
    struct sq__base_cache *b = r->base;
    if (b->has_world && b->world == w && r->world_generation == w->generation &&
        b->world_heights == w->heights && b->world_nx == w->nx && b->world_ny == w->ny)
        return SQ_OK;
    b->has_world = false;
    sq_result res = build_terrain(r, w);
    if (res == SQ_OK) res = build_obstacles(r, w);
    if (res != SQ_OK) return res;
    b->has_world = true;
    b->world = w;
    b->world_heights = w->heights;
    b->world_nx = w->nx;
    b->world_ny = w->ny;
    r->world_generation = w->generation;
    return SQ_OK;
}

/* ---- surfaces ----------------------------------------------------------------------------- */
static void surface_slot_free(surface_slot *s)
{
    glDeleteTextures(1, &s->height_tex);
    glDeleteTextures(1, &s->coverage_tex);
    memset(s, 0, sizeof *s);
}

static void upload_surface(sq_renderer *r, surface_slot *s, const sq_surface_view *v)
{
    if (s->height_tex && s->nx == v->nx && s->ny == v->ny && s->version == v->version &&
        s->height == v->height_m && s->coverage == v->coverage && s->has_coverage == !!v->coverage)
        return;
    if (!s->height_tex || s->nx != v->nx || s->ny != v->ny) {
        surface_slot_free(s);
        s->height_tex = sq__gl_texture_2d(GL_R32F, v->nx, v->ny, GL_NEAREST);
        s->coverage_tex = sq__gl_texture_2d(GL_R32F, v->nx, v->ny, GL_NEAREST);
        s->nx = v->nx;
        s->ny = v->ny;
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTextureSubImage2D(s->height_tex, 0, 0, 0, v->nx, v->ny, GL_RED, GL_FLOAT, v->height_m);
    if (v->coverage)
        glTextureSubImage2D(s->coverage_tex, 0, 0, 0, v->nx, v->ny, GL_RED, GL_FLOAT,
                            v->coverage);
    s->has_coverage = v->coverage != NULL;
    s->version = v->version;
    s->height = v->height_m;
    s->coverage = v->coverage;
    (void)r;
}

/* Every surface drawable's heights and coverage into its slot (the shadow cascades draw them
 * before the lit pass does). */
void sq__surfaces_upload(sq_renderer *r, const sq_drawable *ds, int count)
{
    int slot = 0;
    for (int i = 0; i < count && slot < SQ_MAX_SURFACES; i++)
        if (ds[i].kind == SQ_DRAWABLE_SURFACE) upload_surface(r, &r->base->surfaces[slot++], &ds[i].u.surface);
}

/* The grid's uniforms of program p (surface_grid.glsl) and its textures. */
static void bind_surface_grid(GLuint p, const surface_slot *s, const sq_surface_view *v)
{
    glProgramUniform2i(p, 0, v->nx, v->ny);
    glProgramUniform3f(p, 1, v->origin_m.x, v->origin_m.y, v->origin_m.z);
    glProgramUniform2f(p, 2, v->dx_m, v->dy_m);
    glProgramUniform1i(p, 3, s->has_coverage ? 1 : 0);
    glBindTextureUnit(1, s->height_tex);
    glBindTextureUnit(2, s->coverage_tex);
}

void sq__surfaces_draw_depth(sq_renderer *r, const sq_mat4 *view_proj, const sq_drawable *ds,
                             int count, unsigned mask)
{
    const GLuint p = r->prog_surface_depth;
    glProgramUniformMatrix4fv(p, 8, 1, GL_FALSE, view_proj->m);
    glUseProgram(p);
    glBindVertexArray(r->empty_vao);
    int slot = 0;
    for (int i = 0; i < count && slot < SQ_MAX_SURFACES; i++) {
        if (ds[i].kind != SQ_DRAWABLE_SURFACE) continue;
        const sq_surface_view *v = &ds[i].u.surface;
        surface_slot *s = &r->base->surfaces[slot];
        if (mask & (1u << slot)) {
            upload_surface(r, s, v);
            bind_surface_grid(p, s, v);
            glDrawArrays(GL_TRIANGLES, 0, (v->nx - 1) * (v->ny - 1) * 6);
        }
        slot++;
    }
}

static void draw_surface(sq_renderer *r, surface_slot *s, const sq_surface_view *v)
{
    upload_surface(r, s, v);
    sq_vec3 albedo = v->albedo;
    if (!(albedo.x > 0.0f || albedo.y > 0.0f || albedo.z > 0.0f))
        albedo = sq__material_albedo(v->material);
    const GLuint p = r->prog_surface;
    bind_surface_grid(p, s, v);
    glProgramUniform3f(p, 4, albedo.x, albedo.y, albedo.z);
    glProgramUniform1i(p, 5, (int)v->material);
    glUseProgram(p);
    glBindVertexArray(r->empty_vao);
    sq__render_triangles_in_parts(r, (v->nx - 1) * (v->ny - 1) * 6);
}

/* ---- frame ------------------------------------------------------------------------------ */
static void copy_mat(float *dst, const sq_mat4 *m) { memcpy(dst, m->m, sizeof m->m); }
static void copy_v4(float *dst, sq_vec3 v, float w)
{
    dst[0] = v.x;
    dst[1] = v.y;
    dst[2] = v.z;
    dst[3] = w;
}

static void upload_frame_block(sq_renderer *r, const sq_world *w)
{
    frame_block f;
    memset(&f, 0, sizeof f);
    copy_mat(f.view_proj, &r->view_proj);
    copy_mat(f.inv_view_proj, &r->inv_view_proj);
    copy_mat(f.view, &r->view);
    copy_mat(f.sun_shadow_matrix, &r->sun_shadow_matrix);
    copy_v4(f.cam_pos, r->cam_pos, (float)r->time_s);
    copy_v4(f.sun_dir, sq_v3_norm(w->sun_dir), r->sun_shadow_tex ? 1.0f : 0.0f);
    copy_v4(f.sun_radiance, w->sun_radiance, w->turbidity);
    copy_v4(f.sky_zenith, w->sky_zenith, r->near_m);
    copy_v4(f.sky_horizon, w->sky_horizon, r->far_m);
    copy_v4(f.ground_albedo, w->ground_albedo, (float)w->terrain_kind);
    f.viewport[0] = (float)r->width;
    f.viewport[1] = (float)r->height;
    f.viewport[2] = 1.0f / (float)r->width;
    f.viewport[3] = 1.0f / (float)r->height;
    f.params[0] = r->desc.exposure;
    f.params[1] = w->vertical_exaggeration > 0.0f ? 1.0f / w->vertical_exaggeration : 1.0f;
    glNamedBufferSubData(r->frame_ubo, 0, sizeof f, &f);
}

/* Binds what every base pass expects: HDR target, viewport, frame block, sun shadow. */
static void bind_scene_state(sq_renderer *r)
{
    glBindFramebuffer(GL_FRAMEBUFFER, r->hdr_fbo);
    glViewport(0, 0, r->width, r->height);
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, r->frame_ubo);
    glBindTextureUnit(7, r->sun_shadow_tex ? r->sun_shadow_tex : r->white_tex);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_STENCIL_TEST);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
}

static void pass_sky(sq_renderer *r)
{
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glUseProgram(r->prog_sky);
    glBindVertexArray(r->empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

/* Nearest first where it is cheap to know: the meshes (houses, trees in front of the ground), then
 * the obstacles, then the terrain, so that the depth test rejects hidden ground before its
 * (snow) shading runs. */
void sq__render_triangles_in_parts(sq_renderer *r, int vertices)
{
    const int tris = vertices / 3;
    const int per = (tris + SQ_RENDER_PARTS - 1) / SQ_RENDER_PARTS;
    for (int t = 0; t < tris; t += per) {
        const int n = tris - t < per ? tris - t : per;
        glDrawArrays(GL_TRIANGLES, 3 * t, 3 * n);
        if (sq__render_part_done(r)) return;
    }
}

static void pass_opaque(sq_renderer *r, const sq_world *w)
{
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    sq__mesh_pass_draw(r);
    if (r->obstacle_vertex_count > 0) {
        glUseProgram(r->snow_on ? r->prog_mesh_snow : r->prog_mesh);
        glBindVertexArray(r->obstacle_vao);
        glDrawArrays(GL_TRIANGLES, 0, r->obstacle_vertex_count);
    }
    if (r->terrain_index_count > 0) {
        sq_vec3 flat, steep;
        sq__terrain_albedo(w, &flat, &steep);
        const GLuint pt = r->snow_on ? r->prog_terrain_snow : r->prog_terrain;
        glProgramUniform3f(pt, 0, flat.x, flat.y, flat.z);
        glProgramUniform3f(pt, 1, steep.x, steep.y, steep.z);
        /* snow cover: rock from ~45-55 deg (snow holds on the 30-45 deg avalanche slopes), an
         * altitude snow line with meadow/scree below; other covers: rock from ~32-44 deg */
        const bool snow = w->terrain_material == SQ_GROUND_SNOW;
        glProgramUniform3f(pt, 2, 0.20f, 0.22f, 0.13f);
        glProgramUniform1f(pt, 3, snow ? w->snow_line_m : 0.0f);
        glProgramUniform2f(pt, 4, snow ? 0.57f : 0.72f, snow ? 0.70f : 0.85f);
        glUseProgram(pt);
        sq__terrain_draw(r, &r->view_proj, false);
    }
}

static void pass_surfaces(sq_renderer *r, const sq_drawable *ds, int count)
{
    int slot = 0;
    for (int i = 0; i < count; i++) {
        if (ds[i].kind != SQ_DRAWABLE_SURFACE) continue;
        if (slot == 0) {
            glEnable(GL_DEPTH_TEST);
            glDepthFunc(GL_LEQUAL);
            glDepthMask(GL_TRUE);
            /* drawn over the terrain it lies on: pull it toward the camera in depth */
            glEnable(GL_POLYGON_OFFSET_FILL);
            glPolygonOffset(-1.0f, -4.0f);
            glEnable(GL_BLEND);
            glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
        }
        draw_surface(r, &r->base->surfaces[slot], &ds[i].u.surface);
        slot++;
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    glDisable(GL_BLEND);
    glDepthFunc(GL_LESS);
}

static void pass_tonemap(sq_renderer *r)
{
    glBindFramebuffer(GL_FRAMEBUFFER, r->ldr_fbo);
    glViewport(0, 0, r->width, r->height);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glDepthMask(GL_FALSE);
    glProgramUniform1f(r->prog_tonemap, 0, r->desc.exposure);
    glUseProgram(r->prog_tonemap);
    glBindTextureUnit(0, r->hdr_color);
    glBindVertexArray(r->empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
}

/* The frame into hdr_fbo. world_geometry: clear, then sky, terrain and obstacles; otherwise
 * hdr_fbo already holds the caller's colour and depth and only drawables are added. */
/* The context's interrupt (Ctrl-C) or the caller's own (sq_render_desc.cancel). */
static bool interrupt_asked(const sq_renderer *r)
{
    return sq__cancelled(r->ctx) || (r->desc.cancel && r->desc.cancel(r->desc.cancel_user));
}

bool sq__render_cancelled(sq_renderer *r)
{
    if (!r->cancelled && interrupt_asked(r)) r->cancelled = true;
    return r->cancelled;
}

static void drop_part_fence(sq_renderer *r)
{
    if (r->part_fence) glDeleteSync(r->part_fence);
    r->part_fence = NULL;
}

bool sq__render_part_done(sq_renderer *r)
{
    GLsync issued = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    glFlush();
    /* the part before: waited for in steps of 20 ms, polling Ctrl-C between them */
    while (r->part_fence && !sq__render_cancelled(r)) {
        const GLenum w = glClientWaitSync(r->part_fence, 0, 20u * 1000u * 1000u);
        if (w != GL_TIMEOUT_EXPIRED) break; /* signalled, or an error: do not wait forever */
    }
    drop_part_fence(r);
    r->part_fence = issued;
    return sq__render_cancelled(r);
}

static sq_result frame_cancelled(sq_renderer *r)
{
    return sq__fail_cancelled(r->ctx, "render", "while drawing a frame");
}

static sq_result draw_passes(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                             const sq_drawable *drawables, int count, double time_s,
                             bool world_geometry)
{
    sq_context *ctx = r->ctx;
    sq_result res = setup_camera(r, camera);
    if (res != SQ_OK) return res;
    if (world_geometry && (res = check_camera_above_terrain(r, world)) != SQ_OK) return res;
    if ((res = check_drawables(r, drawables, count)) != SQ_OK) return res;
    if (world_geometry && (res = update_world_cache(r, world)) != SQ_OK) return res;
    if (world_geometry && (res = sq__mesh_pass_update(r, world)) != SQ_OK) return res;
    r->world = world;
    r->time_s = time_s;
    r->cancelled = false;
    /* Ctrl-C: polled between the passes and between the draw calls of the long ones */
    if (sq__render_cancelled(r)) return frame_cancelled(r);

    (void)sq__mesh_pass_stats(r, true);
    memset(&r->stats, 0, sizeof r->stats);
    r->terrain_faces = 0;
    r->shell_max_m = 0.0f; /* the snow pass sets it for the camera's shell */
    /* volume light passes first: the opaque passes are shadowed by their light buffer */
    r->sun_shadow_tex = 0;
    r->sun_shadow_matrix = sq_m4_identity();
    glBindBufferBase(GL_UNIFORM_BUFFER, 0, r->frame_ubo);
    upload_frame_block(r, world);
    for (int i = 0; i < count; i++) {
        if (drawables[i].kind != SQ_DRAWABLE_VOLUME) continue;
        if ((res = sq__volume_pass_prepare_shadow(r, &drawables[i].u.volume)) != SQ_OK)
            return res;
        if (sq__render_cancelled(r)) return frame_cancelled(r);
    }
    for (int i = 0; i < count; i++)
        if (drawables[i].kind == SQ_DRAWABLE_CLOUDS &&
            (res = sq__clouds_pass_prepare(r, &drawables[i].u.clouds)) != SQ_OK)
            return res;
    if (sq__render_cancelled(r)) return frame_cancelled(r);
    upload_frame_block(r, world); /* with the sun shadow, if any */
    /* opaque sun shadows of the world's geometry (none when only drawables are added over the
     * caller's picture: its geometry is not known) */
    if (world_geometry) sq__surfaces_upload(r, drawables, count);
    if ((res = sq__shadow_pass_prepare(r, world, world_geometry, drawables, count)) != SQ_OK)
        return res;
    if (sq__render_cancelled(r)) return frame_cancelled(r);
    /* snow lying on the world's surfaces: the occlusion map for this view */
    const sq_snow_cover_view *snow = NULL;
    for (int i = 0; i < count && world_geometry; i++)
        if (drawables[i].kind == SQ_DRAWABLE_SNOW_COVER && !snow) snow = &drawables[i].u.snow_cover;
    if ((res = sq__snow_pass_prepare(r, world, snow)) != SQ_OK) return res;
    if (sq__render_cancelled(r)) return frame_cancelled(r);

    bind_scene_state(r);
    glDepthMask(GL_TRUE);
    if (world_geometry) {
        const float clear_color[4] = {0.0f, 0.0f, 0.0f, 1.0f};
        const float clear_depth = 1.0f;
        glClearNamedFramebufferfv(r->hdr_fbo, GL_COLOR, 0, clear_color);
        glClearNamedFramebufferfv(r->hdr_fbo, GL_DEPTH, 0, &clear_depth);
        pass_sky(r);
        const sq__mesh_stats before = sq__mesh_pass_stats(r, false);
        const int64_t terrain_before = r->terrain_faces;
        pass_opaque(r, world);
        r->stats.camera_terrain_faces = r->terrain_faces - terrain_before;
        const sq__mesh_stats after = sq__mesh_pass_stats(r, false);
        r->stats.camera_faces = after.faces - before.faces;
        r->stats.camera_instances = after.instances - before.instances;
    }
    pass_surfaces(r, drawables, count);
    if ((res = sq__gl_check(ctx, "the opaque passes (sky, terrain, obstacles, surfaces)")) != SQ_OK)
        return res;
    if (sq__render_cancelled(r)) return frame_cancelled(r);

    for (int i = 0; i < count; i++) {
        if (drawables[i].kind != SQ_DRAWABLE_VOLUME) continue;
        bind_scene_state(r);
        if ((res = sq__volume_pass_draw(r, &drawables[i].u.volume)) != SQ_OK) return res;
        if (sq__render_cancelled(r)) return frame_cancelled(r);
    }
    for (int i = 0; i < count; i++) {
        if (drawables[i].kind != SQ_DRAWABLE_PARTICLES) continue;
        bind_scene_state(r);
        if ((res = sq__particle_pass_draw(r, &drawables[i].u.particles)) != SQ_OK) return res;
        if (sq__render_cancelled(r)) return frame_cancelled(r);
    }
    sq__clouds_pass_stats cs0, cs1;
    sq__clouds_pass_get_stats(r, &cs0);
    for (int i = 0; i < count; i++) {
        if (drawables[i].kind != SQ_DRAWABLE_CLOUDS) continue;
        bind_scene_state(r);
        if ((res = sq__clouds_pass_draw(r, &drawables[i].u.clouds)) != SQ_OK) return res;
        if (sq__render_cancelled(r)) return frame_cancelled(r);
    }
    sq__clouds_pass_get_stats(r, &cs1);
    r->stats.cloud_impostors_rendered = (int)(cs1.impostor_renders - cs0.impostor_renders);
    const sq__mesh_stats all = sq__mesh_pass_stats(r, false);
    r->stats.faces = all.faces;
    r->stats.instances = all.instances;
    r->stats.ms_shadow = sq__shadow_pass_ms(r);
    r->stats.shadow_cascades_drawn = sq__shadow_pass_drawn(r);
    r->stats.terrain_faces = r->terrain_faces;
    r->stats.ms_occlusion_map = sq__snow_pass_ms(r);
    r->stats.cpu_ms_occlusion_map = sq__snow_pass_cpu_ms(r);
    return SQ_OK;
}

static sq_result draw_frame(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                            const sq_drawable *drawables, int count, double time_s,
                            bool world_geometry)
{
    const sq_result res = draw_passes(r, world, camera, drawables, count, time_s, world_geometry);
    drop_part_fence(r); /* the frame's end waits for everything anyway (read-back, swap) */
    return res;
}

sq_result sq_renderer_stats(const sq_renderer *r, sq_render_stats *out)
{
    if (!r || !out)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, "render", "sq_renderer_stats: %s is NULL",
                        r ? "out" : "renderer");
    *out = r->stats;
    return SQ_OK;
}

/* GL calls of a renderer start here: its own context made current, or (use_current_context)
 * the caller's context checked and its state saved and neutralised (gl_state.c). */
static sq_result gl_enter(sq_renderer *r, sq__gl_state *saved)
{
    if (r->gl) return sq__gl_context_make_current(r->gl);
    if (!glGetString(GL_VERSION))
        return sq__fail(r->ctx, SQ_ERR_GL, "render",
                        "no OpenGL context is current on this thread; a renderer created with "
                        "use_current_context needs its creator's context current on every call");
    for (int i = 0; i < 64 && glGetError() != GL_NO_ERROR; i++) {} /* the caller's, not ours */
    sq__gl_state_save(saved);
    sq__gl_state_neutral();
    return SQ_OK;
}

static void gl_leave(sq_renderer *r, const sq__gl_state *saved)
{
    if (!r->gl) sq__gl_state_restore(saved);
}

sq_result sq_renderer_draw(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                           const sq_drawable *drawables, int count, double time_s)
{
    if (!r) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "render", "sq_renderer_draw: renderer is NULL");
    sq_context *ctx = r->ctx;
    if (!world || !camera)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "sq_renderer_draw: %s is NULL",
                        world ? "camera" : "world");
    if (count < 0 || (count > 0 && !drawables))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_renderer_draw: count = %d with drawables %s", count,
                        drawables ? "set" : "NULL");
    sq__gl_state saved;
    sq_result res = gl_enter(r, &saved);
    if (res != SQ_OK) return res;
    if (r->width != r->desc.width || r->height != r->desc.height || r->depth_format != GL_DEPTH_COMPONENT32F)
        res = resize_targets(r, r->desc.width, r->desc.height, GL_DEPTH_COMPONENT32F);
    if (res == SQ_OK) res = draw_frame(r, world, camera, drawables, count, time_s, true);
    if (res == SQ_OK) {
        pass_tonemap(r);
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        res = sq__gl_check(ctx, "the frame (volumes, particles, tone mapping)");
    }
    if (res == SQ_OK) r->base->frames++;
    gl_leave(r, &saved);
    return res;
}

/* ---- drawing into the caller's framebuffer ------------------------------------------------- */
/* Depth (and stencil) format of the target's depth buffer, as a sized internal format a texture
 * can have, so that blits between the two match; 0 with *none set when it has no depth. */
static sq_result target_depth_format(sq_renderer *r, GLuint fbo, GLenum *format)
{
    const GLenum da = fbo ? GL_DEPTH_ATTACHMENT : GL_DEPTH;
    const GLenum sa = fbo ? GL_STENCIL_ATTACHMENT : GL_STENCIL;
    GLint type = GL_NONE, bits = 0, comp = 0, stencil = 0;
    *format = 0;
    glGetNamedFramebufferAttachmentParameteriv(fbo, da, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                               &type);
    if (type == GL_NONE) return SQ_OK;
    glGetNamedFramebufferAttachmentParameteriv(fbo, da, GL_FRAMEBUFFER_ATTACHMENT_DEPTH_SIZE,
                                               &bits);
    glGetNamedFramebufferAttachmentParameteriv(fbo, da,
                                               GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &comp);
    GLint stype = GL_NONE;
    glGetNamedFramebufferAttachmentParameteriv(fbo, sa, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                               &stype);
    if (stype != GL_NONE)
        glGetNamedFramebufferAttachmentParameteriv(
            fbo, sa, GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE, &stencil);
    if (comp == GL_FLOAT && bits == 32) *format = stencil ? GL_DEPTH32F_STENCIL8 : GL_DEPTH_COMPONENT32F;
    else if (bits == 24) *format = stencil ? GL_DEPTH24_STENCIL8 : GL_DEPTH_COMPONENT24;
    else if (bits == 16 && !stencil) *format = GL_DEPTH_COMPONENT16;
    else if (bits == 32 && !stencil) *format = GL_DEPTH_COMPONENT32;
    if (!*format)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u: depth buffer of %d bits (%s) with %d "
                        "stencil bits; supported: 16, 24, 32 or 32-bit float depth, 24 or 32F "
                        "with 8 stencil bits",
                        fbo, (int)bits, comp == GL_FLOAT ? "float" : "normalised", (int)stencil);
    return SQ_OK;
}

static sq_result check_target(sq_renderer *r, const sq_render_target *t, GLenum *depth_format)
{
    sq_context *ctx = r->ctx;
    if (t->width < 1 || t->height < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.width x height = %d x %d; both must be >= 1",
                        t->width, t->height);
    if ((int)t->content < 0 || (int)t->content > SQ_TARGET_DRAWABLES_OVER)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.content = %d; must be SQ_TARGET_FRAME (0) or "
                        "SQ_TARGET_DRAWABLES_OVER (1)", (int)t->content);
    if ((int)t->colour < 0 || (int)t->colour > SQ_TARGET_DISPLAY)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.colour = %d; must be SQ_TARGET_LINEAR (0) or "
                        "SQ_TARGET_DISPLAY (1)", (int)t->colour);
    sq_result res = check_size(r, t->width, t->height, "sq_render_target");
    if (res != SQ_OK) return res;
    const GLuint fbo = t->framebuffer;
    if (fbo && !glIsFramebuffer(fbo))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer = %u is not a framebuffer object of the "
                        "current context", fbo);
    const GLenum status = glCheckNamedFramebufferStatus(fbo, GL_DRAW_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u is incomplete (status 0x%04x)", fbo,
                        (unsigned)status);
    /* bound for the queries of bound-framebuffer state (the caller's bindings are restored) */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    GLint samples = 0;
    glGetIntegerv(GL_SAMPLE_BUFFERS, &samples);
    if (samples != 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u is multisampled; draw into a "
                        "single-sample framebuffer (resolve yours first)", fbo);
    GLint read_buf = GL_NONE;
    glGetIntegerv(GL_READ_BUFFER, &read_buf);
    GLint ctype = GL_NONE, cenc = GL_LINEAR, ccomp = GL_NONE;
    if (read_buf != GL_NONE) {
        GLenum ca = (GLenum)read_buf; /* the default framebuffer names its buffers by side */
        if (ca == GL_BACK) ca = GL_BACK_LEFT;
        else if (ca == GL_FRONT) ca = GL_FRONT_LEFT;
        glGetNamedFramebufferAttachmentParameteriv(fbo, ca, GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE,
                                                   &ctype);
        if (ctype != GL_NONE) {
            glGetNamedFramebufferAttachmentParameteriv(
                fbo, ca, GL_FRAMEBUFFER_ATTACHMENT_COMPONENT_TYPE, &ccomp);
            glGetNamedFramebufferAttachmentParameteriv(
                fbo, ca, GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &cenc);
        }
    }
    if (ctype == GL_NONE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u has no colour buffer to read (read "
                        "buffer 0x%04x)", fbo, (unsigned)read_buf);
    if (ccomp == GL_INT || ccomp == GL_UNSIGNED_INT)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u has an integer colour buffer; need a "
                        "float or normalised format", fbo);
    if (cenc == GL_SRGB && t->colour == SQ_TARGET_LINEAR)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u has an sRGB-encoded colour buffer with "
                        "colour = SQ_TARGET_LINEAR; use SQ_TARGET_DISPLAY or a linear format", fbo);
    if ((res = target_depth_format(r, fbo, depth_format)) != SQ_OK) return res;
    if (!*depth_format && t->content == SQ_TARGET_DRAWABLES_OVER)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_target.framebuffer %u has no depth buffer; "
                        "SQ_TARGET_DRAWABLES_OVER tests drawables against the target's depth",
                        fbo);
    return SQ_OK;
}

/* Fullscreen pass reading unit 0 into the bound draw framebuffer's colour (rgb only). */
static void fullscreen(GLuint prog, GLuint tex, int w, int h)
{
    glViewport(0, 0, w, h);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glDepthMask(GL_FALSE);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_FALSE);
    glUseProgram(prog);
    glBindTextureUnit(0, tex);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
}

static sq_result draw_to(sq_renderer *r, const sq_render_target *t, GLenum depth_format,
                         const sq_world *world, const sq_camera *camera,
                         const sq_drawable *drawables, int count, double time_s)
{
    sq_context *ctx = r->ctx;
    const int w = t->width, h = t->height;
    const GLuint fbo = t->framebuffer;
    const bool over = t->content == SQ_TARGET_DRAWABLES_OVER;
    const bool display = t->colour == SQ_TARGET_DISPLAY;
    sq_result res = SQ_OK;
    const GLenum fmt = depth_format ? depth_format : GL_DEPTH_COMPONENT32F;
    if (r->width != w || r->height != h || r->depth_format != fmt)
        res = resize_targets(r, w, h, fmt);
    if (res == SQ_OK && !r->prog_target)
        res = sq__gl_program(ctx, "fullscreen.vert", NULL, "target.frag", &r->prog_target);
    if (res != SQ_OK) return res;
    r->base->frames = 0; /* the read-back functions serve sq_renderer_draw frames only */
    glBindVertexArray(r->empty_vao);
    if (over) { /* the caller's colour (as linear radiance) and depth into hdr_fbo */
        if (display) {
            glBlitNamedFramebuffer(fbo, r->ldr_fbo, 0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT,
                                   GL_NEAREST);
            glBindFramebuffer(GL_DRAW_FRAMEBUFFER, r->hdr_fbo);
            glProgramUniform1i(r->prog_target, 0, 1);
            glProgramUniform1f(r->prog_target, 1, r->desc.exposure);
            fullscreen(r->prog_target, r->ldr_color, w, h);
        } else {
            glBlitNamedFramebuffer(fbo, r->hdr_fbo, 0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT,
                                   GL_NEAREST);
        }
        glBlitNamedFramebuffer(fbo, r->hdr_fbo, 0, 0, w, h, 0, 0, w, h, GL_DEPTH_BUFFER_BIT,
                               GL_NEAREST);
        if ((res = sq__gl_check(ctx, "reading the target's colour and depth")) != SQ_OK)
            return res;
    }
    res = draw_frame(r, world, camera, drawables, count, time_s, !over);
    if (res != SQ_OK) return res;
    /* the result back into the caller's colour (and depth where it changed) */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo);
    glBindVertexArray(r->empty_vao);
    if (display) {
        glProgramUniform1f(r->prog_tonemap, 0, r->desc.exposure);
        fullscreen(r->prog_tonemap, r->hdr_color, w, h);
    } else {
        glProgramUniform1i(r->prog_target, 0, 0);
        fullscreen(r->prog_target, r->hdr_color, w, h);
    }
    bool surfaces = false;
    for (int i = 0; i < count; i++) surfaces |= drawables[i].kind == SQ_DRAWABLE_SURFACE;
    if (depth_format && (!over || surfaces))
        glBlitNamedFramebuffer(r->hdr_fbo, fbo, 0, 0, w, h, 0, 0, w, h, GL_DEPTH_BUFFER_BIT,
                               GL_NEAREST);
    return sq__gl_check(ctx, "writing the frame into the target");
}

sq_result sq_renderer_draw_to(sq_renderer *r, const sq_render_target *target,
                              const sq_world *world, const sq_camera *camera,
                              const sq_drawable *drawables, int count, double time_s)
{
    if (!r)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, "render", "sq_renderer_draw_to: renderer is NULL");
    sq_context *ctx = r->ctx;
    if (r->gl)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_renderer_draw_to: the renderer has its own EGL context; create it "
                        "with sq_render_desc.use_current_context to draw into your framebuffer");
    if (!target || !world || !camera)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "sq_renderer_draw_to: %s is NULL",
                        !target ? "target" : !world ? "world" : "camera");
    if (count < 0 || (count > 0 && !drawables))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_renderer_draw_to: count = %d with drawables %s", count,
                        drawables ? "set" : "NULL");
    sq__gl_state saved;
    sq_result res = gl_enter(r, &saved);
    if (res != SQ_OK) return res;
    GLenum depth_format = 0;
    res = check_target(r, target, &depth_format);
    if (res == SQ_OK)
        res = draw_to(r, target, depth_format, world, camera, drawables, count, time_s);
    gl_leave(r, &saved);
    return res;
}

/* ---- read-back ------------------------------------------------------------------------- */
/* Reverses the order of rows (GL's first row is the bottom one). */
static sq_result flip_rows(sq_context *ctx, void *data, size_t row_bytes, int rows)
{
    unsigned char *tmp = sq_alloc(ctx, row_bytes);
    if (!tmp) return SQ_ERR_OUT_OF_MEMORY;
    unsigned char *p = data;
    for (int y = 0; y < rows / 2; y++) {
        unsigned char *a = p + (size_t)y * row_bytes;
        unsigned char *b = p + (size_t)(rows - 1 - y) * row_bytes;
        memcpy(tmp, a, row_bytes);
        memcpy(a, b, row_bytes);
        memcpy(b, tmp, row_bytes);
    }
    sq_free(ctx, tmp);
    return SQ_OK;
}

static sq_result read_prepare(sq_renderer *r, const void *out, const char *what)
{
    if (!r) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "render", "%s: renderer is NULL", what);
    if (!out) return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render", "%s: output is NULL", what);
    if (r->base->frames == 0)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "%s: no frame drawn yet (call sq_renderer_draw first)", what);
    return SQ_OK;
}

/* Reads the colour of fbo (pixels of the frame size) into out, rows top first. */
static sq_result read_frame(sq_renderer *r, GLuint fbo, GLenum format, GLenum type, int channels,
                            size_t channel_bytes, void *out, const char *what)
{
    sq_result res = read_prepare(r, out, what);
    if (res != SQ_OK) return res;
    sq__gl_state saved;
    if ((res = gl_enter(r, &saved)) != SQ_OK) return res;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, r->width, r->height, format, type, out);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
    res = sq__gl_check(r->ctx, what);
    gl_leave(r, &saved);
    if (res != SQ_OK) return res;
    return flip_rows(r->ctx, out, (size_t)r->width * (size_t)channels * channel_bytes, r->height);
}

sq_result sq_renderer_read_rgba8(sq_renderer *r, uint8_t *rgba)
{
    return read_frame(r, r ? r->ldr_fbo : 0, GL_RGBA, GL_UNSIGNED_BYTE, 4, 1, rgba,
                      "sq_renderer_read_rgba8");
}

sq_result sq_renderer_read_linear(sq_renderer *r, float *rgb)
{
    return read_frame(r, r ? r->hdr_fbo : 0, GL_RGB, GL_FLOAT, 3, sizeof(float), rgb,
                      "sq_renderer_read_linear");
}

/* ---- lifecycle -------------------------------------------------------------------------- */
static sq_result resolve_desc(sq_context *ctx, const sq_render_desc *in, sq_render_desc *out)
{
    sq_render_desc d;
    if (in) d = *in;
    else memset(&d, 0, sizeof d);
    if (d.width == 0 && d.height == 0) {
        d.width = 640;
        d.height = 360;
    } else if (d.width < 1 || d.height < 1) {
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "frame size %d x %d; width and height must both be >= 1 (or both 0 for "
                        "the default 640 x 360)",
                        d.width, d.height);
    }
    if (d.exposure == 0.0f) d.exposure = 1.0f;
    if (!(d.exposure > 0.0f) || !isfinite(d.exposure))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "exposure = %g; must be finite and > 0 (0 -> 1)", (double)d.exposure);
    if (d.volume_slices == 0) d.volume_slices = 128;
    if (d.volume_octaves == 0) d.volume_octaves = 3;
    if (d.volume_octaves < 1 || d.volume_octaves > 8)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume_octaves = %d; must be in 1..8 (0 -> 3)", d.volume_octaves);
    if (d.volume_ms == SQ_VOLUME_MS_DEFAULT) d.volume_ms = SQ_VOLUME_MS_DIFFUSION;
    if ((int)d.volume_ms < SQ_VOLUME_MS_DIFFUSION || (int)d.volume_ms > SQ_VOLUME_MS_NONE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume_ms = %d; must be 0 (diffusion), 1 (diffusion), 2 (octaves) or 3 "
                        "(none)",
                        (int)d.volume_ms);
    if (d.volume_slices < 1 || d.volume_slices > 4096)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume_slices = %d; must be in 1..4096 (0 -> 128)", d.volume_slices);
    if (d.shadow_map_size == 0) d.shadow_map_size = 2048;
    if (d.shadow_cascades == 0) d.shadow_cascades = 3;
    if (d.shadow_distance_m == 0.0f) d.shadow_distance_m = 1500.0f;
    if (d.lod_pixels == 0.0f) d.lod_pixels = 1.0f;
    if (d.cull_pixels == 0.0f) d.cull_pixels = 0.5f;
    if (!(d.lod_pixels > 0.0f && d.lod_pixels <= 1000.0f && d.cull_pixels > 0.0f &&
          d.cull_pixels <= 1000.0f && d.mesh_distance_m >= 0.0f && isfinite(d.mesh_distance_m)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "sq_render_desc: lod_pixels %g, cull_pixels %g, mesh_distance_m %g; need "
                        "0 < pixels <= 1000 and a distance >= 0",
                        (double)d.lod_pixels, (double)d.cull_pixels, (double)d.mesh_distance_m);
    if (d.shadow_map_size < 16 || d.shadow_map_size > 16384 || d.shadow_cascades < 1 ||
        d.shadow_cascades > 4 || !(d.shadow_distance_m > 0.0f) || !isfinite(d.shadow_distance_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "shadow map %d px x %d cascades up to %g m; need 16..16384 px, 1..4 "
                        "cascades and a distance > 0 (0 -> 2048, 3, 1500)",
                        d.shadow_map_size, d.shadow_cascades, (double)d.shadow_distance_m);
    if (d.light_buffer_size == 0) d.light_buffer_size = 256;
    if (d.light_buffer_size < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "light_buffer_size = %d; must be >= 1 (0 -> 256)", d.light_buffer_size);
    *out = d;
    return SQ_OK;
}

/* The smallest of the implementation limits that bound one side of the frame. */
static void side_limit(const sq_render_info *in, int axis, int *value, const char **name)
{
    *value = in->max_texture_size;
    *name = "GL_MAX_TEXTURE_SIZE";
    if (in->max_renderbuffer_size > 0 && in->max_renderbuffer_size < *value) {
        *value = in->max_renderbuffer_size;
        *name = "GL_MAX_RENDERBUFFER_SIZE";
    }
    const int vp = in->max_viewport[axis];
    if (vp > 0 && vp < *value) {
        *value = vp;
        *name = axis == 0 ? "GL_MAX_VIEWPORT_DIMS (width)" : "GL_MAX_VIEWPORT_DIMS (height)";
    }
}

/* Refuses a frame larger than the GL implementation allows; what names it in messages. */
static sq_result check_size(sq_renderer *r, int width, int height, const char *what)
{
    const sq_render_info *in = &r->info;
    const int size[2] = {width, height};
    const char *side[2] = {"width", "height"};
    for (int axis = 0; axis < 2; axis++) {
        int limit;
        const char *name;
        side_limit(in, axis, &limit, &name);
        if (limit > 0 && size[axis] > limit)
            return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                            "%s %s = %d exceeds %s = %d of %s; render at most %d pixels "
                            "per side",
                            what, side[axis], size[axis], name, limit, in->gl_renderer, limit);
    }
    return SQ_OK;
}

/* Refuses a frame or light buffer larger than the GL implementation allows. */
static sq_result check_limits(sq_renderer *r)
{
    const sq_render_info *in = &r->info;
    sq_result res = check_size(r, r->desc.width, r->desc.height, "frame");
    if (res != SQ_OK) return res;
    if (in->max_texture_size > 0 && r->desc.light_buffer_size > in->max_texture_size)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "light_buffer_size = %d exceeds GL_MAX_TEXTURE_SIZE = %d of %s",
                        r->desc.light_buffer_size, in->max_texture_size, in->gl_renderer);
    return SQ_OK;
}

/* (Re)creates the frame buffers at w x h with depth_format (DEPTH_COMPONENT32F for the
 * renderer's own frames; the target's format for sq_renderer_draw_to, so blits match). The new
 * textures are made before the old ones are deleted, so their names differ from the old ones
 * (the passes keep framebuffers of their own around hdr_color and recognise it by name). */
static sq_result resize_targets(sq_renderer *r, int w, int h, GLenum depth_format)
{
    const GLuint old[3] = {r->hdr_color, r->depth_tex, r->ldr_color};
    r->hdr_color = sq__gl_texture_2d(GL_RGBA16F, w, h, GL_NEAREST);
    r->depth_tex = sq__gl_texture_2d(depth_format, w, h, GL_NEAREST);
    r->ldr_color = sq__gl_texture_2d(GL_RGBA8, w, h, GL_NEAREST);
    glDeleteTextures(3, old);
    const bool stencil = depth_format == GL_DEPTH24_STENCIL8 || depth_format == GL_DEPTH32F_STENCIL8;
    if (!r->hdr_fbo) glCreateFramebuffers(1, &r->hdr_fbo);
    if (!r->ldr_fbo) glCreateFramebuffers(1, &r->ldr_fbo);
    glNamedFramebufferTexture(r->hdr_fbo, GL_COLOR_ATTACHMENT0, r->hdr_color, 0);
    glNamedFramebufferTexture(r->hdr_fbo, GL_DEPTH_STENCIL_ATTACHMENT, 0, 0);
    glNamedFramebufferTexture(r->hdr_fbo, stencil ? GL_DEPTH_STENCIL_ATTACHMENT : GL_DEPTH_ATTACHMENT,
                              r->depth_tex, 0);
    glNamedFramebufferTexture(r->ldr_fbo, GL_COLOR_ATTACHMENT0, r->ldr_color, 0);
    r->width = w;
    r->height = h;
    r->depth_format = depth_format;
    sq_result res = sq__gl_check(r->ctx, "frame buffer creation");
    if (res == SQ_OK) res = sq__gl_check_framebuffer(r->ctx, r->hdr_fbo, "HDR (RGBA16F + depth)");
    if (res == SQ_OK) res = sq__gl_check_framebuffer(r->ctx, r->ldr_fbo, "LDR (RGBA8)");
    return res;
}

static sq_result create_targets(sq_renderer *r)
{
    sq_result res = resize_targets(r, r->width, r->height, GL_DEPTH_COMPONENT32F);
    if (res != SQ_OK) return res;
    glCreateVertexArrays(1, &r->empty_vao);
    glCreateBuffers(1, &r->frame_ubo);
    glNamedBufferStorage(r->frame_ubo, sizeof(frame_block), NULL, GL_DYNAMIC_STORAGE_BIT);
    const uint8_t white[4] = {255, 255, 255, 255};
    glCreateTextures(GL_TEXTURE_2D, 1, &r->white_tex);
    glTextureStorage2D(r->white_tex, 1, GL_RGBA8, 1, 1);
    glTextureSubImage2D(r->white_tex, 0, 0, 0, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, white);
    return sq__gl_check(r->ctx, "renderer resources");
}

static sq_result create_programs(sq_renderer *r)
{
    sq_context *ctx = r->ctx;
    sq_result res = sq__gl_program(ctx, "fullscreen.vert", NULL, "sky.frag", &r->prog_sky);
    if (res == SQ_OK)
        res = sq__gl_program_defs(ctx, "terrain.vert", NULL, "terrain.frag",
                                  "#define SQ_NO_SNOW 1", &r->prog_terrain);
    if (res == SQ_OK)
        res = sq__gl_program_defs(ctx, "mesh.vert", NULL, "mesh.frag", "#define SQ_NO_SNOW 1",
                                  &r->prog_mesh);
    if (res == SQ_OK)
        res = sq__gl_program(ctx, "surface.vert", NULL, "surface.frag", &r->prog_surface);
    if (res == SQ_OK)
        res = sq__gl_program(ctx, "depth_surface.vert", NULL, "depth.frag", &r->prog_surface_depth);
    if (res == SQ_OK)
        res = sq__gl_program(ctx, "fullscreen.vert", NULL, "tonemap.frag", &r->prog_tonemap);
    return res;
}

sq_result sq__snow_programs(sq_renderer *r)
{
    sq_result res = SQ_OK;
    if (!r->prog_terrain_snow)
        res = sq__gl_program(r->ctx, "terrain.vert", NULL, "terrain.frag", &r->prog_terrain_snow);
    if (res == SQ_OK && !r->prog_mesh_snow)
        res = sq__gl_program(r->ctx, "mesh.vert", NULL, "mesh.frag", &r->prog_mesh_snow);
    if (res == SQ_OK && r->meshes) res = sq__mesh_pass_snow_programs(r);
    return res;
}

/* use_current_context: a desktop OpenGL 4.5 context must be current on this thread. */
static sq_result check_current_context(sq_context *ctx)
{
    if (!glGetString(GL_VERSION))
        return sq__fail(ctx, SQ_ERR_GL, "render",
                        "sq_render_desc.use_current_context is set but no OpenGL context is "
                        "current on this thread; make your context current first");
    GLint major = 0, minor = 0, profile = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    glGetIntegerv(GL_MINOR_VERSION, &minor);
    glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
    if (!epoxy_is_desktop_gl() || major * 10 + minor < 45)
        return sq__fail(ctx, SQ_ERR_GL, "render",
                        "the current context is %s %d.%d (%s); the renderer needs desktop "
                        "OpenGL 4.5 (core or compatibility profile)",
                        epoxy_is_desktop_gl() ? "OpenGL" : "OpenGL ES", (int)major, (int)minor,
                        (const char *)glGetString(GL_VERSION));
    (void)profile;
    return SQ_OK;
}

static sq_result creation_poll(sq_renderer *r)
{
    return interrupt_asked(r)
               ? sq__fail_cancelled(r->ctx, "render", "while compiling the renderer's shaders")
               : SQ_OK;
}

sq_result sq_renderer_create(sq_context *ctx, const sq_render_desc *desc, sq_renderer **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "sq_renderer_create: out is NULL");
    *out = NULL;
    sq_render_desc d;
    sq_result res = resolve_desc(ctx, desc, &d);
    if (res != SQ_OK) return res;
    sq_renderer *r = sq_alloc_zero(ctx, sizeof *r);
    if (!r) return SQ_ERR_OUT_OF_MEMORY;
    r->ctx = ctx;
    r->desc = d;
    r->desc.egl_device = NULL; /* borrowed for this call only */
    r->width = d.width;
    r->height = d.height;
    r->external = d.use_current_context;
    r->sun_shadow_matrix = sq_m4_identity();
    r->base = sq_alloc_zero(ctx, sizeof *r->base);
    if (!r->base) {
        sq_renderer_destroy(r);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    sq__gl_state saved;
    if (d.use_current_context) res = check_current_context(ctx);
    else res = sq__gl_context_create(ctx, d.egl_device, &r->gl);
    if (res == SQ_OK) res = gl_enter(r, &saved);
    if (res == SQ_OK) {
        sq__gl_query_info(&r->info);
        res = check_limits(r);
        if (res == SQ_OK) res = create_targets(r);
        /* compiling the passes' programs takes seconds on llvmpipe: Ctrl-C between them */
        sq_result (*const create[])(sq_renderer *) = {
            create_programs, sq__volume_pass_create, sq__particle_pass_create,
            sq__clouds_pass_create, sq__mesh_pass_create, sq__shadow_pass_create,
            sq__snow_pass_create};
        for (size_t i = 0; i < sizeof create / sizeof create[0] && res == SQ_OK; i++) {
            if (i > 0) res = creation_poll(r);
            if (res == SQ_OK) res = create[i](r);
        }
        if (res == SQ_OK) res = sq__gl_check(ctx, "renderer creation");
        gl_leave(r, &saved);
    }
    if (res != SQ_OK) {
        sq_renderer_destroy(r);
        return res;
    }
    sq_log(ctx, SQ_LOG_DEBUG, "render", "renderer %dx%d on %s (%s)", r->width, r->height,
           r->info.gl_renderer, r->info.gl_version);
    *out = r;
    return SQ_OK;
}

void sq_renderer_destroy(sq_renderer *r)
{
    if (!r) return;
    sq_context *ctx = r->ctx;
    sq__gl_state saved;
    if ((r->gl || r->external) && gl_enter(r, &saved) == SQ_OK) {
        sq__clouds_pass_destroy(r);
        sq__shadow_pass_destroy(r);
        sq__snow_pass_destroy(r);
        sq__mesh_pass_destroy(r);
        sq__particle_pass_destroy(r);
        sq__volume_pass_destroy(r);
        if (r->base)
            for (int i = 0; i < SQ_MAX_SURFACES; i++) surface_slot_free(&r->base->surfaces[i]);
        const GLuint progs[9] = {r->prog_sky,          r->prog_terrain,  r->prog_mesh,
                                 r->prog_surface,      r->prog_tonemap,  r->prog_target,
                                 r->prog_terrain_snow, r->prog_mesh_snow, r->prog_surface_depth};
        for (int i = 0; i < 9; i++) glDeleteProgram(progs[i]);
        const GLuint bufs[4] = {r->terrain_vbo, r->terrain_ibo, r->obstacle_vbo, r->frame_ubo};
        glDeleteBuffers(4, bufs);
        const GLuint vaos[3] = {r->terrain_vao, r->obstacle_vao, r->empty_vao};
        glDeleteVertexArrays(3, vaos);
        const GLuint fbos[2] = {r->hdr_fbo, r->ldr_fbo};
        glDeleteFramebuffers(2, fbos);
        const GLuint texs[4] = {r->hdr_color, r->depth_tex, r->ldr_color, r->white_tex};
        glDeleteTextures(4, texs);
        gl_leave(r, &saved);
    }
    sq__gl_context_destroy(r->gl);
    sq_free(ctx, r->terrain_tiles);
    sq_free(ctx, r->tile_counts);
    sq_free(ctx, (void *)r->tile_offsets);
    sq_free(ctx, r->base);
    sq_free(ctx, r);
}

sq_result sq_renderer_set_look(sq_renderer *r, float exposure, int volume_slices,
                               bool volume_noise)
{
    if (!r) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "render", "sq_renderer_set_look: renderer is NULL");
    if (exposure == 0.0f) exposure = r->desc.exposure;
    if (volume_slices == 0) volume_slices = r->desc.volume_slices;
    if (!(exposure > 0.0f) || !isfinite(exposure))
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "exposure = %g; must be finite and > 0", (double)exposure);
    if (volume_slices < 1 || volume_slices > 4096)
        return sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume_slices = %d; must be in 1..4096", volume_slices);
    r->desc.exposure = exposure;
    r->desc.volume_slices = volume_slices;
    r->desc.volume_noise = volume_noise;
    return SQ_OK;
}

sq_result sq_renderer_info(const sq_renderer *r, sq_render_info *out)
{
    if (!r || !out)
        return sq__fail(r ? r->ctx : NULL, SQ_ERR_INVALID_ARG, "render",
                        "sq_renderer_info: %s is NULL", r ? "out" : "renderer");
    *out = r->info;
    return SQ_OK;
}
