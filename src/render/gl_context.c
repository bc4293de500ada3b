/* gl_context.c — headless OpenGL 4.5 core context through EGL (ARCHITECTURE "Threads, GL,
 * scale"): the Mesa surfaceless platform first (llvmpipe on machines without a GPU), then the
 * EGL device platform (eglQueryDevicesEXT; vendor drivers). No window system is needed: the
 * context is made current with EGL_NO_SURFACE and draws into frame buffer objects only.
 * GL functions are loaded through libepoxy. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#include "render/render_internal.h"

struct sq__gl_context {
    sq_context *ctx;
    EGLDisplay display;
    EGLContext context;
    char platform[32]; /* "surfaceless" or "device N" */
};

#define SQ_GL_HOWTO                                                                            \
    "install Mesa's llvmpipe (apt-get install libgl1-mesa-dri libegl1) or a GPU driver"

/* EGL displays are process-wide objects inside EGL itself: eglGetPlatformDisplayEXT returns the
 * same handle for the same platform and device to every caller in the process (other renderers,
 * sq_gl_probe, other libraries), and eglTerminate would pull it from under all of them. So a
 * display, once initialised, stays initialised (a second eglInitialize is a no-op) and is
 * released by EGL at process exit; contexts are destroyed with their renderer. Keeping the
 * display also keeps the driver loaded, so its one-time allocations stay attributable (the leak
 * checker's suppressions name the driver libraries). */

static const char *egl_error_name(EGLint e)
{
    switch (e) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
    default: return "unknown EGL error";
    }
}

/* True if the space-separated list holds the extension name exactly. */
static bool has_ext(const char *list, const char *name)
{
    if (!list) return false;
    const size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)) != NULL; p += n) {
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    }
    return false;
}

/* Appends "; text" to the diagnostic of attempts made so far. */
static void note(char *why, size_t cap, const char *fmt, ...) SQ_PRINTF(3, 4);
static void note(char *why, size_t cap, const char *fmt, ...)
{
    size_t len = strlen(why);
    if (len + 3 >= cap) return;
    if (len > 0) {
        memcpy(why + len, "; ", 3);
        len += 2;
    }
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why + len, cap - len, fmt, ap);
    va_end(ap);
}

/* Initialises display d, creates a 4.5 core context and makes it current. On failure writes
 * what failed into why and leaves nothing behind. */
static bool try_display(EGLDisplay d, const char *platform, sq__gl_context *gl, char *why,
                        size_t cap)
{
    if (d == EGL_NO_DISPLAY) {
        note(why, cap, "no display on the %s platform: %s", platform,
             egl_error_name(eglGetError()));
        return false;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) {
        note(why, cap, "eglInitialize failed on the %s platform: %s", platform,
             egl_error_name(eglGetError()));
        return false;
    }
    const char *ext = eglQueryString(d, EGL_EXTENSIONS);
    if (!has_ext(ext, "EGL_KHR_surfaceless_context")) {
        note(why, cap, "the %s platform lacks EGL_KHR_surfaceless_context", platform);
        return false;
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
        note(why, cap, "eglBindAPI(EGL_OPENGL_API) failed on the %s platform: %s", platform,
             egl_error_name(eglGetError()));
        return false;
    }
    const EGLint config_attribs[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                     EGL_NONE};
    EGLConfig config = NULL;
    EGLint nconfig = 0;
    if (!eglChooseConfig(d, config_attribs, &config, 1, &nconfig) || nconfig < 1) {
        if (has_ext(ext, "EGL_KHR_no_config_context")) {
            config = EGL_NO_CONFIG_KHR;
        } else {
            note(why, cap, "no OpenGL-renderable EGL config on the %s platform", platform);
            return false;
        }
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4,
                                      EGL_CONTEXT_MINOR_VERSION, 5,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                      EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                      EGL_NONE};
    EGLContext c = eglCreateContext(d, config, EGL_NO_CONTEXT, context_attribs);
    if (c == EGL_NO_CONTEXT) {
        note(why, cap, "eglCreateContext(OpenGL 4.5 core) failed on the %s platform: %s",
             platform, egl_error_name(eglGetError()));
        return false;
    }
    if (!eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, c)) {
        note(why, cap, "eglMakeCurrent(EGL_NO_SURFACE) failed on the %s platform: %s", platform,
             egl_error_name(eglGetError()));
        eglDestroyContext(d, c);
        return false;
    }
    const int version = epoxy_gl_version();
    if (version < 45 || epoxy_is_desktop_gl() == 0) {
        note(why, cap, "the %s platform gave OpenGL %d.%d, not 4.5 core", platform,
             version / 10, version % 10);
        eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(d, c);
        return false;
    }
    gl->display = d;
    gl->context = c;
    snprintf(gl->platform, sizeof gl->platform, "%s", platform);
    return true;
}

/* The device platform: every device eglQueryDevicesEXT lists, or only the one hint names (an
 * index "0", "1", ... or a substring of its DRM device file, e.g. "renderD129"). */
