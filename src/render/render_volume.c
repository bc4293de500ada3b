/* render_volume.c — the volume pass: half-angle slicing with multiple forward scattering
 * (SPEC 3.2-3.4; S0 §3.4; Kniss et al. 2003; Ikits et al., GPU Gems ch. 39; Harris & Lastra
 * 2001 for the light recursion 3.21 with the Δx factor of 3.19 that S0 omits).
 *
 * Per frame, for the camera and the sun:
 *   1. slice axis s: the half-angle vector between the view direction ω_v and the light
 *      propagation direction ω_l (both propagation directions): s = normalize(ω_v + ω_l) when
 *      ω_v·ω_l >= 0 (light behind the viewer), else s = normalize(ω_l - ω_v). In both cases
 *      s·ω_l > 0, so visiting the planes s·x = d in increasing d is the light-propagation order.
 *   2. K = desc.volume_slices planes across the box (spacing = extent of the box along s / K,
 *      jittered per frame from desc.seed and the time), clipped to the box (grown by two
 *      spacings so that the slabs of boundary planes are not lost) on the CPU.
 *   3. Light passes, once per frame, before the opaque passes (sq__volume_pass_prepare_shadow):
 *      for each plane in light order, volume_light.frag (rendered from the sun with an
 *      orthographic projection fitted to the box) carries the light buffer across the plane's
 *      slab into the next layer of a 2D array texture, so that every plane's incoming light
 *      stays available. The last layer is the sun shadow of the opaque and particle passes.
 *   4. Eye pass (sq__volume_pass_draw): all slice polygons in ONE draw, back to front for the
 *      eye, each fragment reading its plane's layer (volume_eye.frag) and compositing its slab
 *      "over" the scene per channel with dual-source blending (C = C_i + T_i C) into an RGBA32F
 *      copy of the HDR target, which is copied back at the end. Because the light of every
 *      plane is stored, the eye order need not follow the light order, and nothing is read
 *      back and rewritten per slice (no texture barriers between slices).
 * Every fragment clips its slab to the box, to the camera and to the opaque depth (a per-pixel
 * ray interval computed once per frame by volume_bounds.frag), and the first slice in front of
 * the near plane also stands for the ray down to the camera, so a homogeneous medium gets
 * exactly exp(-β_ext d) over any path, camera inside or outside (checked by the Koschmieder
 * tests in tests/volume).
 *
 * Memory: the light array holds one layer (light_size^2 RGBA16F) per in-box slab, e.g. 68 MB
 * for 128 slices at 256^2. Above VOL_LIGHT_BUDGET_BYTES (256 MB, or a quarter of the context's
 * memory limit when that is less) the planes are processed in chunks:
 * the light sweep keeps one checkpoint layer per chunk plus the layers of one chunk, and the
 * eye pass recomputes a chunk's layers from its checkpoint when it needs them (at most one
 * more light sweep). With render.volume_noise on, the noise perturbation of the density is
 * baked once per frame into a 3D texture (volume_bake.comp; twice the density's resolution per
 * axis while that stays within 4 Mi voxels, so the noise's finer octaves add detail below the
 * simulation's cell size) so the passes fetch one texel set per sample. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "render/render_internal.h"
#include "render/volume_sky.h"
#include "squall/rng.h"
#include "world/world_struct.h"

#define VOL_MAX_SLICES 4096
#define VOL_MIN_LIGHT_SIZE 8
#define VOL_MAX_LIGHT_SIZE 4096
#define VOL_MARGIN_SPACINGS 2.0f   /* box growth for the slice polygons, in slice spacings */
#define VOL_HARRIS_GAMMA_SR 0.09   /* forward solid angle kept in the beam (Harris 2001) */
#define VOL_NOISE_N 32             /* tileable value-noise texture for coordinate noise */
#define VOL_NOISE_AMP_VOXELS 3.0f  /* perturbation amplitude, density voxels (S0 Fig 3.12) */
#define VOL_NOISE_FREQ 0.25f       /* noise cells per density voxel (first octave) */
#define VOL_NOISE_DRIFT 0.06f      /* noise cells per simulated second: the pattern evolves
                                      slowly, so that detail does not flicker between frames */
#define VOL_BAKE_UPSAMPLE 2        /* the bake samples this many points per density voxel and
                                      axis (the noise's finer octaves show below the grid's
                                      cell size) ... */
#define VOL_BAKE_MAX_VOXELS ((size_t)1 << 22) /* ... while the bake stays within 4 Mi voxels
                                                 (16 MB); at the density's size otherwise */
#define VOL_RNG_STREAM 0x766f6c756d65ull /* "volume" */
#define VOL_LIGHT_BUDGET_BYTES ((uint64_t)256 << 20) /* light array above which it is chunked
                                                        (or a quarter of the context's memory
                                                        limit, if that is less) */
#define VOL_VERT_FLOATS 4          /* slice vertex: world xyz, light layer */
#define VOL_MAX_TRI_VERTS 12       /* a hexagon as 4 triangles */
#define VOL_LIGHT_GROUP 8          /* slabs per light pass without the blur ring (<= 8 outputs) */
#define VOL_DUST_MARGIN 3          /* cells around the non-zero voxels where the sampled density
                                      can be non-zero (trilinear 1, local maximum 1, B-spline 2) */
#define VOL_TAU_STOP 20.0f         /* optical depth from the camera past which the eye pass draws
                                      no slice (volume_bounds.frag): what lies behind reaches the
                                      pixel through less than exp(-20) = 2e-9 of its radiance */

typedef struct vol_plan {
    sq_vec3 lo, size, hi;   /* the box drawn: the density's, widened by mirror_y_m in y */
    sq_vec3 tex_lo, tex_size; /* the density's box: where texture coordinates run 0..1 */
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

/* What the light layers were computed for: the plan and every input of the light passes. */
typedef struct vol_key {
    vol_plan plan;
    const float *data;
    uint64_t version;
    int nx, ny, nz;
    float sigma_ext[3], albedo[3];
    int light_size;
    bool noise, multiple;
} vol_key;

struct sq__volume_pass {
    GLuint prog_eye;       /* the variant of the current view (one of prog_eyes) */
    GLuint prog_eyes[2];   /* by medium: grey extinction or not */
    GLuint prog_bounds, prog_bake;
    GLuint prog_light[3];  /* by VOL_LIGHT_MODE: single scatter, narrow forward, blurred */
    GLint loc_plane[3], loc_src[3];
    int light_mode;        /* variant of the current plan */
    int light_steps;       /* slabs per light pass of that variant */
    GLuint vao_slices, vbo_slices, vao_empty;
    GLuint density_tex, noise_tex, baked_tex;
    bool density_sharp; /* density_tex is RGBA: density, local maximum, edge weight, 0 */
    sq__volume_dust dust; /* the box outside which the drawn density is 0 */
    int dnx, dny, dnz;
    uint64_t version;
    const float *data;
    bool have_data;
    /* noise-perturbed density of the current frame (render.volume_noise) */
    bool baked_valid;
    const float *baked_data;
    uint64_t baked_version;
    float baked_offset[3];
    /* light array: layers [0, chunks) are checkpoints (layer 0: the unattenuated sun, all
     * ones), the layers from `chunks` on the light after each in-box slab of the resident
     * chunk (the one whose light passes ran last) */
    GLuint light_arr, light_fbo, shadow_tex;
    int light_size, light_layers;
    int chunk_len, chunks, resident;
    int *slot;          /* per plane: layer holding the light that arrives at it */
    bool key_valid;
    vol_key key;
    /* eye pass */
    GLuint bounds_tex, bounds_fbo, acc_tex, acc_fbo, comp_fbo, comp_color;
    GLuint eye_depth;   /* per pixel: window depth beyond which no slice fragment counts */
    GLuint phase_tex;   /* per pixel: phase function toward the eye (bounds pass) */
    int eye_w, eye_h;
    int max_3d;
    /* ambient light inside the medium (volume_sky.c): per voxel the sky's and the ground's
     * visibility (sky_buf, 6 per voxel), recomputed when the density or its optics change, and
     * the ambient radiance it gives (one RGBA32F texture, alpha 1: filtered faster than RGB); with
     * render_desc.volume_ambient_uniform a single texel of the unattenuated ambient */
    GLuint sky_tex, sky_one_tex;
    float *sky_buf, *sky_work;
    size_t sky_cap, sky_work_cap;
    bool sky_valid;
    const float *sky_data;
    uint64_t sky_version;
    int sky_dims[3];
    double sky_key[6]; /* attenuation per channel, cell sizes */
    float sky_amb[6];  /* the ambient colours of the texture: sky's half, ground's half */
    float *verts;       /* VOL_VERT_FLOATS per vertex, up to VOL_MAX_TRI_VERTS per plane */
    int *vfirst, *vcount; /* per plane: its triangles in the vertex buffer */
    int *scissor;         /* per plane: 4 ints, x y w h of the window rectangle outside which
                             its eye-pass fragments are all clear air (w = 0: none drawn) */
    int plane_cap;
};

/* ---- GL state the pass changes, restored on exit ------------------------------------------ */
typedef struct gl_saved {
    GLint fbo, viewport[4], scissor_box[4], program, vao, depth_func;
    GLint blend_src_rgb, blend_dst_rgb, blend_src_a, blend_dst_a, blend_eq_rgb, blend_eq_a;
    GLboolean blend, depth, cull, scissor, depth_mask;
} gl_saved;

static void state_save(gl_saved *s)
{
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &s->fbo);
    glGetIntegerv(GL_VIEWPORT, s->viewport);
    glGetIntegerv(GL_SCISSOR_BOX, s->scissor_box);
    glGetIntegerv(GL_CURRENT_PROGRAM, &s->program);
    glGetIntegerv(GL_VERTEX_ARRAY_BINDING, &s->vao);
    s->blend = glIsEnabled(GL_BLEND);
    s->depth = glIsEnabled(GL_DEPTH_TEST);
    s->cull = glIsEnabled(GL_CULL_FACE);
    s->scissor = glIsEnabled(GL_SCISSOR_TEST);
    glGetBooleanv(GL_DEPTH_WRITEMASK, &s->depth_mask);
    glGetIntegerv(GL_DEPTH_FUNC, &s->depth_func);
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
    glScissor(s->scissor_box[0], s->scissor_box[1], s->scissor_box[2], s->scissor_box[3]);
    glUseProgram((GLuint)s->program);
    glBindVertexArray((GLuint)s->vao);
    enable_if(GL_BLEND, s->blend);
    enable_if(GL_DEPTH_TEST, s->depth);
    enable_if(GL_CULL_FACE, s->cull);
    enable_if(GL_SCISSOR_TEST, s->scissor);
    glDepthMask(s->depth_mask);
    glDepthFunc((GLenum)s->depth_func);
    glBlendFuncSeparate((GLenum)s->blend_src_rgb, (GLenum)s->blend_dst_rgb,
                        (GLenum)s->blend_src_a, (GLenum)s->blend_dst_a);
    glBlendEquationSeparate((GLenum)s->blend_eq_rgb, (GLenum)s->blend_eq_a);
}

