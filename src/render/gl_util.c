/* gl_util.c — embedded GLSL (every src/render/shaders/<name>.glsl compiled into the binary by
 * cmake/EmbedFiles.cmake), a one-level-per-file `#include "name"` for shared shader code,
 * program compilation and linking with driver logs mapped back to "file:line: message", and
 * glGetError translation. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"

/* Generated: build/<dir>/generated/sq_shaders.c */
typedef struct {
    const char *name;
    const char *text;
} sq__embedded_file;
extern const sq__embedded_file sq__shader_files[];
extern const int sq__shader_count;

/* Index of the embedded shader called name ("terrain.frag" or "terrain.frag.glsl"), or -1. */
static int find_shader(const char *name)
{
    if (!name) return -1;
    size_t n = strlen(name);
    if (n > 5 && strcmp(name + n - 5, ".glsl") == 0) n -= 5;
    for (int i = 0; i < sq__shader_count; i++) {
        if (strlen(sq__shader_files[i].name) == n && strncmp(sq__shader_files[i].name, name, n) == 0)
            return i;
    }
    return -1;
}

const char *sq__shader_source(const char *name)
{
    const int i = find_shader(name);
    return i >= 0 ? sq__shader_files[i].text : NULL;
}

/* ---- include expansion ----------------------------------------------------------------- */
/* Included files are marked with `#line 1 K` so that the driver reports their lines as source
 * string K; the table maps K back to the file name. */
#define SQ_MAX_SOURCES 16
#define SQ_MAX_INCLUDE_DEPTH 4

typedef struct {
    sq_context *ctx;
    char *buf;
    size_t len, cap;
    const char *names[SQ_MAX_SOURCES];
    int count;
    bool oom;
} expand_state;

static void put(expand_state *s, const char *p, size_t n)
{
    if (s->oom) return;
    if (s->len + n + 1 > s->cap) {
        size_t cap = s->cap ? s->cap : 4096;
        while (s->len + n + 1 > cap) cap *= 2;
        char *b = sq_alloc(s->ctx, cap);
        if (!b) {
            s->oom = true;
            return;
        }
        if (s->buf) memcpy(b, s->buf, s->len);
        sq_free(s->ctx, s->buf);
        s->buf = b;
        s->cap = cap;
    }
    memcpy(s->buf + s->len, p, n);
    s->len += n;
    s->buf[s->len] = '\0';
}

static void putf(expand_state *s, const char *fmt, ...) SQ_PRINTF(2, 3);
static void putf(expand_state *s, const char *fmt, ...)
{
    char tmp[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n > 0) put(s, tmp, (size_t)n < sizeof tmp ? (size_t)n : sizeof tmp - 1);
}

/* Copies text (source string number src) into s, replacing each `#include "name"` line by the
 * named embedded file. */
static sq_result expand(expand_state *s, const char *name, const char *text, int src, int depth)
{
    int line = 1;
    const char *p = text;
    while (*p) {
        const char *eol = strchr(p, '\n');
        const size_t n = eol ? (size_t)(eol - p) : strlen(p);
        const char *q = p;
        while (q < p + n && (*q == ' ' || *q == '\t')) q++;
        if ((size_t)(p + n - q) > 8 && strncmp(q, "#include", 8) == 0) {
            const char *a = memchr(q, '"', (size_t)(p + n - q));
            const char *b = a ? memchr(a + 1, '"', (size_t)(p + n - a - 1)) : NULL;
            if (!b)
                return sq__fail(s->ctx, SQ_ERR_INTERNAL, "render",
                                "%s:%d: malformed #include (expected #include \"name\")", name,
                                line);
            char inc[96];
            snprintf(inc, sizeof inc, "%.*s", (int)(b - a - 1), a + 1);
            const int idx = find_shader(inc);
            if (idx < 0)
                return sq__fail(s->ctx, SQ_ERR_INTERNAL, "render",
                                "%s:%d: #include \"%s\": no embedded shader of that name", name,
                                line, inc);
            if (depth >= SQ_MAX_INCLUDE_DEPTH || s->count >= SQ_MAX_SOURCES)
                return sq__fail(s->ctx, SQ_ERR_INTERNAL, "render",
                                "%s:%d: #include \"%s\": includes nest deeper than %d or exceed "
                                "%d files",
                                name, line, inc, SQ_MAX_INCLUDE_DEPTH, SQ_MAX_SOURCES);
            const int k = s->count;
            s->names[s->count++] = sq__shader_files[idx].name;
            putf(s, "#line 1 %d\n", k);
            sq_result r = expand(s, s->names[k], sq__shader_files[idx].text, k, depth + 1);
            if (r != SQ_OK) return r;
            if (s->len > 0 && s->buf[s->len - 1] != '\n') put(s, "\n", 1);
            putf(s, "#line %d %d\n", line + 1, src);
        } else {
            put(s, p, n);
            put(s, "\n", 1);
        }
        if (!eol) break;
        p = eol + 1;
        line++;
    }
    return s->oom ? SQ_ERR_OUT_OF_MEMORY : SQ_OK;
}

