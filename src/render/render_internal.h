/* render_internal.h — the renderer's private state shared by its passes. Owned by the base
 * renderer (renderer.c: context, frame buffers, sky, terrain, obstacles, surfaces, tone
 * mapping); the volume pass (render_volume.c) and the particle pass (render_particles.c) add
 * their state through the opaque pointers below and draw through the functions declared here.
 * GL lives on the thread that created the renderer. */
#ifndef SQ_RENDER_INTERNAL_H
#define SQ_RENDER_INTERNAL_H

#include <math.h>
#include <epoxy/gl.h>

#include "core/core_internal.h"
#include "squall/render.h"

typedef struct sq__gl_context sq__gl_context;       /* EGL display + context (gl_context.c) */
typedef struct sq__volume_pass sq__volume_pass;     /* render_volume.c */
typedef struct sq__particle_pass sq__particle_pass; /* render_particles.c */
typedef struct sq__clouds_pass sq__clouds_pass;     /* render_clouds.c */
typedef struct sq__mesh_pass sq__mesh_pass;         /* render_meshes.c */
typedef struct sq__shadow_pass sq__shadow_pass;     /* render_shadow.c */
typedef struct sq__snow_pass sq__snow_pass;         /* render_snowcover.c */

/* A tile of the terrain mesh: its indices (first, count) and its bounding box. */
typedef struct sq__terrain_tile {
    GLsizei first, count;
    float lo[3], hi[3];
} sq__terrain_tile;

struct sq_renderer {
    sq_context *ctx;
    sq_render_desc desc;  /* resolved */
    int width, height;
    sq__gl_context *gl;   /* NULL when drawing in the caller's context */
    bool external;        /* desc.use_current_context: the caller's context, state restored */
    sq_render_info info;

    /* HDR scene target: linear RGB (RGBA16F) + depth texture (DEPTH_COMPONENT32F). Opaque
     * passes write both; volumes and particles read depth_tex and blend into hdr_color. */
    GLuint hdr_fbo, hdr_color, depth_tex;
    GLenum depth_format;  /* of depth_tex: DEPTH_COMPONENT32F, or the draw_to target's format */
    /* tone-mapped 8-bit target for read-back */
    GLuint ldr_fbo, ldr_color;
    GLuint empty_vao; /* for full-screen triangles */

    /* per-frame camera */
    sq_mat4 view, proj, view_proj, inv_view_proj;
    sq_vec3 cam_pos, cam_forward, cam_right, cam_up;
    float near_m, far_m;
    double time_s;
    const sq_world *world;

    /* world geometry cache (rebuilt when world->generation changes) */
    uint64_t world_generation;
    GLuint terrain_vao, terrain_vbo, terrain_ibo;
    GLsizei terrain_index_count;
    /* the terrain's triangles in tiles (renderer.c build_terrain), culled per view */
    sq__terrain_tile *terrain_tiles;
    int terrain_tile_count;
    GLsizei *tile_counts;   /* scratch of the multi-draw: per visible run of tiles */
    const void **tile_offsets;
    float shell_max_m;      /* how far the snow shell may move a vertex this frame (m) */
    bool shell_everywhere;  /* tests: every instance drawn with the shell (no far slots) */
    bool depth_cull_off;    /* tests: depth views draw the back faces of closed meshes too (and
                             * the occlusion map its vertical faces) */
    float map_lod_pixels;   /* tests: the occlusion map's level choice (0: render_snowcover.c's rule) */
    bool map_no_sink;       /* tests: the occlusion map's levels not sunk by their error */
    int64_t terrain_faces;  /* triangles of the terrain drawn since the frame began */
    double terrain_max_slope; /* steepest triangle of the terrain mesh, |grad z| */
    GLuint obstacle_vao, obstacle_vbo;
    GLsizei obstacle_vertex_count;