static void state_set_plain(void)
{
    glDisable(GL_BLEND);
    /* a dual-source blend function makes draws into several colour buffers invalid in Mesa
     * even with blending off (the light passes write up to 8) */
    glBlendFunc(GL_ONE, GL_ZERO);
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

static float v3_get(sq_vec3 v, int a) { return a == 0 ? v.x : a == 1 ? v.y : v.z; }
static void v3_set(sq_vec3 *v, int a, float x)
{
    if (a == 0) v->x = x;
    else if (a == 1) v->y = x;
    else v->z = x;
}

void sq__volume_dust_box(const float *density, int nx, int ny, int nz, sq_vec3 origin,
                         sq_vec3 size, sq__volume_dust *out)
{
    memset(out, 0, sizeof *out);
    /* the box around the non-zero voxels (index space), grown by VOL_DUST_MARGIN cells */
    int lo[3] = {nx, ny, nz}, hi[3] = {-1, -1, -1};
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const float *row = density + ((size_t)k * ny + j) * nx;
            int first = -1, last = -1;
            for (int i = 0; i < nx; i++)
                if (row[i] > 0.0f) {
                    if (first < 0) first = i;
                    last = i;
                }
            if (first < 0) continue;
            lo[0] = first < lo[0] ? first : lo[0];
            hi[0] = last > hi[0] ? last : hi[0];
            lo[1] = j < lo[1] ? j : lo[1];
            hi[1] = j > hi[1] ? j : hi[1];
            lo[2] = k < lo[2] ? k : lo[2];
            hi[2] = k > hi[2] ? k : hi[2];
        }
    if (hi[0] < 0) { /* no dust: an empty box */
        out->empty = true;
        out->lo = sq_v3(1.0f, 1.0f, 1.0f);
        out->hi = sq_v3(0.0f, 0.0f, 0.0f);
        return;
    }
    const int dims[3] = {nx, ny, nz};
    const float m = (float)VOL_DUST_MARGIN;
    for (int a = 0; a < 3; a++) {
        const float cell = v3_get(size, a) / (float)dims[a], o = v3_get(origin, a);
        v3_set(&out->lo, a, o + ((float)lo[a] - m) * cell);
        v3_set(&out->hi, a, o + ((float)hi[a] + 1.0f + m) * cell);
        out->open_lo[a] = lo[a] - VOL_DUST_MARGIN <= 0;
        out->open_hi[a] = hi[a] + 1 + VOL_DUST_MARGIN >= dims[a];
    }
}

