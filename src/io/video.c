/* video.c — MP4 (H.264, yuv420p) through FFmpeg's libavformat, libavcodec and libswscale, and a
 * probe that decodes every frame of a video file (tests, `squall info FILE`).
 *
 * Writing: the file is written to a temporary name in the directory of its final name and
 * renamed on sq_video_close (safe outputs, output.c). Frames arrive as 8-bit RGBA and are
 * converted by swscale to yuv420p with BT.709 coefficients in limited ("TV") range, which is what
 * the stream is tagged with, so players show the colours that were rendered. The encoder is
 * libx264 (crf + preset "medium"), else another H.264 encoder of this FFmpeg. The mov muxer
 * gets movflags=+faststart: the index (moov) is moved to the front on close so the file plays
 * progressively. Time base 1/fps, frame i has pts i.
 *
 * Logging: libav* would print to stderr, and the library never prints. The first use installs an
 * av_log callback (process-wide, once) that keeps the last error-level line per thread; failures
 * append that foreign text to their own message ("... (libav: ...)"). Lower levels are dropped.
 * URLs are always "file:" paths with the file protocol only, so a name with ':' is a file. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "io/io_internal.h"

#if SQ_HAVE_MP4

#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/dict.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
#include <pthread.h>

#define SQ__VIDEO_MAX_SIDE 8192
#define SQ__VIDEO_URL_MAX (SQ__TEMP_NAME_MAX + 8)

struct sq_video_writer {
    sq_context *ctx;
    char path[SQ__TEMP_NAME_MAX];
    char tmp[SQ__TEMP_NAME_MAX];
    bool overwrite;
    bool failed;
    int width, height, fps;
    int64_t frames;
    AVFormatContext *fmt;
    AVCodecContext *enc;
    AVStream *st;
    struct SwsContext *sws;
    AVFrame *frame;
    AVPacket *pkt;
};

/* ---- libav logging and error text ---------------------------------------------------------- */

static _Thread_local char sq__av_last[256];

static void on_av_log(void *avcl, int level, const char *fmt, va_list vl)
{
    (void)avcl;
    if (level > AV_LOG_ERROR) return;
    vsnprintf(sq__av_last, sizeof sq__av_last, fmt, vl);
    size_t n = strlen(sq__av_last);
    while (n > 0 && (sq__av_last[n - 1] == '\n' || sq__av_last[n - 1] == '\r'))
        sq__av_last[--n] = 0;
}

static pthread_once_t sq__av_once = PTHREAD_ONCE_INIT;
static void install_av_log(void) { av_log_set_callback(on_av_log); }

static void av_begin(void)
{
    pthread_once(&sq__av_once, install_av_log);
    sq__av_last[0] = 0;
}

/* Fails with "<what>: <av error text>[ (libav: <last logged error>)]". */
static sq_result fail_av(sq_context *ctx, sq_result code, int averr, const char *fmt, ...)
    SQ_PRINTF(4, 5);
