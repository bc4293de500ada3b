/* render_snowcover.c — the snow-cover drawable in the GL renderer (S2 §2.2, SPEC §6.2–6.5):
 * each frame with a snow-cover view, step 1 of S2 §2.2.2 — the region from the camera frustum
 * clipped at the snow-detail distance (sq__snow_map_region: footprint bounding box, power-of-two
 * texel, origin snapped to whole texels) and, unless the last map still covers it (a static
 * world: sq__snow_map_serves), an orthographic top-down depth render of all opaque world
 * geometry over it (sq__world_depth_draw), from above the highest object — then the Snow
 * block (binding 4) and the map (unit 11) and snow depth (unit 12) for the opaque shaders, whose
 * vertex stage displaces the snow shell and whose fragment stage blends the snow shading
 * (steps 2–3, shaders/snow_common.glsl). Without a snow-cover view the block says "off". */
#include <math.h>
#include <string.h>
#include <sys/resource.h>

#include "render/render_internal.h"
#include "render/snow_map.h"
#include "world/world_struct.h"

/* std140 mirror of the Snow block in shaders/snow_common.glsl. */
typedef struct snow_block {
    float map[4], range[4], depth_grid[4], depth_org[4], taps[4], albedo[4], look[4];
} snow_block;

struct sq__snow_pass {
    GLuint ubo, fbo, occ_tex, depth_tex, dummy_occ, dummy_depth;
    int occ_size, depth_nx, depth_ny;
    uint64_t depth_version;
    const float *depth_ptr;
    float depth_max; /* of the uploaded depth grid (m) */
    sq__snow_map_geom geom; /* of the map drawn last */
    sq__texel_rect valid;   /* its texels drawn for this world generation (the others: cleared
                             * to "no occluder", or drawn for an earlier view: still right) */
    const sq_world *map_world;
    uint64_t map_generation;
    bool map_valid;
    double ms_map; /* this frame's occlusion map (CPU + GL, finished); 0 when the last one served */
    double cpu_ms_map; /* the process's CPU time (all threads) meanwhile */
    int bands_drawn;   /* by the last drawing (tests) */
};