bool sq__volume_slice_rect(const sq__volume_dust *dust, bool mirror_y, sq_vec3 glo, sq_vec3 ghi,
                           sq_vec3 s, float d, const sq_mat4 *view_proj, sq_vec3 cam,
                           sq_vec3 forward, float near_m, int width, int height, int rect[4])
{
    rect[0] = rect[1] = rect[2] = rect[3] = 0;
    if (dust->empty) return false;
    /* the part of the slice box where dust can be */
    sq_vec3 lo = glo, hi = ghi;
    for (int a = 0; a < 3; a++) {
        if (a == 1 && mirror_y) continue;
        if (!dust->open_lo[a]) v3_set(&lo, a, fmaxf(v3_get(glo, a), v3_get(dust->lo, a)));
        if (!dust->open_hi[a]) v3_set(&hi, a, fminf(v3_get(ghi, a), v3_get(dust->hi, a)));
        if (!(v3_get(lo, a) < v3_get(hi, a))) return false;
    }
    sq_vec3 poly[6], cut[7];
    const int m = plane_box_polygon(lo, hi, s, d, poly);
    if (m < 3) return false;
    /* cut by the near plane (a little in front of it: the part behind it is clipped anyway, and
     * every point kept projects with w > 0) */
    const float e = 0.99f * near_m;
    int n = 0;
    for (int i = 0; i < m; i++) {
        const sq_vec3 a = poly[i], b = poly[(i + 1) % m];
        const float da = sq_v3_dot(forward, sq_v3_sub(a, cam)) - e;
        const float db = sq_v3_dot(forward, sq_v3_sub(b, cam)) - e;
        if (da >= 0.0f) cut[n++] = a;
        if ((da >= 0.0f) != (db >= 0.0f)) cut[n++] = sq_v3_lerp(a, b, da / (da - db));
    }
    if (n < 3) return false;
    float x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
    for (int i = 0; i < n; i++) {
        const sq_vec4 c = sq_m4_mul_v4(*view_proj, (sq_vec4){cut[i].x, cut[i].y, cut[i].z, 1.0f});
        if (!(c.w > 0.0f)) { /* not expected after the cut; the whole window then */
            x0 = y0 = -INFINITY;
            x1 = y1 = INFINITY;
            break;
        }
        const float wx = (c.x / c.w * 0.5f + 0.5f) * (float)width;
        const float wy = (c.y / c.w * 0.5f + 0.5f) * (float)height;
        x0 = fminf(x0, wx);
        x1 = fmaxf(x1, wx);
        y0 = fminf(y0, wy);
        y1 = fmaxf(y1, wy);
    }
    const float gx0 = fmaxf(floorf(x0) - 2.0f, 0.0f), gy0 = fmaxf(floorf(y0) - 2.0f, 0.0f);
    const float gx1 = fminf(ceilf(x1) + 2.0f, (float)width);
    const float gy1 = fminf(ceilf(y1) + 2.0f, (float)height);
    if (!(gx0 < gx1) || !(gy0 < gy1)) return false;
    rect[0] = (int)gx0;
    rect[1] = (int)gy0;
    rect[2] = (int)gx1 - rect[0];
    rect[3] = (int)gy1 - rect[1];
    return true;
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
    p->tex_lo = p->lo = v->origin_m;
    p->tex_size = p->size = v->size_m;
    p->lo.y -= v->mirror_y_m;
    p->size.y += 2.0f * v->mirror_y_m;
    p->hi = sq_v3_add(p->lo, p->size);
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
    /* noise texture coordinates (one unit = VOL_NOISE_N cells): a slow drift, different on
     * each axis */
    const float t = (float)fmod(r->time_s, 1.0e5) * (VOL_NOISE_DRIFT / (float)VOL_NOISE_N);
    p->noise_offset[0] = 1.0f * t;
    p->noise_offset[1] = 0.62f * t;
    p->noise_offset[2] = 0.34f * t;
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

/* y wrap of the textures indexed by the density's voxels: mirrored beyond the y faces when the
 * view draws the box beyond them (sq_volume_view.mirror_y_m), else clamped like x and z. */
static void set_wrap_y(GLuint tex, const sq_volume_view *v)
{
    if (tex)
        glTextureParameteri(tex, GL_TEXTURE_WRAP_T,
                            v->mirror_y_m > 0.0f ? GL_MIRRORED_REPEAT : GL_CLAMP_TO_EDGE);
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

/* The shadow texture: the last light layer copied out, read by the opaque and particle passes;
 * outside the box's footprint the sun is unobstructed (border 1). */
static void make_shadow_texture(sq_renderer *r, sq__volume_pass *vp)
{
    const int n = r->desc.light_buffer_size;
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->shadow_tex);
    glTextureStorage2D(vp->shadow_tex, 1, GL_RGBA16F, n, n);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_BORDER);
    glTextureParameteri(vp->shadow_tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_BORDER);
    const float one[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    glTextureParameterfv(vp->shadow_tex, GL_TEXTURE_BORDER_COLOR, one);
    glCreateFramebuffers(1, &vp->light_fbo);
    vp->light_size = n;
}

static uint64_t layer_bytes(int light_size) { return (uint64_t)light_size * light_size * 8u; }

/* Light array layers for `steps` in-box slabs in n planes: one chunk if it fits the budget,
 * else chunks of chunk_len planes with one checkpoint each (the fewest layers that fit, or
 * ~2 sqrt(n) when none does). Sets chunk_len, chunks; (re)allocates when more layers are
 * needed than allocated. */
static sq_result ensure_light_layers(sq_renderer *r, sq__volume_pass *vp, int n, int steps)
{
    const uint64_t per = layer_bytes(vp->light_size);
    uint64_t bytes = sq_context_memory_limit(r->ctx) / 4;
    if (bytes == 0 || bytes > VOL_LIGHT_BUDGET_BYTES) bytes = VOL_LIGHT_BUDGET_BYTES;
    const int budget = bytes / per > 2 ? (int)(bytes / per) : 2;
    int len = n, chunks = 1, need = 1 + steps;
    if (need > budget) {
        /* working layers per chunk <= chunk length; try the longest chunks that fit */
        len = 0;
        for (int m = budget - 2; m >= 1 && len == 0; m--) {
            const int c = (n + m - 1) / m;
            if (c + m <= budget) len = m;
        }
        if (len == 0) len = (int)ceil(sqrt((double)n));
        chunks = (n + len - 1) / len;
        need = chunks + (len < steps ? len : steps);
    }
    vp->chunk_len = len;
    vp->chunks = chunks;
    if (need <= vp->light_layers) return SQ_OK;

    if (vp->light_arr) glDeleteTextures(1, &vp->light_arr);
    vp->light_arr = 0;
    vp->light_layers = 0;
    vp->key_valid = false;
    vp->resident = -1;
    const int alloc = need + 8; /* slack: the plane count moves by a few with the view */
    char what[96];
    snprintf(what, sizeof what, "volume light array (%d layers of %d^2 RGBA16F)", alloc,
             vp->light_size);
    sq_result res = sq_context_check_memory(r->ctx, per * (uint64_t)alloc, what);
    if (res != SQ_OK) return res;
    glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &vp->light_arr);
    glTextureStorage3D(vp->light_arr, 1, GL_RGBA16F, vp->light_size, vp->light_size, alloc);
    set_linear_clamp(vp->light_arr);
    /* layer 0: the sun before any dust (never written again): full light, optical depth 0 */
    const float one[4] = {1.0f, 1.0f, 1.0f, 0.0f};
    glClearTexSubImage(vp->light_arr, 0, 0, 0, 0, vp->light_size, vp->light_size, 1, GL_RGBA,
                       GL_FLOAT, one);
    vp->light_layers = alloc;
    return sq__gl_check(r->ctx, "volume light array allocation");
}

static sq_result ensure_eye_buffers(sq_renderer *r, sq__volume_pass *vp)
{
    if (vp->acc_fbo && vp->eye_w == r->width && vp->eye_h == r->height) return SQ_OK;
    if (vp->acc_fbo) glDeleteFramebuffers(1, &vp->acc_fbo);
    if (vp->bounds_fbo) glDeleteFramebuffers(1, &vp->bounds_fbo);
    if (vp->acc_tex) glDeleteTextures(1, &vp->acc_tex);
    if (vp->bounds_tex) glDeleteTextures(1, &vp->bounds_tex);
    if (vp->eye_depth) glDeleteTextures(1, &vp->eye_depth);
    if (vp->phase_tex) glDeleteTextures(1, &vp->phase_tex);
    vp->acc_fbo = vp->acc_tex = vp->bounds_tex = vp->bounds_fbo = vp->eye_depth = 0;
    vp->phase_tex = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->bounds_tex);
    glTextureStorage2D(vp->bounds_tex, 1, GL_RGBA32F, r->width, r->height);
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->phase_tex);
    glTextureStorage2D(vp->phase_tex, 1, GL_RGBA32F, r->width, r->height);
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->eye_depth);
    glTextureStorage2D(vp->eye_depth, 1, GL_DEPTH_COMPONENT32F, r->width, r->height);
    glCreateFramebuffers(1, &vp->bounds_fbo);
    glNamedFramebufferTexture(vp->bounds_fbo, GL_COLOR_ATTACHMENT0, vp->bounds_tex, 0);
    glNamedFramebufferTexture(vp->bounds_fbo, GL_COLOR_ATTACHMENT1, vp->phase_tex, 0);
    glNamedFramebufferTexture(vp->bounds_fbo, GL_DEPTH_ATTACHMENT, vp->eye_depth, 0);
    const GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(vp->bounds_fbo, 2, bufs);
    /* a driver that cannot hold a texture this large (llvmpipe: 1 GiB each) says
     * GL_OUT_OF_MEMORY here; name the frame size instead of an incomplete frame buffer */
    char what[160];
    snprintf(what, sizeof what,
             "the volume's eye buffers for a %dx%d frame (RGBA32F, %.2f GiB each; render a "
             "smaller frame, --size)",
             r->width, r->height, (double)r->width * r->height * 16.0 / 1073741824.0);
    sq_result res = sq__gl_check(r->ctx, what);
    if (res != SQ_OK) return res;
    res = sq__gl_check_framebuffer(r->ctx, vp->bounds_fbo, "volume ray bounds");
    if (res != SQ_OK) return res;
    /* 32-bit floats: a hundred and more slices blend here (half floats would lose ~0.1 % of
     * the radiance, i.e. several % of a 5 % contrast) */
    glCreateTextures(GL_TEXTURE_2D, 1, &vp->acc_tex);
    glTextureStorage2D(vp->acc_tex, 1, GL_RGBA32F, r->width, r->height);
    glCreateFramebuffers(1, &vp->acc_fbo);
    glNamedFramebufferTexture(vp->acc_fbo, GL_COLOR_ATTACHMENT0, vp->acc_tex, 0);
    glNamedFramebufferTexture(vp->acc_fbo, GL_DEPTH_ATTACHMENT, vp->eye_depth, 0);
    glNamedFramebufferDrawBuffer(vp->acc_fbo, GL_COLOR_ATTACHMENT0);
    glNamedFramebufferReadBuffer(vp->acc_fbo, GL_COLOR_ATTACHMENT0);
    vp->eye_w = r->width;
    vp->eye_h = r->height;
    return sq__gl_check_framebuffer(r->ctx, vp->acc_fbo, "volume eye accumulation buffer");
}