    /* programs owned by the base renderer */
    GLuint prog_sky, prog_terrain, prog_mesh, prog_surface, prog_surface_depth, prog_tonemap;
    /* terrain and obstacles with snow cover (snow_common.glsl): compiled on the first frame with
     * a snow-cover drawable; prog_terrain and prog_mesh have it compiled out (SQ_NO_SNOW).
     * snow_on: this frame draws snow cover (sq__snow_pass_prepare) */
    GLuint prog_terrain_snow, prog_mesh_snow;
    bool snow_on;
    GLuint prog_target; /* sq_renderer_draw_to: target colour <-> linear frame (target.frag) */

    /* Sun shadowing by volumes: the volume pass leaves its final light buffer here (a 2D
     * texture of transmitted sun radiance over the volume box, seen from the sun) with the
     * matrix mapping world positions to its texture coordinates; 0 when no volume. Opaque
     * shading multiplies the sun term by it. Because opaque geometry is drawn before volumes,
     * the base renderer calls sq__volume_pass_prepare_shadow() before the opaque passes.
     * The opaque shaders read its rgb as a transmittance (fraction of the sun's light that
     * arrives, 1 = unshadowed) at texture coordinates (M * p).xy / (M * p).w, and use 1
     * outside [0,1]^2. The base renderer sets sun_shadow_tex = 0 at the start of each frame. */
    GLuint sun_shadow_tex;
    sq_mat4 sun_shadow_matrix;

    sq__volume_pass *volume;
    sq__particle_pass *particles;
    sq__clouds_pass *clouds;
    sq__mesh_pass *meshes;
    sq__shadow_pass *shadow;
    sq__snow_pass *snow;

    /* Frame constants (renderer.c): a uniform buffer bound at binding 0 for the whole frame,
     * the `Frame` block of shaders/frame_common.glsl (camera, sun, sky, near/far, viewport,
     * sun shadow matrix). Any pass may `#include "frame_common.glsl"` to read it and to use
     * the sky model, ambient light and haze of the opaque passes. The Frame block also binds
     * sampler unit 7 (u_sun_shadow); passes that include it leave unit 7 alone. */
    GLuint frame_ubo;
    GLuint white_tex;           /* 1x1 white RGBA8: bound at unit 7 when no sun shadow */
    struct sq__base_cache *base; /* renderer.c: surface textures, validation cache */
    sq_render_stats stats;      /* of the last frame (sq_renderer_stats) */
    bool cancelled;             /* the context was cancelled during this frame (sticky) */
    GLsync part_fence;          /* the last part of a long pass in flight (sq__render_part_done) */
};

/* ---- gl_context.c ---------------------------------------------------------------------- */
/* Creates a headless OpenGL 4.5 core context (EGL surfaceless, else EGL device platform) and
 * makes it current. On failure the message says what failed and how to get a context. */
sq_result sq__gl_context_create(sq_context *ctx, const char *device_hint, sq__gl_context **out);
void sq__gl_context_destroy(sq__gl_context *gl);
void sq__gl_query_info(sq_render_info *info);
/* Makes the context current on this thread if it is not (renderers sharing a thread). */
sq_result sq__gl_context_make_current(sq__gl_context *gl);

/* ---- gl_state.c -------------------------------------------------------------------------- */
/* The caller's GL state around a renderer drawing in the caller's context (see render.h). */
#define SQ_GL_STATE_UNITS 16       /* texture units 0..15 (binding and sampler) */
#define SQ_GL_STATE_TEX_TARGETS 5  /* 2D, 3D, 2D array, cube map, buffer (mesh instances) */
#define SQ_GL_STATE_BUFFERS 8      /* indexed uniform and shader-storage bindings 0..7 */
#define SQ_GL_STATE_IMAGES 8       /* image units 0..7 */
#define SQ_GL_STATE_CAPS 24
#define SQ_GL_STATE_PIXEL 16

typedef struct sq__gl_buffer_binding {
    GLint name;
    GLint64 start, size;
} sq__gl_buffer_binding;

typedef struct sq__gl_image_binding {
    GLint name, level, layered, layer, access, format;
} sq__gl_image_binding;