/* ---- log translation ------------------------------------------------------------------- */
/* Parses the location at the start of a driver log line: Mesa "S:L(C): ", NVIDIA "S(L) : ",
 * AMD "ERROR: S:L: ". Returns the offset of the message after it, or -1. */
static int parse_location(const char *line, int *src, int *lno)
{
    const char *p = line;
    if (strncmp(p, "ERROR: ", 7) == 0) p += 7;
    else if (strncmp(p, "WARNING: ", 9) == 0) p += 9;
    char *end;
    long s = strtol(p, &end, 10);
    if (end == p) return -1;
    p = end;
    long l;
    if (*p == ':') {
        l = strtol(p + 1, &end, 10);
        if (end == p + 1) return -1;
        p = end;
        if (*p == '(') { /* column */
            while (*p && *p != ')') p++;
            if (*p == ')') p++;
        }
    } else if (*p == '(') {
        l = strtol(p + 1, &end, 10);
        if (end == p + 1 || *end != ')') return -1;
        p = end + 1;
    } else {
        return -1;
    }
    while (*p == ' ') p++;
    if (*p == ':') p++;
    while (*p == ' ') p++;
    *src = (int)s;
    *lno = (int)l;
    return (int)(p - line);
}

/* Writes up to four error lines of the log as "file:line: message; ..." into out. */
static void translate_log(const char *log, const char *const *names, int count, char *out,
                          size_t cap)
{
    out[0] = '\0';
    size_t len = 0;
    int shown = 0, total = 0;
    for (const char *p = log; p && *p;) {
        const char *eol = strchr(p, '\n');
        const size_t n = eol ? (size_t)(eol - p) : strlen(p);
        char line[512];
        snprintf(line, sizeof line, "%.*s", (int)n, p);
        p = eol ? eol + 1 : NULL;
        if (line[0] == '\0') continue;
        int src = 0, lno = 0;
        const int off = parse_location(line, &src, &lno);
        const char *msg = off >= 0 ? line + off : line;
        const bool is_error = strstr(line, "error") || strstr(line, "ERROR");
        if (!is_error) continue;
        total++;
        if (shown >= 4) continue;
        char item[600];
        if (off >= 0)
            snprintf(item, sizeof item, "%s%s:%d: %s", shown ? "; " : "",
                     (src >= 0 && src < count) ? names[src] : "?", lno, msg);
        else
            snprintf(item, sizeof item, "%s%s", shown ? "; " : "", msg);
        const size_t m = strlen(item);
        if (len + m + 1 >= cap) break;
        memcpy(out + len, item, m + 1);
        len += m;
        shown++;
    }
    if (total > shown && len + 32 < cap) snprintf(out + len, cap - len, " (+%d more)", total - shown);
    if (total == 0) snprintf(out, cap, "%.*s", (int)(cap - 1), log ? log : "(empty log)");
}

static const char *stage_name(GLenum stage)
{
    switch (stage) {
    case GL_VERTEX_SHADER: return "vertex";
    case GL_GEOMETRY_SHADER: return "geometry";
    case GL_FRAGMENT_SHADER: return "fragment";
    case GL_COMPUTE_SHADER: return "compute";
    default: return "?";
    }
}

