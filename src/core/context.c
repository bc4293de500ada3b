/* context.c — the sq_context: threads, logger, seed, memory limit and aligned allocation. */
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "core_internal.h"

#define SQ_ALIGN 64
/* Allocation header, kept one alignment unit before the returned pointer. */
typedef struct alloc_header {
    uint64_t bytes;
    uint64_t magic;
} alloc_header;
#define SQ_ALLOC_MAGIC 0x5351414C4C4F4331ull

uint64_t sq_physical_memory_bytes(void)
{
    long pages = sysconf(_SC_PHYS_PAGES);
    long page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return 0;
    return (uint64_t)pages * (uint64_t)page;
}

/* threads = 0: OpenMP's own choice, which is OMP_NUM_THREADS when it is set (so
 * `mpirun -x OMP_NUM_THREADS=1` gives each rank one thread) and otherwise the cores this
 * process may run on (its affinity mask: a rank that mpirun bound to one core gets 1). */
static int available_cores(void)
{
#if SQ_HAVE_OPENMP
    return omp_get_max_threads();
#else
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
#endif
}

sq_result sq_context_create(const sq_context_desc *desc, sq_context **out)
{
    if (!out) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_context_create: out is NULL");
    *out = NULL;
    sq_context_desc d = {0};
    if (desc) d = *desc;
    if (d.threads < 0)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "threads = %d; must be >= 0 (0 = all cores)", d.threads);
    sq_context *c = (sq_context *)calloc(1, sizeof *c);
    if (!c) return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory creating the context");
    c->threads = d.threads > 0 ? d.threads : available_cores();
#if !SQ_HAVE_OPENMP
    c->threads = 1;
#endif
    c->log = d.log;
    c->log_user = d.log_user;
    c->log_level = d.log_level == SQ_LOG_DEFAULT ? SQ_LOG_INFO : d.log_level;
    uint64_t phys = sq_physical_memory_bytes();
    c->memory_limit = d.memory_limit_bytes ? d.memory_limit_bytes
                      : phys ? phys / 10 * 8
                             : (uint64_t)8 << 30;
    c->seed = d.seed;
    c->interrupt = d.interrupt;
    c->interrupt_user = d.interrupt_user;
    *out = c;
    return SQ_OK;
}

void sq_context_destroy(sq_context *ctx)
{
    if (!ctx) return;
    for (int i = 0; i < ctx->input_count; i++) free(ctx->inputs[i].path);
    free(ctx->inputs);
    free(ctx);
}

void sq_context_cancel(sq_context *ctx)
{
    if (ctx) ctx->cancel = 1;
}
bool sq_context_cancelled(const sq_context *ctx) { return sq__cancelled(ctx); }
void sq_context_cancel_clear(sq_context *ctx)
{
    if (ctx) ctx->cancel = 0;
}

sq_result sq__fail_cancelled(sq_context *ctx, const char *module, const char *what)
{
    return sq__fail(ctx, SQ_ERR_CANCELLED, module, "interrupted %s", what ? what : "");
}

void sq__context_note_input(sq_context *ctx, const char *path, uint64_t dev, uint64_t ino,
                            const char *what)
{
    if (!ctx || !path) return;
    for (int i = 0; i < ctx->input_count; i++)
        if (ctx->inputs[i].dev == dev && ctx->inputs[i].ino == ino) return;
    if (ctx->input_count == ctx->input_cap) {
        int cap = ctx->input_cap ? 2 * ctx->input_cap : 8;
        sq__input *n = (sq__input *)realloc(ctx->inputs, sizeof *n * (size_t)cap);
        if (!n) return;
        ctx->inputs = n;
        ctx->input_cap = cap;
    }
    sq__input *in = &ctx->inputs[ctx->input_count];
    in->path = strdup(path);
    if (!in->path) return;
    in->dev = dev;
    in->ino = ino;
    snprintf(in->what, sizeof in->what, "%s", what ? what : "input");
    ctx->input_count++;
}

int sq_context_input_count(const sq_context *ctx) { return ctx ? ctx->input_count : 0; }
const char *sq_context_input_path(const sq_context *ctx, int i)
{
    return ctx && i >= 0 && i < ctx->input_count ? ctx->inputs[i].path : NULL;
}
const char *sq_context_input_what(const sq_context *ctx, int i)
{
    return ctx && i >= 0 && i < ctx->input_count ? ctx->inputs[i].what : NULL;
}
int sq_context_threads(const sq_context *ctx) { return ctx ? ctx->threads : 1; }
uint64_t sq_context_seed(const sq_context *ctx) { return ctx ? ctx->seed : 0; }
uint64_t sq_context_memory_limit(const sq_context *ctx) { return ctx ? ctx->memory_limit : 0; }
uint64_t sq_context_bytes_in_use(const sq_context *ctx) { return ctx ? ctx->bytes_in_use : 0; }
uint64_t sq_context_bytes_peak(const sq_context *ctx) { return ctx ? ctx->bytes_peak : 0; }

