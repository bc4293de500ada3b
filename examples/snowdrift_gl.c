/* snowdrift_gl.c — draw a snowdrift into an OpenGL context this program creates itself.
 *
 * An application with its own renderer keeps its context and framebuffer; Squall draws into
 * them. Here the "application" is a headless EGL context (OpenGL 4.5 core, no window) with a
 * framebuffer object of its own: colour RGBA8 and a depth buffer. The renderer is created with
 * use_current_context and draws with sq_renderer_draw_to (squall/render.h): first the whole
 * frame (sky, terrain, houses, snow), then, to show compositing, only the drawables over a
 * plain clear of the application's (a grey backdrop and an empty depth buffer).
 *
 * Build: needs EGL and libepoxy (pkg-config egl epoxy) besides Squall.
 * Run:   ./snowdrift_gl OUT.ppm       (writes OUT.ppm and OUT.ppm.over.ppm) */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <squall/squall.h>

#define W 320
#define H 180

static int fail(const char *what)
{
    fprintf(stderr, "snowdrift_gl: %s: %s\n", what, sq_last_error());
    return 1;
}

/* The application's own context: EGL on Mesa's surfaceless platform, no window. */
static int make_context(void)
{
    EGLDisplay d =
        eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    EGLint major, minor, n = 0;
    EGLConfig cfg;
    const EGLint cfg_attr[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    const EGLint ctx_attr[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                               EGL_CONTEXT_OPENGL_PROFILE_MASK,
                               EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    if (d == EGL_NO_DISPLAY || !eglInitialize(d, &major, &minor) || !eglBindAPI(EGL_OPENGL_API) ||
        !eglChooseConfig(d, cfg_attr, &cfg, 1, &n) || n < 1)
        return -1;
    EGLContext c = eglCreateContext(d, cfg, EGL_NO_CONTEXT, ctx_attr);
    if (c == EGL_NO_CONTEXT || !eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, c)) return -1;
    return 0;
}

/* Reads the framebuffer (bottom row first in GL) into a binary PPM, top row first. */
static int write_ppm(GLuint fbo, const char *path)
{
    static unsigned char rgba[W * H * 4];
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    glReadPixels(0, 0, W, H, GL_RGBA, GL_UNSIGNED_BYTE, rgba);
    FILE *f = fopen(path, "wb");
    if (!f) return -1;
    fprintf(f, "P6\n%d %d\n255\n", W, H);
    for (int y = H - 1; y >= 0; y--)
        for (int x = 0; x < W; x++) fwrite(rgba + 4 * (x + W * y), 1, 3, f);
    return fclose(f);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: snowdrift_gl OUT.ppm\n");
        return 2;
    }
    if (make_context() != 0) {
        fprintf(stderr, "snowdrift_gl: no OpenGL 4.5 core context on EGL's surfaceless platform\n");
        return 1;
    }
    /* The application's framebuffer: RGBA8 colour + 24-bit depth. */
    GLuint fbo, colour, depth;
    glCreateRenderbuffers(1, &colour);
    glNamedRenderbufferStorage(colour, GL_RGBA8, W, H);
    glCreateRenderbuffers(1, &depth);
    glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT24, W, H);
    glCreateFramebuffers(1, &fbo);
    glNamedFramebufferRenderbuffer(fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour);
    glNamedFramebufferRenderbuffer(fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);

    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_WARN;
    sq_context *ctx = NULL;
    if (sq_context_create(&cd, &ctx) != SQ_OK) return fail("context");
    /* A snowfield with one house across a 7 m/s north wind. */
    const sq_obstacle house = {SQ_OBSTACLE_HOUSE, {0.0f, 0.0f, NAN}, {10.0f, 8.0f, 4.0f}, 3.0f,
                               0.0f, {0.0f, 0.0f, 0.0f}};
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.material = SQ_GROUND_SNOW;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 200.0f;
    wd.obstacles = &house;
    wd.obstacle_count = 1;
    sq_world *world = NULL;
    if (sq_world_create(ctx, &wd, &world) != SQ_OK) return fail("world");

    const char *settings[] = {"domain.nx=64", "domain.ny=40", "domain.nz=20",
                              "domain.cell_size_m=1", "wind.speed_mps=7", "wind.dir_deg=0",
                              "snow.snowfall_mmh=4", "snow.speedup=20000", "draw.flakes=5000"};
    sq_phenomenon_desc pd = {0};
    pd.type = "snowdrift";
    pd.settings = settings;
    pd.setting_count = (int)(sizeof settings / sizeof settings[0]);
    sq_phenomenon *snow = NULL;
    if (sq_phenomenon_create(ctx, &pd, world, &snow) != SQ_OK) return fail("snowdrift");

    sq_camera cam = {0};
    cam.position_m = (sq_vec3){-30.0f, -32.0f, 12.0f};
    cam.target_m = (sq_vec3){0.0f, 0.0f, 2.0f};
    cam.fov_y_deg = 50.0f;
    sq_phenomenon_observe(snow, &cam); /* flakes are placed around the camera */
    if (sq_phenomenon_step(snow, 4.0) != SQ_OK) return fail("step");
    sq_drawable drawables[16];
    const int count = sq_phenomenon_drawables(snow, drawables, 16);

    sq_render_desc rd = {0};
    rd.use_current_context = true; /* draw in the context current on this thread */
    sq_renderer *r = NULL;
    if (sq_renderer_create(ctx, &rd, &r) != SQ_OK) return fail("renderer");
    sq_render_target t = {fbo, W, H, SQ_TARGET_FRAME, SQ_TARGET_DISPLAY};
    if (sq_renderer_draw_to(r, &t, world, &cam, drawables, count, 4.0) != SQ_OK)
        return fail("draw");
    if (write_ppm(fbo, argv[1]) != 0) return fail("write");

    /* Compositing: the application clears its own picture, Squall adds only the snow (the
     * drawables), tested against the application's depth buffer. */
    const float grey[4] = {0.35f, 0.4f, 0.45f, 1.0f};
    glClearNamedFramebufferfv(fbo, GL_COLOR, 0, grey);
    const float far_depth = 1.0f;
    glClearNamedFramebufferfv(fbo, GL_DEPTH, 0, &far_depth);
    t.content = SQ_TARGET_DRAWABLES_OVER;
    if (sq_renderer_draw_to(r, &t, world, &cam, drawables, count, 4.0) != SQ_OK)
        return fail("draw over");
    char over[4096];
    snprintf(over, sizeof over, "%s.over.ppm", argv[1]);
    if (write_ppm(fbo, over) != 0) return fail("write");
    printf("%d drawables drawn into the application's framebuffer: %s, %s\n", count, argv[1], over);

    sq_renderer_destroy(r);
    sq_phenomenon_destroy(snow);
    sq_world_destroy(ctx, world);
    sq_context_destroy(ctx);
    glDeleteFramebuffers(1, &fbo);
    glDeleteRenderbuffers(1, &colour);
    glDeleteRenderbuffers(1, &depth);
    return 0;
}