sq_result sq__gl_shader_compile(sq_context *ctx, GLenum stage, const char *name, const char *text,
                                GLuint *out)
{
    *out = 0;
    expand_state s = {.ctx = ctx};
    s.names[s.count++] = name;
    sq_result r = expand(&s, name, text, 0, 0);
    if (r != SQ_OK) {
        sq_free(ctx, s.buf);
        return r;
    }
    GLuint sh = glCreateShader(stage);
    if (!sh) {
        sq_free(ctx, s.buf);
        return sq__fail(ctx, SQ_ERR_GL, "render", "glCreateShader(%s) failed for %s",
                        stage_name(stage), name);
    }
    const GLchar *src = s.buf ? s.buf : "";
    glShaderSource(sh, 1, &src, NULL);
    glCompileShader(sh);
    GLint ok = GL_FALSE;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint n = 0;
        glGetShaderiv(sh, GL_INFO_LOG_LENGTH, &n);
        char *log = sq_alloc_zero(ctx, (size_t)(n > 0 ? n : 1) + 1);
        if (log && n > 0) glGetShaderInfoLog(sh, n, NULL, log);
        char msg[1536];
        translate_log(log, s.names, s.count, msg, sizeof msg);
        sq_free(ctx, log);
        sq_free(ctx, s.buf);
        glDeleteShader(sh);
        return sq__fail(ctx, SQ_ERR_GL, "render", "%s shader %s does not compile: %s",
                        stage_name(stage), name, msg);
    }
    sq_free(ctx, s.buf);
    *out = sh;
    return SQ_OK;
}

sq_result sq__gl_program_link(sq_context *ctx, const char *label, const GLuint *shaders, int n,
                              GLuint *out)
{
    *out = 0;
    GLuint prog = glCreateProgram();
    if (!prog) return sq__fail(ctx, SQ_ERR_GL, "render", "glCreateProgram failed for %s", label);
    for (int i = 0; i < n; i++) glAttachShader(prog, shaders[i]);
    glLinkProgram(prog);
    for (int i = 0; i < n; i++) glDetachShader(prog, shaders[i]);
    GLint ok = GL_FALSE;
    glGetProgramiv(prog, GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint len = 0;
        glGetProgramiv(prog, GL_INFO_LOG_LENGTH, &len);
        char *log = sq_alloc_zero(ctx, (size_t)(len > 0 ? len : 1) + 1);
        if (log && len > 0) glGetProgramInfoLog(prog, len, NULL, log);
        char msg[1536];
        const char *none[1] = {label};
        translate_log(log, none, 0, msg, sizeof msg);
        sq_free(ctx, log);
        glDeleteProgram(prog);
        return sq__fail(ctx, SQ_ERR_GL, "render", "program %s does not link: %s", label, msg);
    }
    *out = prog;
    return SQ_OK;
}

/* text with defines inserted after its first line (the #version line) and a #line 2 that keeps
 * the driver's line numbers those of the file; NULL without memory */
static char *with_defines(sq_context *ctx, const char *text, const char *defines)
{
    const char *eol = strchr(text, '\n');
    const size_t head = eol ? (size_t)(eol - text) + 1 : strlen(text);
    const size_t nd = strlen(defines), nt = strlen(text);
    char *out = sq_alloc(ctx, nt + nd + 16);
    if (!out) return NULL;
    memcpy(out, text, head);
    size_t k = head;
    if (!eol) out[k++] = '\n';
    memcpy(out + k, defines, nd);
    k += nd;
    if (nd > 0 && defines[nd - 1] != '\n') out[k++] = '\n';
    memcpy(out + k, "#line 2\n", 8);
    k += 8;
    memcpy(out + k, text + head, nt - head + 1);
    return out;
}

sq_result sq__gl_program(sq_context *ctx, const char *vert, const char *geom, const char *frag,
                         GLuint *out)
{
    return sq__gl_program_defs(ctx, vert, geom, frag, NULL, out);
}