static sq_result ensure_comp_fbo(sq_renderer *r, sq__volume_pass *vp)
{
    if (vp->comp_fbo && vp->comp_color == r->hdr_color) return SQ_OK;
    if (!vp->comp_fbo) glCreateFramebuffers(1, &vp->comp_fbo);
    glNamedFramebufferTexture(vp->comp_fbo, GL_COLOR_ATTACHMENT0, r->hdr_color, 0);
    glNamedFramebufferDrawBuffer(vp->comp_fbo, GL_COLOR_ATTACHMENT0);
    glNamedFramebufferReadBuffer(vp->comp_fbo, GL_COLOR_ATTACHMENT0);
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
    vp->resident = -1;
    vp->plane_cap = K + 64;
    const size_t cap = (size_t)vp->plane_cap;
    vp->verts = sq_alloc(r->ctx, sizeof(float) * VOL_VERT_FLOATS * VOL_MAX_TRI_VERTS * cap);
    vp->vfirst = sq_alloc(r->ctx, sizeof(int) * cap);
    vp->vcount = sq_alloc(r->ctx, sizeof(int) * cap);
    vp->slot = sq_alloc(r->ctx, sizeof(int) * cap);
    vp->scissor = sq_alloc(r->ctx, 4 * sizeof(int) * cap);
    if (!vp->verts || !vp->vfirst || !vp->vcount || !vp->slot || !vp->scissor)
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                        "volume pass: no memory for %d slice polygons", vp->plane_cap);

    sq_result res = sq__gl_program(r->ctx, "volume_fullscreen.vert", NULL, "volume_bounds.frag",
                                   &vp->prog_bounds);
    if (res == SQ_OK) res = sq__gl_compute_program(r->ctx, "volume_bake.comp", &vp->prog_bake);
    if (res != SQ_OK) return res;

    glCreateVertexArrays(1, &vp->vao_empty);
    glCreateVertexArrays(1, &vp->vao_slices);
    glCreateBuffers(1, &vp->vbo_slices);
    glNamedBufferData(vp->vbo_slices,
                      (GLsizeiptr)(sizeof(float) * VOL_VERT_FLOATS * VOL_MAX_TRI_VERTS * cap), NULL,
                      GL_STREAM_DRAW);
    glVertexArrayVertexBuffer(vp->vao_slices, 0, vp->vbo_slices, 0,
                              VOL_VERT_FLOATS * sizeof(float));
    glEnableVertexArrayAttrib(vp->vao_slices, 0);
    glVertexArrayAttribFormat(vp->vao_slices, 0, VOL_VERT_FLOATS, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vp->vao_slices, 0, 0);

    res = make_noise_texture(r, vp);
    if (res == SQ_OK) make_shadow_texture(r, vp);
    /* uniform ambient: every point sees the whole sky and ground (set per frame) */
    const float one[3] = {1.0f, 1.0f, 1.0f};
    glCreateTextures(GL_TEXTURE_3D, 1, &vp->sky_one_tex);
    glTextureStorage3D(vp->sky_one_tex, 1, GL_RGBA32F, 1, 1, 1);
    glTextureSubImage3D(vp->sky_one_tex, 0, 0, 0, 0, 1, 1, 1, GL_RGB, GL_FLOAT, one);
    set_linear_clamp(vp->sky_one_tex);
    if (res == SQ_OK) res = sq__gl_check(r->ctx, "volume pass create");
    return res;
}

