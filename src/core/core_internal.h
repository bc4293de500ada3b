/* core_internal.h — internal helpers shared by all of libsquall: failure reporting
 * (sq__fail sets the thread-local error text and logs a copy) and the OpenMP wrapper. */
#ifndef SQ_CORE_INTERNAL_H
#define SQ_CORE_INTERNAL_H

#include <stdarg.h>
#include <stdint.h>

#include "sq_config.h"
#include "squall/core.h"

struct sq_context {
    int threads;
    sq_log_fn log;
    void *log_user;
    sq_log_level log_level;
    uint64_t memory_limit;
    uint64_t seed;
    uint64_t bytes_in_use; /* updated atomically */
    uint64_t bytes_peak;
    bool (*interrupt)(void *user);
    void *interrupt_user;
};

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