sq_result sq__gl_program_defs(sq_context *ctx, const char *vert, const char *geom,
                              const char *frag, const char *defines, GLuint *out)
{
    *out = 0;
    const char *names[3] = {vert, geom, frag};
    const GLenum stages[3] = {GL_VERTEX_SHADER, GL_GEOMETRY_SHADER, GL_FRAGMENT_SHADER};
    GLuint sh[3] = {0, 0, 0};
    int n = 0;
    char label[256] = "";
    sq_result r = SQ_OK;
    for (int i = 0; i < 3 && r == SQ_OK; i++) {
        if (!names[i]) continue;
        const char *text = sq__shader_source(names[i]);
        if (!text) {
            r = sq__fail(ctx, SQ_ERR_INTERNAL, "render",
                         "no embedded shader \"%s\" (expected src/render/shaders/%s.glsl)",
                         names[i], names[i]);
            break;
        }
        char *text_defs = defines ? with_defines(ctx, text, defines) : NULL;
        if (defines && !text_defs) {
            r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "render", "no memory for shader %s",
                         names[i]);
            break;
        }
        r = sq__gl_shader_compile(ctx, stages[i], names[i], text_defs ? text_defs : text, &sh[n]);
        sq_free(ctx, text_defs);
        if (r == SQ_OK) {
            size_t len = strlen(label);
            snprintf(label + len, sizeof label - len, "%s%s", n ? "+" : "", names[i]);
            n++;
        }
    }
    if (r == SQ_OK) {
        if (n == 0) r = sq__fail(ctx, SQ_ERR_INTERNAL, "render", "program with no shaders");
        else r = sq__gl_program_link(ctx, label, sh, n, out);
    }
    for (int i = 0; i < n; i++) glDeleteShader(sh[i]);
    return r;
}

sq_result sq__gl_compute_program(sq_context *ctx, const char *comp, GLuint *out)
{
    *out = 0;
    const char *text = sq__shader_source(comp);
    if (!text)
        return sq__fail(ctx, SQ_ERR_INTERNAL, "render",
                        "no embedded shader \"%s\" (expected src/render/shaders/%s.glsl)", comp,
                        comp);
    GLuint sh = 0;
    sq_result r = sq__gl_shader_compile(ctx, GL_COMPUTE_SHADER, comp, text, &sh);
    if (r != SQ_OK) return r;
    r = sq__gl_program_link(ctx, comp, &sh, 1, out);
    glDeleteShader(sh);
    return r;
}

static const char *gl_error_name(GLenum e)
{
    switch (e) {
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    case GL_STACK_OVERFLOW: return "GL_STACK_OVERFLOW";
    case GL_STACK_UNDERFLOW: return "GL_STACK_UNDERFLOW";
    default: return "unknown GL error";
    }
}

GLuint sq__gl_texture_2d(GLenum format, int w, int h, GLenum filter)
{
    GLuint t = 0;
    glCreateTextures(GL_TEXTURE_2D, 1, &t);
    glTextureStorage2D(t, 1, format, w, h);
    glTextureParameteri(t, GL_TEXTURE_MIN_FILTER, (GLint)filter);
    glTextureParameteri(t, GL_TEXTURE_MAG_FILTER, (GLint)filter);
    glTextureParameteri(t, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(t, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    return t;
}

sq_result sq__gl_check(sq_context *ctx, const char *where)
{
    GLenum e = glGetError();
    if (e == GL_NO_ERROR) return SQ_OK;
    GLenum first = e;
    int more = 0;
    while ((e = glGetError()) != GL_NO_ERROR && more < 32) more++;
    return sq__fail(ctx, first == GL_OUT_OF_MEMORY ? SQ_ERR_OUT_OF_MEMORY : SQ_ERR_GL, "render",
                    "OpenGL error %s (0x%04x) in %s%s", gl_error_name(first), (unsigned)first,
                    where, more ? " (and more errors after it)" : "");
}

sq_result sq__gl_check_framebuffer(sq_context *ctx, GLuint fbo, const char *what)
{
    const GLenum st = glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER);
    if (st == GL_FRAMEBUFFER_COMPLETE) return SQ_OK;
    return sq__fail(ctx, SQ_ERR_GL, "render", "frame buffer %s is incomplete (status 0x%04x)",
                    what, (unsigned)st);
}