const char *sq__format_bytes(uint64_t bytes, char buf[32])
{
    const char *units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = (double)bytes;
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        u++;
    }
    snprintf(buf, 32, u ? "%.2f %s" : "%.0f %s", v, units[u]);
    return buf;
}

sq_result sq_context_check_memory(sq_context *ctx, uint64_t bytes, const char *what)
{
    uint64_t limit = sq_context_memory_limit(ctx);
    uint64_t used = sq_context_bytes_in_use(ctx);
    if (bytes > limit || used + bytes > limit) {
        char b1[32], b2[32], b3[32];
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, "memory",
                        "%s needs %llu bytes (%s); the memory limit is %s with %s in use",
                        what ? what : "request", (unsigned long long)bytes,
                        sq__format_bytes(bytes, b1), sq__format_bytes(limit, b2),
                        sq__format_bytes(used, b3));
    }
    return SQ_OK;
}

void *sq_alloc(sq_context *ctx, size_t bytes)
{
    if (bytes == 0) bytes = 1;
    if (bytes > SIZE_MAX - 2 * SQ_ALIGN) {
        sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "memory", "allocation of %zu bytes overflows", bytes);
        return NULL;
    }
    if (ctx && sq_context_check_memory(ctx, bytes, "allocation") != SQ_OK) return NULL;
    size_t total = (bytes + SQ_ALIGN + SQ_ALIGN - 1) / SQ_ALIGN * SQ_ALIGN;
    unsigned char *raw = (unsigned char *)aligned_alloc(SQ_ALIGN, total);
    if (!raw) {
        char b[32];
        sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "memory", "out of memory allocating %s",
                 sq__format_bytes(bytes, b));
        return NULL;
    }
    alloc_header *h = (alloc_header *)raw;
    h->bytes = bytes;
    h->magic = SQ_ALLOC_MAGIC;
    if (ctx) {
        uint64_t now = atomic_fetch_add((_Atomic uint64_t *)&ctx->bytes_in_use, bytes) + bytes;
        if (now > ctx->bytes_peak) ctx->bytes_peak = now;
    }
    return raw + SQ_ALIGN;
}

void *sq_alloc_zero(sq_context *ctx, size_t bytes)
{
    void *p = sq_alloc(ctx, bytes);
    if (p) memset(p, 0, bytes);
    return p;
}

void sq_free(sq_context *ctx, void *p)
{
    if (!p) return;
    unsigned char *raw = (unsigned char *)p - SQ_ALIGN;
    alloc_header *h = (alloc_header *)raw;
    if (ctx && h->magic == SQ_ALLOC_MAGIC)
        atomic_fetch_sub((_Atomic uint64_t *)&ctx->bytes_in_use, h->bytes);
    h->magic = 0;
    free(raw);
}

void sq_log(sq_context *ctx, sq_log_level level, const char *module, const char *fmt, ...)
{
    if (!ctx || !ctx->log || level < ctx->log_level) return;
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    ctx->log(ctx->log_user, level, module ? module : "squall", buf);
}

double sq_time_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

const char *sq_version(void) { return SQ_VERSION_STRING; }

const char *sq_features(void) { return SQ_FEATURES_STRING; }

bool sq_has_feature(const char *name)
{
    if (!name || !*name) return false;
    const char *f = SQ_FEATURES_STRING;
    size_t n = strlen(name);
    while (*f) {
        const char *e = strchr(f, ' ');
        size_t len = e ? (size_t)(e - f) : strlen(f);
        if (len == n && strncmp(f, name, n) == 0) return true;
        if (!e) break;
        f = e + 1;
    }
    return false;
}

sq_result sq_context_poll_interrupt(sq_context *ctx, const char *module, const char *what)
{
    if (!sq__cancelled(ctx)) return SQ_OK; /* sq_context_cancel or the interrupt callback */
    return sq__fail(ctx, SQ_ERR_CANCELLED, module ? module : "squall", "interrupted during %s",
                    what ? what : "set-up");
}