static sq_result fail_av(sq_context *ctx, sq_result code, int averr, const char *fmt, ...)
{
    char what[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (code == SQ_ERR_IO && (averr == AVERROR(ENOSPC) || averr == AVERROR(EDQUOT)))
        return sq__fail(ctx, SQ_ERR_NO_SPACE, "io",
                        "%s: no space left on device (free some space, or write elsewhere)", what);
    char err[AV_ERROR_MAX_STRING_SIZE] = "";
    av_strerror(averr, err, sizeof err);
    char last[sizeof sq__av_last];
    snprintf(last, sizeof last, "%s", sq__av_last);
    return sq__fail(ctx, code, "io", "%s: %s%s%s%s", what, err, last[0] ? " (libav: " : "", last,
                    last[0] ? ")" : "");
}

static void file_url(char *url, size_t size, const char *path)
{
    snprintf(url, size, "file:%s", path);
}

/* ---- writer -------------------------------------------------------------------------------- */

static void writer_free(sq_video_writer *w, bool remove_temp)
{
    if (!w) return;
    if (w->fmt) {
        if (w->fmt->pb) avio_closep(&w->fmt->pb);
        avformat_free_context(w->fmt);
        w->fmt = NULL;
    }
    avcodec_free_context(&w->enc);
    sws_freeContext(w->sws);
    w->sws = NULL;
    av_frame_free(&w->frame);
    av_packet_free(&w->pkt);
    if (remove_temp) sq__output_discard(w->tmp);
    sq_free(w->ctx, w);
}

static const AVCodec *find_h264_encoder(void)
{
    static const char *const names[] = {"libx264", "libopenh264"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        const AVCodec *c = avcodec_find_encoder_by_name(names[i]);
        if (c) return c;
    }
    return avcodec_find_encoder(AV_CODEC_ID_H264);
}

static bool encoder_takes_yuv420p(const AVCodec *c)
{
    if (!c->pix_fmts) return true; /* the encoder does not say: let avcodec_open2 decide */
    for (const enum AVPixelFormat *p = c->pix_fmts; *p != AV_PIX_FMT_NONE; p++)
        if (*p == AV_PIX_FMT_YUV420P) return true;
    return false;
}

/* Sends frame (NULL = flush) and writes every packet the encoder returns. */
static sq_result encode(sq_video_writer *w, const AVFrame *frame)
{
    int ret = avcodec_send_frame(w->enc, frame);
    if (ret < 0)
        return fail_av(w->ctx, SQ_ERR_IO, ret, "cannot encode frame %lld of '%s'",
                       (long long)w->frames, w->path);
    for (;;) {
        ret = avcodec_receive_packet(w->enc, w->pkt);
        if (ret == AVERROR(EAGAIN) || ret == AVERROR_EOF) return SQ_OK;
        if (ret < 0)
            return fail_av(w->ctx, SQ_ERR_IO, ret, "cannot encode frame %lld of '%s'",
                           (long long)w->frames, w->path);
        av_packet_rescale_ts(w->pkt, w->enc->time_base, w->st->time_base);
        w->pkt->stream_index = w->st->index;
        ret = av_interleaved_write_frame(w->fmt, w->pkt); /* takes the packet's reference */
        if (ret < 0) return fail_av(w->ctx, SQ_ERR_IO, ret, "cannot write to '%s'", w->path);
    }
}

static sq_result validate_desc(sq_context *ctx, const sq_video_desc *d, int *fps, int *crf)
{
    if (!d) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video desc is NULL");
    if (!d->path || !*d->path)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video path is empty");
    if (d->width < 2 || d->width > SQ__VIDEO_MAX_SIDE || d->height < 2 ||
        d->height > SQ__VIDEO_MAX_SIDE)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "video '%s' is %dx%d; each side must be in 2..%d", d->path, d->width,
                        d->height, SQ__VIDEO_MAX_SIDE);
    if (d->width % 2 || d->height % 2)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "video '%s' is %dx%d; width and height must be even (yuv420p stores "
                        "colour at half resolution)",
                        d->path, d->width, d->height);
    *fps = d->fps ? d->fps : 30;
    if (*fps < 1 || *fps > 240)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video fps = %d; must be in 1..240", d->fps);
    *crf = d->crf ? d->crf : 20;
    if (*crf < 1 || *crf > 51)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "video crf = %d; must be in 1..51 (0 selects the default 20)", d->crf);
    return SQ_OK;
}