typedef struct sq__gl_state {
    GLint draw_fbo, read_fbo, renderbuffer, viewport[4], scissor_box[4];
    GLint program, pipeline, vao, array_buffer, pack_buffer, unpack_buffer;
    GLint uniform_buffer, storage_buffer;
    sq__gl_buffer_binding ubo[SQ_GL_STATE_BUFFERS], ssbo[SQ_GL_STATE_BUFFERS];
    GLint active_texture;
    GLint textures[SQ_GL_STATE_UNITS][SQ_GL_STATE_TEX_TARGETS];
    GLint samplers[SQ_GL_STATE_UNITS];
    sq__gl_image_binding images[SQ_GL_STATE_IMAGES];
    GLboolean caps[SQ_GL_STATE_CAPS];
    GLint blend[6];
    GLfloat blend_color[4];
    GLint depth_func;
    GLboolean depth_mask;
    GLdouble depth_range[2];
    GLint clip_origin, clip_depth;
    GLboolean color_mask[4];
    GLint stencil_mask, stencil_back_mask;
    GLint polygon_mode[2];
    GLfloat offset_factor, offset_units;
    GLint cull_mode, front_face;
    GLint pixel[SQ_GL_STATE_PIXEL];
} sq__gl_state;

/* Saves everything the renderer may change; sets the state the renderer's passes assume. */
void sq__gl_state_save(sq__gl_state *s);
void sq__gl_state_neutral(void);
void sq__gl_state_restore(const sq__gl_state *s);

/* ---- gl_util.c --------------------------------------------------------------------------- */
/* Compiles and links a program from embedded shader files (names without .glsl, e.g.
 * "terrain.vert", "terrain.frag"; geometry optional NULL). Compile/link errors are reported
 * with the shader name and line. */
sq_result sq__gl_program(sq_context *ctx, const char *vert, const char *geom, const char *frag,
                         GLuint *out);
/* The same with defines ("#define NAME VALUE" lines) inserted after each stage's #version line
 * (program variants: a feature compiled out where a frame does not use it). */
sq_result sq__gl_program_defs(sq_context *ctx, const char *vert, const char *geom,
                              const char *frag, const char *defines, GLuint *out);
/* Text of an embedded shader file by name (NULL if none). */
const char *sq__shader_source(const char *name);
/* Translates glGetError into an sq_result with the place named. */
sq_result sq__gl_check(sq_context *ctx, const char *where);
/* A 2D texture of one level, w x h texels of format, filtered by filter (GL_NEAREST or GL_LINEAR)
 * both ways and clamped to its edge: what the renderer's maps and targets are made of. */
GLuint sq__gl_texture_2d(GLenum format, int w, int h, GLenum filter);
/* Compute program from one embedded shader ("x.comp"). */
sq_result sq__gl_compute_program(sq_context *ctx, const char *comp, GLuint *out);
/* Compiles one shader stage from text; name is used in messages ("name:line: error ...").
 * A line `#include "other.glsl"` (after #version) inserts an embedded shader file, whose
 * errors are reported under its own name. */
sq_result sq__gl_shader_compile(sq_context *ctx, GLenum stage, const char *name, const char *text,
                                GLuint *out);
/* Links compiled shaders (left attached to nothing; the caller deletes them). */
sq_result sq__gl_program_link(sq_context *ctx, const char *label, const GLuint *shaders, int n,
                              GLuint *out);
/* SQ_OK if the frame buffer object is complete, else SQ_ERR_GL naming it. */
sq_result sq__gl_check_framebuffer(sq_context *ctx, GLuint fbo, const char *what);

/* ---- renderer.c ------------------------------------------------------------------------- */
/* Terrain colours by kind: on gentle slopes and on slopes steeper than ~40 degrees. */
void sq__terrain_albedo(const sq_world *w, sq_vec3 *flat, sq_vec3 *steep);
/* Default albedo of a surface drawable's material. */
sq_vec3 sq__material_albedo(sq_material m);