void sq__volume_pass_destroy(sq_renderer *r)
{
    if (!r || !r->volume) return;
    sq__volume_pass *vp = r->volume;
    if (r->sun_shadow_tex == vp->shadow_tex) r->sun_shadow_tex = 0;
    for (int i = 0; i < 2; i++) glDeleteProgram(vp->prog_eyes[i]);
    for (int i = 0; i < 3; i++) glDeleteProgram(vp->prog_light[i]);
    glDeleteProgram(vp->prog_bounds);
    glDeleteProgram(vp->prog_bake);
    glDeleteVertexArrays(1, &vp->vao_slices);
    glDeleteVertexArrays(1, &vp->vao_empty);
    glDeleteBuffers(1, &vp->vbo_slices);
    GLuint tex[11] = {vp->density_tex, vp->noise_tex, vp->baked_tex, vp->light_arr,
                      vp->shadow_tex, vp->acc_tex, vp->bounds_tex, vp->eye_depth, vp->phase_tex,
                      vp->sky_tex, vp->sky_one_tex};
    glDeleteTextures(11, tex);
    GLuint fbo[4] = {vp->light_fbo, vp->acc_fbo, vp->comp_fbo, vp->bounds_fbo};
    glDeleteFramebuffers(4, fbo);
    sq_free(r->ctx, vp->verts);
    sq_free(r->ctx, vp->vfirst);
    sq_free(r->ctx, vp->vcount);
    sq_free(r->ctx, vp->scissor);
    sq_free(r->ctx, vp->slot);
    sq_free(r->ctx, vp->sky_buf);
    sq_free(r->ctx, vp->sky_work);
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
    if (!(v->edge_sharpness >= 0.0f && v->edge_sharpness <= 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume edge_sharpness = %g; must be in [0, 1] (0 = off)",
                        (double)v->edge_sharpness);
    if (!(v->mirror_y_m >= 0.0f) || !isfinite(v->mirror_y_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render",
                        "volume mirror_y_m = %g; must be finite and >= 0 m (0 = the box only)",
                        (double)v->mirror_y_m);
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

/* The sharp-edge texture (sq_volume_view.edge_sharpness; volume_common.glsl vol_density): per
 * voxel the density, its maximum M and minimum m over the 27 voxels around it (clamped at the
 * faces), and the edge weight e = sharpness * smoothstep(0.5, 0.9, (M - m) / M): 1 where the
 * density falls from its local maximum to below a tenth of it within a cell, 0 where it
 * changes by less than half over two cells (a smooth haze keeps its trilinear shape). */
void sq__volume_edge_texture(const float *density, int nx, int ny, int nz, float sharpness,
                             float *rgba)
{
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                float mx = 0.0f, mn = INFINITY;
                for (int c = k > 0 ? k - 1 : 0; c <= (k + 1 < nz ? k + 1 : k); c++)
                    for (int b = j > 0 ? j - 1 : 0; b <= (j + 1 < ny ? j + 1 : j); b++)
                        for (int a = i > 0 ? i - 1 : 0; a <= (i + 1 < nx ? i + 1 : i); a++) {
                            /* comparisons, not fmaxf/fminf (a libm call each without
                             * -ffinite-math-only; the density is finite, checked before) */
                            const float d = density[((size_t)c * ny + b) * nx + a];
                            const float x = d > 0.0f ? d : 0.0f;
                            mx = x > mx ? x : mx;
                            mn = x < mn ? x : mn;
                        }
                float e = 0.0f;
                if (mx > 0.0f) {
                    const float t = fminf(fmaxf(((mx - mn) / mx - 0.5f) / 0.4f, 0.0f), 1.0f);
                    e = sharpness * t * t * (3.0f - 2.0f * t);
                }
                float *o = rgba + 4 * (((size_t)k * ny + j) * nx + i);
                o[0] = density[((size_t)k * ny + j) * nx + i];
                o[1] = mx;
                o[2] = e;
                o[3] = 0.0f;
            }
}

/* Uploads the density when its version, size or storage changed (R32F, x fastest as GL; RGBA32F
 * with sharp edges: llvmpipe filters a four-channel float texel faster than a three-channel
 * one, -17 % of a haboob frame's CPU time; alpha unused). */
static sq_result upload_density(sq_renderer *r, const sq_volume_view *v)
{
    sq__volume_pass *vp = r->volume;
    if (vp->have_data && vp->version == v->version && vp->data == v->density &&
        vp->dnx == v->nx && vp->dny == v->ny && vp->dnz == v->nz &&
        vp->density_sharp == (v->edge_sharpness > 0.0f))
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
    sq__volume_dust_box(v->density, v->nx, v->ny, v->nz, v->origin_m, v->size_m, &vp->dust);
    const bool sharp = v->edge_sharpness > 0.0f;
    if (!vp->density_tex || vp->dnx != v->nx || vp->dny != v->ny || vp->dnz != v->nz ||
        vp->density_sharp != sharp) {
        if (vp->density_tex) glDeleteTextures(1, &vp->density_tex);
        if (vp->baked_tex) glDeleteTextures(1, &vp->baked_tex);
        vp->baked_tex = 0;
        glCreateTextures(GL_TEXTURE_3D, 1, &vp->density_tex);
        glTextureStorage3D(vp->density_tex, 1, sharp ? GL_RGBA32F : GL_R32F, v->nx, v->ny, v->nz);
        set_linear_clamp(vp->density_tex);
        vp->density_sharp = sharp;
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
    if (sharp) {
        float *rgba = sq_alloc(r->ctx, sizeof(float) * 4 * n);
        if (!rgba)
            return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                            "volume pass: no memory for the sharp-edge texture of %zu voxels", n);
        sq__volume_edge_texture(v->density, v->nx, v->ny, v->nz, v->edge_sharpness, rgba);
        glTextureSubImage3D(vp->density_tex, 0, 0, 0, 0, v->nx, v->ny, v->nz, GL_RGBA, GL_FLOAT,
                            rgba);
        sq_free(r->ctx, rgba);
    } else {
        glTextureSubImage3D(vp->density_tex, 0, 0, 0, 0, v->nx, v->ny, v->nz, GL_RED, GL_FLOAT,
                            v->density);
    }
    vp->have_data = true;
    vp->baked_valid = false;
    vp->key_valid = false;
    vp->version = v->version;
    vp->data = v->density;
    vp->dnx = v->nx;
    vp->dny = v->ny;
    vp->dnz = v->nz;
    return sq__gl_check(r->ctx, "volume density upload (glTextureSubImage3D)");
}

/* The diffuse light's attenuation per density unit and channel (volume_sky.c): sigma_ext times
 * the diffusion decay constant sqrt(3 (1 - albedo)(1 - albedo <cos>)), <cos> the phase
 * function's mean cosine. */
static void diffuse_sigma(const sq_renderer *r, const sq_volume_view *v, double out[3])
{
    for (int c = 0; c < 3; c++) {
        const double g = r->desc.isotropic_phase
                             ? 0.0
                             : (1.0 - (double)v->w2) * (double)v->g[c] + (double)v->w2 * (double)v->g2;
        const double a = (double)v->albedo[c];
        out[c] = (double)v->sigma_ext[c] * sqrt(fmax(3.0 * (1.0 - a) * (1.0 - a * g), 0.0));
    }
}

static void ambient_radiance(const sq_world *w, sq_vec3 *from_sky, sq_vec3 *from_ground);

/* The ambient radiance texture of the view: per voxel the sky's half of the ambient times its
 * visibility plus the ground's half times its visibility (volume_sky.c), RGB. The visibility is
 * recomputed when the density, its size or its optics change, the texture when it or the
 * ambient colours change; with render_desc.volume_ambient_uniform a single texel holding the
 * unattenuated ambient. One texture fetch per eye-pass fragment. */
static sq_result ambient_texture(sq_renderer *r, const sq_volume_view *v, GLuint *tex)
{
    sq__volume_pass *vp = r->volume;
    sq_vec3 as, ag;
    ambient_radiance(r->world, &as, &ag);
    const float amb[6] = {as.x, as.y, as.z, ag.x, ag.y, ag.z};
    if (r->desc.volume_ambient_uniform) {
        const float one[3] = {as.x + ag.x, as.y + ag.y, as.z + ag.z};
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
        glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
        glTextureSubImage3D(vp->sky_one_tex, 0, 0, 0, 0, 1, 1, 1, GL_RGB, GL_FLOAT, one);
        *tex = vp->sky_one_tex;
        return SQ_OK;
    }
    double key[6];
    diffuse_sigma(r, v, key);
    key[3] = (double)v->size_m.x / v->nx;
    key[4] = (double)v->size_m.y / v->ny;
    key[5] = (double)v->size_m.z / v->nz;
    const bool same_dims = vp->sky_dims[0] == v->nx && vp->sky_dims[1] == v->ny &&
                           vp->sky_dims[2] == v->nz;
    const bool vis_ok = vp->sky_valid && same_dims && vp->sky_data == v->density &&
                        vp->sky_version == v->version && memcmp(key, vp->sky_key, sizeof key) == 0;
    if (vis_ok && memcmp(amb, vp->sky_amb, sizeof amb) == 0) {
        *tex = vp->sky_tex;
        return SQ_OK;
    }
    const size_t n = (size_t)v->nx * (size_t)v->ny * (size_t)v->nz;
    if (!vis_ok) {
        const size_t nw = sq__volume_sky_work_floats(v->nx, v->ny);
        if (vp->sky_cap < 6 * n) {
            sq_free(r->ctx, vp->sky_buf);
            vp->sky_cap = 0;
            if (!(vp->sky_buf = sq_alloc(r->ctx, sizeof(float) * 6 * n)))
                return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                                "volume pass: no memory for the ambient visibility of %zu voxels",
                                n);
            vp->sky_cap = 6 * n;
        }
        /* the sweep's scratch, later the radiance to upload (3 n floats) */
        const size_t nwork = nw > 3 * n ? nw : 3 * n;
        if (vp->sky_work_cap < nwork) {
            sq_free(r->ctx, vp->sky_work);
            vp->sky_work_cap = 0;
            if (!(vp->sky_work = sq_alloc(r->ctx, sizeof(float) * nwork)))
                return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render",
                                "volume pass: no memory for the ambient visibility sweep");
            vp->sky_work_cap = nwork;
        }
        vp->sky_valid = false;
        sq__volume_sky_visibility(v->density, v->nx, v->ny, v->nz, key + 3, key, vp->sky_work,
                                  vp->sky_buf);
    }
    if (!vp->sky_tex || !same_dims) {
        if (vp->sky_tex) glDeleteTextures(1, &vp->sky_tex);
        glCreateTextures(GL_TEXTURE_3D, 1, &vp->sky_tex);
        glTextureStorage3D(vp->sky_tex, 1, GL_RGBA32F, v->nx, v->ny, v->nz);
        set_linear_clamp(vp->sky_tex);
    }
    set_wrap_y(vp->sky_tex, v);
    float *rad = vp->sky_work;
    const float *vs = vp->sky_buf, *vg = vp->sky_buf + 3 * n;
    for (size_t q = 0; q < 3 * n; q += 3)
        for (int c = 0; c < 3; c++) rad[q + c] = amb[c] * vs[q + c] + amb[3 + c] * vg[q + c];
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glPixelStorei(GL_UNPACK_IMAGE_HEIGHT, 0);
    glTextureSubImage3D(vp->sky_tex, 0, 0, 0, 0, v->nx, v->ny, v->nz, GL_RGB, GL_FLOAT, rad);
    vp->sky_valid = true;
    vp->sky_data = v->density;
    vp->sky_version = v->version;
    vp->sky_dims[0] = v->nx;
    vp->sky_dims[1] = v->ny;
    vp->sky_dims[2] = v->nz;
    memcpy(vp->sky_key, key, sizeof key);
    memcpy(vp->sky_amb, amb, sizeof amb);
    *tex = vp->sky_tex;
    return sq__gl_check(r->ctx, "volume ambient radiance upload");
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
static void um4(GLuint prog, const char *name, const sq_mat4 *m)
{
    glProgramUniformMatrix4fv(prog, glGetUniformLocation(prog, name), 1, GL_FALSE, m->m);
}

static void set_common_uniforms(GLuint prog, const sq_volume_view *v, const vol_plan *p)
{
    u3(prog, "u_box_lo", p->lo);
    u3(prog, "u_box_size", p->size);
    u3(prog, "u_tex_lo", p->tex_lo);
    u3(prog, "u_tex_size", p->tex_size);
    u3(prog, "u_s", p->s);
    u3(prog, "u_wl", p->wl);
    u1f(prog, "u_dlambda", p->dlambda);
    u3a(prog, "u_sigma_ext", v->sigma_ext);
    u3a(prog, "u_albedo", v->albedo);
}

/* Compiles a vertex + fragment program with `#define <defines>` inserted after the fragment
 * shader's #version line (a #line directive keeps the driver's line numbers). */
static sq_result variant_program(sq_renderer *r, const char *vert, const char *frag,
                                 const char *defines, GLuint *out)
{
    *out = 0;
    const char *vs = sq__shader_source(vert), *fs = sq__shader_source(frag);
    const char *eol = fs ? strchr(fs, '\n') : NULL;
    if (!vs || !eol)
        return sq__fail(r->ctx, SQ_ERR_INTERNAL, "render",
                        "no embedded shader \"%s\" or \"%s\" with a #version line", vert, frag);
    const size_t head = (size_t)(eol - fs) + 1, len = strlen(fs);
    char *text = sq_alloc(r->ctx, len + strlen(defines) + 32);
    if (!text)
        return sq__fail(r->ctx, SQ_ERR_OUT_OF_MEMORY, "render", "no memory for shader %s", frag);
    memcpy(text, fs, head);
    sprintf(text + head, "#define %s\n#line 2\n", defines);
    strcat(text + head, fs + head);
    GLuint sh[2] = {0, 0};
    sq_result res = sq__gl_shader_compile(r->ctx, GL_VERTEX_SHADER, vert, vs, &sh[0]);
    if (res == SQ_OK) res = sq__gl_shader_compile(r->ctx, GL_FRAGMENT_SHADER, frag, text, &sh[1]);
    if (res == SQ_OK) res = sq__gl_program_link(r->ctx, frag, sh, 2, out);
    glDeleteShader(sh[0]);
    glDeleteShader(sh[1]);
    sq_free(r->ctx, text);
    return res;
}

/* Selects (compiling on first use) the light program for the plan: single-scatter ablation,
 * forward in-scatter of the centre texel, or with the blur ring when its radius reaches half
 * a texel; and sets its uniforms. */
static sq_result set_light_uniforms(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    sq__volume_pass *vp = r->volume;
    const float n = (float)vp->light_size;
    const bool wide = fmaxf(p->blur_uv[0], p->blur_uv[1]) * n >= 0.5f;
    const int mode = r->desc.single_scatter_only ? 0 : (wide ? 2 : 1);
    const int steps = mode == 2 ? 1 : VOL_LIGHT_GROUP;
    if (!vp->prog_light[mode]) {
        char def[64];
        snprintf(def, sizeof def, "VOL_LIGHT_MODE %d\n#define VOL_LIGHT_STEPS %d", mode, steps);
        sq_result res = variant_program(r, "volume_light.vert", "volume_light.frag", def,
                                        &vp->prog_light[mode]);
        if (res != SQ_OK) return res;
        vp->loc_plane[mode] = glGetUniformLocation(vp->prog_light[mode], "u_plane");
        vp->loc_src[mode] = glGetUniformLocation(vp->prog_light[mode], "u_src");
    }
    vp->light_mode = mode;
    vp->light_steps = steps;
    const GLuint prog = vp->prog_light[mode];
    set_common_uniforms(prog, v, p);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_size"), n, n);
    glProgramUniform4f(prog, glGetUniformLocation(prog, "u_uv_rect"), p->u0, p->v0, p->u1, p->v1);
    u3(prog, "u_e1", p->e1);
    u3(prog, "u_e2", p->e2);
    u3a(prog, "u_forward", p->forward);
    glProgramUniform2f(prog, glGetUniformLocation(prog, "u_blur"), p->blur_uv[0], p->blur_uv[1]);
    const float wl[3] = {p->wl.x, p->wl.y, p->wl.z};
    float inv_wl[3];
    for (int c = 0; c < 3; c++)
        inv_wl[c] = fabsf(wl[c]) > 1e-10f ? 1.0f / wl[c] : (wl[c] < 0.0f ? -1e10f : 1e10f);
    u3a(prog, "u_inv_wl", inv_wl);
    return SQ_OK;
}

/* Radiance units: the renderer's surfaces reflect albedo * (sun_radiance cos + ambient), i.e.
 * a white Lambertian plane facing the sun has radiance sun_radiance, so the sun's irradiance
 * is E = pi * sun_radiance and the in-scattered radiance of a medium is E p(theta) per unit
 * scattering depth. */
static sq_vec3 sun_irradiance(const sq_world *w) { return sq_v3_scale(w->sun_radiance, SQ_PI_F); }

/* Phase-averaged ambient radiance on the medium: the sky above (the mean of the base renderer's
 * hemisphere blend, mix(horizon, zenith, 0.35)) and the ground below (Lambertian, lit by the
 * sun and that sky), each over half the sphere (isotropic weighting of the two hemispheres).
 * Same units as sq_ambient() of frame_common.glsl, with no factor pi in either: under a
 * uniform environment of radiance L a white Lambertian surface receives pi L and reflects
 * radiance L, and a scattering medium of albedo 1 in-scatters integral L p dω = L. */
static void ambient_radiance(const sq_world *w, sq_vec3 *from_sky, sq_vec3 *from_ground)
{
    const sq_vec3 sky = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const sq_vec3 sun = sq_v3_norm(w->sun_dir);
    const float mu = sun.z > 0.0f ? sun.z : 0.0f;
    const sq_vec3 ground =
        sq_v3_mul(w->ground_albedo, sq_v3_add(sq_v3_scale(w->sun_radiance, mu), sky));
    *from_sky = sq_v3_scale(sky, 0.5f);
    *from_ground = sq_v3_scale(ground, 0.5f);
}

/* Selects (compiling on first use) the eye program for the medium (one exponential per
 * transmittance when the extinction is grey) and sets its uniforms and those of the bounds
 * pass, which evaluates what depends on the pixel's ray only (slab length, near-plane cut,
 * phase function). */
static sq_result set_eye_uniforms(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    sq__volume_pass *vp = r->volume;
    const bool grey_ext = v->sigma_ext[0] == v->sigma_ext[1] && v->sigma_ext[1] == v->sigma_ext[2];
    const int variant = grey_ext ? 1 : 0;
    if (!vp->prog_eyes[variant]) {
        sq_result res = variant_program(r, "volume_slice.vert", "volume_eye.frag",
                                        grey_ext ? "VOL_GREY_EXT 1" : "VOL_GREY_EXT 0",
                                        &vp->prog_eyes[variant]);
        if (res != SQ_OK) return res;
    }
    vp->prog_eye = vp->prog_eyes[variant];
    const GLuint prog = vp->prog_eye;
    set_common_uniforms(prog, v, p);
    um4(prog, "u_view_proj", &r->view_proj);
    u3(prog, "u_cam", r->cam_pos);
    um4(prog, "u_light_matrix", &p->light_matrix);
    const float wl[3] = {p->wl.x, p->wl.y, p->wl.z};
    float inv_back[3];
    for (int c = 0; c < 3; c++)
        inv_back[c] = fabsf(wl[c]) > 1e-10f ? -1.0f / wl[c] : (wl[c] > 0.0f ? -1e10f : 1e10f);
    u3a(prog, "u_inv_back", inv_back);
    u3(prog, "u_sun_radiance", sun_irradiance(r->world));
    /* multiple scattering: diffusion (render_internal.h, sq__volume_ms_diffusion) or the
     * octaves (sq__volume_ms_weight) */
    const int ms_mode = r->desc.volume_ms == SQ_VOLUME_MS_DIFFUSION ? 2
                        : r->desc.volume_ms == SQ_VOLUME_MS_OCTAVES ? 1
                                                                     : 0;
    glProgramUniform1i(prog, glGetUniformLocation(prog, "u_ms_mode"), ms_mode);
    glProgramUniform1i(prog, glGetUniformLocation(prog, "u_ms_octaves"),
                       r->desc.volume_octaves - 1);
    glProgramUniform3f(prog, glGetUniformLocation(prog, "u_ms_abc"), (float)SQ_VOL_MS_A,
                       (float)SQ_VOL_MS_B, (float)SQ_VOL_MS_C);
    u1f(prog, "u_ms_g", r->desc.isotropic_phase ? 0.0f : v->g[1]);

    const GLuint pb = vp->prog_bounds;
    um4(pb, "u_inv_view_proj", &r->inv_view_proj);
    glProgramUniform2f(pb, glGetUniformLocation(pb, "u_viewport"), (float)r->width,
                       (float)r->height);
    u3(pb, "u_cam", r->cam_pos);
    u3(pb, "u_box_lo", p->lo);
    u3(pb, "u_box_size", p->size);
    um4(pb, "u_view_proj", &r->view_proj);
    u3(pb, "u_s", p->s);
    u1f(pb, "u_spacing", p->spacing);
    u3(pb, "u_cam_forward", sq_v3_norm(r->cam_forward));
    u1f(pb, "u_near", r->near_m);
    u3(pb, "u_sun_dir", p->sun_dir);
    const bool iso = r->desc.isotropic_phase;
    float g[3];
    for (int c = 0; c < 3; c++) g[c] = iso ? 0.0f : v->g[c];
    u3a(pb, "u_g", g);
    glProgramUniform2f(pb, glGetUniformLocation(pb, "u_g2w2"), iso ? 0.0f : v->g2, v->w2);
    /* slices behind opaque dust are not drawn (volume_bounds.frag) */
    u3(pb, "u_tex_lo", p->tex_lo);
    u3(pb, "u_tex_size", p->tex_size);
    u1f(pb, "u_d_first", p->d_first);
    glProgramUniform1i(pb, glGetUniformLocation(pb, "u_planes"), p->n);
    u1f(pb, "u_sigma_min", fminf(v->sigma_ext[0], fminf(v->sigma_ext[1], v->sigma_ext[2])));
    u1f(pb, "u_tau_stop", VOL_TAU_STOP);
    sq_vec3 dlo = vp->dust.lo, dhi = vp->dust.hi;
    if (v->mirror_y_m > 0.0f && dlo.x <= dhi.x) { /* mirrored beyond the y faces: all of y */
        dlo.y = p->lo.y;
        dhi.y = p->hi.y;
    }
    u3(pb, "u_dust_lo", dlo);
    u3(pb, "u_dust_hi", dhi);
    return SQ_OK;
}

/* The density the passes sample: the uploaded one, or with render.volume_noise its
 * noise-perturbed bake for this frame's noise offset (computed once per frame). */
static GLuint shading_density(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    sq__volume_pass *vp = r->volume;
    if (!r->desc.volume_noise) return vp->density_tex;
    if (vp->baked_valid && vp->baked_data == v->density && vp->baked_version == v->version &&
        memcmp(vp->baked_offset, p->noise_offset, sizeof vp->baked_offset) == 0)
        return vp->baked_tex;
    const size_t cells = (size_t)v->nx * (size_t)v->ny * (size_t)v->nz;
    const int up = cells * VOL_BAKE_UPSAMPLE * VOL_BAKE_UPSAMPLE * VOL_BAKE_UPSAMPLE <=
                           VOL_BAKE_MAX_VOXELS
                       ? VOL_BAKE_UPSAMPLE
                       : 1;
    const int bx = v->nx * up, by = v->ny * up, bz = v->nz * up;
    if (!vp->baked_tex) {
        glCreateTextures(GL_TEXTURE_3D, 1, &vp->baked_tex);
        glTextureStorage3D(vp->baked_tex, 1, GL_R32F, bx, by, bz);
        set_linear_clamp(vp->baked_tex);
    }
    const GLuint prog = vp->prog_bake;
    glProgramUniform3i(prog, glGetUniformLocation(prog, "u_dims"), bx, by, bz);
    glProgramUniform3i(prog, glGetUniformLocation(prog, "u_src_dims"), v->nx, v->ny, v->nz);
    u1f(prog, "u_noise_amp", VOL_NOISE_AMP_VOXELS);
    u1f(prog, "u_noise_freq", VOL_NOISE_FREQ / (float)VOL_NOISE_N);
    u3a(prog, "u_noise_offset", p->noise_offset);
    glBindTextureUnit(0, vp->density_tex);
    glBindTextureUnit(5, vp->noise_tex);
    glBindImageTexture(0, vp->baked_tex, 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_R32F);
    glUseProgram(prog);
    glDispatchCompute((GLuint)(bx + 7) / 8, (GLuint)(by + 7) / 8, (GLuint)bz);
    glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT);
    glBindImageTexture(0, 0, 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
    vp->baked_valid = true;
    vp->baked_data = v->density;
    vp->baked_version = v->version;
    memcpy(vp->baked_offset, p->noise_offset, sizeof vp->baked_offset);
    return vp->baked_tex;
}

/* True if slab k overlaps the box along s (otherwise the light pass would copy). */
static bool slab_in_box(const vol_plan *p, int k)
{
    const float d = p->d_first + (float)k * p->spacing;
    return d + 0.5f * p->spacing > p->smin && d - 0.5f * p->spacing < p->smax;
}

void sq__volume_pass_layout(const sq_renderer *r, int *chunks, int *chunk_len)
{
    const sq__volume_pass *vp = r ? r->volume : NULL;
    if (chunks) *chunks = vp ? vp->chunks : 0;
    if (chunk_len) *chunk_len = vp ? vp->chunk_len : 0;
}

static int chunk_first(const sq__volume_pass *vp, int c) { return c * vp->chunk_len; }
static int chunk_end(const sq__volume_pass *vp, const vol_plan *p, int c)
{
    const int e = (c + 1) * vp->chunk_len;
    return e < p->n ? e : p->n;
}

/* Layer of the light arriving at every plane: chunk c starts from checkpoint layer c, and each
 * in-box slab of the chunk writes the next working layer (from layer `chunks` on), as
 * sweep_chunk does. */
static void assign_slots(sq__volume_pass *vp, const vol_plan *p)
{
    for (int c = 0; c < vp->chunks; c++) {
        int src = c, steps = 0;
        for (int k = chunk_first(vp, c); k < chunk_end(vp, p, c); k++) {
            vp->slot[k] = src;
            if (slab_in_box(p, k)) src = vp->chunks + steps++;
        }
    }
}

static int count_steps(const vol_plan *p)
{
    int s = 0;
    for (int k = 0; k < p->n; k++) s += slab_in_box(p, k) ? 1 : 0;
    return s;
}

/* One light pass: the light of layer src carried across the n slabs k, k + 1, ... (in the box,
 * n <= light_steps) into layers dst, dst + 1, ... */
static void light_pass(sq__volume_pass *vp, const vol_plan *p, int k, int n, int src, int dst)
{
    const int m = vp->light_mode;
    GLenum bufs[VOL_LIGHT_GROUP];
    for (int i = 0; i < vp->light_steps; i++) {
        bufs[i] = i < n ? GL_COLOR_ATTACHMENT0 + (GLenum)i : GL_NONE;
        if (i < n)
            glNamedFramebufferTextureLayer(vp->light_fbo, GL_COLOR_ATTACHMENT0 + (GLenum)i,
                                           vp->light_arr, 0, dst + i);
    }
    glNamedFramebufferDrawBuffers(vp->light_fbo, vp->light_steps, bufs);
    glProgramUniform1f(vp->prog_light[m], vp->loc_plane[m], p->d_first + (float)k * p->spacing);
    glProgramUniform1i(vp->prog_light[m], vp->loc_src[m], src);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glTextureBarrier(); /* the next pass reads a layer this one wrote */
}

/* Runs the light passes of chunk c from its checkpoint (program, textures, FBO and viewport
 * bound by the caller), up to light_steps consecutive in-box slabs per pass. With store_next,
 * the light after the chunk becomes checkpoint c + 1. Returns the layer holding the light
 * after the chunk. */
static int sweep_chunk(sq_renderer *r, const vol_plan *p, int c, bool store_next)
{
    sq__volume_pass *vp = r->volume;
    int src = c, steps = 0;
    const int end = chunk_end(vp, p, c);
    for (int k = chunk_first(vp, c); k < end;) {
        if (!slab_in_box(p, k)) {
            k++;
            continue;
        }
        int n = 1;
        while (n < vp->light_steps && k + n < end && slab_in_box(p, k + n)) n++;
        const int dst = vp->chunks + steps;
        light_pass(vp, p, k, n, src, dst);
        if (sq__render_part_done(r)) break; /* Ctrl-C: the frame ends (renderer.c) */
        steps += n;
        src = dst + n - 1;
        k += n;
    }
    if (store_next && c + 1 < vp->chunks) {
        const int n = vp->light_size;
        glCopyImageSubData(vp->light_arr, GL_TEXTURE_2D_ARRAY, 0, 0, 0, src, vp->light_arr,
                           GL_TEXTURE_2D_ARRAY, 0, 0, 0, c + 1, n, n, 1);
    }
    vp->resident = sq__render_cancelled(r) ? -1 : c; /* a chunk cut short is not resident */
    return src;
}

/* The eye pass over the slices of chunk c, back to front as they lie in the vertex buffer, each
 * inside its window rectangle (vp->scissor: the fragments outside it are clear air, which the
 * eye shader discards, so the picture is the same pixel for pixel, and llvmpipe neither bins
 * nor shades them); in VOL_EYE_PARTS parts with sq__render_part_done after each, so that
 * Ctrl-C reaches a pass of seconds on llvmpipe. */
#define VOL_EYE_PARTS 16
static void draw_slices_culled(sq_renderer *r, const vol_plan *p, int c)
{
    const sq__volume_pass *vp = r->volume;
    const int k0 = chunk_first(vp, c), k1 = chunk_end(vp, p, c), count = k1 - k0;
    const int per = (count + VOL_EYE_PARTS - 1) / VOL_EYE_PARTS;
    glEnable(GL_SCISSOR_TEST);
    for (int i = 0; i < count; i++) {
        const int k = p->front_to_back ? k1 - 1 - i : k0 + i;
        const int *rect = vp->scissor + 4 * k;
        if (vp->vcount[k] > 0 && rect[2] > 0 && rect[3] > 0) {
            glScissor(rect[0], rect[1], rect[2], rect[3]);
            glDrawArrays(GL_TRIANGLES, vp->vfirst[k], vp->vcount[k]);
        }
        if (((i + 1) % per == 0 || i + 1 == count) && sq__render_part_done(r)) break;
    }
    glDisable(GL_SCISSOR_TEST);
}

static void bind_light_pass(sq__volume_pass *vp, GLuint density)
{
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->light_fbo);
    glViewport(0, 0, vp->light_size, vp->light_size);
    glUseProgram(vp->prog_light[vp->light_mode]);
    glBindVertexArray(vp->vao_empty);
    glBindTextureUnit(0, density);
    glBindTextureUnit(1, vp->light_arr);
}

