/* view_record.c — recording the window's picture to MP4: every simulation frame shown is read
 * back once from the GL area and handed to the library's H.264 writer (sq_video_*, the encoder
 * `squall render` uses through sq_run), at the scene's output.fps, so that the video runs at the
 * scene's time scale whatever the drawing rate was. Safe output: the writer works on a temporary
 * name that stop renames; an existing file is kept unless --overwrite; never the scene file. */
#include <stdlib.h>
#include <string.h>

#include "view.h"

sq_result view_record_start(viewer *v, const char *path)
{
    if (v->rec) return sq_set_error(SQ_ERR_INVALID_ARG, "record %s: already recording to %s", path,
                                    v->rec_path);
    sq_result r = view_shot_check(v, path);
    if (r != SQ_OK) return r;
    const int w = v->fb_width & ~1, h = v->fb_height & ~1;
    if (w < 16 || h < 16)
        return sq_set_error(SQ_ERR_INVALID_ARG, "record %s: the drawing area is %dx%d; at least "
                            "16x16 is needed", path, v->fb_width, v->fb_height);
    v->rec_px = (uint8_t *)malloc((size_t)v->fb_width * (size_t)v->fb_height * 4);
    if (!v->rec_px) return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "record %s: no memory", path);
    sq_video_desc d;
    memset(&d, 0, sizeof d);
    d.path = path;
    d.width = w;
    d.height = h;
    d.fps = v->scene ? sq_scene_output_settings(v->scene)->fps : 24;
    d.overwrite = v->overwrite;
    r = sq_video_open(v->ctx, &d, &v->rec);
    if (r != SQ_OK) {
        free(v->rec_px);
        v->rec_px = NULL;
        return r;
    }
    snprintf(v->rec_path, sizeof v->rec_path, "%s", path);
    v->rec_width = w;
    v->rec_height = h;
    v->rec_last_frame = -1;
    v->rec_frames = 0;
    v->rec_error[0] = 0;
    v->redraw = true;
    return SQ_OK;
}

void view_record_frame(viewer *v, int frame)
{
    if (!v->rec || frame == v->rec_last_frame || v->rec_error[0]) return;
    if (v->fb_width < v->rec_width || v->fb_height < v->rec_height) return; /* shrunk: skip */
    if (!view_shot_read(v->fb_width, v->fb_height, v->rec_px)) return;
    /* the top-left rec_width x rec_height pixels, packed */
    for (int y = 0; y < v->rec_height; y++)
        memmove(v->rec_px + (size_t)y * (size_t)v->rec_width * 4,
                v->rec_px + (size_t)y * (size_t)v->fb_width * 4, (size_t)v->rec_width * 4);
    const sq_result r = sq_video_add_rgba8(v->rec, v->rec_px);
    if (r != SQ_OK)
        snprintf(v->rec_error, sizeof v->rec_error, "recording %s: %s", v->rec_path, sq_last_error());
    v->rec_last_frame = frame;
    v->rec_frames++;
}

sq_result view_record_stop(viewer *v)
{
    if (!v->rec) return SQ_OK;
    sq_result r;
    if (v->rec_error[0]) {
        sq_video_abort(v->rec);
        r = sq_set_error(SQ_ERR_IO, "%s", v->rec_error);
    } else {
        r = sq_video_close(v->rec);
    }
    v->rec = NULL;
    free(v->rec_px);
    v->rec_px = NULL;
    return r;
}

void view_record_abort(viewer *v)
{
    if (!v->rec) return;
    sq_video_abort(v->rec);
    v->rec = NULL;
    free(v->rec_px);
    v->rec_px = NULL;
}