/* ---- render_volume.c --------------------------------------------------------------------- */
/* Multiple-scattering octaves of the sun light in a volume (after Wrenninge, Kulla &
 * Lundqvist 2013, "Oz: the great and volumetric", SIGGRAPH talk): light scattered many times
 * is approximated by further copies of the single-scattering source whose extinction, weight
 * and phase asymmetry shrink by a, b and c per octave. Here octave i >= 1 adds only what its
 * weaker extinction lets through beyond the direct beam,
 *     albedo^i * b^i * (exp(-a^i tau) - exp(-tau)) * p_HG(theta, c^i g),
 * tau being the sun's optical depth to the point (green), so that it vanishes as tau^2 in thin
 * media (like true double scattering) and adds no energy there; the eye pass (volume_eye.frag)
 * evaluates this sum. tests/volume checks it against the line integral and that a conservative
 * slab sends out no more than it receives. */
#define SQ_VOL_MS_A 0.5 /* extinction scale per octave */
#define SQ_VOL_MS_B 0.5 /* weight per octave */
#define SQ_VOL_MS_C 0.85 /* phase asymmetry scale per octave */
static inline double sq__volume_ms_weight(int i, double tau)
{
    return pow(SQ_VOL_MS_B, i) * (exp(-pow(SQ_VOL_MS_A, i) * tau) - exp(-tau));
}

/* Multiple scattering of the sun light by diffusion (render_desc.volume_ms DIFFUSION, the
 * default): the light scattered out of the sun's beam at least once, in the delta-Eddington
 * P1 (diffusion) approximation of a slab along the sun ray (Joseph, Wiscombe & Weinman 1976,
 * J. Atmos. Sci. 33; Meador & Weaver 1980, J. Atmos. Sci. 37). The slab is the medium that the
 * sun ray through the point crosses: tau the sun's optical depth to the point, tau0 the whole
 * ray's (the light pass accumulates both). With the forward peak f = g^2 kept in the beam
 * (w' = w (1 - f) / (1 - w f), g' = g / (1 + g), depths t = (1 - w f) tau), the diffuse
 * fluence phi and flux F (along the sun's propagation, per unit sun irradiance) obey
 *     dF/dt = -(1 - w') phi + w' e^-t,   dphi/dt = -3 (1 - w' g') F + 3 w' g' e^-t,
 * plus the loss through the sides of a body of finite width W (geometric buckling
 * 2 (pi / W)^2, W = SQ_VOL_MS_WIDTH t0 + 4 h extrapolated, h = 1 / (3 (1 - w' g'))):
 * phi = A e^-kt + B e^-k(t0-t) + C e^-t, k^2 = 3 (1 - w')(1 - w' g') + 2 (pi / W)^2,
 * C = 3 w' (1 + g' - w' g') / (k^2 - 1), no diffuse light entering either face (Marshak:
 * phi + 2F = 0 at t = 0, phi - 2F = 0 at t0). The radiance (phi + 3 F cos) / 4pi scattered
 * toward the eye with the full phase function gives the source
 *     J_diff = max(phi + 3 g F cos(theta), 0) / (4 pi)
 * (per unit sun irradiance, before the albedo; theta between the sun's propagation and the
 * direction to the eye). The beam of the delta-Eddington picture, exp(-(1 - w f) tau), holds
 * light scattered into the forward peak that the light pass's beam exp(-tau) does not; it is
 * scattered to the eye once more (two HG lobes ~ one of g^2):
 *     J_beam = max(exp(-(1 - w f) tau) - exp(-tau), 0) p_HG(theta, g^2).
 * Both vanish in thin media faster than single scattering (J_diff ~ tau, J_beam ~ tau: their
 * light reaches the eye after a second scattering). From a semi-infinite layer (albedo 0.82,
 * g 0.69, the sun overhead) the model returns about 5 times what single scattering does,
 * close to Monte Carlo (tests/volume), and a conservative slab sends out no more than it
 * receives. SQ_VOL_MS_WIDTH was chosen among 0.5, 1, 2 by the comparison scenes of
 * docs/validation.md. volume_eye.frag evaluates the same expressions per channel. */
