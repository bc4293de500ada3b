/* cli_util.c — option helpers, exit codes, JSON lines, benchmark timing and STREAM triad. */
#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "squall/par.h"

#ifdef _OPENMP
#define CLI_OMP(x) _Pragma(#x)
#else
#define CLI_OMP(x)
#endif

int sq_cli_exit_code(sq_result r)
{
    switch (r) {
    case SQ_OK: return SQ_EXIT_OK;
    case SQ_ERR_INVALID_ARG:
    case SQ_ERR_PARSE:
    case SQ_ERR_NOT_FOUND:
    case SQ_ERR_EXISTS:
    case SQ_ERR_TOO_LARGE:
    case SQ_ERR_IO: return SQ_EXIT_USAGE;
    default: return SQ_EXIT_RUNTIME;
    }
}

void sq_cli_error(const char *fmt, ...)
{
    char buf[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    for (char *p = buf; *p; p++)
        if (*p == '\n') *p = ' ';
    /* a distributed run: every rank holds the same (agreed) message; rank 0 says it */
    if (sq_par_rank() != 0) return;
    fprintf(stderr, "squall: %s\n", buf);
}

bool sq_cli_flag(int argc, char **argv, const char *name)
{
    for (int i = 0; i < argc; i++)
        if (strcmp(argv[i], name) == 0) return true;
    return false;
}

const char *sq_cli_value(int argc, char **argv, const char *name)
{
    size_t n = strlen(name);
    for (int i = 0; i < argc; i++) {
        if (strcmp(argv[i], name) == 0) return i + 1 < argc ? argv[i + 1] : "";
        if (strncmp(argv[i], name, n) == 0 && argv[i][n] == '=') return argv[i] + n + 1;
    }
    return NULL;
}

bool sq_cli_int(int argc, char **argv, const char *name, int def, int min, int max, int *out)
{
    const char *v = sq_cli_value(argc, argv, name);
    *out = def;
    if (!v) return true;
    char *end = NULL;
    long x = strtol(v, &end, 10);
    if (!*v || *end || x < min || x > max) {
        sq_cli_error("%s %s: expected a whole number from %d to %d", name, v, min, max);
        return false;
    }
    *out = (int)x;
    return true;
}

bool sq_cli_double(int argc, char **argv, const char *name, double def, double min, double max,
                   double *out)
{
    const char *v = sq_cli_value(argc, argv, name);
    *out = def;
    if (!v) return true;
    char *end = NULL;
    double x = strtod(v, &end);
    if (!*v || *end || !isfinite(x) || x < min || x > max) {
        sq_cli_error("%s %s: expected a number from %g to %g", name, v, min, max);
        return false;
    }
    *out = x;
    return true;
}

static void stderr_logger(void *user, sq_log_level level, const char *module, const char *msg)
{
    (void)user;
    /* Errors are printed once by the command itself; the logger shows warnings and info. */
    if (level == SQ_LOG_ERROR) return;
    if (sq_par_rank() != 0 && level != SQ_LOG_DEBUG) return; /* once, not once per rank */
    const char *tag = level == SQ_LOG_WARN ? "warning: " : "";
    fprintf(stderr, "squall[%s]: %s%s\n", module, tag, msg);
}

/* Ctrl-C / SIGTERM: a flag the commands and the library's long stages poll (through the
 * context's interrupt callback), so that set-up and frame loops stop cleanly. */
volatile int sq_cli_interrupted_flag;
static void on_signal(int sig)
{
    sq_cli_interrupted_flag = 1;
    signal(sig, SIG_DFL); /* a second Ctrl-C ends the process at once */
}
bool sq_cli_interrupted(void) { return sq_cli_interrupted_flag != 0; }
void sq_cli_catch_interrupts(void)
{
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
}
static bool interrupt_cb(void *user)
{
    (void)user;
    return sq_cli_interrupted_flag != 0;
}

sq_result sq_cli_context(int argc, char **argv, sq_context **out)
{
    int threads = 0;
    if (!sq_cli_int(argc, argv, "--threads", 0, 0, 4096, &threads)) return SQ_ERR_INVALID_ARG;
    sq_context_desc d = {0};
    d.threads = threads;
    d.log = stderr_logger;
    d.interrupt = interrupt_cb;
    d.log_level = sq_cli_flag(argc, argv, "--quiet")     ? SQ_LOG_ERROR
                  : sq_cli_flag(argc, argv, "--verbose") ? SQ_LOG_DEBUG
                                                         : SQ_LOG_WARN;
    return sq_context_create(&d, out);
}

/* ---- JSON -------------------------------------------------------------------------------- */
static void jput(sq_json *j, const char *s)
{
    size_t n = strlen(s);
    if (j->len + n + 1 < sizeof j->buf) {
        memcpy(j->buf + j->len, s, n);
        j->len += n;
        j->buf[j->len] = 0;
    }
}

static void jkey(sq_json *j, const char *key)
{
    jput(j, j->fields++ ? ", \"" : "\"");
    jput(j, key);
    jput(j, "\": ");
}

static void jstring(sq_json *j, const char *s)
{
    jput(j, "\"");
    char c[8];
    for (; s && *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\') {
            c[0] = '\\';
            c[1] = (char)ch;
            c[2] = 0;
        } else if (ch < 0x20) {
            snprintf(c, sizeof c, "\\u%04x", ch);
        } else {
            c[0] = (char)ch;
            c[1] = 0;
        }
        jput(j, c);
    }
    jput(j, "\"");
}