static vol_key make_key(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    vol_key k;
    memset(&k, 0, sizeof k); /* padding too: keys are compared with memcmp */
    k.plan = *p;
    k.data = v->density;
    k.version = v->version;
    k.nx = v->nx;
    k.ny = v->ny;
    k.nz = v->nz;
    memcpy(k.sigma_ext, v->sigma_ext, sizeof k.sigma_ext);
    memcpy(k.albedo, v->albedo, sizeof k.albedo);
    k.light_size = r->volume->light_size;
    k.noise = r->desc.volume_noise;
    k.multiple = !r->desc.single_scatter_only;
    return k;
}

/* All light passes of the plan, once (SPEC 3.4 step 4b): every plane's incoming light ends up
 * in the light array (or, chunked, its chunk's checkpoint), the last one in the shadow
 * texture published for the opaque and particle passes. */
static sq_result sweep_light(sq_renderer *r, const sq_volume_view *v, const vol_plan *p,
                             GLuint density)
{
    sq__volume_pass *vp = r->volume;
    vp->key_valid = false;
    sq_result res = ensure_light_layers(r, vp, p->n, count_steps(p));
    if (res != SQ_OK) return res;
    assign_slots(vp, p);
    if ((res = set_light_uniforms(r, v, p)) != SQ_OK) return res;
    bind_light_pass(vp, density);
    int last = 0;
    for (int c = 0; c < vp->chunks; c++) {
        last = sweep_chunk(r, p, c, true);
        if (sq__render_cancelled(r)) return SQ_OK; /* the key stays invalid; the frame ends */
    }
    const int n = vp->light_size;
    glCopyImageSubData(vp->light_arr, GL_TEXTURE_2D_ARRAY, 0, 0, 0, last, vp->shadow_tex,
                       GL_TEXTURE_2D, 0, 0, 0, 0, n, n, 1);
    r->sun_shadow_tex = vp->shadow_tex;
    r->sun_shadow_matrix = p->light_matrix;
    vp->key = make_key(r, v, p);
    vp->key_valid = true;
    return sq__gl_check(r->ctx, "volume light passes");
}

