/* state.c — checkpoint records (issue 17 part 4): the stream a scene, its phenomena and their
 * solvers write their complete state to, and read it back from in the same order. A record is
 * a tag (what it holds, e.g. "lbm/f"), a byte count and the bytes, in the host's byte order
 * (the checkpoint file records which). The stream keeps an FNV-1a 64 hash of every byte for the
 * file's checksum. Readers check each record's tag and size against what they expect, so a
 * checkpoint of another build, scene or phenomenon version is refused with the record named,
 * never read into the wrong place. */
#include <stdio.h>
#include <string.h>

#include "core_internal.h"

#define SQ__FNV_OFFSET 0xcbf29ce484222325ull
#define SQ__FNV_PRIME 0x100000001b3ull
#define SQ__STATE_TAG_MAX 255

uint64_t sq__fnv1a(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = (const unsigned char *)data;
    for (size_t i = 0; i < n; i++) {
        h ^= p[i];
        h *= SQ__FNV_PRIME;
    }
    return h;
}

void sq__state_writer_init(sq_state_writer *w, sq_context *ctx,
                           sq_result (*write)(void *user, const void *data, size_t n), void *user)
{
    memset(w, 0, sizeof *w);
    w->ctx = ctx;
    w->write = write;
    w->user = user;
    w->hash = SQ__FNV_OFFSET;
}

void sq__state_reader_init(sq_state_reader *r, sq_context *ctx, const char *source,
                           sq_result (*read)(void *user, void *data, size_t n), void *user)
{
    memset(r, 0, sizeof *r);
    r->ctx = ctx;
    r->read = read;
    r->user = user;
    r->hash = SQ__FNV_OFFSET;
    snprintf(r->source, sizeof r->source, "%s", source ? source : "checkpoint");
}

sq_result sq__state_write_raw(sq_state_writer *w, const void *data, size_t n)
{
    if (w->status != SQ_OK) return w->status;
    w->hash = sq__fnv1a(w->hash, data, n);
    w->bytes += n;
    w->status = w->write(w->user, data, n);
    return w->status;
}

sq_result sq__state_read_raw(sq_state_reader *r, void *data, size_t n)
{
    if (r->status != SQ_OK) return r->status;
    r->status = r->read(r->user, data, n);
    if (r->status == SQ_OK) {
        r->hash = sq__fnv1a(r->hash, data, n);
        r->bytes += n;
    }
    return r->status;
}

sq_result sq_state_put(sq_state_writer *w, const char *tag, const void *data, size_t bytes)
{
    if (!w || !tag) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_state_put: writer or tag is NULL");
    const size_t tl = strlen(tag);
    if (tl == 0 || tl > SQ__STATE_TAG_MAX || (bytes && !data))
        return sq__fail(w->ctx, SQ_ERR_INVALID_ARG, "state",
                        "checkpoint record '%.40s': tag of %zu characters (1..%d) and %zu bytes "
                        "without data",
                        tag, tl, SQ__STATE_TAG_MAX, bytes && !data ? bytes : (size_t)0);
    const uint16_t t16 = (uint16_t)tl;
    const uint64_t b64 = (uint64_t)bytes;
    sq__state_write_raw(w, &t16, sizeof t16);
    sq__state_write_raw(w, tag, tl);
    sq__state_write_raw(w, &b64, sizeof b64);
    if (bytes) sq__state_write_raw(w, data, bytes);
    return w->status;
}

/* Reads the next record's header into r->tag / r->len (once; sq_state_get consumes it). */
static sq_result next_header(sq_state_reader *r)
{
    if (r->have_header) return SQ_OK;
    uint16_t t16 = 0;
    if (sq__state_read_raw(r, &t16, sizeof t16) != SQ_OK) return r->status;
    if (t16 == 0 || t16 > SQ__STATE_TAG_MAX)
        return r->status = sq__fail(r->ctx, SQ_ERR_PARSE, "state",
                                    "checkpoint '%s': a record tag of %u characters at byte %llu; "
                                    "the file is damaged",
                                    r->source, (unsigned)t16, (unsigned long long)r->bytes);
    if (sq__state_read_raw(r, r->tag, t16) != SQ_OK) return r->status;
    r->tag[t16] = 0;
    if (sq__state_read_raw(r, &r->len, sizeof r->len) != SQ_OK) return r->status;
    r->have_header = true;
    return SQ_OK;
}

sq_result sq_state_get(sq_state_reader *r, const char *tag, void *data, size_t bytes)
{
    if (!r || !tag) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_state_get: reader or tag is NULL");
    if (next_header(r) != SQ_OK) return r->status;
    if (strcmp(r->tag, tag) != 0 || r->len != (uint64_t)bytes)
        return r->status = sq__fail(r->ctx, SQ_ERR_INVALID_ARG, "state",
                                    "checkpoint '%s': expected record '%s' of %zu bytes, found "
                                    "'%s' of %llu bytes: the checkpoint belongs to another scene, "
                                    "phenomenon version or build",
                                    r->source, tag, bytes, r->tag, (unsigned long long)r->len);
    r->have_header = false;
    if (bytes) sq__state_read_raw(r, data, bytes);
    return r->status;
}

sq_result sq_state_peek(sq_state_reader *r, const char **tag, uint64_t *bytes)
{
    if (!r) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_state_peek: reader is NULL");
    if (next_header(r) != SQ_OK) return r->status;
    if (tag) *tag = r->tag;
    if (bytes) *bytes = r->len;
    return SQ_OK;
}