sq_result sq_video_open(sq_context *ctx, const sq_video_desc *desc, sq_video_writer **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "sq_video_open: out is NULL");
    *out = NULL;
    int fps = 0, crf = 0;
    sq_result r = validate_desc(ctx, desc, &fps, &crf);
    if (r != SQ_OK) return r;
    if (strlen(desc->path) >= SQ__TEMP_NAME_MAX - 64)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video path '%.80s...' is too long",
                        desc->path);
    /* Cheap checks first: a run that cannot write its output fails before any work. */
    r = sq_output_check(desc->path, desc->overwrite);
    if (r == SQ_OK) r = sq_output_check_inputs(ctx, desc->path, false);
    if (r != SQ_OK) return sq__io_relog(ctx, r);

    av_begin();
    const AVCodec *codec = find_h264_encoder();
    if (!codec)
        return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                        "cannot write '%s': this FFmpeg (%s) has no H.264 encoder; libx264 is "
                        "missing (on Debian it comes with the libavcodec package)",
                        desc->path, LIBAVCODEC_IDENT);
    if (!encoder_takes_yuv420p(codec))
        return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                        "cannot write '%s': H.264 encoder '%s' does not take yuv420p", desc->path,
                        codec->name);

    sq_video_writer *w = (sq_video_writer *)sq_alloc_zero(ctx, sizeof *w);
    if (!w) return sq__io_relog(ctx, SQ_ERR_OUT_OF_MEMORY);
    w->ctx = ctx;
    snprintf(w->path, sizeof w->path, "%s", desc->path);
    w->overwrite = desc->overwrite;
    w->width = desc->width;
    w->height = desc->height;
    w->fps = fps;

    int fd = -1;
    r = sq__output_open_temp(w->path, w->overwrite, w->tmp, sizeof w->tmp, &fd);
    if (r != SQ_OK) {
        writer_free(w, false);
        return sq__io_relog(ctx, r);
    }
    close(fd); /* reserved exclusively; libavformat reopens it by name */
    char url[SQ__VIDEO_URL_MAX];
    file_url(url, sizeof url, w->tmp);

    int ret = avformat_alloc_output_context2(&w->fmt, NULL, "mp4", url);
    if (ret < 0 || !w->fmt) {
        r = fail_av(ctx, SQ_ERR_UNSUPPORTED, ret, "cannot write '%s': no mp4 muxer", w->path);
        goto fail;
    }
    w->st = avformat_new_stream(w->fmt, NULL);
    w->enc = avcodec_alloc_context3(codec);
    w->frame = av_frame_alloc();
    w->pkt = av_packet_alloc();
    if (!w->st || !w->enc || !w->frame || !w->pkt) {
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "cannot write '%s': out of memory", w->path);
        goto fail;
    }
    AVCodecContext *enc = w->enc;
    enc->width = w->width;
    enc->height = w->height;
    enc->pix_fmt = AV_PIX_FMT_YUV420P;
    enc->time_base = (AVRational){1, fps};
    enc->framerate = (AVRational){fps, 1};
    enc->sample_aspect_ratio = (AVRational){1, 1};
    enc->color_range = AVCOL_RANGE_MPEG;
    enc->colorspace = AVCOL_SPC_BT709;
    enc->color_primaries = AVCOL_PRI_BT709;
    enc->color_trc = AVCOL_TRC_BT709;
    enc->thread_count = ctx ? sq_context_threads(ctx) : 1;
    if (w->fmt->oformat->flags & AVFMT_GLOBALHEADER) enc->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    AVDictionary *opts = NULL;
    av_dict_set(&opts, "preset", "medium", 0);
    av_dict_set_int(&opts, "crf", crf, 0);
    ret = avcodec_open2(enc, codec, &opts); /* options an encoder lacks stay in opts: ignored */
    av_dict_free(&opts);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_UNSUPPORTED, ret,
                    "cannot write '%s': H.264 encoder '%s' failed to start", w->path, codec->name);
        goto fail;
    }
    ret = avcodec_parameters_from_context(w->st->codecpar, enc);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_INTERNAL, ret, "cannot write '%s'", w->path);
        goto fail;
    }
    w->st->time_base = enc->time_base;
    w->st->avg_frame_rate = enc->framerate;

    AVDictionary *io_opts = NULL;
    av_dict_set(&io_opts, "protocol_whitelist", "file", 0);
    ret = avio_open2(&w->fmt->pb, url, AVIO_FLAG_WRITE, NULL, &io_opts);
    av_dict_free(&io_opts);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_IO, ret, "cannot write '%s' (temporary '%s')", w->path, w->tmp);
        goto fail;
    }
    AVDictionary *mux_opts = NULL;
    av_dict_set(&mux_opts, "movflags", "+faststart", 0);
    ret = avformat_write_header(w->fmt, &mux_opts);
    av_dict_free(&mux_opts);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_IO, ret, "cannot write the header of '%s'", w->path);
        goto fail;
    }

    w->sws = sws_getContext(w->width, w->height, AV_PIX_FMT_RGBA, w->width, w->height,
                            AV_PIX_FMT_YUV420P, SWS_BICUBIC | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INP,
                            NULL, NULL, NULL);
    if (!w->sws) {
        r = sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                     "cannot write '%s': swscale cannot convert RGBA to yuv420p", w->path);
        goto fail;
    }
    /* RGBA in full range -> BT.709 YUV in limited range, matching the stream's colour tags. */
    sws_setColorspaceDetails(w->sws, sws_getCoefficients(SWS_CS_DEFAULT), 1,
                             sws_getCoefficients(SWS_CS_ITU709), 0, 0, 1 << 16, 1 << 16);
    w->frame->format = AV_PIX_FMT_YUV420P;
    w->frame->width = w->width;
    w->frame->height = w->height;
    w->frame->color_range = AVCOL_RANGE_MPEG;
    w->frame->colorspace = AVCOL_SPC_BT709;
    w->frame->color_primaries = AVCOL_PRI_BT709;
    w->frame->color_trc = AVCOL_TRC_BT709;
    ret = av_frame_get_buffer(w->frame, 0);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_OUT_OF_MEMORY, ret, "cannot write '%s'", w->path);
        goto fail;
    }
    sq_log(ctx, SQ_LOG_DEBUG, "io", "'%s': %dx%d at %d fps, %s crf %d, temporary '%s'", w->path,
           w->width, w->height, fps, codec->name, crf, w->tmp);
    *out = w;
    return SQ_OK;