/* CPU time of the process, all threads (ms). */
static double cpu_ms(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return 1e3 * ((double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec) +
           1e-3 * ((double)u.ru_utime.tv_usec + (double)u.ru_stime.tv_usec);
}

sq_result sq__snow_pass_create(sq_renderer *r)
{
    sq__snow_pass *s = sq_alloc_zero(r->ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    r->snow = s;
    glCreateBuffers(1, &s->ubo);
    snow_block zero;
    memset(&zero, 0, sizeof zero);
    glNamedBufferStorage(s->ubo, sizeof zero, &zero, GL_DYNAMIC_STORAGE_BIT);
    const float far = 1.0f, none = 0.0f;
    s->dummy_occ = sq__gl_texture_2d(GL_R32F, 1, 1, GL_NEAREST);
    glTextureSubImage2D(s->dummy_occ, 0, 0, 0, 1, 1, GL_RED, GL_FLOAT, &far);
    s->dummy_depth = sq__gl_texture_2d(GL_R32F, 1, 1, GL_NEAREST);
    glTextureSubImage2D(s->dummy_depth, 0, 0, 0, 1, 1, GL_RED, GL_FLOAT, &none);
    return sq__gl_check(r->ctx, "snow pass creation");
}

void sq__snow_pass_destroy(sq_renderer *r)
{
    sq__snow_pass *s = r->snow;
    if (!s) return;
    glDeleteBuffers(1, &s->ubo);
    const GLuint tex[4] = {s->occ_tex, s->depth_tex, s->dummy_occ, s->dummy_depth};
    glDeleteTextures(4, tex);
    if (s->fbo) glDeleteFramebuffers(1, &s->fbo);
    sq_free(r->ctx, s);
    r->snow = NULL;
}

static sq_result ensure_map(sq_renderer *r, int size)
{
    sq__snow_pass *s = r->snow;
    if (s->occ_tex && s->occ_size == size) return SQ_OK;
    glDeleteTextures(1, &s->occ_tex);
    if (s->fbo) glDeleteFramebuffers(1, &s->fbo);
    s->occ_tex = sq__gl_texture_2d(GL_DEPTH_COMPONENT32F, size, size, GL_NEAREST);
    glTextureParameteri(s->occ_tex, GL_TEXTURE_COMPARE_MODE, GL_NONE);
    glCreateFramebuffers(1, &s->fbo);
    glNamedFramebufferTexture(s->fbo, GL_DEPTH_ATTACHMENT, s->occ_tex, 0);
    glNamedFramebufferDrawBuffer(s->fbo, GL_NONE);
    glNamedFramebufferReadBuffer(s->fbo, GL_NONE);
    s->occ_size = size;
    s->map_valid = false;
    return sq__gl_check_framebuffer(r->ctx, s->fbo, "snow occlusion map");
}

static void upload_depth(sq_renderer *r, const sq_snow_cover_view *v)
{
    sq__snow_pass *s = r->snow;
    if (s->depth_tex && s->depth_nx == v->nx && s->depth_ny == v->ny &&
        s->depth_version == v->version && s->depth_ptr == v->depth_m)
        return;
    if (!s->depth_tex || s->depth_nx != v->nx || s->depth_ny != v->ny) {
        glDeleteTextures(1, &s->depth_tex);
        s->depth_tex = sq__gl_texture_2d(GL_R32F, v->nx, v->ny, GL_LINEAR);
        s->depth_nx = v->nx;
        s->depth_ny = v->ny;
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTextureSubImage2D(s->depth_tex, 0, 0, 0, v->nx, v->ny, GL_RED, GL_FLOAT, v->depth_m);
    float mx = 0.0f;
    for (size_t i = 0; i < (size_t)v->nx * (size_t)v->ny; i++)
        if (v->depth_m[i] > mx) mx = v->depth_m[i]; /* NaN never raises it */
    s->depth_max = mx;
    s->depth_version = v->version;
    s->depth_ptr = v->depth_m;
}

/* The world's top (highest object) and bottom for the sky camera. */
static void vertical_range(const sq_renderer *r, const sq_world *w, float *top, float *bottom)
{
    sq_vec3 wmin, wmax, mmin, mmax;
    bool any;
    sq_world_bounds(w, &wmin, &wmax);
    sq__mesh_pass_bounds(r, &mmin, &mmax, &any);
    float t = wmax.z;
    if (any) t = fmaxf(t, mmax.z);
    for (int i = 0; i < w->obstacle_count; i++)
        t = fmaxf(t, w->obstacles[i].center_m.z + w->obstacles[i].size_m.z + w->obstacles[i].roof_m);
    *top = t + 1.0f;
    *bottom = wmin.z - 1.0f;
}

/* World -> clip of the sky camera over the texels t of map g: their x, y to [-1, 1], depth 0 at
 * top .. 1 at bottom (the same for every t: a texel's depth does not depend on the band). */
static sq_mat4 sky_matrix(const sq__snow_map_geom *g, sq__texel_rect t)
{
    const double x0 = g->origin[0] + t.lo[0] * g->texel_m, y0 = g->origin[1] + t.lo[1] * g->texel_m;
    const double ex = (t.hi[0] - t.lo[0]) * g->texel_m, ey = (t.hi[1] - t.lo[1]) * g->texel_m;
    const float span = g->top_z - g->bottom_z;
    sq_mat4 m = sq_m4_identity();
    m.m[0] = (float)(2.0 / ex);
    m.m[12] = (float)(-2.0 * x0 / ex - 1.0);
    m.m[5] = (float)(2.0 / ey);
    m.m[13] = (float)(-2.0 * y0 / ey - 1.0);
    m.m[10] = -2.0f / span;  /* clip z = 2 (top - z) / span - 1 */
    m.m[14] = 2.0f * g->top_z / span - 1.0f;
    return m;
}

/* Texels beyond the view's box drawn with it (each side): a vertex of a triangle the camera sees
 * may lie outside the frustum (a terrain cell of 16 m); and the view may move this far before
 * a band is drawn again. */
#define MAP_GROW_TEXELS 32

/* Draws the texels t of the map (bound framebuffer): a viewport and scissor on them and the
 * sky camera over them, so that the instances and terrain tiles outside are culled. */
static void draw_texels(sq_renderer *r, const sq_snow_cover_view *v, sq__texel_rect t)
{
    const sq__snow_map_geom *g = &r->snow->geom;
    glViewport(t.lo[0], t.lo[1], t.hi[0] - t.lo[0], t.hi[1] - t.lo[1]);
    glScissor(t.lo[0], t.lo[1], t.hi[0] - t.lo[0], t.hi[1] - t.lo[1]);
    sq__depth_view dv;
    memset(&dv, 0, sizeof dv);
    dv.view_proj = sky_matrix(g, t);
    dv.ortho = true;
    dv.px_per_m = (float)(1.0 / g->texel_m);
    /* levels of an error up to half a texel (the exposure's edges move by less than the map
     * resolves), sunk by it (dv.sink): no level's top lies above the finest surface */
    dv.lod_pixels = fmaxf(0.5f, (float)((double)v->depth_bias_m / g->texel_m));
    if (r->map_lod_pixels > 0.0f) dv.lod_pixels = r->map_lod_pixels;
    dv.sink = !r->map_no_sink;
    dv.top_only = true; /* straight down: walls cover no texel */
    dv.min_pixels = 0.5f;
    sq__world_depth_draw(r, &dv);
}

sq_result sq__snow_pass_prepare(sq_renderer *r, const sq_world *w, const sq_snow_cover_view *v)
{
    sq__snow_pass *s = r->snow;
    snow_block b;
    memset(&b, 0, sizeof b);
    GLuint occ = s->dummy_occ, depth = s->dummy_depth;
    s->ms_map = s->cpu_ms_map = 0.0;
    s->bands_drawn = 0;
    r->snow_on = false;
    if (v && v->depth_m && v->nx > 0 && v->ny > 0) {
        sq_result res = sq__snow_programs(r);
        if (res == SQ_OK) res = ensure_map(r, v->map_size);
        if (res != SQ_OK) return res;
        upload_depth(r, v);
        float top, bottom;
        vertical_range(r, w, &top, &bottom);
        sq_camera cam;
        memset(&cam, 0, sizeof cam);
        cam.position_m = r->cam_pos;
        cam.target_m = sq_v3_add(r->cam_pos, r->cam_forward);
        cam.up = r->cam_up;
        cam.fov_y_deg = 2.0f * atanf(1.0f / r->proj.m[5]) * 180.0f / SQ_PI_F;
        cam.near_m = r->near_m;
        cam.far_m = r->far_m;
        const sq__snow_map_geom need = sq__snow_map_region(
            &cam, (float)r->width / (float)r->height, v->detail_distance_m, v->map_size, 4, top,
            bottom);
        /* the world is static between generations and the map's texels are the world's: the
         * map stays while the view's box is inside it (the same texels, so the same
         * exposures), and only the texels the view reads are drawn -- its box and
         * MAP_GROW_TEXELS around it, the first time; then, as the view moves, the bands it
         * newly reads (the texels drawn before are still right) */
        const bool keep = s->map_valid && s->map_world == w && s->map_generation == w->generation &&
                          sq__snow_map_serves(&s->geom, &need);
        const sq__snow_map_geom *at = keep ? &s->geom : &need;
        const sq__texel_rect reads = sq__snow_map_rect(at, &need, 0);
        if (!keep || !sq__texel_rect_inside(reads, s->valid)) {
            /* timed alone: the GL work queued before (shadow cascades) finished first */
            glFinish();
            const double t0 = sq_time_now(), c0 = cpu_ms();
            /* the map must not stay bound for sampling while it is rendered into */
            glBindTextureUnit(11, s->dummy_occ);
            glBindFramebuffer(GL_FRAMEBUFFER, s->fbo);
            glDepthMask(GL_TRUE);
            if (!keep) {
                s->geom = need;
                memset(&s->valid, 0, sizeof s->valid);
                const float one = 1.0f; /* no occluder */
                glClearNamedFramebufferfv(s->fbo, GL_DEPTH, 0, &one);
            }
            const sq__texel_rect want = sq__snow_map_rect(&s->geom, &need, MAP_GROW_TEXELS);
            sq__texel_rect band[4];
            const int nb = sq__texel_rect_minus(want, s->valid, band);
            glEnable(GL_SCISSOR_TEST);
            for (int k = 0; k < nb; k++) draw_texels(r, v, band[k]);
            glDisable(GL_SCISSOR_TEST);
            s->valid = want;
            s->bands_drawn = nb;
            glFinish(); /* the map's cost is measured whole (`squall bench snow-cover`) */
            s->ms_map = (sq_time_now() - t0) * 1e3;
            s->cpu_ms_map = cpu_ms() - c0;
            s->map_world = w;
            s->map_generation = w->generation;
            s->map_valid = true;
        }
        occ = s->occ_tex;
        depth = s->depth_tex;
        /* the shell moves a vertex by at most the depth: terrain tiles are culled that much wider */
        r->shell_max_m = s->depth_max;
        const sq__snow_map_geom *g = &s->geom;
        b.map[0] = (float)g->origin[0];
        b.map[1] = (float)g->origin[1];
        b.map[2] = (float)g->texel_m;
        b.map[3] = (float)g->size;
        b.range[0] = g->top_z;
        b.range[1] = g->bottom_z;
        b.range[2] = v->detail_distance_m;
        b.range[3] = 0.8f * v->detail_distance_m;
        b.depth_grid[0] = 1.0f / v->dx_m;
        b.depth_grid[1] = 1.0f / v->dy_m;
        b.depth_grid[2] = 1.0f;
        r->snow_on = true;
        b.depth_grid[3] = v->shell_blend;
        b.depth_org[0] = v->origin_m.x;
        b.depth_org[1] = v->origin_m.y;
        b.depth_org[2] = (float)v->nx;
        b.depth_org[3] = (float)v->ny;
        b.taps[0] = (float)v->taps;
        b.taps[1] = v->tap_radius_texels;
        b.taps[2] = v->depth_bias_m;
        b.taps[3] = v->noise_amplitude;
        b.albedo[0] = v->albedo.x;
        b.albedo[1] = v->albedo.y;
        b.albedo[2] = v->albedo.z;
        b.albedo[3] = v->brdf == SQ_SNOW_BRDF_BLINN_PHONG ? 1.0f : 0.0f;
        b.look[0] = v->sparkle;
        b.look[1] = v->shininess;
        b.look[2] = v->noise_scale_m > 0.0f ? v->noise_scale_m : 1.0f;
        /* metres per pixel at 1 m from the camera: the exposure's allowance for the camera's
         * drawing is at least a pixel at the point's distance, and the drawn level's error
         * where larger (render_meshes.c, location 3 of the mesh programs) */
        b.look[3] = 2.0f / ((float)r->height * r->proj.m[5]);
    }
    glNamedBufferSubData(s->ubo, 0, sizeof b, &b);
    glBindBufferBase(GL_UNIFORM_BUFFER, 4, s->ubo);
    glBindTextureUnit(11, occ);
    glBindTextureUnit(12, depth);
    return sq__gl_check(r->ctx, "snow occlusion map");
}

double sq__snow_pass_ms(const sq_renderer *r) { return r->snow ? r->snow->ms_map : 0.0; }

double sq__snow_pass_cpu_ms(const sq_renderer *r) { return r->snow ? r->snow->cpu_ms_map : 0.0; }

int sq__snow_pass_bands(const sq_renderer *r) { return r->snow ? r->snow->bands_drawn : 0; }

bool sq__snow_pass_map(sq_renderer *r, sq__snow_map_geom *g, float *height)
{
    const sq__snow_pass *s = r->snow;
    if (!s || !s->map_valid) return false;
    *g = s->geom;
    g->need_lo[0] = s->geom.origin[0] + s->valid.lo[0] * s->geom.texel_m;
    g->need_lo[1] = s->geom.origin[1] + s->valid.lo[1] * s->geom.texel_m;
    g->need_hi[0] = s->geom.origin[0] + s->valid.hi[0] * s->geom.texel_m;
    g->need_hi[1] = s->geom.origin[1] + s->valid.hi[1] * s->geom.texel_m;
    if (!height) return true;
    if (r->gl && sq__gl_context_make_current(r->gl) != SQ_OK) return false;
    const size_t n = (size_t)s->geom.size * (size_t)s->geom.size;
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glGetTextureImage(s->occ_tex, 0, GL_DEPTH_COMPONENT, GL_FLOAT, (GLsizei)(n * sizeof(float)), height);
    const float span = s->geom.top_z - s->geom.bottom_z;
    for (size_t i = 0; i < n; i++) height[i] = s->geom.top_z - height[i] * span;
    return true;
}
