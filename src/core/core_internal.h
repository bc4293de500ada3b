/* core_internal.h — internal helpers shared by all of libsquall: failure reporting
 * (sq__fail sets the thread-local error text and logs a copy) and the OpenMP wrapper. */
#ifndef SQ_CORE_INTERNAL_H
#define SQ_CORE_INTERNAL_H

#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>

#include "sq_config.h"
#include "squall/core.h"

/* An input file by identity (see sq_context_input_count). */
typedef struct sq__input {
    uint64_t dev, ino;
    char *path;
    char what[48];
} sq__input;

struct sq_context {
    int threads;
    sq_log_fn log;
    void *log_user;
    sq_log_level log_level;
    uint64_t memory_limit;
    uint64_t seed;
    uint64_t bytes_in_use; /* updated atomically */
    uint64_t bytes_peak;
    volatile sig_atomic_t cancel; /* set by sq_context_cancel (signal handlers) */
    bool (*interrupt)(void *user); /* sq_context_desc.interrupt: polled like cancel */
    void *interrupt_user;
    sq__input *inputs;
    int input_count, input_cap;
};

/* Checkpoint record streams (state.c) over a write / read callback. */
struct sq_state_writer {
    sq_context *ctx;
    sq_result (*write)(void *user, const void *data, size_t n);
    void *user;
    uint64_t hash, bytes; /* FNV-1a 64 of everything written, and its length */
    sq_result status;     /* the first failure; later calls do nothing */
};
struct sq_state_reader {
    sq_context *ctx;
    sq_result (*read)(void *user, void *data, size_t n); /* all n bytes, or fails (named) */
    void *user;
    uint64_t hash, bytes;
    sq_result status;
    char source[256];     /* the file, for messages */
    char tag[256];        /* the record header read ahead (have_header) */
    uint64_t len;
    bool have_header;
};
uint64_t sq__fnv1a(uint64_t h, const void *data, size_t n);
void sq__state_writer_init(sq_state_writer *w, sq_context *ctx,
                           sq_result (*write)(void *user, const void *data, size_t n), void *user);
void sq__state_reader_init(sq_state_reader *r, sq_context *ctx, const char *source,
                           sq_result (*read)(void *user, void *data, size_t n), void *user);
/* Bytes outside records (file headers), hashed like the records. */
sq_result sq__state_write_raw(sq_state_writer *w, const void *data, size_t n);
sq_result sq__state_read_raw(sq_state_reader *r, void *data, size_t n);

/* True once sq_context_cancel was called or the desc's interrupt callback asks to stop: long
 * loops check it and return SQ_ERR_CANCELLED. */
static inline bool sq__cancelled(const sq_context *ctx)
{
    return ctx && (ctx->cancel || (ctx->interrupt && ctx->interrupt(ctx->interrupt_user)));
}
/* Fails with SQ_ERR_CANCELLED naming what was interrupted. */
sq_result sq__fail_cancelled(sq_context *ctx, const char *module, const char *what);
/* Records an input file (device, inode of the file path names, symlinks followed); a file
 * recorded before is not added twice. what: e.g. "scene file". Out of memory is ignored (the
 * record is a protection, never a reason to fail a read). */
void sq__context_note_input(sq_context *ctx, const char *path, uint64_t dev, uint64_t ino,
                            const char *what);

/* Sets the thread-local error text (printf-style), logs it at ERROR level under module
 * (ctx may be NULL: then only the text is set) and returns r. The text should name the field,
 * file or place, the value and the rule. */
sq_result sq__fail(sq_context *ctx, sq_result r, const char *module, const char *fmt, ...)
    SQ_PRINTF(4, 5);
sq_result sq__failv(sq_context *ctx, sq_result r, const char *module, const char *fmt,
                    va_list ap);
/* Sets the error text without logging (for pure functions without a context). */
sq_result sq__set_error(sq_result r, const char *fmt, ...) SQ_PRINTF(2, 3);

/* Formats bytes as "1.50 GiB". buf needs 32 bytes. */
const char *sq__format_bytes(uint64_t bytes, char buf[32]);

/* OpenMP through one macro. Usage:
 *     const int nt = sq_context_threads(ctx);
 *     SQ_OMP(omp parallel for schedule(static) num_threads(nt))
 *     for (...)
 * Without OpenMP the pragma disappears and the loop runs serially. */
#if SQ_HAVE_OPENMP
#define SQ_OMP(x) _Pragma(#x)
#include <omp.h>
static inline int sq__thread_num(void) { return omp_get_thread_num(); }
#else
#define SQ_OMP(x)
static inline int sq__thread_num(void) { return 0; }
#endif

/* Number of elements per thread chunk for fixed-order reductions: thread t of nt handles
 * [sq__chunk_begin(n, nt, t), sq__chunk_begin(n, nt, t+1)). */
static inline int64_t sq__chunk_begin(int64_t n, int nt, int t) { return n * t / nt; }

#endif