fail:
    writer_free(w, true);
    return r;
}

sq_result sq_video_add_rgba8(sq_video_writer *w, const uint8_t *rgba)
{
    if (!w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_video_add_rgba8: writer is NULL");
    if (w->failed)
        return sq__fail(w->ctx, SQ_ERR_IO, "io", "video '%s' failed earlier; close or abort it",
                        w->path);
    if (!rgba)
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "io", "frame %lld of '%s' has no pixels",
                        (long long)w->frames, w->path);
    av_begin();
    int ret = av_frame_make_writable(w->frame);
    if (ret < 0) {
        w->failed = true;
        return fail_av(w->ctx, SQ_ERR_OUT_OF_MEMORY, ret, "frame %lld of '%s'",
                       (long long)w->frames, w->path);
    }
    const uint8_t *const src[4] = {rgba, NULL, NULL, NULL};
    const int src_stride[4] = {4 * w->width, 0, 0, 0};
    sws_scale(w->sws, src, src_stride, 0, w->height, w->frame->data, w->frame->linesize);
    w->frame->pts = w->frames;
    sq_result r = encode(w, w->frame);
    if (r != SQ_OK) {
        w->failed = true;
        return r;
    }
    w->frames++;
    return SQ_OK;
}

sq_result sq_video_close(sq_video_writer *w)
{
    if (!w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_video_close: writer is NULL");
    sq_context *ctx = w->ctx;
    av_begin();
    sq_result r = SQ_OK;
    if (w->failed) {
        r = sq__fail(ctx, SQ_ERR_IO, "io", "video '%s' was not written: an earlier frame failed",
                     w->path);
    } else if (w->frames == 0) {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video '%s' has no frames; nothing was written",
                     w->path);
    } else {
        r = encode(w, NULL); /* flush the frames the encoder still holds */
        if (r == SQ_OK) {
            int ret = av_write_trailer(w->fmt); /* faststart moves the index to the front */
            if (ret < 0) r = fail_av(ctx, SQ_ERR_IO, ret, "cannot finish '%s'", w->path);
        }
        if (r == SQ_OK) {
            int ret = avio_closep(&w->fmt->pb);
            if (ret < 0) r = fail_av(ctx, SQ_ERR_IO, ret, "cannot finish '%s'", w->path);
        }
        if (r == SQ_OK) r = sq__io_relog(ctx, sq__output_finish(w->tmp, w->path, w->overwrite));
    }
    if (r == SQ_OK) {
        sq_log(ctx, SQ_LOG_INFO, "io", "wrote '%s' (%lld frames)", w->path, (long long)w->frames);
        w->tmp[0] = 0; /* renamed: nothing to remove */
    }
    writer_free(w, r != SQ_OK);
    return r;
}

void sq_video_abort(sq_video_writer *w) { writer_free(w, true); }

/* ---- probe --------------------------------------------------------------------------------- */

typedef struct probe_acc {
    int64_t frames;
    double luma_sum;
    double pixels;
    struct SwsContext *gray; /* for frames whose luma is not an 8-bit plane 0 */
    uint8_t *gray_buf;
    size_t gray_size;
} probe_acc;