/* Fills the slice polygons as triangles, back to front for the eye, each vertex carrying its
 * plane's light layer; returns the vertex count. */
/* The slice polygons (the planes cut by the box grown by VOL_MARGIN_SPACINGS) into the vertex
 * buffer, and each plane's window rectangle outside which its fragments are clear air
 * (sq__volume_slice_rect; the whole window with render.volume_noise, whose bake moves the
 * density by up to VOL_NOISE_AMP_VOXELS). */
static int build_slices(sq_renderer *r, const sq_volume_view *v, const vol_plan *p)
{
    sq__volume_pass *vp = r->volume;
    const float grow = VOL_MARGIN_SPACINGS * p->spacing;
    const sq_vec3 glo = sq_v3_sub(p->lo, sq_v3(grow, grow, grow));
    const sq_vec3 ghi = sq_v3_add(p->hi, sq_v3(grow, grow, grow));
    const sq_vec3 forward = sq_v3_norm(r->cam_forward);
    int nv = 0;
    for (int i = 0; i < p->n; i++) {
        /* increasing d is front to back when the light comes from behind the viewer */
        const int k = p->front_to_back ? p->n - 1 - i : i;
        sq_vec3 poly[6];
        const float d = p->d_first + (float)k * p->spacing;
        const int m = plane_box_polygon(glo, ghi, p->s, d, poly);
        vp->vfirst[k] = nv;
        vp->vcount[k] = m >= 3 ? 3 * (m - 2) : 0;
        int *rect = vp->scissor + 4 * k;
        if (r->desc.volume_noise) {
            rect[0] = rect[1] = 0;
            rect[2] = r->width;
            rect[3] = r->height;
        } else {
            sq__volume_slice_rect(&vp->dust, v->mirror_y_m > 0.0f, glo, ghi, p->s, d,
                                  &r->view_proj, r->cam_pos, forward, r->near_m, r->width,
                                  r->height, rect);
        }
        const float layer = (float)vp->slot[k];
        for (int t = 1; t + 1 < m; t++) {
            const sq_vec3 tri[3] = {poly[0], poly[t], poly[t + 1]};
            for (int c = 0; c < 3; c++) {
                float *o = vp->verts + VOL_VERT_FLOATS * (size_t)nv++;
                o[0] = tri[c].x;
                o[1] = tri[c].y;
                o[2] = tri[c].z;
                o[3] = layer;
            }
        }
    }
    glNamedBufferSubData(vp->vbo_slices, 0,
                         (GLsizeiptr)(sizeof(float) * VOL_VERT_FLOATS * (size_t)nv), vp->verts);
    return nv;
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
    set_wrap_y(r->volume->density_tex, v);
    set_wrap_y(r->volume->baked_tex, v);
    make_plan(r, v, p);
    if (p->n > r->volume->plane_cap) p->n = r->volume->plane_cap; /* K + 64; not reached */
    return SQ_OK;
}