#define SQ_VOL_MS_K2_GUARD 0.01 /* |k^2 - 1| below this is moved to 1 -+ this (C's pole) */
#define SQ_VOL_MS_WIDTH 0.5     /* body width / sun ray's depth, for the sideways loss */
static inline double sq__volume_ms_diffusion(double w, double g, double tau, double tau0,
                                             double cos_theta)
{
    const double f = g * g, sc = 1.0 - w * f;
    double ws = w * (1.0 - f) / sc;
    if (ws > 0.999) ws = 0.999;
    const double gs = g / (1.0 + g);
    const double h = 1.0 / (3.0 * (1.0 - ws * gs));
    const double t = sc * tau, t0 = sc * (tau0 > tau ? tau0 : tau);
    const double wdt = SQ_VOL_MS_WIDTH * t0 + 4.0 * h, pi = 3.14159265358979323846;
    double k2 = 3.0 * (1.0 - ws) * (1.0 - ws * gs) + 2.0 * pi * pi / (wdt * wdt);
    if (fabs(k2 - 1.0) < SQ_VOL_MS_K2_GUARD)
        k2 = k2 < 1.0 ? 1.0 - SQ_VOL_MS_K2_GUARD : 1.0 + SQ_VOL_MS_K2_GUARD;
    const double k = sqrt(k2);
    const double C = 3.0 * ws * (1.0 + gs - ws * gs) / (k2 - 1.0), S = 3.0 * h * ws * gs;
    const double ek = exp(-k * t0), ec = exp(-t0);
    const double a11 = 1.0 + 2.0 * h * k, a12 = ek * (1.0 - 2.0 * h * k);
    const double r1 = -C * (1.0 + 2.0 * h) - 2.0 * S, r2 = -C * ec * (1.0 - 2.0 * h) + 2.0 * S * ec;
    const double det = a11 * a11 - a12 * a12;
    const double A = (r1 * a11 - a12 * r2) / det, B = (a11 * r2 - a12 * r1) / det;
    const double e1 = exp(-k * t), e2 = exp(-k * (t0 - t)), e3 = exp(-t);
    const double phi = A * e1 + B * e2 + C * e3;
    const double F = S * e3 - h * (-k * A * e1 + k * B * e2 - C * e3);
    const double j = phi + 3.0 * g * F * cos_theta;
    return j > 0.0 ? j / (4.0 * pi) : 0.0;
}
/* J_beam of the comment above (per unit sun irradiance, before the albedo). */
static inline double sq__volume_ms_beam(double w, double g, double tau, double cos_theta)
{
    const double f = g * g, b = exp(-(1.0 - w * f) * tau) - exp(-tau);
    const double d = 1.0 + f * f - 2.0 * f * cos_theta;
    return b > 0.0 ? b * (1.0 - f * f) / (4.0 * 3.14159265358979323846 * d * sqrt(d)) : 0.0;
}

/* The box around the non-zero voxels of a density grid (world metres; origin and size: the
 * grid's box), grown by the voxels within which the eye pass's density lookup reaches
 * (render_volume.c VOL_DUST_MARGIN): outside it that lookup reads 0. open_lo / open_hi: on that
 * side the grown box reaches the grid's face, beyond which the clamped texture repeats the
 * face's voxels (the box is then open there). empty: no voxel above 0. */
typedef struct sq__volume_dust {
    sq_vec3 lo, hi;
    bool open_lo[3], open_hi[3];
    bool empty;
} sq__volume_dust;
void sq__volume_dust_box(const float *density, int nx, int ny, int nz, sq_vec3 origin,
                         sq_vec3 size, sq__volume_dust *out);
/* The window rectangle (rect: x, y, w, h in pixels, origin bottom left) outside which no eye-pass
 * fragment of the slice plane s . x = d can meet dust: the plane cut by the part of the slice box
 * [glo, ghi] that the dust box covers (all of it along an open side, and along y when the
 * texture is mirrored there) and by the camera's near plane (forward . (x - cam) >= near_m),
 * projected with view_proj, grown by two pixels and clipped to the width x height window.
 * Returns false, rect all 0, where no fragment can. */
bool sq__volume_slice_rect(const sq__volume_dust *dust, bool mirror_y, sq_vec3 glo, sq_vec3 ghi,
                           sq_vec3 s, float d, const sq_mat4 *view_proj, sq_vec3 cam,
                           sq_vec3 forward, float near_m, int width, int height, int rect[4]);

/* The RGBA density texture of sharp edges: density, local maximum over 27 voxels, edge weight,
 * 0 (render_volume.c; rgba holds 4 nx ny nz floats). */