static sq_result accumulate(sq_context *ctx, const char *path, probe_acc *a, const AVFrame *f)
{
    const AVPixFmtDescriptor *d = av_pix_fmt_desc_get((enum AVPixelFormat)f->format);
    const uint8_t *plane = NULL;
    int stride = 0;
    if (d &&
        !(d->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL | AV_PIX_FMT_FLAG_BITSTREAM)) &&
        d->comp[0].plane == 0 && d->comp[0].depth == 8 && d->comp[0].step == 1 &&
        d->comp[0].shift == 0 && d->comp[0].offset == 0) {
        plane = f->data[0];
        stride = f->linesize[0];
    } else {
        a->gray = sws_getCachedContext(a->gray, f->width, f->height, (enum AVPixelFormat)f->format,
                                       f->width, f->height, AV_PIX_FMT_GRAY8, SWS_POINT, NULL, NULL,
                                       NULL);
        size_t need = (size_t)f->width * (size_t)f->height;
        if (a->gray && need > a->gray_size) {
            av_free(a->gray_buf);
            a->gray_buf = (uint8_t *)av_malloc(need);
            a->gray_size = a->gray_buf ? need : 0;
        }
        if (!a->gray || !a->gray_buf)
            return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                            "video '%s': cannot take the luma of pixel format %s", path,
                            d ? d->name : "unknown");
        uint8_t *dst[4] = {a->gray_buf, NULL, NULL, NULL};
        int dst_stride[4] = {f->width, 0, 0, 0};
        sws_scale(a->gray, (const uint8_t *const *)f->data, f->linesize, 0, f->height, dst,
                  dst_stride);
        plane = a->gray_buf;
        stride = f->width;
    }
    double sum = 0.0;
    for (int y = 0; y < f->height; y++) {
        const uint8_t *row = plane + (ptrdiff_t)y * stride;
        uint64_t s = 0;
        for (int x = 0; x < f->width; x++) s += row[x];
        sum += (double)s;
    }
    a->luma_sum += sum;
    a->pixels += (double)f->width * (double)f->height;
    a->frames++;
    return SQ_OK;
}

/* Receives every decoded frame available now. */
static sq_result drain(sq_context *ctx, const char *path, AVCodecContext *dc, AVFrame *frame,
                       probe_acc *a)
{
    for (;;) {
        int ret = avcodec_receive_frame(dc, frame);
        if (ret == AVERROR(EAGAIN) || ret == AVERROR_EOF) return SQ_OK;
        if (ret < 0)
            return fail_av(ctx, SQ_ERR_PARSE, ret, "video '%s' is corrupt at frame %lld", path,
                           (long long)a->frames);
        sq_result r = accumulate(ctx, path, a, frame);
        av_frame_unref(frame);
        if (r != SQ_OK) return r;
    }
}