void sq_json_begin(sq_json *j)
{
    j->len = 0;
    j->fields = 0;
    j->buf[0] = 0;
    jput(j, "{");
}
void sq_json_str(sq_json *j, const char *key, const char *value)
{
    jkey(j, key);
    jstring(j, value);
}
void sq_json_num(sq_json *j, const char *key, double value)
{
    char b[64];
    jkey(j, key);
    if (!isfinite(value))
        jput(j, "null");
    else {
        snprintf(b, sizeof b, "%.6g", value);
        jput(j, b);
    }
}
void sq_json_int(sq_json *j, const char *key, long long value)
{
    char b[32];
    jkey(j, key);
    snprintf(b, sizeof b, "%lld", value);
    jput(j, b);
}
void sq_json_bool(sq_json *j, const char *key, bool value)
{
    jkey(j, key);
    jput(j, value ? "true" : "false");
}
void sq_json_raw(sq_json *j, const char *key, const char *raw_json)
{
    jkey(j, key);
    jput(j, raw_json);
}
void sq_json_end(sq_json *j, FILE *out)
{
    jput(j, "}");
    fprintf(out, "%s\n", j->buf);
    fflush(out);
}

/* ---- timing ------------------------------------------------------------------------------ */
static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

double sq_bench_median(double *v, int n)
{
    if (n <= 0) return NAN;
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

sq_result sq_bench_per_rank(const double mine[3], const sq_bench_rank_keys *keys, char *json,
                            size_t size, double *slowest_ms, double *bytes_total)
{
    const int nr = sq_par_size();
    double *all = (double *)calloc((size_t)(3 * nr), sizeof(double));
    int64_t *cnt = (int64_t *)calloc((size_t)nr, sizeof(int64_t));
    if (!all || !cnt) {
        free(all);
        free(cnt);
        return sq_set_error(SQ_ERR_OUT_OF_MEMORY, "out of memory for the per-rank figures");
    }
    for (int q = 0; q < nr; q++) cnt[q] = 3;
    const sq_result r = sq_par_allgather_f64(mine, cnt, all);
    *slowest_ms = 0.0;
    *bytes_total = 0.0;
    size_t len = (size_t)snprintf(json, size, "[");
    for (int q = 0; q < nr && len < size; q++) {
        const double *rq = all + 3 * q;
        if (rq[1] > *slowest_ms) *slowest_ms = rq[1];
        *bytes_total += rq[2];
        len += (size_t)snprintf(json + len, size - len,
                                "%s{\"rank\": %d, \"cells\": %.0f, \"%s\": %.6g, \"%s\": %.6g, "
                                "\"%s\": %.0f}",
                                q ? ", " : "", q, rq[0], keys->ms, rq[1], keys->rate,
                                rq[1] > 0 ? rq[0] / (rq[1] * 1e-3) / 1e6 : 0.0, keys->bytes,
                                rq[2]);
    }
    if (len < size) snprintf(json + len, size - len, "]");
    free(all);
    free(cnt);
    return r;
}

sq_bench_stats sq_bench_time(int (*fn)(void *user), void *user, int warmup, int reps)
{
    sq_bench_stats s = {0, 0, 0, 0};
    for (int i = 0; i < warmup; i++)
        if (fn(user)) return s;
    if (reps < 1) reps = 1;
    double *t = (double *)malloc(sizeof(double) * (size_t)reps);
    if (!t) return s;
    int done = 0;
    for (; done < reps; done++) {
        double t0 = sq_time_now();
        if (fn(user)) break;
        t[done] = (sq_time_now() - t0) * 1e3;
    }
    if (done > 0) {
        s.median_ms = sq_bench_median(t, done); /* sorts t */
        s.min_ms = t[0];
        s.max_ms = t[done - 1];
    }
    s.reps = done;
    free(t);
    return s;
}

double sq_bench_stream_triad_gbps(int threads)
{
    const int nt = threads > 0 ? threads : 1;
    (void)nt;
    const size_t n = (size_t)1 << 24; /* 16 Mi doubles = 128 MiB per array */
    double *a = (double *)aligned_alloc(64, n * sizeof(double));
    double *b = (double *)aligned_alloc(64, n * sizeof(double));
    double *c = (double *)aligned_alloc(64, n * sizeof(double));
    if (!a || !b || !c) {
        free(a);
        free(b);
        free(c);
        return 0.0;
    }
    double best = 1e30;
    CLI_OMP(omp parallel for schedule(static) num_threads(nt))
    for (size_t i = 0; i < n; i++) {
        a[i] = 0.0;
        b[i] = 1.0;
        c[i] = 2.0;
    }
    for (int r = 0; r < 5; r++) {
        double t0 = sq_time_now();
        const double s = 3.0;
    CLI_OMP(omp parallel for schedule(static) num_threads(nt))
        for (size_t i = 0; i < n; i++) a[i] = b[i] + s * c[i];
        double t = sq_time_now() - t0;
        if (t < best) best = t;
    }
    volatile double sink = a[n / 2];
    (void)sink;
    free(a);
    free(b);
    free(c);
    return 3.0 * 8.0 * (double)n / best / 1e9;
}

void sq_bench_json_common(sq_json *j, const char *case_name, const sq_bench_args *a,
                          const sq_bench_stats *s)
{
    sq_json_str(j, "case", case_name);
    sq_json_int(j, "threads", a->threads);
    sq_json_num(j, "ms_per_step", s->median_ms);
    sq_json_num(j, "ms_min", s->min_ms);
    sq_json_num(j, "ms_max", s->max_ms);
    sq_json_num(j, "steps_per_s", s->median_ms > 0 ? 1e3 / s->median_ms : (double)NAN);
    sq_json_num(j, "stream_gbps", a->stream_gbps);
    sq_json_int(j, "reps", s->reps);
}