void sq__volume_edge_texture(const float *density, int nx, int ny, int nz, float sharpness,
                             float *rgba);
sq_result sq__volume_pass_create(sq_renderer *r);
void sq__volume_pass_destroy(sq_renderer *r);
/* Uploads (if its version changed) and runs the light passes so sun_shadow_tex is ready. */
sq_result sq__volume_pass_prepare_shadow(sq_renderer *r, const sq_volume_view *v);
/* Half-angle slicing into hdr_color, tested against depth_tex. */
sq_result sq__volume_pass_draw(sq_renderer *r, const sq_volume_view *v);
/* How the light array of the last frame was laid out: chunks (1 = unchunked) and planes per
 * chunk; 0, 0 before any volume frame. For tests of the chunked path. */
void sq__volume_pass_layout(const sq_renderer *r, int *chunks, int *chunk_len);

/* ---- render_particles.c ------------------------------------------------------------------ */
sq_result sq__particle_pass_create(sq_renderer *r);
void sq__particle_pass_destroy(sq_renderer *r);
/* Instanced camera-facing quads with soft depth fade, blended into hdr_color. */
sq_result sq__particle_pass_draw(sq_renderer *r, const sq_particles_view *p);

/* ---- render_clouds.c --------------------------------------------------------------------- */
sq_result sq__clouds_pass_create(sq_renderer *r);
void sq__clouds_pass_destroy(sq_renderer *r);
/* The particles' MFS light (cached while the view's version and the sun stay) and, when the
 * view asks for shadows and no volume set one, the sun shadow of the opaque passes. */
sq_result sq__clouds_pass_prepare(sq_renderer *r, const sq_clouds_view *v);
/* Impostors and back-to-front billboards into hdr_color, tested against depth_tex. */
sq_result sq__clouds_pass_draw(sq_renderer *r, const sq_clouds_view *v);
typedef struct sq__clouds_pass_stats {
    double ms_light;      /* last light computation (CPU) */
    double ms_draw_cpu;   /* last draw call's CPU side (sorting, packing, submission) */
    uint64_t relights, impostor_renders;
    int particles_drawn, impostors_drawn;
} sq__clouds_pass_stats;
void sq__clouds_pass_get_stats(const sq_renderer *r, sq__clouds_pass_stats *out);
/* ---- render_meshes.c, render_shadow.c: world meshes, sun shadows, depth views ----------- */
/* A view for drawing world geometry: its view-projection, and how it picks LODs and culls
 * small instances (pixels per metre: orthographic views have one value; perspective views give
 * it at 1 m and divide by the distance from eye). */
typedef struct sq__depth_view {
    sq_mat4 view_proj;  /* world -> clip (OpenGL conventions) */
    bool ortho;         /* orthographic: no near/far culling (draw with depth clamp) */
    sq_vec3 eye;        /* perspective: the eye, for distances */
    float px_per_m;     /* ortho: pixels per metre; perspective: H / (2 tan(fov_y / 2)) */
    float lod_pixels;   /* largest projected LOD error (px); 0 -> 1 */
    float min_pixels;   /* instances with a smaller projected radius are skipped; 0 -> 0.5 */
    float max_distance_m; /* perspective: instances farther from the eye are skipped; 0 = none */
    float shell_max_m;    /* perspective, snow: the deepest shell (m); instances on which it moves
                           * no vertex by half a pixel are drawn without it (0 = all with it) */
    bool sink;            /* the snow occlusion map: each instance's level sunk by its error
                           * (shaders/depth_meshes.vert SQ_SINK) */
    bool top_only;        /* a view straight down (the occlusion map): only the faces whose
                           * projection on the ground has an area (render_meshes.c top_faces) */
} sq__depth_view;

/* Polls the context's cancellation (Ctrl-C): true once it is cancelled, and then for the rest of
 * the frame. Passes that issue much work check it between draw calls and stop issuing; the
 * frame then ends with SQ_ERR_CANCELLED (renderer.c). */