static bool try_devices(const char *client_ext, const char *hint, sq__gl_context *gl,
                        char *why, size_t cap)
{
    if (!has_ext(client_ext, "EGL_EXT_device_enumeration") &&
        !has_ext(client_ext, "EGL_EXT_device_base")) {
        note(why, cap, "EGL offers no device enumeration (EGL_EXT_device_enumeration)");
        return false;
    }
    if (!has_ext(client_ext, "EGL_EXT_platform_device")) {
        note(why, cap, "EGL offers no device platform (EGL_EXT_platform_device)");
        return false;
    }
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (!eglQueryDevicesEXT(16, devices, &n) || n < 1) {
        note(why, cap, "eglQueryDevicesEXT found no device");
        return false;
    }
    bool matched = false;
    for (EGLint i = 0; i < n; i++) {
        if (hint) {
            char index[16];
            snprintf(index, sizeof index, "%d", (int)i);
            const char *file = NULL;
            const char *dext = eglQueryDeviceStringEXT(devices[i], EGL_EXTENSIONS);
            if (has_ext(dext, "EGL_EXT_device_drm"))
                file = eglQueryDeviceStringEXT(devices[i], EGL_DRM_DEVICE_FILE_EXT);
            if (strcmp(hint, index) != 0 && !(file && strstr(file, hint))) continue;
        }
        matched = true;
        char platform[32];
        snprintf(platform, sizeof platform, "device %d", (int)i);
        EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], NULL);
        if (try_display(d, platform, gl, why, cap)) return true;
    }
    if (hint && !matched)
        note(why, cap, "no EGL device matches egl_device \"%s\" (%d devices; give an index or "
                       "part of the DRM device path)", hint, (int)n);
    return false;
}

sq_result sq__gl_context_create(sq_context *ctx, const char *device_hint, sq__gl_context **out)
{
    *out = NULL;
    sq__gl_context *gl = sq_alloc_zero(ctx, sizeof *gl);
    if (!gl) return SQ_ERR_OUT_OF_MEMORY;
    gl->ctx = ctx;
    char why[768] = "";

    /* Client extensions (EGL 1.5 or EGL_EXT_client_extensions): needed before any platform
     * display can be asked for; libepoxy aborts on a call whose extension is missing. */
    const char *client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    bool ok = false;
    if (!client_ext) {
        note(why, sizeof why, "no EGL client extensions (no EGL vendor library found)");
    } else if (!has_ext(client_ext, "EGL_EXT_platform_base")) {
        note(why, sizeof why, "EGL lacks EGL_EXT_platform_base");
    } else {
        if (!device_hint) {
            if (has_ext(client_ext, "EGL_MESA_platform_surfaceless")) {
                EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA,
                                                        EGL_DEFAULT_DISPLAY, NULL);
                ok = try_display(d, "surfaceless", gl, why, sizeof why);
            } else {
                note(why, sizeof why, "EGL offers no surfaceless platform");
            }
        }
        if (!ok) ok = try_devices(client_ext, device_hint, gl, why, sizeof why);
    }
    if (!ok) {
        sq_free(ctx, gl);
        return sq__fail(ctx, SQ_ERR_GL, "render",
                        "no usable OpenGL 4.5 context (EGL: %s); " SQ_GL_HOWTO, why);
    }
    *out = gl;
    return SQ_OK;
}

sq_result sq__gl_context_make_current(sq__gl_context *gl)
{
    if (eglGetCurrentContext() == gl->context) return SQ_OK;
    if (!eglMakeCurrent(gl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, gl->context))
        return sq__fail(gl->ctx, SQ_ERR_GL, "render", "eglMakeCurrent failed (%s platform): %s",
                        gl->platform, egl_error_name(eglGetError()));
    return SQ_OK;
}

void sq__gl_context_destroy(sq__gl_context *gl)
{
    if (!gl) return;
    if (gl->context != EGL_NO_CONTEXT) {
        if (eglGetCurrentContext() == gl->context)
            eglMakeCurrent(gl->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(gl->display, gl->context);
    }
    sq_free(gl->ctx, gl);
}

/* Copies a GL string (may be NULL on a broken driver). */
static void copy_string(char *dst, size_t cap, GLenum name)
{
    const GLubyte *s = glGetString(name);
    snprintf(dst, cap, "%s", s ? (const char *)s : "(unknown)");
}

void sq__gl_query_info(sq_render_info *info)
{
    memset(info, 0, sizeof *info);
    copy_string(info->gl_vendor, sizeof info->gl_vendor, GL_VENDOR);
    copy_string(info->gl_renderer, sizeof info->gl_renderer, GL_RENDERER);
    copy_string(info->gl_version, sizeof info->gl_version, GL_VERSION);
    copy_string(info->glsl_version, sizeof info->glsl_version, GL_SHADING_LANGUAGE_VERSION);
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &info->max_texture_size);
    glGetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &info->max_3d_texture_size);
    glGetIntegerv(GL_MAX_VIEWPORT_DIMS, info->max_viewport);
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &info->max_renderbuffer_size);
}

sq_result sq_gl_probe(sq_context *ctx, sq_render_info *out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "render", "sq_gl_probe: out is NULL");
    memset(out, 0, sizeof *out);
    /* Keep whatever context the caller has current (e.g. a live renderer on this thread). */
    EGLDisplay prev_display = eglGetCurrentDisplay();
    EGLContext prev_context = eglGetCurrentContext();
    sq__gl_context *gl = NULL;
    sq_result r = sq__gl_context_create(ctx, NULL, &gl);
    if (r != SQ_OK) return r;
    sq__gl_query_info(out);
    sq__gl_context_destroy(gl);
    if (prev_context != EGL_NO_CONTEXT)
        eglMakeCurrent(prev_display, EGL_NO_SURFACE, EGL_NO_SURFACE, prev_context);
    return SQ_OK;
}