sq_result sq__volume_pass_prepare_shadow(sq_renderer *r, const sq_volume_view *v)
{
    vol_plan p;
    sq_result res = prepare(r, v, &p);
    if (res != SQ_OK) return res;
    gl_saved saved;
    state_save(&saved);
    state_set_plain();
    const GLuint density = shading_density(r, v, &p);
    res = sweep_light(r, v, &p, density);
    state_restore(&saved);
    return res;
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

    gl_saved saved;
    state_save(&saved);
    state_set_plain();
    const GLuint density = shading_density(r, v, &p);
    GLuint ambient = 0;
    if ((res = ambient_texture(r, v, &ambient)) != SQ_OK) {
        state_restore(&saved);
        return res;
    }
    /* the light of this plan is normally left by prepare_shadow; another volume drawn in
     * between (or a draw without it) needs the sweep again */
    const vol_key key = make_key(r, v, &p);
    if (!vp->key_valid || memcmp(&key, &vp->key, sizeof key) != 0)
        res = sweep_light(r, v, &p, density);
    if (res != SQ_OK) {
        state_restore(&saved);
        return res;
    }
    build_slices(r, v, &p);
    if ((res = set_light_uniforms(r, v, &p)) != SQ_OK) {
        state_restore(&saved);
        return res;
    }
    if ((res = set_eye_uniforms(r, v, &p)) != SQ_OK) {
        state_restore(&saved);
        return res;
    }

    /* per-pixel ray interval the volume may fill (box, camera, opaque depth) */
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->bounds_fbo);
    glViewport(0, 0, r->width, r->height);
    glBindTextureUnit(0, density);
    glBindTextureUnit(2, r->depth_tex);
    glUseProgram(vp->prog_bounds);
    glBindVertexArray(vp->vao_empty);
    glEnable(GL_DEPTH_TEST); /* depth writes need the test on */
    glDepthFunc(GL_ALWAYS);
    glDepthMask(GL_TRUE);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDepthMask(GL_FALSE);
    glDisable(GL_DEPTH_TEST);

    /* the scene into the float accumulation buffer */
    glBlitNamedFramebuffer(vp->comp_fbo, vp->acc_fbo, 0, 0, r->width, r->height, 0, 0, r->width,
                           r->height, GL_COLOR_BUFFER_BIT, GL_NEAREST);

    /* slices back to front, chunk by chunk (one chunk unless the light array is chunked) */
    for (int i = 0; i < vp->chunks && !sq__render_cancelled(r); i++) {
        const int c = p.front_to_back ? vp->chunks - 1 - i : i;
        if (vp->resident != c) {
            state_set_plain();
            bind_light_pass(vp, density);
            sweep_chunk(r, &p, c, false);
        }
        int first = vp->vfirst[chunk_first(vp, c)], last = first;
        for (int k = chunk_first(vp, c); k < chunk_end(vp, &p, c); k++) {
            if (vp->vfirst[k] < first) first = vp->vfirst[k];
            if (vp->vfirst[k] + vp->vcount[k] > last) last = vp->vfirst[k] + vp->vcount[k];
        }
        if (last <= first) continue;
        glBindFramebuffer(GL_DRAW_FRAMEBUFFER, vp->acc_fbo);
        glViewport(0, 0, r->width, r->height);
        glUseProgram(vp->prog_eye);
        glBindVertexArray(vp->vao_slices);
        glBindTextureUnit(0, density);
        glBindTextureUnit(1, vp->light_arr);
        glBindTextureUnit(2, vp->bounds_tex);
        glBindTextureUnit(3, vp->phase_tex);
        glBindTextureUnit(4, ambient);
        glBindTextureUnit(5, vp->shadow_tex); /* alpha: the sun ray's whole optical depth */
        glEnable(GL_BLEND);
        glBlendEquation(GL_FUNC_ADD);
        glBlendFuncSeparate(GL_ONE, GL_SRC1_COLOR, GL_ZERO, GL_ONE);
        glEnable(GL_DEPTH_TEST); /* early rejection behind the per-pixel bound; no writes */
        glDepthFunc(GL_LEQUAL);
        glDepthMask(GL_FALSE);
        draw_slices_culled(r, &p, c);
    }
    glDisable(GL_BLEND);
    glDisable(GL_DEPTH_TEST);

    /* back into the HDR target */
    glBlitNamedFramebuffer(vp->acc_fbo, vp->comp_fbo, 0, 0, r->width, r->height, 0, 0, r->width,
                           r->height, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    state_restore(&saved);
    return sq__gl_check(r->ctx, "volume pass (half-angle slicing)");
}
