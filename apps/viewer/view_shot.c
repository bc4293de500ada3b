/* view_shot.c — screenshots of the GL area: the framebuffer bound for drawing (the GtkGLArea's)
 * read back as 8-bit RGBA (alpha as GTK composites it), flipped to rows top first and written as PNG through the library's
 * writer (temporary name, renamed when complete; an existing file only with --overwrite).
 * The scene file and the files it reads are never a screenshot's destination. */
#include <epoxy/gl.h>
#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "view.h"

sq_result view_shot_check(const viewer *v, const char *path)
{
    char real[VIEW_PATH_MAX];
    if (v->scene_real[0] && realpath(path, real) && strcmp(real, v->scene_real) == 0)
        return sq_set_error(SQ_ERR_INVALID_ARG,
                            "screenshot '%s' is the scene file being viewed; inputs are never "
                            "written",
                            path);
    /* and every file the scene read (a heightmap, DEM, mesh; also through a hard link) */
    return sq_output_check_inputs(v->ctx, path, false);
}

bool view_shot_read(int width, int height, uint8_t *px)
{
    const size_t row = (size_t)width * 4;
    uint8_t *tmp = (uint8_t *)malloc(row);
    if (!tmp) return false;
    GLint fbo = 0;
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &fbo);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, (GLuint)fbo);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, px);
    for (int y = 0; y < height / 2; y++) { /* GL rows are bottom first */
        uint8_t *a = px + (size_t)y * row, *b = px + (size_t)(height - 1 - y) * row;
        memcpy(tmp, a, row);
        memcpy(a, b, row);
        memcpy(b, tmp, row);
    }
    free(tmp);
    return true;
}

sq_result view_shot_write(viewer *v, const char *path, int width, int height)
{
    sq_result r = view_shot_check(v, path);
    if (r != SQ_OK) return r;
    uint8_t *px = (uint8_t *)malloc((size_t)width * 4 * (size_t)height);
    if (!px || !view_shot_read(width, height, px)) {
        free(px);
        return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "screenshot '%s': no memory", path);
    }
    r = sq_png_write_rgba8(path, width, height, px, v->overwrite);
    free(px);
    return r;
}