bool sq__render_cancelled(sq_renderer *r);
/* Between the parts of a long pass (a volume's slices, batches of particles or instances): the
 * part just issued is flushed and the one before it waited for, so one part stays in flight.
 * A software rasteriser otherwise defers a whole pass to the end of the frame, where Ctrl-C
 * could not reach it; this way it is answered within about two parts. Returns
 * sq__render_cancelled(r): stop issuing when true. */
bool sq__render_part_done(sq_renderer *r);
/* Draws `vertices` vertices of the bound VAO as triangles in SQ_RENDER_PARTS consecutive draws with sq__render_part_done between them:
 * the same picture, and Ctrl-C reaches a pass of seconds (a surface of 10^6 triangles). The
 * terrain (sq__terrain_draw) is drawn in as many parts of its visible tiles. */
#define SQ_RENDER_PARTS 8
void sq__render_triangles_in_parts(sq_renderer *r, int vertices);

typedef struct sq__mesh_stats {
    int64_t instances, faces; /* drawn since the last reset, over all views */
} sq__mesh_stats;

sq_result sq__mesh_pass_create(sq_renderer *r);
void sq__mesh_pass_destroy(sq_renderer *r);
/* Uploads the world's meshes and instances when the world or its generation changed. */
sq_result sq__mesh_pass_update(sq_renderer *r, const sq_world *w);
/* The camera's view as a depth view (after the camera is set up). */
sq__depth_view sq__depth_view_camera(const sq_renderer *r);
/* Planes (a, b, c, d; a x + b y + c z + d >= 0 inside) of a view-projection: left, right,
 * bottom, top, near, far (Gribb & Hartmann). */
void sq__frustum_planes(const sq_mat4 *vp, float pl[6][4]);
/* Whether the box lo..hi, grown by pad on every side, is not wholly outside one of the planes
 * 0..last (an orthographic view drawn with depth clamping: last = 3, no near/far). */
bool sq__box_may_be_seen(float pl[6][4], int last, const float lo[3], const float hi[3], float pad);
/* The terrain tiles view_proj may see (grown by shell_max_m for the snow shell) with the bound
 * program, in one multi-draw; counts the triangles in r->terrain_faces. */
void sq__terrain_draw(sq_renderer *r, const sq_mat4 *view_proj, bool ortho);
/* Lit, shadowed instances for the camera into the bound HDR target (the Frame block bound). */
void sq__mesh_pass_draw(sq_renderer *r);
/* Depth only, with v's view-projection, into the bound target. */
void sq__mesh_pass_draw_depth(sq_renderer *r, const sq__depth_view *v);
/* The culled instances of view v drawn with the caller's program, whose vertex shader includes
 * mesh_common.glsl (attributes 0..3, instance table at unit 9). materials: per part the
 * program's uniforms at locations 0 (vec3 base colour), 1 (int tint slot), 2 (int has texture)
 * are set and the texture bound at unit 10; back faces of closed meshes are culled. */
void sq__mesh_pass_draw_with(sq_renderer *r, const sq__depth_view *v, GLuint program,
                             bool materials);
/* Box around every instance (any = false when there are none). */
void sq__mesh_pass_bounds(const sq_renderer *r, sq_vec3 *mn, sq_vec3 *mx, bool *any);
sq__mesh_stats sq__mesh_pass_stats(sq_renderer *r, bool reset);
/* The instance programs with snow cover (on the first frame that draws snow; the default ones
 * have it compiled out). */
sq_result sq__mesh_pass_snow_programs(sq_renderer *r);

sq_result sq__shadow_pass_create(sq_renderer *r);
void sq__shadow_pass_destroy(sq_renderer *r);
/* Fits the cascades to the camera, renders them, uploads the Shadow block and binds it (UBO 3,
 * the map at unit 8). Call after the camera is set and the world caches are up to date.
 * draw = false: no shadows this frame (the block says 0 cascades). */
sq_result sq__shadow_pass_prepare(sq_renderer *r, const sq_world *w, bool draw,
                                  const sq_drawable *drawables, int count);
/* Whether the world's opaque geometry can shadow any of itself under its sun: obstacles or mesh
 * instances, or a terrain with a triangle steeper than the sun's elevation (surface drawables
 * are casters of their own, counted by the caller). The cascades are not drawn when not (the
 * picture is the same: nothing would be in shadow). */