sq_result sq_video_probe(sq_context *ctx, const char *path, sq_video_info *out)
{
    if (out) memset(out, 0, sizeof *out);
    if (!path || !*path) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video path is empty");
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "sq_video_probe: out is NULL");
    if (access(path, R_OK) != 0)
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot open '%s': %s", path, strerror(errno));
    av_begin();
    char url[SQ__VIDEO_URL_MAX];
    if (strlen(path) + 6 > sizeof url)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "video path '%.80s...' is too long", path);
    file_url(url, sizeof url, path);

    AVFormatContext *fmt = NULL;
    AVCodecContext *dc = NULL;
    AVPacket *pkt = NULL;
    AVFrame *frame = NULL;
    probe_acc acc = {0};
    sq_result r = SQ_OK;
    AVDictionary *opts = NULL;
    av_dict_set(&opts, "protocol_whitelist", "file", 0);
    int ret = avformat_open_input(&fmt, url, NULL, &opts);
    av_dict_free(&opts);
    if (ret < 0) return fail_av(ctx, SQ_ERR_PARSE, ret, "cannot read video '%s'", path);
    ret = avformat_find_stream_info(fmt, NULL);
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_PARSE, ret, "cannot read video '%s'", path);
        goto done;
    }
    const AVCodec *dec = NULL;
    int si = av_find_best_stream(fmt, AVMEDIA_TYPE_VIDEO, -1, -1, &dec, 0);
    if (si < 0 || !dec) {
        r = si == AVERROR_DECODER_NOT_FOUND
                ? sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io", "video '%s': no decoder for its codec",
                           path)
                : sq__fail(ctx, SQ_ERR_PARSE, "io", "'%s' has no video stream", path);
        goto done;
    }
    AVStream *st = fmt->streams[si];
    dc = avcodec_alloc_context3(dec);
    pkt = av_packet_alloc();
    frame = av_frame_alloc();
    if (!dc || !pkt || !frame) {
        r = sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "probing '%s': out of memory", path);
        goto done;
    }
    ret = avcodec_parameters_to_context(dc, st->codecpar);
    if (ret >= 0) {
        dc->thread_count = ctx ? sq_context_threads(ctx) : 1;
        ret = avcodec_open2(dc, dec, NULL);
    }
    if (ret < 0) {
        r = fail_av(ctx, SQ_ERR_UNSUPPORTED, ret, "video '%s': decoder '%s' failed to start", path,
                    dec->name);
        goto done;
    }
    while ((ret = av_read_frame(fmt, pkt)) >= 0) {
        if (pkt->stream_index == si) {
            ret = avcodec_send_packet(dc, pkt);
            if (ret < 0 && ret != AVERROR(EAGAIN)) {
                av_packet_unref(pkt);
                r = fail_av(ctx, SQ_ERR_PARSE, ret, "video '%s' is corrupt at frame %lld", path,
                            (long long)acc.frames);
                goto done;
            }
            r = drain(ctx, path, dc, frame, &acc);
        }
        av_packet_unref(pkt);
        if (r != SQ_OK) goto done;
    }
    if (ret != AVERROR_EOF) {
        r = fail_av(ctx, SQ_ERR_PARSE, ret, "video '%s' is corrupt at frame %lld", path,
                    (long long)acc.frames);
        goto done;
    }
    ret = avcodec_send_packet(dc, NULL); /* flush the decoder */
    if (ret < 0 && ret != AVERROR_EOF) {
        r = fail_av(ctx, SQ_ERR_PARSE, ret, "video '%s': flushing the decoder", path);
        goto done;
    }
    r = drain(ctx, path, dc, frame, &acc);
    if (r != SQ_OK) goto done;

    out->width = st->codecpar->width;
    out->height = st->codecpar->height;
    out->frames = acc.frames > INT32_MAX ? INT32_MAX : (int)acc.frames;
    AVRational fr = st->avg_frame_rate.num > 0 ? st->avg_frame_rate : st->r_frame_rate;
    out->fps = fr.den > 0 ? av_q2d(fr) : 0.0;
    snprintf(out->codec, sizeof out->codec, "%s", avcodec_get_name(st->codecpar->codec_id));
    const char *pf = av_get_pix_fmt_name((enum AVPixelFormat)st->codecpar->format);
    snprintf(out->pix_fmt, sizeof out->pix_fmt, "%s", pf ? pf : "unknown");
    out->mean_luma = acc.pixels > 0.0 ? acc.luma_sum / acc.pixels : 0.0;
done:
    sws_freeContext(acc.gray);
    av_free(acc.gray_buf);
    av_frame_free(&frame);
    av_packet_free(&pkt);
    avcodec_free_context(&dc);
    avformat_close_input(&fmt);
    return r;
}

#else /* !SQ_HAVE_MP4 */

struct sq_video_writer {
    int unused;
};

static sq_result no_mp4(sq_context *ctx)
{
    return sq__fail(ctx, SQ_ERR_UNSUPPORTED, "io",
                    "squall was built without MP4 support (SQ_WITH_MP4=OFF); write PNG frames");
}

sq_result sq_video_open(sq_context *ctx, const sq_video_desc *desc, sq_video_writer **out)
{
    (void)desc;
    if (out) *out = NULL;
    return no_mp4(ctx);
}
sq_result sq_video_add_rgba8(sq_video_writer *w, const uint8_t *rgba)
{
    (void)w;
    (void)rgba;
    return no_mp4(NULL);
}
sq_result sq_video_close(sq_video_writer *w)
{
    (void)w;
    return no_mp4(NULL);
}
void sq_video_abort(sq_video_writer *w) { (void)w; }
sq_result sq_video_probe(sq_context *ctx, const char *path, sq_video_info *out)
{
    (void)path;
    if (out) memset(out, 0, sizeof *out);
    return no_mp4(ctx);
}

#endif