bool sq__shadow_casters_possible(const sq_renderer *r, const sq_world *w);
/* Binds the Shadow block and map (or the 1x1 stand-in) for passes that include frame_common. */
void sq__shadow_bind(sq_renderer *r);
/* All opaque world geometry (terrain, obstacles, mesh instances) into the bound depth target
 * with v's view-projection: the shadow cascades and the snow occlusion map use this. The caller
 * binds the framebuffer, sets the viewport and clears depth. */
void sq__world_depth_draw(sq_renderer *r, const sq__depth_view *v);
/* The frame's surface drawables (heightfields: avalanche snow, deposits), uploaded by
 * sq__surfaces_upload, into the bound depth target with view_proj; only those whose index in
 * the frame's surface list has its bit set in mask. */
void sq__surfaces_upload(sq_renderer *r, const sq_drawable *drawables, int count);
void sq__surfaces_draw_depth(sq_renderer *r, const sq_mat4 *view_proj, const sq_drawable *drawables,
                             int count, unsigned mask);
/* CPU time of the last shadow render (ms; GL work may still be queued). */
/* A shadow cascade's slice and its map's box in the sun's frame (x, y across the sun's direction,
 * z toward it): half-size, centre, depth range. */
typedef struct sq__cascade_box {
    float split; /* far end of the slice along the view axis (m) */
    float texel; /* m */
    float half, cx, cy, zlo, zhi;
} sq__cascade_box;
/* The C cascades' boxes (render_shadow.c) for a camera at cam looking along unit fwd with half
 * field-of-view tangents tx, ty, near n and shadow distance f; size texels across a slice's
 * sphere plus margin texels each side (0: no keeping: origins on whole texels); reach (m)
 * toward the sun beyond the slice. No GL: the map of a cascade is kept while its box is the same. */
void sq__shadow_cascades(sq_vec3 cam, sq_vec3 fwd, float tx, float ty, float n, float f, int C,
                         int size, int margin, sq_vec3 sun, float reach, sq__cascade_box *out);
double sq__shadow_pass_ms(const sq_renderer *r);
/* Cascades drawn by the last frame (the others kept their maps). */
int sq__shadow_pass_drawn(const sq_renderer *r);

/* ---- render_snowcover.c: snow lying on the opaque surfaces --------------------------------- */
sq_result sq__snow_pass_create(sq_renderer *r);
void sq__snow_pass_destroy(sq_renderer *r);
/* With a snow-cover view (else NULL: the Snow block says off): the occlusion map for the
 * camera, the snow depth texture, the Snow block (UBO 4) and textures (units 11, 12) bound for
 * the opaque shaders. Call after the camera is set and the world caches are up to date. */
sq_result sq__snow_pass_prepare(sq_renderer *r, const sq_world *w, const sq_snow_cover_view *v);
/* renderer.c: the terrain, obstacle and instance programs with snow cover, compiled once (the
 * snow pass calls it on the first frame with snow; r->snow_on selects them). */
sq_result sq__snow_programs(sq_renderer *r);
/* Time of this frame's occlusion map: from the GL work before it finished to the map's finished
 * (ms; 0 when the last map served or without snow). */
double sq__snow_pass_ms(const sq_renderer *r);
/* The process's CPU time (all threads) while it was drawn (ms). */
double sq__snow_pass_cpu_ms(const sq_renderer *r);
/* The occlusion map in use (tests): its placement in *g (need_lo / need_hi: the box of the texels
 * drawn for the world's generation) and, when height is not NULL, g->size² heights of the
 * highest surface at the texel centres (top - depth x span, row j = y index), the form
 * sq__snow_map_fill gives on the CPU; false when there is no map yet. */
struct sq__snow_map_geom;
bool sq__snow_pass_map(sq_renderer *r, struct sq__snow_map_geom *g, float *height);
/* Rectangles of texels this frame drew into the occlusion map (0: the last map served whole). */
int sq__snow_pass_bands(const sq_renderer *r);

#endif
